"""The footprint check of roar.planning.footprint compiled by Numba: a module-level kernel, so that
Numba's disk cache serves every later process and the RRT's growth step (rrt_kernel) calls it."""

import math

import numba as nb


@nb.njit(cache=True, nogil=True, fastmath=True)
def first_collision(blocked, x0, y0, inv_res, poses, bx, by):
    """Index of the first of poses (N, 3: x, y, heading) at which a body point (bx, by) lies in a
    blocked cell or off the grid; -1 if none."""
    nx, ny = blocked.shape
    for k in range(poses.shape[0]):
        c, s = math.cos(poses[k, 2]), math.sin(poses[k, 2])
        for p in range(bx.shape[0]):
            fx = (poses[k, 0] + c * bx[p] - s * by[p] - x0) * inv_res
            fy = (poses[k, 1] + s * bx[p] + c * by[p] - y0) * inv_res
            if fx < 0.0 or fy < 0.0:
                return k
            i, j = int(fx), int(fy)
            if i >= nx or j >= ny or blocked[i, j]:
                return k
    return -1
