"""`roar drive`: keyboard teleop in the terminal.

W / Up      throttle +0.1        A / Left    steer 0.2 further left
S / Down    throttle -0.1        D / Right   steer 0.2 further right
space       stop (neutral)       Q / Ctrl-C  quit (sends neutral)
"""

from __future__ import annotations

import os
import select
import sys
import termios
import tty
from dataclasses import dataclass

from roar.cli.main import UserError
from roar.vehicle import Vehicle

THROTTLE_STEP = 0.1
STEERING_STEP = 0.2
MAX_TELEOP_THROTTLE = 0.5  # keyboards are coarse: half throttle is plenty indoors

KEYS = {
    b"w": "faster", b"\x1b[A": "faster", b"s": "slower", b"\x1b[B": "slower",
    b"a": "left", b"\x1b[D": "left", b"d": "right", b"\x1b[C": "right",
    b" ": "stop", b"q": "quit", b"\x03": "quit", b"\x04": "quit",
}


def parse_keys(data: bytes) -> list[str]:
    """Key presses in a chunk of terminal input -> actions (unknown keys ignored)."""
    actions, i = [], 0
    while i < len(data):
        for length in (3, 1):
            chunk = data[i:i + length]
            action = KEYS.get(chunk if length == 3 else chunk.lower())  # arrows are case-sensitive
            if action:
                actions.append(action)
                i += length
                break
        else:
            i += 1
    return actions


@dataclass
class Teleop:
    throttle: float = 0.0
    steering: float = 0.0

    def apply(self, action: str) -> bool:
        """Update for one action; False means quit."""
        if action == "quit":
            return False
        if action == "stop":
            self.throttle = self.steering = 0.0
        elif action in ("faster", "slower"):
            step = THROTTLE_STEP if action == "faster" else -THROTTLE_STEP
            self.throttle = round(max(-MAX_TELEOP_THROTTLE, min(MAX_TELEOP_THROTTLE, self.throttle + step)), 2)
        else:
            step = STEERING_STEP if action == "right" else -STEERING_STEP
            self.steering = round(max(-1.0, min(1.0, self.steering + step)), 2)
        return True


def run(car: Vehicle, fd: int | None = None, out=None) -> int:
    fd = sys.stdin.fileno() if fd is None else fd
    out = out or sys.stdout
    if not os.isatty(fd):
        raise UserError("roar drive reads the keyboard: run it in a terminal (use `roar send` in scripts)")
    state = Teleop()
    saved = termios.tcgetattr(fd)
    out.write(__doc__.split("\n", 2)[2] + "\n")
    try:
        tty.setraw(fd, termios.TCSANOW)  # Ctrl-C arrives as a key, so quitting always sends neutral
        running = True
        while running:
            ready, _, _ = select.select([fd], [], [], 0.1)
            if ready:
                for action in parse_keys(os.read(fd, 64)):
                    running = running and state.apply(action)
                car.drive(state.throttle, state.steering)
            link = "link ok" if car.connected else "LINK DOWN"
            last = car.replies[-1] if car.replies else ""
            out.write(f"\r\x1b[Kthrottle {state.throttle:+.1f}  steering {state.steering:+.1f}  "
                      f"({link}) {last}")
            out.flush()
    finally:
        termios.tcsetattr(fd, termios.TCSADRAIN, saved)
        out.write("\r\nstopped\n")
    return 0
