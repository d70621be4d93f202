"""`roar replay run.mcap`: what a recording holds (duration, clock, car; per channel the count,
rate and longest gap), drawn with --plot, or its commands played to a car with --to; a rosbag2
folder: its topics, types, counts and rates."""

from __future__ import annotations

import sys

from roar.cli.sdk import ArgumentParser, UserError, path_option


def parser() -> ArgumentParser:
    p = ArgumentParser(prog="roar replay",
                       description="Summarise a recording (`roar record`, `--log`, Vehicle(record=...)): its "
                                   "duration, clock and car, and per channel the message count, rate and the "
                                   "longest gap, so a stalled sensor or link shows at a glance. --plot draws it; "
                                   "--to URL plays its commands to a car (the simulator, or a real one after you "
                                   "confirm) through the library, which re-sends them and ends at neutral.")
    p.add_argument("file", type=path_option, metavar="MCAP", help="the recording (or a rosbag2 folder: its topics)")
    p.add_argument("--plot", type=path_option, metavar="PNG", help="draw the path, the speed and the commands")
    p.add_argument("--to", metavar="URL", help="play the recorded commands to this car at their recorded times "
                                               "(a real car asks first; the failsafe rules hold as ever)")
    p.add_argument("--yes", action="store_true", help="with --to a real car: do not ask")
    return p


def main(argv: list[str]) -> int:
    from roar.replay import commands, play, plot, summary
    from roar.transports import open_url
    from roar.user_files import unwritable
    from roar.vehicle import Vehicle

    args = parser().parse_args(argv)
    if args.file.is_dir() and (args.file / "metadata.yaml").is_file():  # a rosbag2 (a ROS user's, or --bag's)
        if args.plot is not None or args.to is not None:
            raise UserError(f"{args.file} is a rosbag2: it is summarised only (--plot and --to take a roar recording)")
        try:
            from roar.ros2.bag import summary as bag_summary
        except ImportError as e:
            raise UserError(f"reading a rosbag2 needs {e.name}: pip install 'roar-platform[ros2]'") from None
        print(bag_summary(args.file))
        return 0
    if args.plot is not None and unwritable(args.plot):
        raise UserError(f"--plot {unwritable(args.plot)}")
    print(summary(args.file), flush=True)
    if args.plot is not None:
        plot(args.file, args.plot)
        print(f"plot: {args.plot}")
    if args.to is None:
        return 0
    todo = commands(args.file)
    if not todo:
        raise UserError(f"{args.file}: no control messages to play")
    open_url(args.to)  # a URL that names no car is refused before anyone is asked to confirm driving one
    scheme = args.to.split(":", 1)[0].lower()
    if scheme not in ("sim", "loop") and not args.yes:
        if not sys.stdin.isatty():
            raise UserError(f"--to {args.to} drives a real car: run in a terminal to confirm, or add --yes")
        answer = input(f"play {len(todo)} commands over {todo[-1][0]:.1f} s to {args.to}? the car will move "
                       f"(type yes): ")
        if answer.strip().lower() != "yes":
            print("not played")
            return 1
    with Vehicle(args.to, calibration=None) as car:
        played = play(args.file, car)
    print(f"played {played} commands to {args.to} over {todo[-1][0]:.1f} s; neutral sent")
    return 0
