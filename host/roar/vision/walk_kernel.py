"""The lane detector's walk along a line (roar.vision.lanes.LaneDetector._follow says what it
does), compiled by Numba: in Python a frame's three walks, a window's pixels gathered, moved into
the car's frame and kept per step, took 3-5 ms, most of a camera-only race's frame. Imported only
once Numba is known to be there (roar.compiled)."""

import math

import numba as nb
import numpy as np


@nb.njit(cache=True, nogil=True)
def walk(mask: np.ndarray, x: float, y: float, dx: float, dy: float, known: bool, step: float, x_far: float,
         y_left: float, m_per_px: float, window_m: float, min_pixels: int, min_ahead: float,
         max_turn_rad_per_m: float, elongated: float, points: np.ndarray) -> int:
    """Walk from (x, y) [m] along (dx, dy) (a unit vector, `known` or a guess) over the bird's-eye
    mask (rows from x_far down, columns from y_left right, m_per_px each): the window centres
    found, one a step, into points[:, :2]; returns how many."""
    rows, cols = mask.shape
    half = window_m / 2
    found = 0
    for _ in range(points.shape[0]):
        if dx < min_ahead:  # the line turns across the view: a fit y(x) ends here
            break
        nx, ny = -dy, dx
        x_lo, x_hi, y_lo, y_hi = math.inf, -math.inf, math.inf, -math.inf  # round the window's corners:
        for s in (-1.0, 1.0):  # either side, near and far
            for a in (0.0, 1.0):
                cx, cy = x + s * nx * half + a * dx * step, y + s * ny * half + a * dy * step
                x_lo, x_hi, y_lo, y_hi = min(x_lo, cx), max(x_hi, cx), min(y_lo, cy), max(y_hi, cy)
        r0, r1 = int(max(0.0, (x_far - x_hi) / m_per_px)), int(min(float(rows), (x_far - x_lo) / m_per_px + 1))
        c0, c1 = int(max(0.0, (y_left - y_hi) / m_per_px)), int(min(float(cols), (y_left - y_lo) / m_per_px + 1))
        if r1 - r0 < 2 or c1 - c0 < 2:
            break
        xs, ys = np.empty((r1 - r0) * (c1 - c0)), np.empty((r1 - r0) * (c1 - c0))  # its pixels, in the car's frame
        n = 0
        for r in range(r0, r1):
            for c in range(c0, c1):
                if mask[r, c]:
                    px, py = x_far - r * m_per_px, y_left - c * m_per_px
                    along = (px - x) * dx + (py - y) * dy
                    across = (px - x) * nx + (py - y) * ny
                    if along >= 0.0 and along < step and abs(across) <= half:
                        xs[n], ys[n] = px, py
                        n += 1
        if n < min_pixels:  # nothing here (a dash's gap, a shadow): on in the same direction
            x, y = x + dx * step, y + dy * step
            continue
        mx, my = xs[:n].mean(), ys[:n].mean()
        gx, gy, gap = 0.0, 0.0, 0.0
        if found:
            gx, gy = mx - points[found - 1, 0], my - points[found - 1, 1]
            gap = math.hypot(gx, gy)
        if found and gap > step / 4:  # the direction turns to run through the last two points
            turn = math.atan2(dx * gy - dy * gx, dx * gx + dy * gy)
            limit = max_turn_rad_per_m * gap
            turn = max(-limit, min(limit, turn))
            c, s = math.cos(turn), math.sin(turn)
            dx, dy = c * dx - s * dy, s * dx + c * dy
            if dx < min_ahead:  # this stretch already runs across the view: y(x) ends before it
                break
        elif not found and not known and n >= 3:  # a line found anew turns to its pixels' long axis
            sxx = ((xs[:n] - mx) ** 2).sum() / (n - 1)
            syy = ((ys[:n] - my) ** 2).sum() / (n - 1)
            sxy = ((xs[:n] - mx) * (ys[:n] - my)).sum() / (n - 1)
            mid, spread = (sxx + syy) / 2, math.hypot((sxx - syy) / 2, sxy)
            big, small = mid + spread, mid - spread
            if big >= elongated ** 2 * max(small, 1e-12):  # clearly longer than wide: it has a direction
                ax, ay = (big - syy, sxy) if abs(big - syy) + abs(sxy) > abs(big - sxx) + abs(sxy) else (sxy, big - sxx)
                norm = math.hypot(ax, ay)
                ax, ay = ax / norm, ay / norm
                dx, dy = (ax, ay) if ax * dx + ay * dy >= 0 else (-ax, -ay)
        points[found, 0], points[found, 1] = mx, my
        found += 1
        x, y = mx + dx * step / 2, my + dy * step / 2
    return found
