"""`roar calibrate`: set trim and end-points with the car holding each pulse as you type it.

At each prompt type a pulse width in microseconds (e.g. 1520), or +N / -N to nudge it, and
the car moves there at once; an empty line accepts the value shown.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TextIO

from roar.cli.sdk import ArgumentParser, UserError, add_url, path_option
from roar.calibration import ARM_WINDOW, THROTTLE_TRIM_RANGE, Calibration, ChannelCalibration
from roar.protocol import spec
from roar.vehicle import Vehicle

LO, HI, MID = spec.CONTROL_MIN_US, spec.CONTROL_MAX_US, spec.CONTROL_NEUTRAL_US


class Aborted(Exception):
    pass


def _ask(prompt: str, value: int, send, inp: TextIO, out: TextIO, lo: int = LO, hi: int = HI) -> int:
    """Adjust one pulse width interactively; returns the accepted value."""
    send(value)
    while True:
        out.write(f"  {prompt} [{value} us]: ")
        out.flush()
        line = inp.readline()
        if not line:
            raise Aborted
        text = line.strip()
        if not text:
            return value
        try:
            new = value + int(text) if text[0] in "+-" else int(text)
        except ValueError:
            out.write(f"  type a number of microseconds, +N or -N, or just Enter (got {text!r})\n")
            continue
        if not lo <= new <= hi:
            out.write(f"  {new} us is outside {lo}..{hi} us\n")
            continue
        value = new
        send(value)


def _yes(prompt: str, inp: TextIO, out: TextIO, default: bool) -> bool:
    out.write(f"  {prompt} [{'Y/n' if default else 'y/N'}]: ")
    out.flush()
    line = inp.readline()
    if not line:
        raise Aborted
    return default if not line.strip() else line.strip().lower().startswith("y")


def walk(car: Vehicle, path: Path, inp: TextIO, out: TextIO) -> int:
    """The walk-through on car, saved to path; prompts on out, answers from inp."""
    old = Calibration.load(path) if path.exists() else Calibration()
    out.write(__doc__.split("\n", 2)[2] + f"\nLift the car so its wheels are off the ground. Saving to {path}.\n")
    try:
        st = old.steering
        def hold(throttle_us: int, steering_us: int) -> None:  # the car shows each value as it is typed
            car.send_pulses(throttle_us, steering_us)
            car.flush()

        steer = lambda us: hold(MID, us)  # noqa: E731
        out.write("\nSteering\n")
        s_trim = _ask("trim: wheels pointing straight ahead", st.trim_us, steer, inp, out)
        s_min = _ask("left end: full left lock, servo not straining", st.min_us, steer, inp, out, hi=s_trim)
        s_max = _ask("right end: full right lock, servo not straining", st.max_us, steer, inp, out, lo=s_trim)
        steer(s_max)
        s_rev = not _yes("are the wheels turned to the RIGHT now?", inp, out, default=True)
        steer(s_trim)

        th = old.throttle
        throttle = lambda us: hold(us, s_trim)  # noqa: E731
        out.write("\nThrottle (wheels off the ground!)\n")
        out.write(f"  (the car arms only on a throttle within {ARM_WINDOW} us of {MID}, so trim stays in "
                  f"{THROTTLE_TRIM_RANGE[0]}..{THROTTLE_TRIM_RANGE[1]} us; if the wheels creep there, set the "
                  f"ESC's neutral: most learn it at power-up)\n")
        t_trim = _ask("trim: wheels still (ESC neutral)", min(max(th.trim_us, THROTTLE_TRIM_RANGE[0]), THROTTLE_TRIM_RANGE[1]),
                      throttle, inp, out, *THROTTLE_TRIM_RANGE)
        t_max = _ask("high end: full speed (the highest pulse you allow)", th.max_us, throttle, inp, out, lo=t_trim)
        throttle(t_trim)
        t_rev = not _yes("did the wheels turn FORWARD at the high end?", inp, out, default=True)
        t_min = _ask("low end: full speed the other way (the lowest pulse you allow)", th.min_us, throttle, inp, out, hi=t_trim)
        throttle(t_trim)
    except Aborted:
        out.write("\n")
        raise UserError("input ended: calibration not saved") from None
    try:
        new = Calibration(throttle=ChannelCalibration(trim_us=t_trim, min_us=t_min, max_us=t_max, reversed=t_rev),
                          steering=ChannelCalibration(trim_us=s_trim, min_us=s_min, max_us=s_max, reversed=s_rev))
    except ValueError as e:
        out.write("\n")
        raise UserError(f"calibration not saved: {e}") from None
    new.save(path)
    out.write(f"\nsaved {path}:\n  throttle {t_min}/{t_trim}/{t_max} us{' reversed' if t_rev else ''}\n"
              f"  steering {s_min}/{s_trim}/{s_max} us{' reversed' if s_rev else ''}\n")
    return 0


def parser() -> ArgumentParser:
    from roar.calibration import default_path

    p = ArgumentParser(prog="roar calibrate",
                       description="Walk through steering and throttle trim and end-points with the car "
                                   "holding each pulse as you type it; saves a calibration file.")
    add_url(p)
    p.add_argument("--file", type=path_option, default=None, metavar="TOML",
                   help=f"where to save (default: {default_path()})")
    return p


def main(argv: list[str]) -> int:
    from roar.calibration import default_path
    from roar.user_files import unwritable

    args = parser().parse_args(argv)
    path = args.file or default_path()
    problem = unwritable(path)  # before the walk-through, not after it
    if problem:
        raise UserError(f"--file {problem}")
    with Vehicle(args.url, calibration=None) as car:
        return walk(car, path, sys.stdin, sys.stdout)
