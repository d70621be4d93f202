"""A camera without Bullet for flat worlds: each pixel's ray cast onto the floor (its paint: a
raster away from its edges, its triangles near them), the walls (marched on the track's distance field once a
bearing: they stand upright) and the few solids (boxes, cylinders, cones and floating lamps:
their surfaces solved exactly), batched over cameras and rows in compiled loops. PyBullet's
renderers' pinhole (square pixels, the principal point between the middle pixels, depth along the
optical axis, white beyond the far plane) and shading (ambient + diffuse by a face's angle to the
light); no specular, shadows or anti-aliasing.

Two users: roar_sim.batch.camera (every car of a batch at once) and World.render with the "rays"
renderer (roar_sim.world.renderer: one car's camera in a PyBullet world whose every body it
accounts for, ~10 x faster than TinyRenderer at 320 x 240).

    scenes = Scenes([track])                                   # floors, walls, solids per track
    rgb, depth = render(scenes, cams, [0], 320, 240, fov_deg=...)  # cams [n, 5]: x, y, z, yaw, pitch
"""

from __future__ import annotations

import math

import numpy as np

from roar_sim.world import floor
from roar_sim.world.appearance import (PAINT_EDGE, SOLID_COLUMNS, WALL_HEIGHT_M, WALL_RGBA, WALL_THICKNESS_M, Light,
                                       solid_row)
from roar_sim.world.lidar_caster import wall_boxes
from roar_sim.world.cache import per_shape

PAINT_CELL_M = 0.1  # [m] the paint's index grid: each cell lists the triangles that meet it
RASTER_M = 0.02  # [m] the paint's raster: a cell's colour class where no triangle's edge comes near it, else
#                  appearance.PAINT_EDGE: a point there is found among the triangles (exact edges; most pixels
#                  read one cell)
MARGIN_M = 1.0  # [m] the grid reaches this far beyond the walls
# Walls stand upright, so where a ray meets one depends on its bearing alone: each frame marches
# BINS bearings once on the floor's plane (uniform in q, the bearing's tangent off the heading, out
# to the frame's widest) and every pixel reads its own
BINS = 1024
# PyBullet's renderers' own light where a world sets none (World.light None), as TinyRenderer shades a
# face: ambient 0.6 + diffuse 0.35 x (its normal . this), measured on a box's four faces (shaded 0.75,
# 0.69, 0.60, 0.60: -x and +y lit) and the floor (0.94); not of unit length, so used as it is
PYBULLET_LIGHT = (-0.42, 0.25, 0.97)


class Scenes:
    """Every track's floor paint (roar_sim.world.floor's, each of a colour class: 0 is asphalt, then
    each paint in turn) as a raster and, near its edges, triangles indexed on a grid; its walls
    (a distance field, or their boxes); and its solids (rows of SOLID_COLUMNS; a tunnel's cones and
    people from the start, add() others); the classes' and walls' colours as lit."""

    def __init__(self, tracks, light: Light | None = None, fields: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        """fields: (every track's walls' distance field one after another, its meta rows), where a
        roar_sim.batch TrackPool holds them: the walls are marched on them; None: each wall's box
        is met exactly (lidar_caster.wall_boxes, by the lidar's slab kernel), nothing to build."""
        self.tracks = list(tracks)
        self.light = light or Light(direction=PYBULLET_LIGHT)
        colours = [floor.ASPHALT_RGB]
        tris, classes, starts, owners, rasters, meta = [], [], [], [], [], []
        tri_base = pair_base = cell_base = raster_base = 0
        for track in self.tracks:
            t, c, (x0, y0, nx, ny), cell_start, cell_tris, own, raster = floor_paint(track)
            for rgb in own:
                if rgb not in colours:
                    colours.append(rgb)
            to_ours = np.array([colours.index(rgb) for rgb in own] + [PAINT_EDGE] * (256 - len(own)), dtype=np.uint8)
            tris.append(t)
            classes.append(to_ours[c])
            starts.append(cell_start + pair_base)
            owners.append(cell_tris + tri_base)
            rasters.append(to_ours[raster].ravel())
            meta.append((x0, y0, PAINT_CELL_M, nx, ny, cell_base, RASTER_M, *raster.shape, raster_base))
            tri_base, pair_base, cell_base = tri_base + len(t), pair_base + len(cell_tris), cell_base + len(cell_start)
            raster_base += raster.size
        self.paint = np.ascontiguousarray(np.concatenate(tris))  # [M, 6] every track's paint triangles
        self.paint_class = np.concatenate(classes)  # [M] their colours (palette rows)
        self.cell_start = np.concatenate(starts)  # each track's index grid, one after another
        self.cell_tris = np.concatenate(owners)
        self.raster = np.concatenate(rasters)  # each track's raster, one after another
        # [K, 10]: x0, y0, cell, nx, ny, its first cell; the raster's cell, size and first index
        self.meta = np.array(meta, dtype=np.float64)
        self.field, self.field_meta = fields if fields is not None else (None, None)
        self.wall_boxes = None if fields is not None else [
            wall_boxes(t, WALL_THICKNESS_M) if t.walls else np.zeros((0, 5)) for t in self.tracks]
        to_light = np.asarray(self.light.direction, dtype=float)
        # (the renderers shade a face by ambient + diffuse times its normal's cosine to this)
        self.to_light = to_light if light is None else to_light / np.linalg.norm(to_light)
        self.colour = np.asarray(self.light.colour, dtype=float)
        floor_shade = self.light.ambient + self.light.diffuse * self.colour * max(0.0, float(self.to_light[2]))
        self.palette = np.clip(np.array(colours, dtype=np.float64) * floor_shade, 0, 255)
        self.wall_rgb = np.asarray(WALL_RGBA[:3]) * 255
        self._solids: list[list[tuple]] = [[*_course_solids(t)] for t in self.tracks]
        self._packed: tuple[np.ndarray, np.ndarray] | None = None
        self._tables = (np.empty((0, BINS)), np.empty((0, BINS, 3)))

    def add(self, track_index: int, rows) -> None:
        """Solids (rows of SOLID_COLUMNS, e.g. solid_row's) standing in a track's world."""
        self._solids[track_index] += [tuple(r) for r in rows]
        self._packed = None

    def set_solids(self, track_index: int, rows) -> None:
        """A track's solids, all of them, from now (a world's that change: lamps switched)."""
        self._solids[track_index] = [tuple(r) for r in rows]
        self._packed = None

    def solids(self) -> tuple[np.ndarray, np.ndarray]:
        """(every track's solids [S, SOLID_COLUMNS], one track after another; [K, 2] each track's
        first row and count)."""
        if self._packed is None:
            counts = [len(s) for s in self._solids]
            rows = [r for s in self._solids for r in s]
            self._packed = (np.array(rows, dtype=np.float64).reshape(-1, SOLID_COLUMNS),
                            np.column_stack([np.concatenate([[0], np.cumsum(counts)[:-1]]), counts]).astype(np.int64))
        return self._packed

    def tables(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        """The bearings' tables for n cameras' frames (render's scratch, kept between frames)."""
        if self._tables[0].shape[0] != n:
            self._tables = (np.empty((n, BINS)), np.empty((n, BINS, 3)))
        return self._tables


def floor_paint(track):
    """(triangles [M, 6]: each paint triangle's corners x0, y0, x1, y1, x2, y2 [m]; classes uint8 [M]:
    each one's colour, an index into colours; (x0, y0, nx, ny): the index grid's first cell's corner
    [m] and its size in PAINT_CELL_M cells; cell_start [nx * ny + 1], cell_tris: the triangles each
    cell meets are cell_tris[cell_start[c]:cell_start[c + 1]]; colours, asphalt first; raster uint8
    [rnx, rny]: the class of each RASTER_M cell from the same corner, PAINT_EDGE where an edge is within a
    cell), made once per track shape in a process."""
    def make():
        colours = [floor.ASPHALT_RGB]
        tris, classes = [np.zeros((0, 6))], [np.zeros(0, np.uint8)]
        for paint in floor.paints(track):
            if paint.rgb not in colours:
                colours.append(paint.rgb)
            corners = paint.vertices[paint.triangles][:, :, :2].reshape(-1, 6)
            tris.append(corners)
            classes.append(np.full(len(corners), colours.index(paint.rgb), np.uint8))
        tris, classes = np.concatenate(tris), np.concatenate(classes)
        walls = np.concatenate(track.walls)
        low = np.minimum(walls.min(axis=0), tris.reshape(-1, 2).min(axis=0, initial=np.inf)) - MARGIN_M
        high = np.maximum(walls.max(axis=0), tris.reshape(-1, 2).max(axis=0, initial=-np.inf)) + MARGIN_M
        nx, ny = (np.ceil((high - low) / PAINT_CELL_M).astype(int) + 1).tolist()
        xs, ys = tris[:, 0::2], tris[:, 1::2]

        def cell_of(v, axis):
            return ((v - low[axis]) // PAINT_CELL_M).astype(int)

        ix0, ix1, iy0, iy1 = cell_of(xs.min(1), 0), cell_of(xs.max(1), 0), cell_of(ys.min(1), 1), cell_of(ys.max(1), 1)
        cells, owners = [], []
        for a in range(int((ix1 - ix0).max(initial=0)) + 1):
            for b in range(int((iy1 - iy0).max(initial=0)) + 1):
                hit = (ix0 + a <= ix1) & (iy0 + b <= iy1)
                cells.append(((ix0 + a) * ny + iy0 + b)[hit])
                owners.append(np.flatnonzero(hit))
        cells, owners = np.concatenate(cells), np.concatenate(owners)
        order = np.argsort(cells, kind="stable")
        cell_start = np.searchsorted(cells[order], np.arange(nx * ny + 1)).astype(np.int64)
        grid = (float(low[0]), float(low[1]), nx, ny)
        raster = _raster(tris, classes, low, high)
        return tris, classes, grid, cell_start, owners[order].astype(np.int64), colours, raster

    return per_shape("floor paint triangles", track, make)


def _raster(tris: np.ndarray, classes: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """The paint's classes at RASTER_M, PAINT_EDGE in every cell an edge crosses and the cells round it
    (so that a cell not PAINT_EDGE lies wholly inside one class)."""
    from PIL import Image, ImageDraw

    rnx, rny = (np.ceil((high - low) / RASTER_M).astype(int) + 1).tolist()
    image, edges = Image.new("L", (rnx, rny), 0), Image.new("L", (rnx, rny), 0)  # x along columns
    fill, outline = ImageDraw.Draw(image), ImageDraw.Draw(edges)
    cells = (tris.reshape(-1, 3, 2) - low) / RASTER_M
    for corners, c in zip(cells, classes):
        points = [tuple(p) for p in corners]
        fill.polygon(points, fill=int(c))
        outline.polygon(points, outline=1)
    raster = np.asarray(image, dtype=np.uint8).T.copy()  # [rnx, rny]
    near = np.asarray(edges, dtype=bool).T
    grown = near.copy()
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            grown |= np.roll(np.roll(near, dx, axis=0), dy, axis=1)
    raster[grown] = PAINT_EDGE
    return raster


def _course_solids(track):
    """A tunnel's cones and people as the world stands them (roar_sim.world.obstacles)."""
    course = getattr(track, "course", None)
    if course is None:
        return []
    from roar_sim.world.obstacles import cone_row, person_row

    return [cone_row(x, y) for x, y in course.cones] + [person_row(x, y) for x, y in course.people]


def pinhole(width: int, height: int, fov_deg: float) -> tuple[float, float, float, float]:
    """(fx, fy, cx, cy) [px] of PyBullet's camera with this vertical field of view: square pixels,
    the principal point between the middle pixels."""
    fy = (height / 2) / math.tan(math.radians(fov_deg) / 2)
    return fy, fy, (width - 1) / 2, (height - 1) / 2


def render(scenes: Scenes, cams: np.ndarray, track_of, width: int, height: int, fov_deg: float,
           far_m: float = 10.0, noise: float = 0.0, keys: np.ndarray | None = None,
           out=None) -> tuple[np.ndarray, np.ndarray]:
    """(RGB uint8 [n, height, width, 3], depth float32 [n, height, width] [m]) of n cameras: cams
    [n, 5] each one's place (x, y, height [m]) and its yaw and downward pitch [rad], track_of [n]
    the scene each looks at. noise: the sensor's sigma (drawn from each camera's key, the same
    every run)."""
    cams = np.ascontiguousarray(cams, dtype=np.float64).reshape(-1, 5)
    n = len(cams)
    track_of = np.ascontiguousarray(np.broadcast_to(np.asarray(track_of, dtype=np.int64), (n,)))
    fx, fy, cx, cy = pinhole(width, height, fov_deg)
    rgb, depth = out if out is not None else (np.empty((n, height, width, 3), np.uint8),
                                               np.empty((n, height, width), np.float32))
    keys = np.zeros(n, np.uint64) if keys is None else keys
    # the widest bearing a pixel has off the heading: the widest column by the rows' least reach ahead
    pitch = float(np.abs(cams[:, 4]).max())
    least_ahead = max(math.cos(pitch) - (height / 2) / fy * math.sin(pitch), 0.05)
    q_max = (width / 2) / fx / least_ahead * 1.02
    from roar.compiled import compiled

    walls_around, solids_near, pixels, _ = compiled("the ray-cast camera", _kernels, "sim")
    light = scenes.light
    wall_at, wall_shade = scenes.tables(n)
    reach = far_m * math.sqrt(1.0 + q_max**2)  # [m] on the floor's plane: the farthest a ray within the far plane gets
    if scenes.field is not None:
        walls_around(cams, track_of, scenes.field, scenes.field_meta, scenes.to_light, scenes.colour, light.ambient,
                     light.diffuse, reach, q_max, wall_at, wall_shade)
    else:
        _walls_by_boxes(scenes, cams, track_of, reach, q_max, wall_at, wall_shade)
    solids, solid_at = scenes.solids()
    solids = solids if len(solids) else np.zeros((1, SOLID_COLUMNS))  # (none at all: a row no track owns)
    near = np.empty((n, len(solids)), np.int64)
    near_count = solids_near(cams, track_of, solids,
                              solid_at, reach, near)
    pixels(cams, track_of, scenes.paint, scenes.paint_class, scenes.cell_start, scenes.cell_tris, scenes.raster,
           scenes.meta,
           scenes.palette, scenes.wall_rgb, fx, fy, cx, cy, float(far_m), q_max, WALL_HEIGHT_M, float(noise), keys,
           wall_at, wall_shade, solids, near, near_count,
           scenes.to_light, scenes.colour, light.ambient, light.diffuse, rgb, depth)
    return rgb, depth


def _walls_by_boxes(scenes: Scenes, cams: np.ndarray, track_of: np.ndarray, reach: float, q_max: float,
                    wall_at: np.ndarray, wall_shade: np.ndarray) -> None:
    """walls_around's tables from each wall's box, met exactly (the lidar's slab kernel); a face's
    normal from the hits at the neighbouring bearings (the nearer of them: on the same wall)."""
    from roar_sim.world.lidar_caster import _kernels as beam_kernels
    from roar.compiled import compiled

    slabs = compiled("the simulated lidar's ray casting", beam_kernels, "sim")[0]
    wall_faces = compiled("the ray-cast camera", _kernels, "sim")[3]
    light = scenes.light
    q = np.linspace(-q_max, q_max, BINS)
    for i, (ox, oy, _, yaw, _) in enumerate(cams):
        boxes = scenes.wall_boxes[track_of[i]]
        boxes = np.ascontiguousarray(boxes[np.hypot(boxes[:, 0] - ox, boxes[:, 1] - oy)
                                           < reach + np.hypot(boxes[:, 3], boxes[:, 4])])
        angles = yaw - np.arctan(q)
        out = np.full(BINS, reach)
        slabs(float(ox), float(oy), angles, boxes, out)
        wall_faces(float(ox), float(oy), angles, out, reach, scenes.to_light, scenes.colour, light.ambient,
                   light.diffuse, wall_at[i], wall_shade[i])


def warm() -> None:
    """Compile the kernels into Numba's disk cache (~8 s, once per install: make setup does it), so
    that a car's first frame takes ~0.7 s, not a stall of its real-time loop."""
    from roar.tracks import get
    from roar_sim.world.obstacles import BOX_RGBA

    track = get("oval")
    box = solid_row(*track.pose_at(1.0)[:2], 0.0, 0.1, 0.1, 0.0, 0.2, 0.0, BOX_RGBA)
    cams = np.array([[*track.start_pose[:2], 0.09, track.start_pose[2], 0.2]])
    fields = (np.full(16, 1e3, np.float32), np.array([[-50.0, -50.0, 25.0, 4, 4, 0]]))
    for scenes in (Scenes([track]), Scenes([track], fields=fields)):  # both ways to the walls
        scenes.add(0, [box])
        render(scenes, cams, 0, 32, 24, 70.0, noise=1.0)


def _kernels(nb):
    from roar_sim.world.ray_kernels import pixels, solids_near, wall_faces, walls_around

    return walls_around, solids_near, pixels, wall_faces
