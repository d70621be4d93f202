"""Speed profile of a closed path from its curvature and the car's limits, and the lap time it
gives: the physical limit a driver is measured against.

    v(s) <= min(v_max, sqrt(a_lat(v) / kappa(s)))       grip in corners (a_lat fades with speed)
    forward pass:  v[i+1]^2 <= v[i]^2 + 2 e a_accel ds   how fast the car can speed up
    backward pass: v[i]^2   <= v[i+1]^2 + 2 e a_brake ds  how late it can brake
    e = sqrt(1 - (v^2 kappa / a_lat(v))^2)              what the bend leaves of the grip (>= ELLIPSE_FLOOR)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


ELLIPSE_FLOOR = 0.3  # the least share of its acceleration and braking a car keeps at its cornering limit


@dataclass(frozen=True)
class CarLimits:
    max_speed_m_s: float  # [m/s] top speed at full throttle
    max_accel_m_s2: float  # [m/s^2] from rest at full throttle
    max_brake_m_s2: float  # [m/s^2] slowing down (for an ESC without brake: reversing the motor)
    max_lateral_m_s2: float  # [m/s^2] steady cornering before the tyres slide
    # the strongest reverse throttle that brakes it in a straight line (a fast car's rear wheels
    # reversed at full power lose their grip and it spins); max_brake_m_s2 is measured at it
    max_reverse: float = 1.0
    # where the grip fades with speed: (speed [m/s], lateral [m/s^2]) points, the first where the
    # car holds max_lateral_m_s2, then the most it held at faster speeds (a fast car's wheels are
    # braked by the simulator's damping and its tyres slip more); beyond the last, bends no
    # tighter than the last point's radius. Empty: max_lateral_m_s2 up to top speed.
    lateral_fade: tuple[tuple[float, float], ...] = ()

    def __post_init__(self) -> None:
        for name, value in vars(self).items():
            if name != "lateral_fade" and not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number, got {value!r}")
        try:
            points = tuple((float(v), float(a)) for v, a in self.lateral_fade)
        except (TypeError, ValueError):
            raise ValueError(f"lateral_fade must be (speed, lateral) pairs, got {self.lateral_fade!r}") from None
        speeds, laterals = [v for v, _ in points], [a for _, a in points]
        if points and not (all(math.isfinite(x) and x > 0 for x in speeds + laterals) and len(points) > 1
                           and speeds == sorted(set(speeds)) and laterals == sorted(laterals, reverse=True)):
            raise ValueError(f"lateral_fade must be two or more positive (speed, lateral) pairs, speeds rising and "
                             f"laterals falling, got {self.lateral_fade!r}")
        object.__setattr__(self, "lateral_fade", points)  # a list read from JSON: kept as a tuple

    def with_margin(self, fraction: float) -> CarLimits:
        """The limits a driver plans with: `fraction` of the grip (cornering and braking), all of
        the car's own speed and acceleration (the motor cannot be overdriven anyway)."""
        return CarLimits(self.max_speed_m_s, self.max_accel_m_s2, fraction * self.max_brake_m_s2,
                         fraction * self.max_lateral_m_s2, self.max_reverse,
                         tuple((v, fraction * a) for v, a in self.lateral_fade))

    def lateral_at(self, speed_m_s: np.ndarray | float) -> np.ndarray:
        """[m/s^2] the lateral acceleration it holds at each speed [m/s]."""
        v = np.asarray(speed_m_s, dtype=float)
        if not self.lateral_fade:
            return np.full(v.shape, self.max_lateral_m_s2)
        speeds, laterals = np.array(self.lateral_fade).T
        held = np.interp(v, speeds, laterals, left=self.max_lateral_m_s2)
        beyond = v > speeds[-1]  # no tighter than the last circle measured
        return np.where(beyond, laterals[-1] * (speeds[-1] / np.maximum(v, 1e-9)) ** 2, held)

    def corner_speed(self, kappa: np.ndarray) -> np.ndarray:
        """[m/s] the fastest it takes a bend of curvature kappa [1/m] (up to its top speed)."""
        kappa = np.maximum(np.asarray(kappa, dtype=float), 1e-9)
        v = np.minimum(self.max_speed_m_s, np.sqrt(self.max_lateral_m_s2 / kappa))
        if self.lateral_fade:  # v^2 kappa - a_lat(v) rises with v: halve the span to where it is 0
            low, high = np.zeros_like(v), v
            for _ in range(30):
                mid = (low + high) / 2
                fits = mid ** 2 * kappa <= self.lateral_at(mid)
                low, high = np.where(fits, mid, low), np.where(fits, high, mid)
            v = low
        return v


def curvature(points: np.ndarray) -> np.ndarray:
    """[1/m] unsigned curvature at each point of a closed polyline (circle through neighbours)."""
    return np.abs(signed_curvature(points))


def signed_curvature(points: np.ndarray) -> np.ndarray:
    """[1/m] curvature at each point of a closed polyline, left (anticlockwise) bends positive."""
    a, b, c = np.roll(points, 1, axis=0), points, np.roll(points, -1, axis=0)
    ab, bc, ca = (np.linalg.norm(b - a, axis=1), np.linalg.norm(c - b, axis=1), np.linalg.norm(a - c, axis=1))
    cross = (b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]
    return 2 * cross / np.maximum(ab * bc * ca, 1e-12)


def speed_profile(points: np.ndarray, limits: CarLimits, passes: int = 3) -> np.ndarray:
    """[m/s] the fastest speed at each point of a closed path within the limits."""
    kappa = curvature(points)
    v = limits.corner_speed(kappa)
    ds = np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1)  # point i to i+1
    n = len(v)
    for _ in range(passes):  # a closed loop: go round until the wrap-around settles
        # the grip a bend takes is not there to speed up or brake with (the friction ellipse)
        grip = kappa / limits.lateral_at(v)  # the share of the grip per (m/s)^2 at each point
        for i in range(n):
            j = (i + 1) % n
            share = math.sqrt(max(ELLIPSE_FLOOR ** 2, 1.0 - (v[i] ** 2 * grip[i]) ** 2))
            v[j] = min(v[j], math.sqrt(v[i] ** 2 + 2 * share * limits.max_accel_m_s2 * ds[i]))
        for i in range(n - 1, -1, -1):
            j = (i + 1) % n
            share = math.sqrt(max(ELLIPSE_FLOOR ** 2, 1.0 - (v[j] ** 2 * grip[j]) ** 2))
            v[i] = min(v[i], math.sqrt(v[j] ** 2 + 2 * share * limits.max_brake_m_s2 * ds[i]))
    return v


def lap_time(points: np.ndarray, speeds: np.ndarray) -> float:
    """[s] time to drive the closed path at the given point speeds (mean speed per segment)."""
    ds = np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1)
    mean = (speeds + np.roll(speeds, -1)) / 2
    return float(np.sum(ds / np.maximum(mean, 1e-9)))


def limit_lap_time(points: np.ndarray, limits: CarLimits) -> float:
    """[s] the physical-limit lap time of a closed path for a car with these limits."""
    return lap_time(points, speed_profile(points, limits))
