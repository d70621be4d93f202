"""Pure pursuit: steer along the circle through the car's rear axle and a goal point on the path
l_d ahead, with l_d growing with speed: l_d = K_dd * v + l_min.

    curvature = 2 sin(alpha) / l_d,  steering angle = atan(wheelbase * curvature)

alpha is the goal's bearing from the car's heading (left positive)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PurePursuit:
    wheelbase_m: float  # [m]
    k_dd_s: float = 0.35  # [s] look-ahead per m/s
    min_lookahead_m: float = 0.45  # [m]
    max_lookahead_m: float = 2.0  # [m]

    def lookahead_m(self, speed_m_s: float) -> float:
        return min(self.max_lookahead_m, self.k_dd_s * max(0.0, speed_m_s) + self.min_lookahead_m)

    @staticmethod
    def curvature(x: float, y: float, yaw: float, goal: tuple[float, float]) -> float:
        """[1/m] of the arc from the pose to the goal, left positive: 2 sin(alpha) / distance."""
        dx, dy = goal[0] - x, goal[1] - y
        distance = math.hypot(dx, dy)
        return 0.0 if distance < 1e-9 else 2 * math.sin(math.atan2(dy, dx) - yaw) / distance

    def steering_angle(self, x: float, y: float, yaw: float, goal: tuple[float, float]) -> float:
        """[rad] front-wheel angle (left positive) that puts the rear axle on the arc to goal."""
        return math.atan(self.wheelbase_m * self.curvature(x, y, yaw, goal))


def goal_on_path(points: np.ndarray, start_index: int, distance_m: float) -> tuple[float, float]:
    """The point `distance_m` along a closed polyline from points[start_index] (interpolated).
    ValueError for a polyline of zero length (it would have no point ahead)."""
    n = len(points)
    loop = float(np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1).sum())
    if not loop > 0:
        raise ValueError("the path has zero length: its points are all the same")
    i, left = start_index % n, distance_m % loop
    while True:
        j = (i + 1) % n
        seg = float(np.linalg.norm(points[j] - points[i]))
        if seg >= left:
            t = left / seg if seg > 0 else 0.0
            p = points[i] + t * (points[j] - points[i])
            return float(p[0]), float(p[1])
        left -= seg
        i = j
