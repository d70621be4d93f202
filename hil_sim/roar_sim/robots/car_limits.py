"""The simulated car's physical limits, measured by driving it through the firmware: top speed
and acceleration at full throttle, braking by reversing the motor (the ESC has no brake of its
own beyond the first tap), and the steady lateral acceleration it holds in a corner.

SIMULATED_LIMITS holds the measured values; the suite re-measures them and fails if the car
model changes without this table following.

    python -m roar_sim.robots.car_limits      measures and prints them
"""

from __future__ import annotations

import sys

from roar.autopilot import CarLimits, CarModel
from roar.protocol import encode, spec
from roar_sim.plants.esc_servo import SteeringServo
from roar_sim.robots.esc import SimCar
from roar_sim.runs.limits import HOLDS_LINE, circle, drive, print_against, straight_line
from roar_sim.plants.racecar import WHEELBASE_M

SIMULATED_LIMITS = CarLimits(max_speed_m_s=2.93, max_accel_m_s2=1.78, max_brake_m_s2=3.35, max_lateral_m_s2=3.38)
SIMULATED_CAR = CarModel(wheelbase_m=WHEELBASE_M, max_steer_rad=SteeringServo().max_angle_rad,
                         limits=SIMULATED_LIMITS)
N = spec.CONTROL_NEUTRAL_US


def _drive(sim: SimCar, throttle_us: int, steering_us: int, seconds: float) -> list:
    return drive(sim, lambda: sim.write(encode(throttle_us, steering_us)), seconds)


def measure() -> CarLimits:
    with SimCar() as sim:
        _drive(sim, N, N, 0.2)
        run = _drive(sim, spec.CONTROL_MAX_US, N, 4.0)
        top, accel, brake = straight_line(run, _drive(sim, spec.CONTROL_MIN_US, N, 2.0))
    lateral = 0.0
    for steer_us in (1650, 1700, 1750, 1800):  # circles at a fixed steering angle, faster and faster
        base_radius = None
        for throttle_us in range(1700, 2001, 50):
            with SimCar() as sim:
                _drive(sim, N, N, 0.2)
                radius, accel_lateral = circle(_drive(sim, throttle_us, steer_us, 5.0)[-100:])  # the last 2 s
            base_radius = base_radius or radius  # the slowest run: no slip
            if radius > HOLDS_LINE * base_radius:
                break  # the circle has widened: the tyres slide (understeer)
            lateral = max(lateral, accel_lateral)
    return CarLimits(round(top, 2), round(accel, 2), round(brake, 2), round(lateral, 2))


def main() -> int:
    print_against(measure(), SIMULATED_LIMITS)
    return 0


if __name__ == "__main__":
    sys.exit(main())
