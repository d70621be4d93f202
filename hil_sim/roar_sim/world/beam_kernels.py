"""The simulated lidar's beams cast on boxes (the slab method) and on circles, compiled by Numba
(roar_sim.world.lidar_caster): module-level kernels, so that Numba's disk cache serves every
later process."""

import math

import numba as nb
import numpy as np


@nb.njit(cache=True, nogil=True, fastmath=True)
def slabs(ox, oy, angles, boxes, out):
    """out[b]: the nearer of itself and the first of boxes (K, 5: centre x, centre y, yaw, half
    length, half width) that the beam from (ox, oy) at world angle angles[b] meets [m]."""
    dxs, dys = np.cos(angles), np.sin(angles)
    for k in range(boxes.shape[0]):
        cx, cy, yaw, hl, hw = boxes[k, 0], boxes[k, 1], boxes[k, 2], boxes[k, 3], boxes[k, 4]
        c, s = math.cos(yaw), math.sin(yaw)
        px, py = c * (ox - cx) + s * (oy - cy), -s * (ox - cx) + c * (oy - cy)  # the origin in the box's frame
        for b in range(angles.shape[0]):
            ux, uy = c * dxs[b] + s * dys[b], -s * dxs[b] + c * dys[b]
            near, far = -1e30, 1e30
            if abs(ux) < 1e-12:
                if abs(px) > hl:
                    continue
            else:
                t1, t2 = (-hl - px) / ux, (hl - px) / ux
                near, far = max(near, min(t1, t2)), min(far, max(t1, t2))
            if abs(uy) < 1e-12:
                if abs(py) > hw:
                    continue
            else:
                t1, t2 = (-hw - py) / uy, (hw - py) / uy
                near, far = max(near, min(t1, t2)), min(far, max(t1, t2))
            if near <= far and 0.0 < near < out[b]:
                out[b] = near


@nb.njit(cache=True, nogil=True, fastmath=True)
def circles(ox, oy, angles, discs, out):
    """out[b]: the nearer of itself and the first of discs (M, 3: centre x, centre y, radius [m])
    that the beam from (ox, oy) at world angle angles[b] meets from outside [m]."""
    dxs, dys = np.cos(angles), np.sin(angles)
    for k in range(discs.shape[0]):
        px, py, r = ox - discs[k, 0], oy - discs[k, 1], discs[k, 2]
        c = px * px + py * py - r * r
        if c <= 0.0:
            continue  # the beams start inside it
        for b in range(angles.shape[0]):
            half = px * dxs[b] + py * dys[b]
            disc = half * half - c
            if half < 0.0 and disc >= 0.0:
                t = -half - math.sqrt(disc)
                if t < out[b]:
                    out[b] = t
