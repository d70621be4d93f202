"""A simulated car as a serial port: a pseudo-terminal whose other end is the firmware logic.

    roar sim --serial [--robot esc|iarrc] [--track oval] [--seconds 0 (= until Ctrl-C)]

prints a path such as /dev/pts/5. Anything that speaks the control message over that port (a
pyserial script, a terminal program) drives the simulated car in real time, and reads the
lines the firmware prints (READY, ERR <reason>, FAILSAFE, ARMED), as with a real car on USB.
With --robot iarrc it is the IARRC car: setpoints in, telemetry lines out, its transmitter's
mode switch flipped to autonomous when the first setpoint arrives. (The ROAR Junior has no
serial port: `roar sim --robot junior --http` serves it.)
"""

from __future__ import annotations

import argparse
import os
import sys
import termios
import threading
import tty

from roar.tracks.names import FORMS
from roar.cli.sdk import (ArgumentParser, ExitStatus, UserError, add_foxglove_option, run_command, seconds_option,
                             stopped_status)
from roar_sim import robots
from roar_sim.core.lockstep import CONTROL_PERIOD_S
from roar_sim.robots import Robot
from roar.tracks import get

CHUNK_S = 0.002  # [s] simulated (and, in real time, wall) time between reads of the port
MAX_UNSENT_BYTES = 4096  # [bytes] reply bytes held for a slow reader; whole lines beyond are dropped


class PtyCar:
    """A robot behind a pty. Call pump() repeatedly (or serve()) to move bytes and time."""

    def __init__(self, sim: Robot, log=None) -> None:
        """log: a roar_sim.links.sim_log.SimLog of sim, stepped each control period."""
        self.sim, self.log = sim, log
        self._next_log_s = 0.0
        self.master, self._slave = os.openpty()
        tty.setraw(self._slave, termios.TCSANOW)  # bytes pass unchanged: no echo, no line editing
        os.set_blocking(self.master, False)
        self.path = os.ttyname(self._slave)
        self._serving = threading.Event()
        self._thread: threading.Thread | None = None
        self._unsent = b""  # the rest of a line the pty did not take whole

    def pump(self, seconds: float = CHUNK_S) -> None:
        try:
            data = os.read(self.master, 4096)
        except (BlockingIOError, InterruptedError):
            data = b""
        if data:
            self.sim.write(data)
        self.sim.run(seconds)
        if self.log is not None and self.sim.time_s + 1e-9 >= self._next_log_s:
            self.log.step()
            self._next_log_s = self.sim.time_s + CONTROL_PERIOD_S
        for line in self.sim.read():  # like the firmware: whole lines, dropped when there is no room
            data = (line + "\n").encode("ascii")
            if len(self._unsent) + len(data) <= MAX_UNSENT_BYTES:
                self._unsent += data
        if self._unsent:
            try:
                self._unsent = self._unsent[os.write(self.master, self._unsent):]
            except BlockingIOError:
                pass  # nobody reads now: keep it for the next pump, never block

    def serve(self, seconds: float = 0.0) -> None:
        """Run until `seconds` of simulated time have passed (0 = forever)."""
        end = self.sim.time_s + seconds
        while seconds <= 0 or self.sim.time_s < end:
            self.pump()

    def start(self) -> PtyCar:
        """Serve from a background thread until close() (give the robot realtime=True)."""
        self._serving.set()
        self._thread = threading.Thread(target=self._serve_while_started, name="pty-car", daemon=True)
        self._thread.start()
        return self

    def _serve_while_started(self) -> None:
        while self._serving.is_set():
            self.pump()

    def close(self) -> None:
        """Unplug: stop serving and close both ends of the pty (the host sees the port vanish)."""
        self._serving.clear()
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        for fd in (self.master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass
        if self.log is not None:
            self.log.close()
        self.sim.close()

    def __enter__(self) -> PtyCar:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def serial_robots() -> list[str]:
    return [name for name in robots.names() if "serial" in robots.get(name).links]


def parser() -> argparse.ArgumentParser:
    p = ArgumentParser(prog="roar sim --serial", description=__doc__)
    p.add_argument("--robot", default="esc", metavar="NAME",
                   help="esc: the ESC car (throttle, steering; default); iarrc: the IARRC car (speed setpoints)")
    p.add_argument("--track", default="oval", help=f"{FORMS} (default: oval)")
    p.add_argument("--seconds", type=seconds_option, default=0.0, metavar="S", help="stop after this long (default: run until Ctrl-C)")
    p.add_argument("--gui", action="store_true", help="open the PyBullet window (needs a display)")
    add_foxglove_option(p, "the car's channels")
    return p


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    kind = robots.get(args.robot)
    if "serial" not in kind.links:
        raise UserError(f"the {kind.title} has no serial port (robots with one: {', '.join(serial_robots())})"
                        + ("; serve it over HTTP with roar sim --robot junior --http" if "http" in kind.links else ""))
    sim = kind(get(args.track), realtime=True, gui=args.gui)
    log = None
    if args.foxglove is not None:
        from roar_sim.links.sim_log import SimLog

        try:
            log = SimLog(sim, None, None, args.foxglove, drain_lines=False)
        except BaseException:
            sim.close()
            raise
    with PtyCar(sim, log) as car:
        print(f"simulated {kind.title} on {car.path} (115200 baud, any setting works); Ctrl-C to stop", flush=True)
        if log is not None:
            print(f"its channels live: Foxglove, Open connection, ws://127.0.0.1:{args.foxglove}", flush=True)
        status = ExitStatus.OK
        try:
            car.serve(args.seconds)
        except KeyboardInterrupt as e:  # Ctrl-C or SIGTERM: say where the car was left
            status = stopped_status(e)
        s = car.sim.state()
        print(f"stopped after {car.sim.time_s:.1f} s: car at x={s.x:.2f} m, y={s.y:.2f} m, speed {s.speed:.2f} m/s")
    return status


if __name__ == "__main__":
    sys.exit(run_command("roar sim --serial", main))
