"""`roar dataset run.mcap --out tub`: a recording's camera frames, each with the command the car
was driving by, as a DonkeyCar tub or one .npz, for imitation learning (roar.dataset)."""

from __future__ import annotations

from roar.cli.sdk import ArgumentParser, UserError, path_option


def parser() -> ArgumentParser:
    p = ArgumentParser(prog="roar dataset",
                       description="Turn a recording's camera frames, each with the command the car was driving "
                                   "by when it was taken, into a dataset: a DonkeyCar tub v2 (--format donkey: "
                                   "DonkeyCar's own trainer reads it) or one .npz of arrays (--format npz: "
                                   "images, angle, throttle, t_s; examples/dataset_npz.py loads it for PyTorch). "
                                   "Angle and throttle are the pulses as fractions of their range, -1..1.")
    p.add_argument("file", type=path_option, metavar="MCAP", help="the recording (with camera frames)")
    p.add_argument("--format", choices=["donkey", "npz"], default="donkey", help="default donkey")
    p.add_argument("--out", type=path_option, required=True, metavar="PATH", help="the tub's folder, or the .npz")
    return p


def main(argv: list[str]) -> int:
    from roar.dataset import write_donkey, write_npz
    from roar.user_files import unusable_folder, unwritable

    args = parser().parse_args(argv)
    problem = unusable_folder(args.out) if args.format == "donkey" else unwritable(args.out)
    if problem:
        raise UserError(f"--out {problem}")
    count = (write_donkey if args.format == "donkey" else write_npz)(args.file, args.out)
    print(f"{count} frames with their commands into {args.out} ({args.format})")
    return 0
