"""`roar record URL --out run.mcap`: drive a car with the keyboard (or hold it at neutral for
--for seconds) while everything is recorded into an MCAP file."""

from __future__ import annotations

import sys
import time

from roar.cli.sdk import (ArgumentParser, UserError, add_calibration_option, add_foxglove_option, add_url,
                          number_option, open_vehicle, path_option)


def parser() -> ArgumentParser:
    p = ArgumentParser(prog="roar record",
                       description="Drive with the keyboard (as `roar drive`) while everything is recorded into an "
                                   "MCAP file: every control message as sent (its text and what the car's parser "
                                   "makes of it), every line the car sends, and the car's state and pose, in "
                                   "Foxglove's own message types where one fits. Open the file in Foxglove, or "
                                   "read it with `roar replay`. With --for, no keyboard: the car is held at "
                                   "neutral and listened to for that long (its boot lines, telemetry).")
    add_url(p)
    p.add_argument("--out", type=path_option, required=True, metavar="MCAP", help="the file to write (replaced)")
    p.add_argument("--for", dest="seconds", type=number_option(0, 3600, "s", low_open=True), default=None,
                   metavar="SECONDS", help="listen at neutral this long instead of driving with the keyboard")
    add_foxglove_option(p, when="also ")
    add_calibration_option(p)
    return p


def main(argv: list[str]) -> int:
    from roar.cli.teleop import run

    args = parser().parse_args(argv)
    if args.seconds is None and not sys.stdin.isatty():  # before the car is opened and the file made
        raise UserError("roar record drives with the keyboard: run it in a terminal, or give --for SECONDS")
    from roar.recorder import Recorder

    if args.out.suffix.lower() != ".mcap":  # a typo like run.png would have an image replaced by a recording
        print(f"roar record: note: {args.out} does not end in .mcap; an MCAP recording is written there all the same",
              file=sys.stderr, flush=True)

    recorder = Recorder(args.out, {"car": args.url, "command": " ".join(sys.argv)},
                        simulated=args.url.split(":", 1)[0].lower() == "sim", serve_port=args.foxglove)
    if args.foxglove is not None:
        print(f"serving the channels live: Foxglove, Open connection, ws://127.0.0.1:{args.foxglove}", flush=True)
    try:
        car = open_vehicle(args, record=recorder)
    except BaseException:
        recorder.close()
        raise
    with car:
        if args.seconds is None:
            status = run(car)
        else:
            print(f"recording {args.url} at neutral for {args.seconds:g} s into {args.out}", flush=True)
            time.sleep(args.seconds)
            status = 0
    print(f"recorded {car.recorder.messages} messages into {args.out} (open it in Foxglove, or `roar replay "
          f"{args.out}`)")
    return status
