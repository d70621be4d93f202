"""The ray casting kernels, compiled by Numba: RayMarcher's march (each step as long as the
distance to the nearest wall allows), the particle filter's march_log_weights, and bresenham (every
cell along the ray, the plain method the benchmark measures against). Imported only once Numba is
known to be there (roar.compiled); module-level functions, so that Numba's disk cache serves
every later process (a kernel closed over another one is compiled again in each process).
"""

import math

import numba as nb
import numpy as np

EDGE_HALVINGS = 4  # a ray's last step halved this many times to the wall's edge: within 1/16 of a step (<= 0.5 cell)


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
