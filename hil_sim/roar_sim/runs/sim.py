"""`roar sim`: a simulated robot as a program reaches a real one -- raced round a track, or served
on a serial port (a pty), over HTTP (the Junior) or as the phone's UDP streams -- until Ctrl-C."""

from __future__ import annotations

import argparse
import sys

from roar.cli.sdk import ArgumentParser, UserError, add_foxglove_option, path_option, run_command, seconds_option
from roar.tracks.names import FORMS

SIM_DESCRIPTION = """Run a simulated robot (--robot esc, iarrc or junior; default esc) as a program reaches a
real one:
  (no link)   race the autopilot round a track and report the laps (like `roar race`)
  --serial    serve the car on a pseudo-terminal and print its path, for any program that speaks
              serial (the ESC and IARRC cars)
  --http      serve the ROAR Junior's HTTP control route (HOST:PORT, default 127.0.0.1:8081) and its
              camera routes (the port below), and print both URLs
  --stream    be the ESC car's phone: camera, depth and state over UDP (ROAR's ports 8001-8003),
              control on 8004 (`roar sim --stream --help` for its options)
Ctrl-C stops a served robot (exit status 130)."""
RENAMED = {"--junior": "--robot junior --http", "--car": "--robot"}  # earlier spellings, answered in one line


def parser() -> argparse.ArgumentParser:
    from roar_sim import robots

    p = ArgumentParser(prog="roar sim", description=SIM_DESCRIPTION)
    p.add_argument("--robot", choices=robots.names(), default="esc", help="which robot (default esc)")
    link = p.add_mutually_exclusive_group()
    link.add_argument("--serial", action="store_true", help="serve the car as a serial port (a pty) in real time")
    link.add_argument("--http", nargs="?", const="127.0.0.1:8081", metavar="HOST:PORT",
                      help="serve the Junior over HTTP in real time (default 127.0.0.1:8081; camera on PORT-1)")
    link.add_argument("--stream", action="store_true",
                      help="be the car's phone: its streams over UDP (`roar sim --stream --help` for its options)")
    p.add_argument("--track", default=None,
                   help=f"{FORMS} (default: oval; with --http an open floor)")
    p.add_argument("--gui", action="store_true", help="open the PyBullet window (needs a display)")
    p.add_argument("--seconds", type=seconds_option, default=None, metavar="S",
                   help="with --serial or --http: stop after this long (default: Ctrl-C)")
    p.add_argument("--laps", type=int, default=None, help="without a link: laps to drive (default 2)")
    p.add_argument("--plot", type=path_option, metavar="PNG", help="without a link: write the driven path to this PNG")
    add_foxglove_option(p, "the car's channels", when="without a link (then in real time), with --serial or --http: ")
    return p


def variants() -> dict[tuple[str, ...], argparse.ArgumentParser]:
    """--stream has its own options (size, rate, push): the phone's parser."""
    from roar_sim.links.phone_udp import parser as stream_parser

    return {("--stream",): stream_parser()}


def main(argv: list[str]) -> int:
    for old, new in RENAMED.items():
        if any(a == old or a.startswith(old + "=") for a in argv):
            raise UserError(f"{old} is {new} now (roar sim --help)")
    from roar_sim import robots

    if "--stream" in argv:
        from roar_sim.links.phone_udp import main as stream

        return stream([a for a in argv if a != "--stream"])
    args = parser().parse_args(argv)
    kind = robots.get(args.robot)
    for flag, name in (("serial", "--serial"), ("http", "--http")):
        if getattr(args, flag) not in (None, False) and flag not in kind.links:
            has = [n for n in robots.names() if flag in robots.get(n).links]
            raise UserError(f"the {kind.title} has no {'serial port' if flag == 'serial' else 'HTTP port'}: "
                            f"{name} serves {' or '.join(has)}")
    served = args.serial or args.http is not None
    if served and (args.laps is not None or args.plot):
        raise UserError("--laps and --plot are for a race (roar sim without --serial or --http)")
    if not served and args.seconds is not None:
        raise UserError("--seconds is how long --serial or --http serve; a race ends after its laps "
                        "(roar race --seconds sets its time limit)")
    gui = ["--gui"] if args.gui else []
    foxglove = ["--foxglove", str(args.foxglove)] if args.foxglove is not None else []
    seconds = ["--seconds", str(args.seconds)] if args.seconds is not None else []
    if args.http is not None:
        from roar_sim.links.junior_http import main as serve_junior

        track = ["--track", args.track] if args.track is not None else []
        return serve_junior(["--http", args.http, *seconds, *track, *gui, *foxglove])
    args.track = "oval" if args.track is None else args.track
    if args.serial:
        from roar_sim.links.pty import main as serve

        return serve(["--robot", args.robot, "--track", args.track, *seconds, *gui, *foxglove])
    from roar_sim.runs.race import main as race

    plot = ["--plot", str(args.plot)] if args.plot else []
    laps = ["--laps", str(args.laps)] if args.laps is not None else []
    return race(["--robot", args.robot, "--track", args.track, *laps, *gui, *plot,
                 *([*foxglove, "--realtime"] if foxglove else [])])


if __name__ == "__main__":
    sys.exit(run_command("roar sim", main, sys.argv[1:]))
