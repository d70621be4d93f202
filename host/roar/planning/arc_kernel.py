"""The arcs of roar.planning.arcs compiled by Numba (the RRT asks for them from every node of its
tree thousands of times a plan): module-level kernels, so that Numba's disk cache serves every
later process. The formulas are arcs.py's."""

import math

import numba as nb
import numpy as np


@nb.njit(cache=True, nogil=True)
def arc(x, y, heading, px, py, r_min_m, reverse, max_turn_rad):
    """(signed radius, centre x, centre y, signed turn, length, heading at the end) of the arc from
    the pose (x, y, heading) to (px, py)."""
    th = heading + math.pi if reverse else heading
    c, s = math.cos(th), math.sin(th)
    dx, dy = px - x, py - y
    ahead, left = c * dx + s * dy, -s * dx + c * dy  # along the direction of travel; d . v_left
    d2 = dx * dx + dy * dy
    if abs(left) <= 1e-12 * max(d2, 1e-300):  # straight
        radius = math.inf
        angle = 0.0 if ahead >= 0 else math.inf
        length = math.sqrt(d2) if ahead >= 0 else math.inf
    else:
        radius = d2 / (2 * left)
        angle = 2 * math.atan2(left, ahead)
        length = abs(angle * radius)
    if abs(radius) < r_min_m or abs(angle) > max_turn_rad:
        length = math.inf
    finite_r = radius if math.isfinite(radius) else 0.0
    end = heading + angle if math.isfinite(angle) else heading
    return radius, x - s * finite_r, y + c * finite_r, angle, length, end


@nb.njit(cache=True, nogil=True)
def arcs_into(x, y, heading, px, py, r_min_m, reverse, max_turn_rad, out):
    """out (6, N): arc()'s six numbers for the arc from each pose (x[k], y[k], heading[k]) to (px, py)."""
    for k in range(x.shape[0]):
        out[0, k], out[1, k], out[2, k], out[3, k], out[4, k], out[5, k] = arc(
            x[k], y[k], heading[k], px, py, r_min_m, reverse, max_turn_rad)


@nb.njit(cache=True, nogil=True)
def arc_poses(x, y, heading, radius_m, angle_rad, length_m, direction, step_m):
    """(K, 3) poses along one arc from its start (excluded) to its end (included), at most step_m apart."""
    n = max(1, int(math.ceil(length_m / step_m)))
    th = heading + (math.pi if direction < 0 else 0.0)
    c, s = math.cos(th), math.sin(th)
    out = np.empty((n, 3))
    for i in range(n):
        f = (i + 1) / n
        if math.isinf(radius_m):
            ahead, left, turn = f * length_m, 0.0, 0.0
        else:
            turn = f * angle_rad
            ahead, left = radius_m * math.sin(turn), radius_m * (1 - math.cos(turn))
        out[i, 0], out[i, 1], out[i, 2] = x + c * ahead - s * left, y + s * ahead + c * left, heading + turn
    return out
