"""The car's rectangle and whether it fits at poses on a planning grid: the rectangle is
rasterised at each pose (points at most half a cell apart over its whole area, edges included,
so every cell it covers by more than a sliver is read) and any blocked cell under it is a
collision. The map is not inflated: a car of another size needs only another Footprint.

    fp = Footprint(rear_m=0.06, front_m=0.41, half_width_m=0.15)   # the ROAR 1/10 car, about its rear axle
    fp.first_collision(grid, poses)          # index of the first pose (N, 3) that touches a blocked cell, or -1
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from roar.compiled import compiled
from roar.planning.grid import PlanningError, PlanningGrid

MARGIN_M = 0.03  # [m] added round the car's outline: the pose's error while it follows a path


def _build(nb):
    from roar.planning import footprint_kernel

    return footprint_kernel.first_collision


@dataclass(frozen=True)
class Footprint:
    """The car's outline about its reference point (the rear axle: where a pose is): rear_m behind
    it, front_m ahead, half_width_m either side [m]; margin_m more all round."""

    rear_m: float = 0.06  # [m] the ROAR 1/10 car (racecar.urdf): 0.46 m long
    front_m: float = 0.41  # [m]
    half_width_m: float = 0.15  # [m] 0.29 m wide
    margin_m: float = MARGIN_M

    def __post_init__(self) -> None:
        for name in ("rear_m", "front_m", "half_width_m", "margin_m"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and 0 <= v <= 5):
                raise PlanningError(f"footprint {name} must be 0..5 m, got {v!r}")
        if self.front_m + self.rear_m <= 0 or self.half_width_m <= 0:
            raise PlanningError("a footprint needs a length and a width")

    def corners(self) -> np.ndarray:
        """(4, 2) [m] the outline (margin included) in the car's frame."""
        m = self.margin_m
        back, front, half = -self.rear_m - m, self.front_m + m, self.half_width_m + m
        return np.array([[back, -half], [front, -half], [front, half], [back, half]])

    def body_points(self, resolution_m: float) -> tuple[np.ndarray, np.ndarray]:
        """(x, y) [m] points covering the outline at most half a cell apart, edges included (made
        once per resolution)."""
        cache = self.__dict__.setdefault("_cache", {})
        if resolution_m not in cache:
            cache[resolution_m] = self._body_points(resolution_m)
        return cache[resolution_m]

    def _body_points(self, resolution_m: float) -> tuple[np.ndarray, np.ndarray]:
        (back, right), (front, left) = self.corners()[0], self.corners()[2]
        nx = int(math.ceil((front - back) / (resolution_m / 2))) + 1
        ny = int(math.ceil((left - right) / (resolution_m / 2))) + 1
        x, y = np.meshgrid(np.linspace(back, front, nx), np.linspace(right, left, ny), indexing="ij")
        # the outline first: most collisions are found at its edge, and the kernel stops at the first
        edge = (np.arange(nx)[:, None] % (nx - 1) == 0) | (np.arange(ny)[None, :] % (ny - 1) == 0)
        order = np.concatenate([np.flatnonzero(edge.ravel()), np.flatnonzero(~edge.ravel())])
        return np.ascontiguousarray(x.ravel()[order]), np.ascontiguousarray(y.ravel()[order])

    def first_collision(self, grid: PlanningGrid, poses) -> int:
        """Index of the first of the poses (N, 3) [m, m, rad] at which the car touches a blocked
        cell (or leaves the grid); -1 if it fits at every one."""
        p = np.ascontiguousarray(poses, dtype=float).reshape(-1, 3)
        bx, by = self.body_points(grid.resolution_m)
        kernel = compiled("the planner's footprint checks", _build, "planning")
        return int(kernel(grid.blocked, grid.x0, grid.y0, 1.0 / grid.resolution_m, p, bx, by))

    def fits(self, grid: PlanningGrid, poses) -> bool:
        return self.first_collision(grid, poses) < 0

    def touches_discs(self, poses, centres_xy, radius_m: float) -> bool:
        """Whether the rectangle (margin included) at any of poses (N, 3) comes nearer than
        radius_m [m] to any of centres_xy (M, 2) [m]: the car against round obstacles (cones),
        exactly, with no grid."""
        p = np.asarray(poses, dtype=float).reshape(-1, 3)
        c = np.asarray(centres_xy, dtype=float).reshape(-1, 2)
        if not len(p) or not len(c):
            return False
        dx, dy = c[None, :, 0] - p[:, None, 0], c[None, :, 1] - p[:, None, 1]
        cos, sin = np.cos(p[:, 2])[:, None], np.sin(p[:, 2])[:, None]
        u, v = cos * dx + sin * dy, -sin * dx + cos * dy  # the centres in the car's frame at each pose
        (back, right), (front, left) = self.corners()[0], self.corners()[2]
        out_u = np.maximum(np.maximum(back - u, u - front), 0.0)
        out_v = np.maximum(np.maximum(right - v, v - left), 0.0)
        return bool((np.hypot(out_u, out_v) < radius_m).any())
