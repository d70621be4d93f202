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

from roar.errors import MissingNumba
from roar.tracks.occupancy_map import OccupancyMap

EDGE_HALVINGS = 4  # a ray's last step halved this many times to the wall's edge: within 1/16 of a step (<= 0.5 cell)


def numba():
    try:
        import numba
    except ImportError:
        raise MissingNumba("the particle filter's ray casting needs Numba: pip install 'roar-platform[localization]'") \
            from None
    return numba


def compiled(name: str, build):
    """build(numba) -> kernels, once a process (Numba also caches the machine code on disk)."""
    if name not in _COMPILED:
        _COMPILED[name] = build(numba())
    return _COMPILED[name]


_COMPILED: dict[str, object] = {}


def _kernels():
    """The ray casting kernels: march, march_log_weights, bresenham."""
    return compiled("ray casting", _build_casters)


def _build_casters(nb):
    @nb.njit(cache=True, nogil=True, fastmath=True, inline="always")
    def ray(dist, x0, y0, c, s, max_cells):
        """[cells] from (x0, y0) (cell spans: int() is the index) along (c, s) to the first
        occupied cell of dist[ix, iy] (its distance to the nearest occupied cell's centre, 0 on
        one), max_cells if none or the map ends first."""
        nx, ny = dist.shape
        t = last = 0.0
        while t < max_cells:
            px, py = x0 + t * c, y0 + t * s
            if px < 0.0 or py < 0.0 or px >= nx or py >= ny:
                return max_cells
            d = dist[int(px), int(py)]
            if d == 0.0:  # in a wall, free at the last step: halve the step to where the wall starts
                free, wall = last, t  # (the step's end lies up to half a cell in: 1.2 cm long on average)
                for _ in range(EDGE_HALVINGS):
                    mid = 0.5 * (free + wall)
                    if dist[int(x0 + mid * c), int(y0 + mid * s)] == 0.0:
                        wall = mid
                    else:
                        free = mid
                return wall
            last = t
            # from anywhere in this cell the nearest occupied cell is about d - 1 away (both ends
            # within a cell of their centres): a step that long cuts at most a corner
            t += max(d - 1.0, 0.5)
        return max_cells

    @nb.njit(cache=True, nogil=True, fastmath=True)
    def march(dist, xs, ys, headings, angles, max_cells, out):
        """Rays from (xs, ys) [cells] at headings + angles; out[p, b] the range [cells]."""
        ca, sa = np.cos(angles), np.sin(angles)
        for p in range(xs.shape[0]):
            ch, sh = math.cos(headings[p]), math.sin(headings[p])
            for b in range(angles.shape[0]):
                out[p, b] = ray(dist, xs[p] + 0.5, ys[p] + 0.5, ch * ca[b] - sh * sa[b], sh * ca[b] + ch * sa[b],
                                max_cells)

    @nb.njit(cache=True, nogil=True, fastmath=True)
    def march_log_weights(dist, xs, ys, headings, angles, max_cells, measured, log_table, out):
        """march() with each beam's expected range [cells] looked up at once in the beam
        model's log_table[measured, expected]: out[p] the sum over beams (measured[b] the cell
        index of beam b's reading)."""
        ca, sa = np.cos(angles), np.sin(angles)
        for p in range(xs.shape[0]):
            ch, sh = math.cos(headings[p]), math.sin(headings[p])
            total = 0.0
            for b in range(angles.shape[0]):
                t = ray(dist, xs[p] + 0.5, ys[p] + 0.5, ch * ca[b] - sh * sa[b], sh * ca[b] + ch * sa[b], max_cells)
                total += log_table[measured[b], int(t + 0.5)]
            out[p] = total

    @nb.njit(cache=True, nogil=True)
    def bresenham(occupied, xs, ys, headings, angles, max_cells, out):
        """occupied[ix, iy]; the same rays walked cell by cell (Bresenham's line to the ray's
        end at max range)."""
        nx, ny = occupied.shape
        for p in range(xs.shape[0]):
            for b in range(angles.shape[0]):
                a = headings[p] + angles[b]
                x0, y0 = int(math.floor(xs[p] + 0.5)), int(math.floor(ys[p] + 0.5))
                x1 = int(math.floor(xs[p] + max_cells * math.cos(a) + 0.5))
                y1 = int(math.floor(ys[p] + max_cells * math.sin(a) + 0.5))
                dx, dy = abs(x1 - x0), -abs(y1 - y0)
                sx, sy = (1 if x0 < x1 else -1), (1 if y0 < y1 else -1)
                err, x, y = dx + dy, x0, y0
                r = max_cells
                while True:
                    if x < 0 or y < 0 or x >= nx or y >= ny:
                        break
                    if occupied[x, y]:
                        r = min(math.hypot(x - xs[p], y - ys[p]), max_cells)
                        break
                    if x == x1 and y == y1:
                        break
                    e2 = 2 * err
                    if e2 >= dy:
                        err += dy
                        x += sx
                    if e2 <= dx:
                        err += dx
                        y += sy
                out[p, b] = r

    return {"march": march, "march_log_weights": march_log_weights, "bresenham": bresenham}


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
