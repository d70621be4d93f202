"""A camera for the batched world's flat worlds: each pixel's ray cast onto the floor (its paint, a
raster of each track) and the walls (marched on the track's distance field once a bearing: they
stand upright), batched over cars and rows in compiled loops. The PyBullet car's camera as
roar/Race-v0 has it: the ZED link's place, the same pinhole (roar.vision's SIMULATED_CAR_CAMERA:
vertical field of view, pitch, principal point between the middle pixels), PyBullet's default
light on the same colours, white beyond the far plane, depth along the optical axis; on request a
mount turned per car (shake=, as roar_sim.sensors.camera_noise shakes it) and the sensor's noise
(noise=, its sigma; drawn from each car's key, the same every run).

    floors = FloorPool(pool)                          # every track's paint at 1 cm
    rgb, depth = render(world, floors, 320, 240)      # uint8 [n, 240, 320, 3], float32 [n, 240, 320]

What it leaves out: cones, boxes, people, start lights and markers standing up (a flat world's
paint and walls only), shadows, and the renderers' anti-aliasing.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from roar.vision.geometry import SIMULATED_CAR_CAMERA
from roar_sim.batch import kernels as k
from roar_sim.batch.model import URDF_LIDAR_AHEAD_M
from roar_sim.world import floor
from roar_sim.world.scene import WALL_HEIGHT_M, WALL_RGBA, Light

FLOOR_RES_M = 0.01  # [m] the floor raster's cell
CAMERA_AHEAD_M = 0.39  # [m] the ZED link ahead of the base's origin (racecar.urdf; measured on a settled car)
CAMERA_HEIGHT_M = 0.0908  # [m] ...and above the floor
NEAR_M, FAR_M = 0.05, 10.0  # [m] the renderers' planes (roar_sim.world.scene.World.render's)
BACKGROUND = 255  # what is beyond the far plane: PyBullet's white
MARGIN_M = 1.0  # [m] the raster reaches this far beyond the walls
EDGE_HIT_M = 1e-3  # [m] a ray this near a wall's face has met it
# Walls stand upright, so where a ray meets one depends on its bearing alone: each frame marches
# BINS bearings once on the floor's plane (uniform in q, the bearing's tangent off the heading, out
# to Q_MAX: past a 320 x 240 frame's corners at the camera's pitch) and every pixel reads its own
BINS = 1024
Q_MAX = 1.3


class FloorPool:
    """Every pool track's floor as colour classes at FLOOR_RES_M (0: asphalt, then each paint of
    roar_sim.world.floor in turn) and the classes' colours as lit from above."""

    def __init__(self, pool, light: Light | None = None) -> None:
        from PIL import Image, ImageDraw

        self.light = light or Light()
        colours = [floor.ASPHALT_RGB]
        rasters, meta, at = [], [], 0
        for track in pool.tracks:
            walls = np.concatenate(track.walls)
            low = walls.min(axis=0) - MARGIN_M
            high = walls.max(axis=0) + MARGIN_M
            nx, ny = (np.ceil((high - low) / FLOOR_RES_M).astype(int) + 1).tolist()
            image = Image.new("L", (nx, ny), 0)  # x along columns, y along rows
            draw = ImageDraw.Draw(image)
            for paint in floor.paints(track):
                if paint.rgb not in colours:
                    colours.append(paint.rgb)
                index = colours.index(paint.rgb)
                cells = (paint.vertices[:, :2] - low) / FLOOR_RES_M
                for tri in paint.triangles:
                    draw.polygon([tuple(cells[j]) for j in tri], fill=index)
            raster = np.asarray(image, dtype=np.uint8).T  # [nx, ny]
            rasters.append(raster.ravel())
            meta.append((low[0], low[1], FLOOR_RES_M, nx, ny, at))
            at += raster.size
        self.raster = np.concatenate(rasters)
        self.meta = np.array(meta, dtype=np.float64)
        to_light = np.asarray(self.light.direction, dtype=float)
        self.to_light = to_light / np.linalg.norm(to_light)  # (the renderers shade a face by ambient + diffuse
        #                                                      times its normal's cosine to this)
        floor_shade = self.light.ambient + self.light.diffuse * max(0.0, float(self.to_light[2]))
        self.palette = np.clip(np.array(colours, dtype=np.float64) * floor_shade, 0, 255)
        self.wall_rgb = np.asarray(WALL_RGBA[:3]) * 255
        self._tables = (np.empty((0, BINS)), np.empty((0, BINS)))

    def tables(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        """The bearings' tables for n cars' frames (render's scratch, kept between frames)."""
        if self._tables[0].shape[0] != n:
            self._tables = (np.empty((n, BINS)), np.empty((n, BINS)))
        return self._tables


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
def _walls_around(cams, track_of, field, field_meta, to_light, ambient, diffuse, reach, wall_at, wall_shade):
    """wall_at[i, b] [m]: how far car i's camera sees a wall on the floor's plane along bearing b
    (BINS bins uniform in q, the bearing's tangent off the camera's heading, right +, over -Q_MAX..
    Q_MAX); wall_shade[i, b]: that wall's face lit (ambient + diffuse by its normal)."""
    n, bins = wall_at.shape
    for job in nb.prange(n * bins):
        i, b = job // bins, job % bins
        k_ = track_of[i]
        ox, oy, yaw = cams[i, 0], cams[i, 1], cams[i, 3]
        q = -Q_MAX + 2.0 * Q_MAX * b / (bins - 1)
        norm = math.sqrt(1.0 + q * q)
        dx, dy = (math.cos(yaw) + q * math.sin(yaw)) / norm, (math.sin(yaw) - q * math.cos(yaw)) / norm
        fx0, fy0, fres = field_meta[k_, 0], field_meta[k_, 1], field_meta[k_, 2]
        fnx, fny, fstart = int(field_meta[k_, 3]), int(field_meta[k_, 4]), int(field_meta[k_, 5])
        r = 0.0
        hit = False
        while r < reach:
            d = k._sdf_in(field, fx0, fy0, fres, fnx, fny, fstart, ox + r * dx, oy + r * dy)
            if d < EDGE_HIT_M:
                hit = True
                break
            r += d
        wall_at[i, b] = r if hit else 1e9
        if hit:
            px, py, e = ox + r * dx, oy + r * dy, 0.01
            gx = (k._sdf_in(field, fx0, fy0, fres, fnx, fny, fstart, px + e, py)
                  - k._sdf_in(field, fx0, fy0, fres, fnx, fny, fstart, px - e, py))
            gy = (k._sdf_in(field, fx0, fy0, fres, fnx, fny, fstart, px, py + e)
                  - k._sdf_in(field, fx0, fy0, fres, fnx, fny, fstart, px, py - e))
            g = math.sqrt(gx * gx + gy * gy) + 1e-12
            wall_shade[i, b] = ambient + diffuse * max(0.0, (gx * to_light[0] + gy * to_light[1]) / g)


@nb.njit(cache=True, nogil=True, fastmath=True, parallel=True)
def _pixels(cams, track_of, raster, raster_meta, palette, wall_rgb, fx, fy, cx, cy, wall_height, noise, keys,
            wall_at, wall_shade, rgb, depth):
    """Every pixel of every car's frame: the floor where its ray meets the floor before a wall (by
    _walls_around's table at its bearing), a wall's face, or the white beyond."""
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
        x0, y0, res = raster_meta[k_, 0], raster_meta[k_, 1], raster_meta[k_, 2]
        nx, ny, start = int(raster_meta[k_, 3]), int(raster_meta[k_, 4]), int(raster_meta[k_, 5])
        t_ground = oz / -dz if dz < 0.0 else 1e9
        # (a camera below the walls' top: a rising ray is past everything where it rises above them)
        t_end = min(t_ground, FAR_M, (wall_height - oz) / dz if dz > 0.0 else 1e9)
        for u in range(width):
            right = (u - cx) / fx
            q = right / ahead
            at = (q + Q_MAX) / (2.0 * Q_MAX) * (bins - 1)
            j = min(bins - 2, max(0, int(at)))
            w_ = min(1.0, max(0.0, at - j))
            a, b = wall_at[i, j], wall_at[i, j + 1]
            r_wall = a if b > 1e8 else b if a > 1e8 else a + (b - a) * w_  # [m] on the floor's plane
            t_wall = r_wall / (ahead * math.sqrt(1.0 + q * q))
            if t_wall < t_end:
                shade = wall_shade[i, j + 1 if w_ > 0.5 else j]
                r, g, bl = wall_rgb[0] * shade, wall_rgb[1] * shade, wall_rgb[2] * shade
                depth[i, v, u] = t_wall
            elif t_ground < FAR_M:
                dx, dy = bx + right * sy_, by - right * cy_
                fxg, fyg = (ox + t_ground * dx - x0) / res, (oy + t_ground * dy - y0) / res
                c = 0
                if 0.0 <= fxg < nx and 0.0 <= fyg < ny:
                    c = raster[start + int(fxg) * ny + int(fyg)]
                r, g, bl = palette[c, 0], palette[c, 1], palette[c, 2]
                depth[i, v, u] = t_ground
            else:
                r = g = bl = BACKGROUND
                depth[i, v, u] = FAR_M
            if noise > 0.0:
                h = _mix(keys[i] * np.uint64(0x9E3779B97F4A7C15) + np.uint64(v * width + u))
                r += noise * _normal(h, 0)
                g += noise * _normal(h, 1)
                bl += noise * _normal(h, 2)
            rgb[i, v, u, 0] = min(255.0, max(0.0, r + 0.5))
            rgb[i, v, u, 1] = min(255.0, max(0.0, g + 0.5))
            rgb[i, v, u, 2] = min(255.0, max(0.0, bl + 0.5))


def camera_poses(world, shake: np.ndarray | None = None) -> np.ndarray:
    """[n, 5]: each car's camera (x, y, height [m], yaw, pitch [rad]); shake [n, 2]: its mount turned
    by (yaw, pitch) more."""
    states = world.states()
    scale = world.params[:, k.P_LIDAR] / URDF_LIDAR_AHEAD_M  # each car's size over the URDF's
    yaw = states[:, 2]
    ahead = CAMERA_AHEAD_M * scale
    cams = np.column_stack([states[:, 0] + ahead * np.cos(yaw), states[:, 1] + ahead * np.sin(yaw),
                            CAMERA_HEIGHT_M * scale, yaw, np.full(world.n, SIMULATED_CAR_CAMERA.pitch_rad)])
    if shake is not None:
        cams[:, 3] += shake[:, 0]
        cams[:, 4] += shake[:, 1]
    return cams


def render(world, floors: FloorPool, width: int, height: int, shake: np.ndarray | None = None,
           noise: float = 0.0, keys: np.ndarray | None = None, out=None) -> tuple[np.ndarray, np.ndarray]:
    """(RGB uint8 [n, height, width, 3], depth float32 [n, height, width] [m]) of every car's camera."""
    model = SIMULATED_CAR_CAMERA.model(width, height)
    rgb, depth = out if out is not None else (np.empty((world.n, height, width, 3), np.uint8),
                                               np.empty((world.n, height, width), np.float32))
    keys = np.zeros(world.n, np.uint64) if keys is None else keys
    light = floors.light
    cams = camera_poses(world, shake)
    wall_at, wall_shade = floors.tables(world.n)
    reach = FAR_M * math.sqrt(1.0 + Q_MAX**2)  # [m] on the floor's plane: the farthest a ray within the far plane gets
    _walls_around(cams, world.track_of, world.pool.field, world.pool.meta, floors.to_light, light.ambient,
                  light.diffuse, reach, wall_at, wall_shade)
    _pixels(cams, world.track_of, floors.raster, floors.meta, floors.palette, floors.wall_rgb, model.fx, model.fy,
            model.cx, model.cy, WALL_HEIGHT_M, float(noise), keys, wall_at, wall_shade, rgb, depth)
    return rgb, depth
