"""The ray-cast camera's compiled loops (roar_sim.world.ray_camera; Numba, module level so that its
disk cache serves every later process): the walls round each camera by bearing, the solids near
it, and every pixel."""

import math

import numba as nb
import numpy as np

from roar_sim.world.appearance import HALF_L, HALF_W, PAINT_EDGE, HEIGHT, RADIUS, RED, X, Y, YAW, Z0
from roar_sim.world.wall_field import sdf_in

BACKGROUND = 255  # what is beyond the far plane: PyBullet's white
EDGE_HIT_M = 1e-3  # [m] a ray this near a wall's face has met it


@nb.njit(cache=True, nogil=True, fastmath=True)
def _mix(x):
    """splitmix64's finaliser: a 64-bit hash."""
    x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return x ^ (x >> np.uint64(31))


@nb.njit(cache=True, nogil=True, fastmath=True)
def _normal(h, channel):
    """A standard normal draw, near enough (Irwin-Hall: three 7-bit uniforms summed), from 21 bits of
    the hash h: channel 0, 1 or 2 of a pixel."""
    bits = h >> np.uint64(21 * channel)
    total = 0.0
    for _ in range(3):
        total += (float(bits & np.uint64(0x7F)) + 0.5) / 128.0
        bits >>= np.uint64(7)
    return (total - 1.5) * 2.0


@nb.njit(cache=True, nogil=True, fastmath=True, parallel=True)
def walls_around(cams, track_of, field, field_meta, to_light, colour, ambient, diffuse, reach, q_max, wall_at,
                  wall_shade):
    """wall_at[i, b] [m]: how far camera i sees a wall on the floor's plane along bearing b (BINS
    bins uniform in q, the bearing's tangent off the camera's heading, right +, over -q_max..q_max);
    wall_shade[i, b]: that wall's face lit per channel (ambient + diffuse by its normal)."""
    n, bins = wall_at.shape
    for job in nb.prange(n * bins):
        i, b = job // bins, job % bins
        k_ = track_of[i]
        ox, oy, yaw = cams[i, 0], cams[i, 1], cams[i, 3]
        q = -q_max + 2.0 * q_max * b / (bins - 1)
        norm = math.sqrt(1.0 + q * q)
        dx, dy = (math.cos(yaw) + q * math.sin(yaw)) / norm, (math.sin(yaw) - q * math.cos(yaw)) / norm
        fx0, fy0, fres = field_meta[k_, 0], field_meta[k_, 1], field_meta[k_, 2]
        fnx, fny, fstart = int(field_meta[k_, 3]), int(field_meta[k_, 4]), int(field_meta[k_, 5])
        r = 0.0
        hit = False
        while r < reach:
            d = sdf_in(field, fx0, fy0, fres, fnx, fny, fstart, ox + r * dx, oy + r * dy)
            if d < EDGE_HIT_M:
                hit = True
                break
            r += d
        wall_at[i, b] = r if hit else 1e9
        if hit:
            px, py, e = ox + r * dx, oy + r * dy, 0.01
            gx = (sdf_in(field, fx0, fy0, fres, fnx, fny, fstart, px + e, py)
                  - sdf_in(field, fx0, fy0, fres, fnx, fny, fstart, px - e, py))
            gy = (sdf_in(field, fx0, fy0, fres, fnx, fny, fstart, px, py + e)
                  - sdf_in(field, fx0, fy0, fres, fnx, fny, fstart, px, py - e))
            g = math.sqrt(gx * gx + gy * gy) + 1e-12
            cos = max(0.0, (gx * to_light[0] + gy * to_light[1]) / g)
            for ch in range(3):
                wall_shade[i, b, ch] = ambient + diffuse * colour[ch] * cos


@nb.njit(cache=True, nogil=True, fastmath=True)
def wall_faces(ox, oy, angles, out, reach, to_light, colour, ambient, diffuse, wall_at, wall_shade):
    """One camera's wall_at and wall_shade rows (walls_around's) from the ranges `out` [m] at which
    its bearings `angles` [rad, world] met the walls' boxes (reach: none): a face's normal from the
    hit at the neighbouring bearing nearer this one's (on the same wall), turned to the camera."""
    bins = angles.shape[0]
    xs, ys = np.empty(bins), np.empty(bins)
    for b in range(bins):
        wall_at[b] = out[b] if out[b] < reach else 1e9
        xs[b], ys[b] = ox + out[b] * math.cos(angles[b]), oy + out[b] * math.sin(angles[b])
    for b in range(bins):
        lo = min(b, bins - 2)  # the segment lo -> lo + 1: to the next hit (at the last bearing, from the one before)
        if 0 < b < bins - 1 and math.hypot(xs[b] - xs[b - 1], ys[b] - ys[b - 1]) < math.hypot(
                xs[b + 1] - xs[b], ys[b + 1] - ys[b]):
            lo = b - 1  # the one before is shorter
        alx, aly = xs[lo + 1] - xs[lo], ys[lo + 1] - ys[lo]
        norm = max(math.hypot(alx, aly), 1e-12)
        nx, ny = -aly / norm, alx / norm
        facing = nx * (ox - xs[b]) + ny * (oy - ys[b])
        side = 1.0 if facing > 0.0 else (-1.0 if facing < 0.0 else 0.0)
        cos = max(0.0, side * (nx * to_light[0] + ny * to_light[1]))
        for ch in range(3):
            wall_shade[b, ch] = ambient + diffuse * colour[ch] * cos


@nb.njit(cache=True, nogil=True, fastmath=True)
def solids_near(cams, track_of, solids, solid_at, reach, near):
    """near[i, :count] the solids of camera i's track within `reach` [m] and not wholly behind it;
    returns each camera's count."""
    n = cams.shape[0]
    counts = np.zeros(n, np.int64)
    for i in range(n):
        first, many = solid_at[track_of[i], 0], solid_at[track_of[i], 1]
        cx, cy = math.cos(cams[i, 3]), math.sin(cams[i, 3])
        for j in range(first, first + many):
            bound = math.sqrt(solids[j, HALF_L] ** 2 + solids[j, HALF_W] ** 2) + abs(solids[j, RADIUS])
            rx, ry = solids[j, X] - cams[i, 0], solids[j, Y] - cams[i, 1]
            if math.sqrt(rx * rx + ry * ry) - bound < reach and rx * cx + ry * cy > -bound:
                near[i, counts[i]] = j
                counts[i] += 1
    return counts


@nb.njit(cache=True, nogil=True, fastmath=True)
def _hit_solid(s, ox, oy, oz, dx, dy, dz):
    """(t, normal x, y, z) where the ray o + t d first meets solid row s (t > 0); t = inf if never."""
    inf = math.inf
    cx, cy, z0, h, radius = s[X], s[Y], s[Z0], s[HEIGHT], s[RADIUS]
    rx, ry, rz = ox - cx, oy - cy, oz - z0
    if radius == 0.0:  # a box turned by yaw: the slab method in its own frame
        c, sn = math.cos(s[YAW]), math.sin(s[YAW])
        o = (c * rx + sn * ry, -sn * rx + c * ry, rz - h / 2)
        d = (c * dx + sn * dy, -sn * dx + c * dy, dz)
        half = (s[HALF_L], s[HALF_W], h / 2)
        t0, t1, axis, sign = -inf, inf, -1, 0.0
        for a in range(3):
            if abs(d[a]) < 1e-12:
                if abs(o[a]) > half[a]:
                    return inf, 0.0, 0.0, 0.0
                continue
            ta, tb = (-half[a] - o[a]) / d[a], (half[a] - o[a]) / d[a]
            entering = -1.0 if ta < tb else 1.0  # which face the ray enters by
            if ta > tb:
                ta, tb = tb, ta
            if ta > t0:
                t0, axis, sign = ta, a, entering
            t1 = min(t1, tb)
        if t0 > t1 or t0 <= 0.0 or axis < 0:
            return inf, 0.0, 0.0, 0.0
        if axis == 0:
            return t0, sign * c, sign * sn, 0.0
        if axis == 1:
            return t0, -sign * sn, sign * c, 0.0
        return t0, 0.0, 0.0, sign
    best, nx_, ny_, nz_ = inf, 0.0, 0.0, 0.0
    if radius > 0.0:  # a cylinder: its side, then its top
        a = dx * dx + dy * dy
        b = 2.0 * (rx * dx + ry * dy)
        cc = rx * rx + ry * ry - radius * radius
        disc = b * b - 4.0 * a * cc
        if a > 1e-12 and disc >= 0.0:
            t = (-b - math.sqrt(disc)) / (2.0 * a)
            z = rz + t * dz
            if t > 0.0 and 0.0 <= z <= h:
                best, nx_, ny_ = t, (rx + t * dx) / radius, (ry + t * dy) / radius
        if abs(dz) > 1e-12:
            t = (h - rz) / dz
            if 0.0 < t < best and (rx + t * dx) ** 2 + (ry + t * dy) ** 2 <= radius * radius:
                best, nx_, ny_, nz_ = t, 0.0, 0.0, 1.0
        return best, nx_, ny_, nz_
    k = -radius / h  # a cone: its side's radius shrinks by k a metre up, to its apex at h
    pz = rz - h
    a = dx * dx + dy * dy - k * k * dz * dz
    b = 2.0 * (rx * dx + ry * dy - k * k * pz * dz)
    cc = rx * rx + ry * ry - k * k * pz * pz
    if abs(a) < 1e-12:
        return inf, 0.0, 0.0, 0.0
    disc = b * b - 4.0 * a * cc
    if disc < 0.0:
        return inf, 0.0, 0.0, 0.0
    root = math.sqrt(disc)
    for t in ((-b - root) / (2.0 * a), (-b + root) / (2.0 * a)):
        z = rz + t * dz
        if 0.0 < t < best and 0.0 <= z <= h:
            best = t
    if best == inf:
        return inf, 0.0, 0.0, 0.0
    px, py = rx + best * dx, ry + best * dy
    r = math.sqrt(px * px + py * py) + 1e-12
    norm = math.sqrt(1.0 + k * k)
    return best, px / r / norm, py / r / norm, k / norm


@nb.njit(cache=True, nogil=True, fastmath=True, inline="always")
def _paint_at(x, y, paint, paint_class, cell_start, cell_tris, raster, x0, y0, cell, nx, ny, cell_base, rres, rnx,
              rny, rbase):
    """The colour class of the floor at (x, y) [m]: its raster cell's, where no edge is near; else the
    paint triangle there (from its grid cell's list), else 0 (asphalt)."""
    fx, fy = (x - x0) / rres, (y - y0) / rres
    if not (0.0 <= fx < rnx and 0.0 <= fy < rny):
        return 0
    c = raster[rbase + int(fx) * rny + int(fy)]
    if c != PAINT_EDGE:
        return c
    ix, iy = int(math.floor((x - x0) / cell)), int(math.floor((y - y0) / cell))
    if not (0 <= ix < nx and 0 <= iy < ny):
        return 0
    c = cell_base + ix * ny + iy
    for m in range(cell_start[c], cell_start[c + 1]):
        t = cell_tris[m]
        ax, ay, bx, by, cx, cy = paint[t, 0], paint[t, 1], paint[t, 2], paint[t, 3], paint[t, 4], paint[t, 5]
        d1 = (bx - ax) * (y - ay) - (by - ay) * (x - ax)
        d2 = (cx - bx) * (y - by) - (cy - by) * (x - bx)
        d3 = (ax - cx) * (y - cy) - (ay - cy) * (x - cx)
        if not ((d1 < 0.0 or d2 < 0.0 or d3 < 0.0) and (d1 > 0.0 or d2 > 0.0 or d3 > 0.0)):
            return paint_class[t]
    return 0


@nb.njit(cache=True, nogil=True, fastmath=True, parallel=True)
def pixels(cams, track_of, paint, paint_class, cell_start, cell_tris, raster, paint_meta, palette, wall_rgb, fx, fy,
           cx, cy, far, q_max, wall_height, noise, keys, wall_at, wall_shade, solids, near, near_count, to_light,
           colour, ambient, diffuse, rgb, depth):
    """Every pixel of every camera's frame: the floor where its ray meets the floor before a wall (by
    walls_around's table at its bearing), a wall's face, or the white beyond; then the nearest
    solid it meets before that."""
    n, height, width = depth.shape
    bins = wall_at.shape[1]
    for row in nb.prange(n * height):
        i, v = row // height, row % height
        k_ = track_of[i]
        ox, oy, oz, yaw, pitch = cams[i, 0], cams[i, 1], cams[i, 2], cams[i, 3], cams[i, 4]
        cy_, sy_, cp, sp = math.cos(yaw), math.sin(yaw), math.cos(pitch), math.sin(pitch)
        down = (v - cy) / fy
        ahead = cp - down * sp  # [m] the ray's reach along the car's heading per metre of depth
        dz = -sp - down * cp
        bx, by = ahead * cy_, ahead * sy_
        px0, py0, cell = paint_meta[k_, 0], paint_meta[k_, 1], paint_meta[k_, 2]
        pnx, pny, cell_base = int(paint_meta[k_, 3]), int(paint_meta[k_, 4]), int(paint_meta[k_, 5])
        rres, rnx = paint_meta[k_, 6], int(paint_meta[k_, 7])
        rny, rbase = int(paint_meta[k_, 8]), int(paint_meta[k_, 9])
        t_ground = oz / -dz if dz < 0.0 else 1e9
        # (a camera below the walls' top: a rising ray is past everything where it rises above them)
        t_end = min(t_ground, far, (wall_height - oz) / dz if dz > 0.0 else 1e9)
        for u in range(width):
            right = (u - cx) / fx
            dx, dy = bx + right * sy_, by - right * cy_
            q = right / ahead if ahead > 1e-9 else 1e9
            at = (q + q_max) / (2.0 * q_max) * (bins - 1)
            j = min(bins - 2, max(0, int(at)))
            w_ = min(1.0, max(0.0, at - j))
            a, b = wall_at[i, j], wall_at[i, j + 1]
            r_wall = a if b > 1e8 else b if a > 1e8 else a + (b - a) * w_  # [m] on the floor's plane
            t_wall = r_wall / (ahead * math.sqrt(1.0 + q * q)) if ahead > 1e-9 else 1e9
            if t_wall < t_end:
                jj = j + 1 if w_ > 0.5 else j
                r = wall_rgb[0] * wall_shade[i, jj, 0]
                g = wall_rgb[1] * wall_shade[i, jj, 1]
                bl = wall_rgb[2] * wall_shade[i, jj, 2]
                t_hit = t_wall
            elif t_ground < far:
                c = _paint_at(ox + t_ground * dx, oy + t_ground * dy, paint, paint_class, cell_start, cell_tris,
                              raster, px0, py0, cell, pnx, pny, cell_base, rres, rnx, rny, rbase)
                r, g, bl = palette[c, 0], palette[c, 1], palette[c, 2]
                t_hit = t_ground
            else:
                r = g = bl = BACKGROUND
                t_hit = far
            for m in range(near_count[i]):
                s = solids[near[i, m]]
                t, sx, sy, sz = _hit_solid(s, ox, oy, oz, dx, dy, dz)
                if t < t_hit and t < far:
                    t_hit = t
                    cos = max(0.0, sx * to_light[0] + sy * to_light[1] + sz * to_light[2])
                    r = s[RED] * (ambient + diffuse * colour[0] * cos)
                    g = s[RED + 1] * (ambient + diffuse * colour[1] * cos)
                    bl = s[RED + 2] * (ambient + diffuse * colour[2] * cos)
            depth[i, v, u] = t_hit
            if noise > 0.0:
                h = _mix(keys[i] * np.uint64(0x9E3779B97F4A7C15) + np.uint64(v * width + u))
                r += noise * _normal(h, 0)
                g += noise * _normal(h, 1)
                bl += noise * _normal(h, 2)
            rgb[i, v, u, 0] = min(255.0, max(0.0, r + 0.5))
            rgb[i, v, u, 1] = min(255.0, max(0.0, g + 0.5))
            rgb[i, v, u, 2] = min(255.0, max(0.0, bl + 0.5))
