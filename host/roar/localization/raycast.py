"""Ray casting on an occupancy map: how far each beam of each particle would reach before a wall.
This is the particle filter's cost (2,500 particles x 60 beams = 150,000 rays an update).

RayMarcher marches each ray on the map's Euclidean distance transform (each step as long as the
distance to the nearest wall allows); bresenham() walks every cell along the ray, the plain
method it is measured against in the benchmark. Both are compiled by Numba, one CPU thread.
Rays run in the map's cells: a cell is hit when it is occupied; a ray leaving the map reads max.

    caster = RayMarcher(grid, max_range_m=10.0)
    ranges = caster.cast(poses, angles)        # (P, B) [m]: poses (P, 3) in the world, angles (B,) [rad]
"""

from __future__ import annotations

import math

import numpy as np

from roar.compiled import compiled
from roar.errors import MissingNumba  # noqa: F401 (raised by compiled(); imported from here too)
from roar.tracks.occupancy_map import OccupancyMap


def _kernels():
    """The ray casting kernels: march, march_log_weights, bresenham."""
    return compiled("the particle filter's ray casting", _build_casters)


def _build_casters(nb):
    from roar.localization import ray_kernels as k

    return {"march": k.march, "march_log_weights": k.march_log_weights, "bresenham": k.bresenham}


class MapFrame:
    """A map's cells as casting sees them: ix along the image's columns, iy up its rows (so that
    angles read as in the world, less the origin's yaw); world poses to cell poses."""

    def __init__(self, grid: OccupancyMap) -> None:
        self.grid = grid
        self.resolution_m = grid.resolution_m
        self.occupied = np.ascontiguousarray(grid.occupied[::-1].T)  # [ix, iy]
        self.free = np.ascontiguousarray(grid.free[::-1].T)
        self._ox, self._oy, self._yaw = grid.origin

    def cell_poses(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(xs, ys, headings) in cells (cell centres at integers) of world poses (P, 3)."""
        c, s = math.cos(self._yaw), math.sin(self._yaw)
        dx, dy = poses[:, 0] - self._ox, poses[:, 1] - self._oy
        u, v = c * dx + s * dy, -s * dx + c * dy
        r = self.resolution_m
        return (np.ascontiguousarray(u / r - 0.5), np.ascontiguousarray(v / r - 0.5),
                np.ascontiguousarray(poses[:, 2] - self._yaw))

    def world_points(self, ix: np.ndarray, iy: np.ndarray) -> np.ndarray:
        """(N, 2) [m] the world points of (fractional) cells."""
        u, v = (np.asarray(ix) + 0.5) * self.resolution_m, (np.asarray(iy) + 0.5) * self.resolution_m
        c, s = math.cos(self._yaw), math.sin(self._yaw)
        return np.stack([self._ox + c * u - s * v, self._oy + s * u + c * v], axis=-1)


class RayMarcher:
    """Ray marching on the map's distance transform (built once: scipy's exact EDT)."""

    def __init__(self, grid: OccupancyMap, max_range_m: float = 10.0) -> None:
        from scipy import ndimage

        self.frame = MapFrame(grid)
        self.max_range_m = max_range_m
        self.max_cells = max_range_m / grid.resolution_m
        self.dist = np.ascontiguousarray(ndimage.distance_transform_edt(~self.frame.occupied)).astype(np.float32)
        self._march = _kernels()["march"]

    def cast(self, poses, angles) -> np.ndarray:
        """(P, B) [m] ranges of beams at `angles` [rad] (B,) from each world pose (P, 3)."""
        return self.cast_cells(poses, angles) * self.frame.resolution_m

    def cast_cells(self, poses, angles) -> np.ndarray:
        """cast() in cells (float32), as the beam model's table reads them."""
        xs, ys, hs = self.frame.cell_poses(np.asarray(poses, dtype=np.float64).reshape(-1, 3))
        out = np.empty((xs.shape[0], np.size(angles)), np.float32)
        self._march(self.dist, xs, ys, hs, np.ascontiguousarray(angles, dtype=np.float64), self.max_cells, out)
        return out


class BresenhamCaster(RayMarcher):
    """The same interface, each ray walked cell by cell: the benchmark's plain reference."""

    def __init__(self, grid: OccupancyMap, max_range_m: float = 10.0) -> None:
        self.frame = MapFrame(grid)
        self.max_range_m = max_range_m
        self.max_cells = max_range_m / grid.resolution_m
        self._walk = _kernels()["bresenham"]

    def cast_cells(self, poses, angles) -> np.ndarray:
        xs, ys, hs = self.frame.cell_poses(np.asarray(poses, dtype=np.float64).reshape(-1, 3))
        out = np.empty((xs.shape[0], np.size(angles)), np.float32)
        self._walk(self.frame.occupied, xs, ys, hs, np.ascontiguousarray(angles, dtype=np.float64), self.max_cells,
                   out)
        return out
