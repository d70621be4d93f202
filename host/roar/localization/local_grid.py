"""A local occupancy grid: what the lidar sees round the car, in the world frame, for what the
known map does not show (people, cones, other cars). The MIT racecar's way: one transform from
the scan's frame to grid cells per scan, applied to all its points at once.

    grid = LocalGrid(size_m=10.0, resolution_m=0.05, known=load_map("tunnel_map.yaml"))
    grid.update(scan, sensor_pose, t_s)     # sensor_pose: where the lidar is in the world (x, y, yaw)
    grid.occupied()                          # (n, n) bool, [i, j] = cell (origin + i, origin + j)
    grid.unmapped()                          # occupied and not a wall of the known map
    grid.planner_view()                      # occupied | the known map's walls: what a planner reads
    grid.cell_centres()                      # (n, n, 2) [m] world points of the cells

The grid is a square of cells of the world's lattice (cell i covers [i, i + 1) x resolution),
re-centred on the sensor at each update: cells that scroll in are unknown. Each cell holds the
log-odds of being occupied: a beam's end adds HIT, every cell it passed through adds MISS (the
space it saw free), and all of it decays towards unknown with HALF_LIFE_S, so a person who walks
away fades from the grid. Beams that are no measurement are skipped (counted in .skipped_beams).
"""

from __future__ import annotations

import math

import numpy as np

from roar.checks import number
from roar.localization.odometry import Pose, checked_pose
from roar.localization.particle_filter import LocalizationError
from roar.compiled import compiled
from roar.localization.scan import LaserScan
from roar.tracks.occupancy_map import OccupancyMap

HIT, MISS = 0.9, -0.4  # log-odds a beam's end adds to its cell, and a cell it passed through
LIMIT = 3.5  # log-odds kept within +-LIMIT (so a cell can change its mind within a few scans)
OCCUPIED_ABOVE = 0.6  # log-odds above which a cell is occupied
HALF_LIFE_S = 2.0  # [s] the log-odds halve in this long without new evidence
WALL_NEIGHBOURS = 2  # [cells] a hit this near a known wall is that wall (the lidar's noise and the map's cells)


def _build_trace(nb):
    @nb.njit(cache=True, nogil=True, fastmath=True)
    def trace(sx, sy, ends_x, ends_y, hit, free, hits):
        """Beams from (sx, sy) to each end (in cells of the grid, centres at integers): every
        cell before the end marked in free, the end's cell in hits where `hit`."""
        n = free.shape[0]
        for b in range(ends_x.shape[0]):
            dx, dy = ends_x[b] - sx, ends_y[b] - sy
            length = math.sqrt(dx * dx + dy * dy)
            steps = int(length * 2.0)  # half-cell steps
            if steps > 0:
                ux, uy = dx / length * 0.5, dy / length * 0.5
                for k in range(steps - 1):  # up to a cell short of the end
                    i, j = int(math.floor(sx + k * ux + 0.5)), int(math.floor(sy + k * uy + 0.5))
                    if i < 0 or j < 0 or i >= n or j >= n:
                        break
                    free[i, j] = True
            if hit[b]:
                i, j = int(math.floor(ends_x[b] + 0.5)), int(math.floor(ends_y[b] + 0.5))
                if 0 <= i < n and 0 <= j < n:
                    hits[i, j] = True

    return trace


class LocalGrid:
    def __init__(self, size_m: float = 10.0, resolution_m: float = 0.05, known: OccupancyMap | None = None,
                 half_life_s: float = HALF_LIFE_S) -> None:
        try:
            self.resolution_m = number("resolution_m", resolution_m, 0.005, 1.0, "m")
            size_m = number("size_m", size_m, 10 * self.resolution_m, 200.0, "m")
            self.half_life_s = number("half_life_s", half_life_s, 0.01, 3600.0, "s")
        except ValueError as e:
            raise LocalizationError(str(e)) from None
        if known is not None and not isinstance(known, OccupancyMap):
            raise LocalizationError(f"known must be an OccupancyMap, got {type(known).__name__}")
        self.n = int(round(size_m / self.resolution_m))
        self.known = known
        self.log_odds = np.zeros((self.n, self.n), np.float32)
        self.origin = (0, 0)  # the world lattice cell of [0, 0]
        self.time_s: float | None = None
        self.skipped_beams = 0
        self._trace = compiled("the local grid's beams", _build_trace)
        self._angles_key = None
        self._cos = self._sin = None
        self._grown: dict[int, np.ndarray] = {}  # grow_cells -> the known map's walls grown by that many cells

    def update(self, scan: LaserScan, sensor_pose: Pose, t_s: float | None = None) -> None:
        """Add a scan taken from sensor_pose (the lidar's world pose) at t_s (default: the scan's time)."""
        x, y, yaw = checked_pose("sensor pose", sensor_pose)
        t = scan.time_s if t_s is None else t_s
        r = self.resolution_m
        centre = (math.floor(x / r), math.floor(y / r))
        self._scroll((centre[0] - self.n // 2, centre[1] - self.n // 2))
        if self.time_s is not None and t > self.time_s:
            self.log_odds *= np.float32(0.5 ** ((t - self.time_s) / self.half_life_s))
        self.time_s = t
        usable = scan.usable()
        self.skipped_beams += int(np.count_nonzero(~usable))
        key = (scan.angles.shape, float(scan.angles[0]), float(scan.angles[-1]))
        if key != self._angles_key:  # the beams' directions, once per kind of scan
            self._angles_key, self._cos, self._sin = key, np.cos(scan.angles), np.sin(scan.angles)
        ranges = np.minimum(scan.ranges[usable], scan.range_max_m)
        c, s = math.cos(yaw), math.sin(yaw)
        # the one transform from the scan's frame to grid cells: rotate, translate, scale, shift
        sx, sy = x / r - self.origin[0] - 0.5, y / r - self.origin[1] - 0.5
        px, py = ranges * self._cos[usable], ranges * self._sin[usable]
        ends_x = np.ascontiguousarray(sx + (c * px - s * py) / r)
        ends_y = np.ascontiguousarray(sy + (s * px + c * py) / r)
        hit = np.ascontiguousarray(scan.ranges[usable] < scan.range_max_m)
        free = np.zeros((self.n, self.n), np.bool_)
        hits = np.zeros((self.n, self.n), np.bool_)
        self._trace(sx, sy, ends_x, ends_y, hit, free, hits)
        lo = self.log_odds
        lo[free & ~hits] += np.float32(MISS)
        lo[hits] += np.float32(HIT)
        np.clip(lo, -LIMIT, LIMIT, out=lo)

    def _scroll(self, origin: tuple[int, int]) -> None:
        """Re-centre: the cells still in the square keep their values, the rest are unknown."""
        di, dj = origin[0] - self.origin[0], origin[1] - self.origin[1]
        if (di, dj) == (0, 0):
            return
        n, old = self.n, self.log_odds
        new = np.zeros_like(old)
        if abs(di) < n and abs(dj) < n:
            new[max(0, -di):n - max(0, di), max(0, -dj):n - max(0, dj)] = \
                old[max(0, di):n - max(0, -di), max(0, dj):n - max(0, -dj)]
        self.log_odds, self.origin = new, origin

    def occupied(self) -> np.ndarray:
        return self.log_odds > OCCUPIED_ABOVE

    def free(self) -> np.ndarray:
        return self.log_odds < -OCCUPIED_ABOVE

    def cell_centres(self) -> np.ndarray:
        """(n, n, 2) [m] the world point of every cell's centre."""
        i, j = np.meshgrid(np.arange(self.n) + self.origin[0], np.arange(self.n) + self.origin[1], indexing="ij")
        return np.stack([(i + 0.5) * self.resolution_m, (j + 0.5) * self.resolution_m], axis=-1)

    def known_walls(self, grow_cells: int = 0) -> np.ndarray:
        """(n, n) bool: the known map's occupied cells under this grid (grown by grow_cells)."""
        if self.known is None:
            return np.zeros((self.n, self.n), bool)
        from scipy import ndimage

        if grow_cells not in self._grown:  # the known map never changes: grown once (a planner asks every period)
            self._grown[grow_cells] = ndimage.binary_dilation(self.known.occupied, iterations=grow_cells) \
                if grow_cells else self.known.occupied
        walls = self._grown[grow_cells]
        cells = np.round(self.known.to_cells(self.cell_centres().reshape(-1, 2))).astype(int)
        rows, cols = walls.shape
        inside = (cells[:, 0] >= 0) & (cells[:, 0] < cols) & (cells[:, 1] >= 0) & (cells[:, 1] < rows)
        out = np.zeros(len(cells), bool)
        out[inside] = walls[cells[inside, 1], cells[inside, 0]]
        return out.reshape(self.n, self.n)

    def unmapped(self) -> np.ndarray:
        """Occupied cells that are not the known map's walls (within WALL_NEIGHBOURS cells of one)."""
        return self.occupied() & ~self.known_walls(WALL_NEIGHBOURS)

    def planner_view(self) -> np.ndarray:
        """What a planner reads: occupied here, or a wall of the known map."""
        return self.occupied() | self.known_walls()
