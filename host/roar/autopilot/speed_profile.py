"""Speed profile of a closed path from its curvature and the car's limits, and the lap time it
gives: the physical limit a driver is measured against.

    v(s) <= min(v_max, sqrt(a_lat / kappa(s)))          grip in corners
    forward pass:  v[i+1]^2 <= v[i]^2 + 2 a_accel ds     how fast the car can speed up
    backward pass: v[i]^2   <= v[i+1]^2 + 2 a_brake ds   how late it can brake
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class CarLimits:
    max_speed_m_s: float  # [m/s] top speed at full throttle
    max_accel_m_s2: float  # [m/s^2] from rest at full throttle
    max_brake_m_s2: float  # [m/s^2] slowing down (for an ESC without brake: reversing the motor)
    max_lateral_m_s2: float  # [m/s^2] steady cornering before the tyres slide
    # the strongest reverse throttle that brakes it in a straight line (a fast car's rear wheels
    # reversed at full power lose their grip and it spins); max_brake_m_s2 is measured at it
    max_reverse: float = 1.0

    def __post_init__(self) -> None:
        for name, value in vars(self).items():
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number, got {value!r}")

    def with_margin(self, fraction: float) -> CarLimits:
        """The limits a driver plans with: `fraction` of the grip (cornering and braking), all of
        the car's own speed and acceleration (the motor cannot be overdriven anyway)."""
        return CarLimits(self.max_speed_m_s, self.max_accel_m_s2, fraction * self.max_brake_m_s2,
                         fraction * self.max_lateral_m_s2, self.max_reverse)


def curvature(points: np.ndarray) -> np.ndarray:
    """[1/m] unsigned curvature at each point of a closed polyline (circle through neighbours)."""
    a, b, c = np.roll(points, 1, axis=0), points, np.roll(points, -1, axis=0)
    ab, bc, ca = (np.linalg.norm(b - a, axis=1), np.linalg.norm(c - b, axis=1), np.linalg.norm(a - c, axis=1))
    cross = np.abs((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0])
    return 2 * cross / np.maximum(ab * bc * ca, 1e-12)


def speed_profile(points: np.ndarray, limits: CarLimits, passes: int = 3) -> np.ndarray:
    """[m/s] the fastest speed at each point of a closed path within the limits."""
    kappa = curvature(points)
    v = np.minimum(limits.max_speed_m_s, np.sqrt(limits.max_lateral_m_s2 / np.maximum(kappa, 1e-9)))
    ds = np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1)  # point i to i+1
    n = len(v)
    for _ in range(passes):  # a closed loop: go round until the wrap-around settles
        for i in range(n):
            j = (i + 1) % n
            v[j] = min(v[j], math.sqrt(v[i] ** 2 + 2 * limits.max_accel_m_s2 * ds[i]))
        for i in range(n - 1, -1, -1):
            j = (i + 1) % n
            v[i] = min(v[i], math.sqrt(v[j] ** 2 + 2 * limits.max_brake_m_s2 * ds[i]))
    return v


def lap_time(points: np.ndarray, speeds: np.ndarray) -> float:
    """[s] time to drive the closed path at the given point speeds (mean speed per segment)."""
    ds = np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1)
    mean = (speeds + np.roll(speeds, -1)) / 2
    return float(np.sum(ds / np.maximum(mean, 1e-9)))


def limit_lap_time(points: np.ndarray, limits: CarLimits) -> float:
    """[s] the physical-limit lap time of a closed path for a car with these limits."""
    return lap_time(points, speed_profile(points, limits))
