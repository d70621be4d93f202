"""The occupancy a planner reads: one world-aligned grid of blocked cells, made of the known map
(every cell that is not free: walls and the unknown beyond them), what the local grid sees that
the map lacks, and discs where the camera placed cones.

    grid = PlanningGrid.from_map(known)             # roar.tracks.occupancy_map.OccupancyMap
    grid = grid.with_local(local_grid)              # roar.localization.local_grid.LocalGrid
    grid = grid.with_discs(cones_xy, 0.1)           # [m] centres and radius
    grid.blocked[i, j]                              # the cell [x0 + i r, x0 + (i+1) r) x [y0 + j r, ...)

Nothing is inflated: the car's own rectangle is checked against these cells (roar.planning.footprint).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from roar.errors import NoPath, PlanningError


@dataclass(frozen=True)
class PlanningGrid:
    blocked: np.ndarray  # (nx, ny) bool, [i, j]: the cell whose corner is (x0 + i r, y0 + j r)
    resolution_m: float  # [m] r
    x0: float  # [m]
    y0: float  # [m]

    def __post_init__(self) -> None:
        b = self.blocked
        if not isinstance(b, np.ndarray) or b.ndim != 2 or b.dtype != bool or min(b.shape) < 2:
            raise PlanningError("a planning grid needs a 2-D bool array of at least 2 x 2 cells")
        if not (math.isfinite(self.resolution_m) and 0.005 <= self.resolution_m <= 1.0):
            raise PlanningError(f"resolution must be 0.005..1 m, got {self.resolution_m!r}")
        if not (math.isfinite(self.x0) and math.isfinite(self.y0)):
            raise PlanningError("the grid's origin must be finite")

    @classmethod
    def from_map(cls, known) -> PlanningGrid:
        """The cells of a map (roar.tracks.occupancy_map.OccupancyMap) that are not free. Its yaw
        must be 0 (map_server's maps nearly always are)."""
        ox, oy, yaw = known.origin
        if abs(yaw) > 1e-9:
            raise PlanningError(f"the map's origin turns by {yaw:g} rad: a planner reads maps with yaw 0")
        if not known.free.any():
            raise NoPath("the map has no free space: nowhere to drive")
        return cls(np.ascontiguousarray(np.flipud(~known.free).T), float(known.resolution_m), float(ox), float(oy))

    @property
    def shape(self) -> tuple[int, int]:
        return self.blocked.shape

    def cells(self, xy) -> np.ndarray:
        """(N, 2) integer cells (i, j) of world points (N, 2) [m] (may lie outside the grid)."""
        p = np.asarray(xy, dtype=float).reshape(-1, 2)
        return np.floor((p - (self.x0, self.y0)) / self.resolution_m).astype(np.int64)

    def centres(self, ij) -> np.ndarray:
        """(N, 2) [m] world centres of cells (N, 2)."""
        return (np.asarray(ij, dtype=float) + 0.5) * self.resolution_m + (self.x0, self.y0)

    def blocked_at(self, xy) -> np.ndarray:
        """(N,) bool: each point's cell blocked (or off the grid)."""
        ij = self.cells(xy)
        nx, ny = self.shape
        inside = (ij[:, 0] >= 0) & (ij[:, 0] < nx) & (ij[:, 1] >= 0) & (ij[:, 1] < ny)
        out = np.ones(len(ij), bool)
        out[inside] = self.blocked[ij[inside, 0], ij[inside, 1]]
        return out

    def _with_cells(self, ij: np.ndarray) -> PlanningGrid:
        nx, ny = self.shape
        ij = ij[(ij[:, 0] >= 0) & (ij[:, 0] < nx) & (ij[:, 1] >= 0) & (ij[:, 1] < ny)]
        if not len(ij):
            return self
        blocked = self.blocked.copy()
        blocked[ij[:, 0], ij[:, 1]] = True
        return PlanningGrid(blocked, self.resolution_m, self.x0, self.y0)

    def with_local(self, local) -> PlanningGrid:
        """This grid and every cell a LocalGrid holds occupied where the map has no wall."""
        centres = local.cell_centres()[local.unmapped()]
        return self._with_cells(self.cells(centres))

    def with_points(self, xy) -> PlanningGrid:
        """This grid with the cells of world points (N, 2) [m] blocked."""
        return self._with_cells(self.cells(np.asarray(xy, dtype=float).reshape(-1, 2)))

    def with_discs(self, centres_xy, radius_m: float) -> PlanningGrid:
        """This grid with every cell whose centre lies within radius_m of a centre blocked, and the
        cell of each centre."""
        c = np.asarray(centres_xy, dtype=float).reshape(-1, 2)
        if not len(c):
            return self
        r = self.resolution_m
        k = int(math.ceil(radius_m / r)) + 1
        di, dj = np.meshgrid(np.arange(-k, k + 1), np.arange(-k, k + 1), indexing="ij")
        offsets = np.stack([di.ravel(), dj.ravel()], axis=1)
        ij = self.cells(c)[:, None, :] + offsets[None]
        near = np.linalg.norm(self.centres(ij.reshape(-1, 2)).reshape(ij.shape) - c[:, None, :], axis=2) <= radius_m
        near[:, len(offsets) // 2] = True
        return self._with_cells(ij[near])

    def free_cells(self) -> np.ndarray:
        """(M, 2) every free cell (i, j): where a planner samples."""
        return np.argwhere(~self.blocked)
