"""What a ROS 2 command asks of a car, as the car's own command: an Ackermann drive (F1TENTH's
/drive: speed [m/s], front-wheel angle [rad]) or a Twist (Nav2's /cmd_vel: forward speed [m/s],
yaw rate [rad/s]) becomes throttle or a speed setpoint, and steering, through what the car is
(roar.autopilot.CarModel: wheelbase, steering lock, top speed).

No ROS here: the bridge (roar.ros2.bridge) hands over the numbers, so this is what the suite checks
without a ROS graph. A number that no car could mean (not finite, a speed beyond ABSURD_SPEED_M_S,
a wheel angle at or beyond a right angle) is refused and counted; one beyond this car's reach
(faster than its top speed, steered past its lock) is driven at that reach."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from roar.autopilot import CarModel, DiffDriveModel, SpeedController
from roar.errors import RefusedCommand

ABSURD_SPEED_M_S = 50.0  # [m/s] no 1/10 car: a command asking more is refused, not clipped
# [m/s] slower than this a Twist's yaw rate asks for no steering (an Ackermann car cannot turn in place)
STANDSTILL_M_S = 0.05


@dataclass(frozen=True)
class Ask:
    """One command, in the car's terms: a speed [m/s] (forward positive) and the curvature of the
    path asked [1/m] (left positive)."""

    speed_m_s: float
    curvature_per_m: float = 0.0


def ackermann(speed_m_s: float, steering_rad: float, wheelbase_m: float) -> Ask:
    if not (math.isfinite(speed_m_s) and math.isfinite(steering_rad)):
        raise RefusedCommand("not a finite number")
    if abs(speed_m_s) > ABSURD_SPEED_M_S:
        raise RefusedCommand(f"speed {speed_m_s:g} m/s")
    if abs(steering_rad) >= math.pi / 2:
        raise RefusedCommand(f"steering angle {steering_rad:g} rad")
    return Ask(speed_m_s, math.tan(steering_rad) / wheelbase_m)


def twist(speed_m_s: float, yaw_rate_rad_s: float) -> Ask:
    if not (math.isfinite(speed_m_s) and math.isfinite(yaw_rate_rad_s)):
        raise RefusedCommand("not a finite number")
    if abs(speed_m_s) > ABSURD_SPEED_M_S:
        raise RefusedCommand(f"speed {speed_m_s:g} m/s")
    return Ask(speed_m_s, 0.0 if abs(speed_m_s) < STANDSTILL_M_S else yaw_rate_rad_s / speed_m_s)


@dataclass
class Driver:
    """Turns Asks into what roar.Vehicle.drive takes, each control period: steering in [-1, 1]
    (right positive, as the car's servo), and throttle in [-1, 1] by a speed controller on the
    measured speed (open loop, speed / top speed, where the car reports none), or the speed itself
    for a car that holds a speed (by_speed)."""

    model: CarModel | DiffDriveModel
    by_speed: bool = False  # the car takes speed setpoints (the IARRC car)
    controller: SpeedController = field(init=False)

    def __post_init__(self) -> None:
        limits = self.model.limits
        self.controller = SpeedController(limits.max_speed_m_s, max_reverse=limits.max_reverse)

    def steering(self, ask: Ask) -> float:
        if isinstance(self.model, DiffDriveModel):  # the wheels' speeds differ by curvature x track / 2
            command = -ask.curvature_per_m * self.model.track_width_m / 2
        else:
            command = -math.atan(self.model.wheelbase_m * ask.curvature_per_m) / self.model.max_steer_rad
        return max(-1.0, min(1.0, command))

    def command(self, ask: Ask, measured_m_s: float | None, dt_s: float) -> dict[str, float]:
        """Keyword arguments for Vehicle.drive."""
        top = self.model.limits.max_speed_m_s
        speed = max(-top, min(top, ask.speed_m_s))
        steering = self.steering(ask)
        if self.by_speed:
            return {"speed": max(0.0, speed), "steering": steering}
        if speed <= 0 or measured_m_s is None:
            self.controller.reset()
            return {"throttle": max(-1.0, min(1.0, speed / top)), "steering": steering}
        return {"throttle": self.controller.step(speed, abs(measured_m_s), dt_s), "steering": steering}

    def neutral(self) -> dict[str, float]:
        self.controller.reset()
        return {"speed": 0.0, "steering": 0.0} if self.by_speed else {"throttle": 0.0, "steering": 0.0}
