"""`roar`: one command for cars on USB serial, Bluetooth LE or in the simulator.

A car is named by a URL:
  sim://                      the simulated car on an open floor (sim://oval for a track)
  serial:///dev/ttyUSB0       a car on USB serial (find the port with `roar ports`)
  ble://  ble://ROAR Car      a car over Bluetooth LE (find it with `roar scan`)
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from roar.calibration import CalibrationError, default_path

EXAMPLES = """examples:
  roar race --track figure-eight         the autopilot laps the simulated car against the physical limit
  roar sim --serial                      the simulated car as a serial port (prints its path)
  roar send sim:// --throttle 0.3 --steering 0.5 --for 5
  roar drive serial:///dev/ttyUSB0       drive with the keyboard
  roar calibrate ble://                  set trim and end-points, saved for next time
  roar <command> --help                  more about one command
"""


class UserError(Exception):
    """A one-line message for the user; exit status 1."""


def _add_url(p: argparse.ArgumentParser) -> None:
    p.add_argument("url", metavar="URL", help="the car: sim://, serial:///dev/ttyUSB0, ble://NAME (see `roar --help`)")


def _add_calibration(p: argparse.ArgumentParser) -> None:
    p.add_argument("--calibration", type=Path, metavar="TOML",
                   help=f"calibration file (default: {default_path()} if it exists)")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="roar", description=__doc__, epilog=EXAMPLES,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("-v", "--verbose", action="store_true", help="log what the library does")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    p = sub.add_parser("send", help="hold one command for a while, then stop",
                       description="Send throttle and steering (each -1..1) for some seconds, then neutral.")
    _add_url(p)
    p.add_argument("--throttle", type=float, default=0.0, help="-1 (full reverse) .. 1 (full forward); default 0")
    p.add_argument("--steering", type=float, default=0.0, help="-1 (full left) .. 1 (full right); default 0")
    p.add_argument("--for", dest="seconds", type=float, default=1.0, metavar="SECONDS",
                   help="how long to hold it (default 1 s, at most 3600)")
    _add_calibration(p)

    p = sub.add_parser("drive", help="drive with the keyboard",
                       description="Keyboard teleop: W/S or Up/Down change throttle by 0.1, A/D or Left/Right "
                                   "steer by 0.2, space stops, Q quits. Neutral is sent on exit.")
    _add_url(p)
    _add_calibration(p)

    p = sub.add_parser("calibrate", help="set trim and end-points interactively",
                       description="Walk through steering and throttle trim and end-points with the car "
                                   "holding each pulse as you type it; saves a calibration file.")
    _add_url(p)
    p.add_argument("--file", type=Path, default=None, metavar="TOML",
                   help=f"where to save (default: {default_path()})")

    p = sub.add_parser("scan", help="list Bluetooth LE cars nearby",
                       description="Scan for cars advertising the ROAR service (or every device with --all).")
    p.add_argument("--timeout", type=float, default=5.0, metavar="SECONDS", help="how long to listen (default 5)")
    p.add_argument("--all", action="store_true", help="list every device, not only ROAR cars")

    sub.add_parser("ports", help="list serial ports", description="List serial ports, marking likely car boards.")

    # Listed here for --help; its own options are parsed by roar_sim.race (see main()).
    sub.add_parser("race", help="race the simulated car with the autopilot", add_help=False)

    p = sub.add_parser("sim", help="run the simulated car",
                       description="Without --serial: race the autopilot round a track and report the laps "
                                   "(like `roar race`). With --serial: serve the simulated car on a "
                                   "pseudo-terminal and print its path, for any program that speaks serial.")
    p.add_argument("--serial", action="store_true", help="serve the car as a serial port (a pty) in real time")
    p.add_argument("--track", default="oval", help="oval, figure-eight or a track .json file (default: oval)")
    p.add_argument("--gui", action="store_true", help="open the PyBullet window (needs a display)")
    p.add_argument("--seconds", type=float, default=0.0, help="with --serial: stop after this long (default: Ctrl-C)")
    p.add_argument("--laps", type=int, default=2, help="without --serial: laps to drive (default 2)")
    p.add_argument("--plot", type=Path, metavar="PNG", help="without --serial: write the driven path to this PNG")
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["race"]:  # the race has its own options and --help
        from roar_sim.race import main as race_main

        try:
            return race_main(argv[1:])
        except KeyboardInterrupt:
            print(file=sys.stderr)
            return 130
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING, format="roar: %(message)s")
    from roar.cli import commands
    from roar.transports import TransportError

    try:
        return getattr(commands, args.command)(args)
    except KeyboardInterrupt:
        print(file=sys.stderr)
        return 130
    except (UserError, TransportError, CalibrationError, ValueError) as e:
        print(f"roar {args.command}: error: {e}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
