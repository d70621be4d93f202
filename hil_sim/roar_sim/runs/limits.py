"""`roar limits`: measure a simulated robot's physical limits (top speed, acceleration, braking,
lateral grip) by driving it through its firmware, and print them beside the table the autopilot
plans with (each robot module's LIMITS; the suite re-measures them and fails when the robot's
model changes without its table following).

    roar limits [esc iarrc junior]      (default: every robot)

Exit status: 0 when every measurement is within 5 % (or 0.02) of its table, 2 otherwise.
"""

from __future__ import annotations

import argparse
import math
import sys

from roar.autopilot import CarLimits
from roar.cli.sdk import ArgumentParser, ExitStatus, run_command
from roar_sim import robots

REL_TOLERANCE, ABS_TOLERANCE = 0.05, 0.02  # how far a measurement may be from its table entry


def agrees(measured: CarLimits, table: CarLimits) -> bool:
    def close(a: float, b: float) -> bool:
        return math.isclose(a, b, rel_tol=REL_TOLERANCE, abs_tol=ABS_TOLERANCE)

    fades = measured.lateral_fade, table.lateral_fade
    return (all(close(getattr(measured, k), getattr(table, k)) for k in vars(table) if k != "lateral_fade")
            and len(fades[0]) == len(fades[1])
            and all(close(a, b) for p, q in zip(*fades) for a, b in zip(p, q)))


def fade_text(fade: tuple) -> str:
    return ", ".join(f"{a:.2f} at {v:.2f} m/s" for v, a in fade) or "none"


def report(name: str, measured: CarLimits, table: CarLimits) -> str:
    kind = robots.get(name)
    lines = [f"{kind.title} ({name}):"]
    for key, value in vars(measured).items():
        if key == "lateral_fade":
            lines.append(f"  {key:18} {fade_text(value)}   (table: {fade_text(table.lateral_fade)})")
        else:
            lines.append(f"  {key:18} {value:6.2f}   (table: {getattr(table, key):.2f})")
    return "\n".join(lines)


def parser() -> argparse.ArgumentParser:
    p = ArgumentParser(prog="roar limits", description=__doc__)
    p.add_argument("robots", nargs="*", choices=[[], *robots.names()], metavar="ROBOT",
                   help=f"which robots ({', '.join(robots.names())}; default: all)")
    return p


def main(argv: list[str] | None = None) -> int:
    names = parser().parse_args(argv).robots or list(robots.names())
    status = ExitStatus.OK
    for name in names:
        kind = robots.get(name)
        measured = kind.measure_limits()
        print(report(name, measured, kind.limits), flush=True)
        if not agrees(measured, kind.limits):
            status = ExitStatus.SHORT
    return status


if __name__ == "__main__":
    sys.exit(run_command("roar limits", main))
