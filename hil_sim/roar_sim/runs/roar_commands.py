"""The simulator's `roar` commands, registered through the "roar.commands" entry point group
(pyproject.toml): `roar race`, `roar sim`, `roar step-response` (the IARRC car's speed
controller), `roar sweep` and `roar platoon`. Each parses its own arguments; the simulator itself is imported only when a command
runs."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from roar.cli.plugins import Command

SIM_DESCRIPTION = """Without --serial: race the autopilot round a track and report the laps (like `roar race`).
With --serial: serve the simulated car on a pseudo-terminal and print its path, for any program
that speaks serial; Ctrl-C stops it (exit status 130).
With --junior: serve the simulated ROAR Junior's HTTP control route (--http HOST:PORT, default
127.0.0.1:8081) and its camera routes (the port below), and print both URLs; Ctrl-C stops it."""


def _race(argv: list[str]) -> int:
    from roar_sim.runs.race import main

    return main(argv)


def _sim(argv: list[str]) -> int:
    p = argparse.ArgumentParser(prog="roar sim", description=SIM_DESCRIPTION)
    p.add_argument("--serial", action="store_true", help="serve the car as a serial port (a pty) in real time")
    p.add_argument("--junior", action="store_true", help="serve the simulated ROAR Junior over HTTP in real time")
    p.add_argument("--stream", action="store_true",
                   help="be the car's phone: camera, depth and state over UDP (ROAR's ports 8001-8003), "
                        "control on 8004 (`roar sim --stream --help` for its options)")
    p.add_argument("--http", default="127.0.0.1:8081", metavar="HOST:PORT",
                   help="with --junior: the control route's address (default 127.0.0.1:8081; camera on PORT-1)")
    p.add_argument("--track", default=None,
                   help="oval, figure-eight, course or a track .json file (default: oval; with --junior an open floor)")
    p.add_argument("--gui", action="store_true", help="open the PyBullet window (needs a display)")
    p.add_argument("--car", choices=("esc", "iarrc"), default="esc",
                   help="with --serial: the ROAR ESC car (default) or the IARRC car (speed setpoints, telemetry)")
    p.add_argument("--seconds", type=float, default=0.0,
                   help="with --serial or --junior: stop after this long (default: Ctrl-C)")
    p.add_argument("--laps", type=int, default=2, help="without --serial: laps to drive (default 2)")
    p.add_argument("--plot", type=Path, metavar="PNG", help="without --serial: write the driven path to this PNG")
    if "--stream" in argv:  # its own options (size, rate, push)
        from roar_sim.links.phone_udp import main as stream

        return stream([a for a in argv if a != "--stream"])
    args = p.parse_args(argv)
    if args.junior and args.serial:
        p.error("--junior serves HTTP, not a serial port: give one of --junior, --serial")
    if args.car != "esc" and not args.serial:
        p.error("--car picks the car behind --serial; in Python use sim://?car=iarrc")
    gui = ["--gui"] if args.gui else []
    if args.junior:
        from roar_sim.links.junior_http import main as serve_junior

        track = ["--track", args.track] if args.track else []
        return serve_junior(["--http", args.http, "--seconds", str(args.seconds), *track, *gui])
    args.track = args.track or "oval"
    if args.serial:
        from roar_sim.links.pty import main as serve

        return serve(["--track", args.track, "--seconds", str(args.seconds), "--car", args.car, *gui])
    from roar_sim.runs.race import main as race

    plot = ["--plot", str(args.plot)] if args.plot else []
    return race(["--track", args.track, "--laps", str(args.laps), *gui, *plot])


race = Command("race the simulated car with the autopilot (`roar race --help`)", _race)
sim = Command("run a simulated car: a race, a serial port (--serial), or the Junior on HTTP (--junior)", _sim)

if __name__ == "__main__":
    sys.exit(_sim(sys.argv[1:]))


def _step_response(argv: list[str]) -> int:
    from roar_sim.runs.step_response import main

    return main(argv)


step_response = Command("the simulated IARRC car's speed PID answering a step, plotted (`roar step-response --help`)",
                        _step_response)


def _sweep(argv: list[str]) -> int:
    from roar_sim.runs.sweep import main

    return main(argv)


sweep = Command("race a grid of autopilot parameters x tracks as Ray tasks; CSV table and plot (`roar sweep --help`)",
                _sweep)


def _platoon(argv: list[str]) -> int:
    from roar_sim.runs.platoon import main

    return main(argv)


platoon = Command("two simulated cars platooning over UDP multicast (`roar platoon --help`)", _platoon)
