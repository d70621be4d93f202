"""Dead reckoning as a real car has it: the distance its wheels turned (an encoder's counts, or a
telemetry distance) and its gyro's yaw rate, integrated into a pose that drifts. The particle
filter takes what this pose moved between two scans; the drift is what the map corrects.

    odo = Odometry(pose=(0, 0, 0))
    odo.update(t_s, travelled_m=encoder.metres(counts), yaw_rate=gyro)   # -> (x, y, yaw)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from roar.checks import number

Pose = tuple[float, float, float]  # x [m], y [m], yaw [rad]
MAX_COORD_M = 1e5  # [m] a pose further from the map's origin than this is a mistake
MAX_YAW_RAD = 1e3  # [rad]


@dataclass(frozen=True)
class Encoder:
    """A wheel (or motor-shaft) encoder: counts per turn of the wheel, and the wheel's radius."""

    counts_per_rev: int  # [counts] per turn of the wheel (the IARRC car's: 10,240)
    wheel_radius_m: float  # [m]

    def metres(self, counts: int) -> float:
        """[m] the distance the wheel rolled in `counts`."""
        return counts / self.counts_per_rev * math.tau * self.wheel_radius_m


class Odometry:
    """A pose from travelled distance and yaw rate (midpoint rule: the heading half way through
    each step). Readings that are no numbers are ignored (counted in .ignored).

    front_axle_m: where the encoders are on the front wheels, this far ahead of the point whose
    pose is kept (the rear axle's middle: a car's wheelbase). In a turn the front wheels run a
    longer arc than the rear axle, by 1 / cos(steering) (9 % at 0.75 m radius for a 0.325 m
    wheelbase); the steering follows from the yaw rate: sin(steering) = yaw rate x front_axle_m
    / the front wheels' speed."""

    def __init__(self, pose: Pose = (0.0, 0.0, 0.0), front_axle_m: float = 0.0) -> None:
        self.pose = tuple(float(v) for v in pose)
        self.front_axle_m = front_axle_m
        self._last: tuple[float, float] | None = None  # (t [s], travelled [m])
        self.ignored = 0

    def update(self, t_s: float, travelled_m: float, yaw_rate: float) -> Pose:
        """The pose after the car has travelled travelled_m in all (signed: reversing counts
        down) by t_s [s], turning at yaw_rate [rad/s] since the last update."""
        if not all(isinstance(v, (int, float)) and math.isfinite(v) for v in (t_s, travelled_m, yaw_rate)):
            self.ignored += 1
            return self.pose
        if self._last is None or t_s <= self._last[0]:
            self._last = (t_s, travelled_m)
            return self.pose
        dt, d = t_s - self._last[0], travelled_m - self._last[1]
        if self.front_axle_m and d:
            sine = min(1.0, abs(yaw_rate) * self.front_axle_m * dt / abs(d))
            d *= math.sqrt(1.0 - sine * sine)  # the rear axle's arc
        x, y, yaw = self.pose
        mid = yaw + yaw_rate * dt / 2
        self.pose = (x + d * math.cos(mid), y + d * math.sin(mid), math.remainder(yaw + yaw_rate * dt, math.tau))
        self._last = (t_s, travelled_m)
        return self.pose


def relative(before: Pose, after: Pose) -> Pose:
    """(dx ahead, dy left, dyaw) [m, m, rad]: how `after` lies in the frame of `before`."""
    dx, dy = after[0] - before[0], after[1] - before[1]
    c, s = math.cos(before[2]), math.sin(before[2])
    return c * dx + s * dy, -s * dx + c * dy, math.remainder(after[2] - before[2], math.tau)


def compose(a: Pose, b: Pose) -> Pose:
    """Pose b (in a's frame) seen from a's parent frame: relative()'s inverse."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], math.remainder(a[2] + b[2], math.tau)


def checked_pose(name: str, pose) -> Pose:
    """A pose (x, y, yaw) of finite numbers, or ValueError naming it in one line."""
    try:
        x, y, yaw = pose
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be (x [m], y [m], yaw [rad]), got {pose!r}") from None
    return (number(f"{name} x", x, -MAX_COORD_M, MAX_COORD_M, "m"), number(f"{name} y", y, -MAX_COORD_M, MAX_COORD_M, "m"),
            number(f"{name} yaw", yaw, -MAX_YAW_RAD, MAX_YAW_RAD, "rad"))
