"""The depth grid's floor fit and cell counts (roar.vision.occupancy says what they do), compiled by
Numba: in NumPy a frame's RANSAC rounds, their refit and the counts took ~2.5 ms, a third of a
camera-only race's frame beside the lane detector. Imported only once Numba is known to be there
(roar.compiled)."""

import math

import numba as nb
import numpy as np


@nb.njit(cache=True, nogil=True)
def fit_floor(low: np.ndarray, picks: np.ndarray, scored_every: int, tolerance_m: float,
              min_level: float) -> tuple[float, float, float, float]:
    """(nx, ny, nz, d) of the plane n . p + d = 0 (n a unit vector, nz > 0) through the low points
    (N, 3): of the planes through each row of picks' three points, roughly level (|nz| >= min_level),
    the first with the most of every scored_every-th point within tolerance_m; then least squares
    z = p x + q y + r on all its inliers. (0, 0, 1, 0) where no plane is level."""
    best_count, best = -1, -1
    best_n = np.zeros(3)
    best_a = np.zeros(3)
    for k in range(picks.shape[0]):
        a, b, c = low[picks[k, 0]], low[picks[k, 1]], low[picks[k, 2]]
        u0, u1, u2 = b[0] - a[0], b[1] - a[1], b[2] - a[2]
        v0, v1, v2 = c[0] - a[0], c[1] - a[1], c[2] - a[2]
        n0, n1, n2 = u1 * v2 - u2 * v1, u2 * v0 - u0 * v2, u0 * v1 - u1 * v0
        norm = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        if norm <= 1e-9:  # a repeated point makes no plane
            continue
        n0, n1, n2 = n0 / norm, n1 / norm, n2 / norm
        if abs(n2) < min_level:
            continue
        offset = a[0] * n0 + a[1] * n1 + a[2] * n2
        count = 0
        for i in range(0, low.shape[0], scored_every):
            if abs(low[i, 0] * n0 + low[i, 1] * n1 + low[i, 2] * n2 - offset) < tolerance_m:
                count += 1
        if count > best_count:  # the first of the best
            best_count, best = count, k
            best_n[0], best_n[1], best_n[2] = n0, n1, n2
            best_a[0], best_a[1], best_a[2] = a[0], a[1], a[2]
    if best < 0:
        return 0.0, 0.0, 1.0, 0.0
    # the normal equations of z = p x + q y + r over the inliers
    sxx = sxy = sx = syy = sy = s1 = sxz = syz = sz = 0.0
    for i in range(low.shape[0]):
        x, y, z = low[i, 0], low[i, 1], low[i, 2]
        if abs((x - best_a[0]) * best_n[0] + (y - best_a[1]) * best_n[1] + (z - best_a[2]) * best_n[2]) < tolerance_m:
            sxx += x * x
            sxy += x * y
            sx += x
            syy += y * y
            sy += y
            s1 += 1.0
            sxz += x * z
            syz += y * z
            sz += z
    normal = np.array([[sxx, sxy, sx], [sxy, syy, sy], [sx, sy, s1]])
    p, q, r = np.linalg.lstsq(normal, np.array([sxz, syz, sz]))[0]  # (lstsq: a degenerate set stays finite)
    scale = math.sqrt(p * p + q * q + 1.0)
    return -p / scale, -q / scale, 1.0 / scale, -r / scale


@nb.njit(cache=True, nogil=True)
def count_cells(points: np.ndarray, plane: np.ndarray, min_height_m: float, max_height_m: float, x_near_m: float,
                y_half_m: float, cell_m: float, counts: np.ndarray) -> None:
    """Add to counts[row, col] each point (N, 3) standing min..max_height_m above the plane, in the
    cell it falls in (rows from x_near_m ahead, columns from y_half_m left, cell_m each)."""
    rows, cols = counts.shape
    for i in range(points.shape[0]):
        x, y, z = points[i, 0], points[i, 1], points[i, 2]
        height = x * plane[0] + y * plane[1] + z * plane[2] + plane[3]
        if not (min_height_m < height < max_height_m):
            continue
        r = int(math.floor((x - x_near_m) / cell_m))
        c = int(math.floor((y_half_m - y) / cell_m))
        if 0 <= r < rows and 0 <= c < cols:
            counts[r, c] += 1
