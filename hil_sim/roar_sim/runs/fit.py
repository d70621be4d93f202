"""`roar fit URL --out mycar.toml`: fit the simulated car to your car. It drives a test drive (a
figure eight in the free floor around the car: throttle steps, braking, a launch, coasting,
steering steps and a sweep, then faster until the tyres let go), records it, fits a model of the
servo, ESC, motor and tyres to it (least squares, 95 % intervals), and finds the car profile the
simulator drives the same way: `sim://?profile=mycar.toml` and `roar race --car-profile
mycar.toml` are then your car. The steering trim it finds goes into your calibration file, so
the car itself drives straight.

    roar fit serial:///dev/ttyUSB0 --pose udp://192.168.1.20 --out mycar.toml   the phone on the car gives its pose
    roar fit udp://192.168.1.20 --out mycar.toml                                driven through the phone
    roar fit mycar.mcap --out mycar.toml                                        again, from the recorded drive
    roar fit sim:// --out sim.toml                                              the simulator's own car

Before it starts: the car stands in the middle of a free area (--area AHEADxACROSS, metres along
the car's heading x to its sides; default 4x6), facing along its shorter side. Ctrl-C or any key
stops the car at neutral; so does leaving the area, or the poses stopping.
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import sys
import threading
from pathlib import Path

from roar.cli.sdk import ArgumentParser, ExitStatus, UserError, int_option, path_option, run_command
from roar.fit.drive import HELD_OUT, MANOEUVRES, Area
from roar.fit.log import FitError, FitLog
from roar.protocol import spec
from roar.user_files import unwritable
from roar_sim.runs.fit_profile import ROUNDS

DEFAULT_AREA = "4x6"
TRIM_LIMIT_US = 150  # [us] a steering trim beyond this is the servo horn off its spline: not written


def parser() -> argparse.ArgumentParser:
    p = ArgumentParser(prog="roar fit", description=__doc__)
    p.add_argument("source", metavar="URL|RECORD.mcap",
                   help="the car to drive (serial://, udp://, sim://, ...), or a test drive recorded before")
    p.add_argument("--out", type=path_option, required=True, metavar="TOML",
                   help="the car profile to write (roar race --car-profile TOML, sim://?profile=TOML)")
    p.add_argument("--base", default="roar", metavar="NAME|TOML",
                   help="the profile whose size, mass and gearing are your car's (default roar, the ROAR car); "
                        "the fit finds the rest")
    p.add_argument("--area", default=DEFAULT_AREA, metavar="AHEADxACROSS",
                   help=f"the free floor around the car in metres, along its heading x to its sides (default "
                        f"{DEFAULT_AREA})")
    p.add_argument("--pose", metavar="URL",
                   help="where the car's pose comes from when its own link gives none: the phone on the car "
                        "(udp://PHONE, ROAR's app) or any URL whose state has a position and heading")
    p.add_argument("--record", type=path_option, metavar="MCAP",
                   help="where to record the test drive (default: the --out name with .mcap)")
    p.add_argument("--plot", type=path_option, metavar="PNG",
                   help="the report: predicted against measured on the held-out manoeuvre (default: the --out "
                        "name with .png)")
    p.add_argument("--calibration", type=path_option, metavar="TOML",
                   help="the calibration file the steering trim goes into (default: yours, as roar calibrate "
                        "keeps it)")
    p.add_argument("--rounds", type=int_option(1, 10), default=ROUNDS, metavar="N",
                   help=f"simulated test drives that correct the profile towards your car (default {ROUNDS}; "
                        f"each about 5 s)")
    p.add_argument("--no-trim", action="store_true", help="leave the calibration file alone")
    p.add_argument("--yes", action="store_true", help="a real car: drive without asking first")
    return p


def main(argv: list[str] | None = None) -> int:
    from roar_sim import ProfileError
    from roar_sim.plants import car_profile

    args = parser().parse_args(argv)
    if not args.source.strip():
        raise UserError("give the car's URL (serial://..., udp://PHONE, sim://) or a recorded test drive (.mcap)")
    area = Area.parse(args.area)
    radius = area.radius()
    try:
        base = car_profile.load(args.base)
    except ProfileError as e:
        raise UserError(f"--base: {e}") from None
    from_record = args.source.lower().endswith(".mcap") and "://" not in args.source
    record_path = args.record or (None if from_record else args.out.with_suffix(".mcap"))
    plot_path = args.plot or args.out.with_suffix(".png")
    for option, path in (("--out", args.out), ("--record", record_path), ("--plot", plot_path)):
        if path is not None and unwritable(path):
            raise UserError(f"{option} {unwritable(path)}")
    if from_record and args.pose:
        raise UserError("--pose is where a drive's poses come from: a recorded drive has its own")
    if from_record:
        record = FitLog.from_mcap(args.source)
        stopped = ""
        print(f"{args.source}: {record.pose_t[-1] - record.pose_t[0]:.0f} s of poses from "
              f"{record.source or 'a pose source'}", flush=True)
    else:
        record, stopped = _drive(args, area, radius, base.wheelbase_m, record_path)
    return _fit(args, record, stopped, base, area, plot_path)


def _drive(args, area: Area, radius: float, wheelbase_m: float, record_path: Path) -> tuple[FitLog, str]:
    from roar.fit.live import Poses, drive_car
    from roar.recorder import Recorder
    from roar.vehicle import Vehicle

    scheme = args.source.split(":", 1)[0].lower()
    if "speedup=" in args.source:
        raise UserError("a test drive runs in real time: leave speedup= out of the URL")
    car = Vehicle(args.source)
    poses = None
    try:
        poses = Poses.open(args.pose) if args.pose else Poses.of_vehicle(car)
        try:
            poses.wait_first()
        except FitError as e:
            if args.pose:
                raise
            raise FitError(f"{args.source} reports no pose, and a fit measures the car by its pose: put the phone "
                           f"on the car and add --pose udp://PHONE (ROAR's app), or drive through it: roar fit "
                           f"udp://PHONE") from e
        if car.told_version() == spec.META_SPEED_VERSION:  # (a busy machine may give the pose first)
            raise FitError(f"{args.source} drives by speed setpoints (it says READY {spec.META_SPEED_VERSION}): the "
                           f"test drive sends an ESC car's pulses; a speed-controlled car is not fitted yet")
        if scheme not in ("sim", "loop") and not args.yes:
            if not sys.stdin.isatty():
                raise UserError(f"{args.source} is a real car that will drive a figure eight: run in a terminal to "
                                f"confirm, or add --yes")
            answer = input(f"the car will drive a figure eight of {radius:.2f} m circles within {area.ahead_m:g} m "
                           f"ahead x {area.across_m:g} m across, for about a minute; clear the area (type yes): ")
            if answer.strip().lower() != "yes":
                print("not driven")
                raise KeyboardInterrupt
        print(f"test drive: a figure eight of {radius:.2f} m circles in {area.ahead_m:g} x {area.across_m:g} m, "
              f"{len(MANOEUVRES)} manoeuvres; Ctrl-C{' or any key' if sys.stdin.isatty() else ''} stops at neutral",
              flush=True)
        stop = threading.Event()
        with Recorder(record_path, {"car": args.source, "pose": poses.name, "command": " ".join(sys.argv)}) as rec, \
                _any_key(stop):
            record, stopped = drive_car(car, poses, area, wheelbase_m, rec, stop,
                                        on_phase=lambda name, t: print(f"  {t:5.1f} s  {name}: "
                                                                       + next(m.what for m in MANOEUVRES
                                                                              if m.name == name), flush=True))
    finally:
        car.close()
        if poses is not None and args.pose:
            poses.close()
    print(f"recorded {record_path} ({record.pose_t[-1] - record.pose_t[0]:.0f} s, {len(record.pose_t)} poses from "
          f"{poses.name})" + (f"; the drive ended early: {stopped}" if stopped else ""), flush=True)
    return record, stopped


def _fit(args, record: FitLog, stopped: str, base, area: Area, plot_path: Path) -> int:
    from roar.fit.identify import fit
    from roar.fit.report import plot
    from roar_sim.plants import car_profile
    from roar_sim.runs.fit_profile import MATCHED, matched_profile, rounded

    names = [n for _, n in record.phases]
    result = fit(record, base.wheelbase_m, held_out=HELD_OUT if HELD_OUT in names else "")
    print("the car as the model sees it (95 % intervals):\n" + result.table(), flush=True)
    if result.held_out is not None:
        v, w = result.held_out.rms()
        print(f"predicted on the held-out {HELD_OUT}: speed within {v:.3f} m/s RMS, yaw rate within {w:.3f} rad/s RMS")
    pose_hz = (len(record.pose_t) - 1) / (record.pose_t[-1] - record.pose_t[0])
    noise_m = record.pose_noise_m()
    print(f"matching the simulated car to it (the same test drive, simulated, poses {pose_hz:.0f} Hz with "
          f"{noise_m * 1000:.1f} mm of noise as measured):", flush=True)
    profile, _ = matched_profile(result.car, result.sigma, base, area, pose_hz, rounds=args.rounds,
                                 progress=lambda text: print(f"  {text}", flush=True), noise_m=noise_m)
    profile = rounded(profile)
    stamp = datetime.date.today().isoformat()
    profile = dataclasses.replace(profile, name=args.out.stem, title=f"fitted on {stamp} from {args.source}"[:60])
    car_profile.save(profile, args.out, f"roar fit {args.source} (base: {args.base}), {stamp}\n"
                     f"load it: roar race --car-profile {args.out}, or sim://?profile={args.out}")
    print(f"wrote {args.out}: " + ", ".join(f"{k} {getattr(profile, k):g}" for k in MATCHED), flush=True)
    plot(record, result, plot_path, title=f"roar fit {args.source}")
    print(f"report: {plot_path}")
    if not args.no_trim:
        print(_trim(args, profile))
    if stopped:
        print(f"the drive ended early ({stopped}): the fit used what was recorded", file=sys.stderr)
        return ExitStatus.SHORT
    return ExitStatus.OK


def _trim(args, profile) -> str:
    """Put the steering trim that makes the car drive straight into the calibration file."""
    import math

    from roar.calibration import HI, LO, MID, Calibration, default_path

    path = args.calibration or default_path()
    calibration = Calibration.load(path) if Path(path).exists() else Calibration()
    steering = calibration.steering
    # the wheels sit at trim with a 1500 us pulse; +1 steers right: the pulse that makes them straight
    offset_us = round((HI - LO) / 2 * math.radians(profile.steering_trim_deg) / profile.max_steer_rad)
    offset_us = -offset_us if steering.reversed else offset_us
    trim_us = MID + offset_us
    if abs(offset_us) > TRIM_LIMIT_US:
        return (f"calibration left as it is: a steering trim of {offset_us:+d} us is more than {TRIM_LIMIT_US} us: "
                f"re-seat the servo horn one spline over, then fit again")
    if not steering.min_us < trim_us < steering.max_us:
        return f"calibration left as it is: a steering trim of {trim_us} us is outside its end-points"
    new = Calibration(throttle=calibration.throttle,
                      steering=dataclasses.replace(steering, trim_us=trim_us))
    new.save(path)
    return f"calibration: steering trim {steering.trim_us} -> {trim_us} us in {path} (the car now drives straight)"


class _any_key:
    """Within the block, a key pressed on the terminal sets `stop` (nothing when stdin is no terminal)."""

    def __init__(self, stop: threading.Event) -> None:
        self.stop, self._saved, self._done = stop, None, threading.Event()

    def __enter__(self):
        if not sys.stdin.isatty():
            return self
        import termios
        import tty

        fd = sys.stdin.fileno()
        self._saved = termios.tcgetattr(fd)
        tty.setcbreak(fd)
        threading.Thread(target=self._watch, args=(fd,), name="any-key", daemon=True).start()
        return self

    def _watch(self, fd: int) -> None:
        import os
        import select

        while not self._done.is_set():
            if select.select([fd], [], [], 0.1)[0]:
                os.read(fd, 64)
                self.stop.set()
                return

    def __exit__(self, *exc) -> None:
        self._done.set()
        if self._saved is not None:
            import termios

            termios.tcsetattr(sys.stdin.fileno(), termios.TCSADRAIN, self._saved)


if __name__ == "__main__":
    sys.exit(run_command("roar fit", main))
