"""`roar drive URL`: drive a car with the keyboard (roar.cli.teleop); neutral on exit."""

from __future__ import annotations

from roar.cli.sdk import ArgumentParser, add_calibration_option, add_log_option, add_url, open_vehicle


def parser() -> ArgumentParser:
    p = ArgumentParser(prog="roar drive",
                       description="Keyboard teleop: W/S or Up/Down change throttle by 0.1, A/D or Left/Right "
                                   "steer by 0.2, space stops, Q quits. Neutral is sent on exit.")
    add_url(p)
    add_calibration_option(p)
    add_log_option(p)
    return p


def main(argv: list[str]) -> int:
    from roar.cli.teleop import run

    args = parser().parse_args(argv)
    with open_vehicle(args) as car:
        return run(car)
