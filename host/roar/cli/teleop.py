"""`roar drive`: keyboard teleop in the terminal.

W / Up      throttle +0.1        A / Left    steer 0.2 further left
S / Down    throttle -0.1        D / Right   steer 0.2 further right
space       stop (neutral)       Q / Ctrl-C  quit (sends neutral)
"""

from __future__ import annotations

import sys
from dataclasses import dataclass

from roar.cli.sdk import UserError
from roar.vehicle import Vehicle

THROTTLE_STEP = 0.1
STEERING_STEP = 0.2
MAX_TELEOP_THROTTLE = 0.5  # keyboards are coarse: half throttle is plenty indoors
POLL_S = 0.1  # [s] the screen refreshes at least this often

# Keys are decoded by blessed, which knows the terminal's own sequences (an arrow is ESC [ A in
# normal cursor mode, ESC O A in application mode) and waits for the rest of a sequence split
# across reads, so a key is never misread as another.
NAMED_KEYS = {"KEY_UP": "faster", "KEY_DOWN": "slower", "KEY_LEFT": "left", "KEY_RIGHT": "right"}
CHARACTERS = {"w": "faster", "s": "slower", "a": "left", "d": "right", " ": "stop", "q": "quit",
              "\x03": "quit", "\x04": "quit"}  # Ctrl-C and Ctrl-D arrive as keys in raw mode


def action_for(key) -> str | None:
    """The teleop action of one blessed Keystroke (None for other keys)."""
    if key.is_sequence:
        return NAMED_KEYS.get(key.name)
    return CHARACTERS.get(str(key).lower())


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


def run(car: Vehicle, out=None) -> int:
    import blessed

    out = out or sys.stdout
    term = blessed.Terminal()
    if not term.is_a_tty or not sys.stdin.isatty():
        raise UserError("roar drive reads the keyboard: run it in a terminal (use `roar send` in scripts)")
    state = Teleop()
    out.write(__doc__.split("\n", 2)[2] + "\n")
    try:
        with term.raw():  # Ctrl-C arrives as a key, so quitting always sends neutral
            running = True
            while running:
                key = term.inkey(timeout=POLL_S)
                action = action_for(key) if key else None
                if action:
                    running = state.apply(action)
                    car.drive(state.throttle, state.steering)
                link = "link ok" if car.connected else "LINK DOWN"
                last = car.replies[-1] if car.replies else ""
                out.write(f"\r{term.clear_eol}throttle {state.throttle:+.1f}  steering {state.steering:+.1f}  "
                          f"({link}) {last}")
                out.flush()
    finally:
        out.write("\r\nstopped\n")
    return 0
