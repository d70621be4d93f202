"""The simulated Junior's physical limits, measured by driving it through its firmware over the
HTTP path: top speed and acceleration at full duty, how fast it slows when the duty drops to 0
(it coasts: the L298N's EN low, the gearbox's friction), and the steady lateral acceleration it
holds on a circle: it reaches its tightest circle (one wheel near stop) before its wheels slide,
so that figure is what it can do, not where grip ends.

JUNIOR_LIMITS holds the measured values; the suite re-measures them and fails if the robot
model changes without this table following.

    python -m roar_sim.robots.junior_limits      measures and prints them
"""

from __future__ import annotations

import sys

from roar.autopilot import CarLimits, DiffDriveModel
from roar.junior import query_for
from roar_sim.plants.junior import WHEEL_TRACK_M
from roar_sim.robots.junior import JuniorSim
from roar_sim.runs.limits import HOLDS_LINE, circle, drive, print_against, straight_line

JUNIOR_LIMITS = CarLimits(max_speed_m_s=0.55, max_accel_m_s2=3.11, max_brake_m_s2=1.36, max_lateral_m_s2=0.89)
JUNIOR_MODEL = DiffDriveModel(track_width_m=WHEEL_TRACK_M, limits=JUNIOR_LIMITS)


def _drive(sim: JuniorSim, left: float, right: float, seconds: float) -> list:
    return drive(sim, lambda: sim.get(query_for(left, right)), seconds)


def measure() -> CarLimits:
    with JuniorSim() as sim:
        _drive(sim, 0, 0, 0.2)
        run = _drive(sim, 1, 1, 2.0)
        top, accel, brake = straight_line(run, _drive(sim, 0, 0, 1.5))
    lateral = 0.0
    for inner in (0.9, 0.8, 0.7, 0.6, 0.5, 0.4, 0.3, 0.2):  # tighter and tighter circles at full outer duty
        with JuniorSim() as sim:
            _drive(sim, 0, 0, 0.2)
            radius, accel_lateral = circle(_drive(sim, 1.0, inner, 3.0)[-50:])  # the last second
        expected = (WHEEL_TRACK_M / 2) * (1 + inner) / (1 - inner)  # no slip: the wheels' speed ratio
        if radius > HOLDS_LINE * expected:
            break  # wider than the wheels ask for: they slide
        lateral = max(lateral, accel_lateral)
    return CarLimits(round(top, 2), round(accel, 2), round(brake, 2), round(lateral, 2))


def main() -> int:
    print_against(measure(), JUNIOR_LIMITS)
    return 0


if __name__ == "__main__":
    sys.exit(main())
