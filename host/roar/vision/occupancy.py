"""Obstacles from a depth image, ROAR's ground-plane way: depth + intrinsics -> points -> the car's
frame (the camera's mounting) -> the floor found as a plane (RANSAC, then least squares, so a
pitching or rolling car still finds it) -> points standing above it counted in a grid of cells
on the floor, in metres in the car's frame.

    grid = occupancy(depth, camera)          # Occupancy: .occupied (rows x cols bool), .cell_xy()
    grid.nearest_ahead(half_width_m=0.3)     # [m] to the nearest occupied cell in the car's path
                                             # (path=lanes.centre.y: along the lane)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from roar.compiled import compiled
from roar.vision.geometry import CameraModel

CELL_M = 0.1  # [m]
X_RANGE_M = (0.3, 4.0)  # [m] ahead
Y_HALF_M = 2.0  # [m] either side
MIN_HEIGHT_M = 0.04  # [m] above the floor: an obstacle, not the floor's noise
MAX_HEIGHT_M = 0.6  # [m] above the car: not in its way
MIN_POINTS = 3  # points a cell needs to be occupied
MAX_THING_M = 0.7  # [m] longest and widest a thing in the road is (a box, a cone, a car); a wall is longer
STRIDE = 2  # use every STRIDE-th pixel each way
RANSAC_ROUNDS = 40
RANSAC_TOLERANCE_M = 0.02  # [m]
RANSAC_SCORED = 2000  # low points each candidate plane is scored on, at most (all of a frame's: 8 ms a frame)
MIN_LEVEL = 0.8  # the floor is roughly level: its normal's upward part at least this


@dataclass(frozen=True)
class Occupancy:
    occupied: np.ndarray  # (rows, cols) bool; row 0 nearest, column 0 leftmost
    counts: np.ndarray  # points per cell
    plane: tuple[float, float, float, float]  # a x + b y + c z + d = 0 in the car's frame, (a, b, c) unit, c > 0
    cell_m: float = CELL_M
    x0: float = X_RANGE_M[0]
    y_left: float = Y_HALF_M

    def cell_xy(self, row: int, col: int) -> tuple[float, float]:
        """[m] the centre of a cell in the car's frame."""
        return self.x0 + (row + 0.5) * self.cell_m, self.y_left - (col + 0.5) * self.cell_m

    def things(self, max_extent_m: float = MAX_THING_M) -> np.ndarray:
        """The occupied cells of compact things standing on the floor (a box, a cone, a car): each
        group of touching cells no longer nor wider than max_extent_m. A wall is a long group
        (seen across a bend it runs right across the view): not a thing in the road."""
        import cv2

        count, labels, stats, _ = cv2.connectedComponentsWithStats(self.occupied.astype(np.uint8), connectivity=8)
        limit = max_extent_m / self.cell_m
        compact = (stats[:, cv2.CC_STAT_WIDTH] <= limit) & (stats[:, cv2.CC_STAT_HEIGHT] <= limit)
        compact[0] = False  # the background
        return compact[labels]

    def nearest_ahead(self, half_width_m: float, path=None, reach_m: float = math.inf,
                      things_only: bool = False) -> float | None:
        """[m] ahead to the nearest occupied cell within half_width_m of the path the car will
        drive -- path(x) -> y [m] (a lane's centre line), or straight ahead -- up to reach_m
        (as far as the path is known); with things_only, only cells of things(), not walls."""
        rows, cols = np.nonzero(self.things() if things_only else self.occupied)
        best = None
        for r, c in zip(rows, cols):
            x, y = self.cell_xy(int(r), int(c))
            if x > reach_m:
                continue
            centre = 0.0 if path is None else float(path(x))
            if abs(y - centre) <= half_width_m and (best is None or x < best):
                best = x
        return best


def camera_points(depth: np.ndarray, camera: CameraModel, stride: int = STRIDE) -> np.ndarray:
    """(N, 3) points (x ahead, y left, z up) [m] in the car's frame of a metric depth image
    (distance along the optical axis), every stride-th pixel; far and invalid pixels dropped."""
    h, w = depth.shape
    v, u = np.mgrid[0:h:stride, 0:w:stride]
    z = depth[::stride, ::stride].astype(np.float64)
    keep = np.isfinite(z) & (z > 0.05) & (z < X_RANGE_M[1] * 2)
    x, y, zc = camera.unproject(u[keep], v[keep], z[keep])
    return np.column_stack([x, y, zc])


def fit_floor(points: np.ndarray, rng: np.random.Generator | None = None) -> tuple[float, float, float, float]:
    """The floor as a plane (nx, ny, nz, d), n . p + d = 0: RANSAC among the low points (RANSAC_ROUNDS
    planes through three drawn points, each scored on an even sample of RANSAC_SCORED of them),
    then least squares on the best one's inliers; z = 0 when there are too few points or no plane
    is roughly level. (Compiled: roar.vision.floor_kernel.)"""
    rng = rng or np.random.default_rng(0)
    low = np.ascontiguousarray(points[points[:, 2] < 0.1], dtype=np.float64)
    if len(low) < 20:
        return 0.0, 0.0, 1.0, 0.0
    picks = rng.integers(0, len(low), (RANSAC_ROUNDS, 3))
    return _kernels().fit_floor(low, picks, max(1, len(low) // RANSAC_SCORED), RANSAC_TOLERANCE_M, MIN_LEVEL)


def occupancy(depth: np.ndarray, camera: CameraModel, cell_m: float = CELL_M) -> Occupancy:
    points = np.ascontiguousarray(camera_points(depth, camera))
    plane = fit_floor(points)
    rows = int(round((X_RANGE_M[1] - X_RANGE_M[0]) / cell_m))
    cols = int(round(2 * Y_HALF_M / cell_m))
    counts = np.zeros((rows, cols), np.int32)
    _kernels().count_cells(points, np.array(plane), MIN_HEIGHT_M, MAX_HEIGHT_M, X_RANGE_M[0], Y_HALF_M, cell_m,
                           counts)
    return Occupancy(counts >= MIN_POINTS, counts, plane, cell_m)


def _kernels():
    return compiled("the depth grid's floor fit", _build_kernels, "vision")


def _build_kernels(_numba):
    from roar.vision import floor_kernel

    return floor_kernel


def figure(rgb: np.ndarray, grid: Occupancy):
    """The camera frame beside the occupancy grid (the car at the bottom, looking up)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, ax_grid) = plt.subplots(1, 2, figsize=(10, 4))  # margins fixed: as lanes.debug_view's
    fig.subplots_adjust(left=0.04, right=0.98, bottom=0.12, top=0.92, wspace=0.2)
    ax.imshow(rgb)
    ax.set_title("camera")
    ax.axis("off")
    rows, cols = grid.occupied.shape
    extent = (grid.y_left, grid.y_left - cols * grid.cell_m, grid.x0, grid.x0 + rows * grid.cell_m)
    ax_grid.imshow(grid.occupied, origin="lower", extent=extent, cmap="Greys", aspect="equal")
    ax_grid.set_xlabel("y [m] (left +)")
    ax_grid.set_ylabel("x [m] ahead")
    ax_grid.set_title(f"occupancy, {grid.cell_m * 100:.0f} cm cells")
    return fig
