"""A track's walls as a distance field on a grid: what a beam or a camera's ray marches on without
Bullet (roar_sim.batch's lidar and footprint, the ray-cast camera of roar_sim.world.ray_camera).

A wall is the simulator's (roar_sim.world.scene): a box WALL_THICKNESS_M thick along each piece of a
wall polyline, half a thickness longer at each end; the field holds the distance to those boxes (each
node's to the boxes of the pieces of its nearest samples, SAMPLE_M apart along them).

    field, (x0, y0, nx, ny) = distance_field(track)      # float32 [nx, ny] [m], RES_M apart
"""

from __future__ import annotations

import numba as nb
import numpy as np

from roar.tracks import Track
from roar_sim.world.appearance import WALL_THICKNESS_M

RES_M = 0.025  # [m] the distance field's cell (at 5 cm a beam grazing a wall's end erred 2-4 cm, 1 time in 100)
SAMPLE_M = 0.01  # [m] between the points each wall is sampled at
MARGIN_M = 0.5  # [m] the field reaches this far beyond the walls
NEAREST = 4  # samples whose pieces each node's distance is measured to


def wall_segments(track: Track) -> tuple[np.ndarray, np.ndarray]:
    """(segments [S, 2, 2] [m]: every wall polyline's pieces, start and end; points [M, 3]: (x, y,
    its segment) along each piece, SAMPLE_M apart at most)."""
    segments, points = [], []
    for wall in track.walls:
        for p, q in zip(wall, np.roll(wall, -1, axis=0)):
            k = max(1, int(np.ceil(np.hypot(*(q - p)) / SAMPLE_M)))
            along = p + np.outer(np.arange(k) / k, q - p)
            points.append(np.column_stack([along, np.full(k, len(segments))]))
            segments.append((p, q))
    return np.array(segments), np.concatenate(points)


def distance_field(track: Track, res_m: float = RES_M) -> tuple[np.ndarray, tuple[float, float, int, int]]:
    """(field float32 [nx, ny] [m] to the nearest wall's face (negative inside a wall), (x0, y0, nx,
    ny)): the grid's first node at (x0, y0), res_m apart. Each node's distance is to the boxes of the
    pieces of its nearest few samples, exactly."""
    from scipy.spatial import cKDTree

    segments, points = wall_segments(track)
    low, high = points[:, :2].min(axis=0) - MARGIN_M, points[:, :2].max(axis=0) + MARGIN_M
    nx, ny = (np.ceil((high - low) / res_m).astype(int) + 1).tolist()
    gx, gy = np.meshgrid(low[0] + res_m * np.arange(nx), low[1] + res_m * np.arange(ny), indexing="ij")
    nodes = np.column_stack([gx.ravel(), gy.ravel()])
    _, nearest = cKDTree(points[:, :2]).query(nodes, k=NEAREST, workers=-1)
    best = np.full(len(nodes), np.inf)
    half_width = WALL_THICKNESS_M / 2
    for j in range(NEAREST):  # each candidate piece's box, as the simulator builds it: signed distance to it
        a, b = segments[points[nearest[:, j], 2].astype(int)].transpose(1, 0, 2)
        d = b - a
        length = np.maximum(np.hypot(*d.T), 1e-12)
        ux, uy = d[:, 0] / length, d[:, 1] / length
        rx, ry = nodes[:, 0] - (a[:, 0] + b[:, 0]) / 2, nodes[:, 1] - (a[:, 1] + b[:, 1]) / 2
        qx = np.abs(rx * ux + ry * uy) - (length / 2 + half_width)
        qy = np.abs(-rx * uy + ry * ux) - half_width
        box = np.hypot(np.maximum(qx, 0.0), np.maximum(qy, 0.0)) + np.minimum(np.maximum(qx, qy), 0.0)
        best = np.minimum(best, box)
    return best.astype(np.float32).reshape(nx, ny), (float(low[0]), float(low[1]), nx, ny)



@nb.njit(cache=True, nogil=True, fastmath=True)
def sdf_in(pool, x0, y0, res, nx, ny, start, x, y):
    """[m] the distance from (x, y) to the nearest wall's face on one grid (its meta row's numbers: first node
    (x0, y0), cell res, nx by ny nodes, its first index `start` in `pool`), bilinear; 1e9 off the grid."""
    fx, fy = (x - x0) / res, (y - y0) / res
    if not (0.0 <= fx < nx - 1 and 0.0 <= fy < ny - 1):
        return 1e9
    ix, iy = int(fx), int(fy)
    tx, ty = fx - ix, fy - iy
    at = start + ix * ny + iy
    a, b, c, d = pool[at], pool[at + 1], pool[at + ny], pool[at + ny + 1]
    return (a * (1 - ty) + b * ty) * (1 - tx) + (c * (1 - ty) + d * ty) * tx
