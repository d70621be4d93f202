"""The track's floor as the camera sees it: asphalt with white edge lines (inside every wall) and a
dashed yellow centre line, painted into a texture and laid on a tessellated quad over the track.

TinyRenderer (the headless renderer) drops whole triangles that cross the camera's near plane,
so the floor is a grid of small cells rather than two huge triangles.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
from roar_sim.world.bullet import pb

from roar.tracks import Track
from roar_sim.world.cache import per_shape

ASPHALT_RGB = (64, 64, 69)
EDGE_LINE_RGB = (240, 240, 240)
CENTRE_LINE_RGB = (230, 200, 40)
MARKER_RGB = (40, 180, 60)  # a tunnel's floor markers: green
PIXEL_M = 0.01  # [m] texture resolution, coarser on tracks too big for MAX_TEXTURE_PX
MAX_TEXTURE_PX = 4096  # [px] per side: at most 48 MiB of RGB, whatever the track's size
MARGIN_M = 0.5  # [m] floor beyond the walls
EDGE_LINE_INSET_M = 0.1  # [m] from the wall to the middle of the edge line
EDGE_LINE_WIDTH_M = 0.05  # [m]
CENTRE_LINE_WIDTH_M = 0.03  # [m]
CENTRE_DASH_M = 0.4  # [m] one dash plus one gap
CELL_M = 0.25  # [m] floor mesh cell, larger on tracks too big for MAX_CELLS
MAX_CELLS = 256  # per side of the floor mesh
FLOOR_Z_M = 0.001  # [m] above the collision plane, so it is drawn on top of it


class FloorImage:
    """The painted floor: an RGB image whose pixel (row, col) covers world point
    (origin_x + col * pixel_m, origin_y + (rows - 1 - row) * pixel_m)."""

    def __init__(self, track: Track) -> None:
        corners = np.vstack([*track.edges(), np.reshape(track.region.bounds, (2, 2))])
        self.origin = corners.min(axis=0) - MARGIN_M  # [m] world (x, y) of the bottom-left pixel
        self.extent = corners.max(axis=0) + MARGIN_M - self.origin  # [m]
        self.pixel_m = max(PIXEL_M, float(self.extent.max()) / MAX_TEXTURE_PX)  # [m]
        cols, rows = np.minimum(np.ceil(self.extent / self.pixel_m), MAX_TEXTURE_PX).astype(int)
        self.rgb = np.empty((rows, cols, 3), np.uint8)
        self.rgb[:] = ASPHALT_RGB
        if track.course is not None:  # a tunnel: a bare floor with its green markers
            for x, y, yaw in track.course.markers:
                self._rectangle(x, y, yaw, MARKER_RGB)
            return
        for line in edge_lines(track):
            self._paint(line, EDGE_LINE_RGB, EDGE_LINE_WIDTH_M)
        self._paint(track.centerline, CENTRE_LINE_RGB, CENTRE_LINE_WIDTH_M, dash_m=CENTRE_DASH_M)

    def pixel(self, xy) -> tuple[int, int]:
        """(row, col) of a world point."""
        col, up = ((np.asarray(xy, dtype=float) - self.origin) / self.pixel_m).astype(int)
        return int(self.rgb.shape[0] - 1 - up), int(col)

    def _rectangle(self, x: float, y: float, yaw: float, rgb: tuple[int, int, int]) -> None:
        """Fill a marker's rectangle (MARKER_SIZE_M, long side along yaw) centred on (x, y)."""
        from roar.tracks.tunnel import MARKER_SIZE_M

        rows, cols = self.rgb.shape[:2]
        reach = float(np.hypot(*MARKER_SIZE_M)) / 2
        r0, c0 = self.pixel((x - reach, y + reach))
        r1, c1 = self.pixel((x + reach, y - reach))
        rr, cc = np.mgrid[max(0, r0):min(rows, r1 + 1), max(0, c0):min(cols, c1 + 1)]
        px = self.origin[0] + (cc + 0.5) * self.pixel_m - x
        py = self.origin[1] + (rows - 1 - rr + 0.5) * self.pixel_m - y
        along, across = px * np.cos(yaw) + py * np.sin(yaw), -px * np.sin(yaw) + py * np.cos(yaw)
        inside = (np.abs(along) <= MARKER_SIZE_M[0] / 2) & (np.abs(across) <= MARKER_SIZE_M[1] / 2)
        self.rgb[rr[inside], cc[inside]] = rgb

    def _paint(self, polyline: np.ndarray, rgb: tuple[int, int, int], width_m: float,
               dash_m: float | None = None) -> None:
        """Stamp a closed polyline, sampled every half pixel, with a square brush."""
        a, b = polyline, np.roll(polyline, -1, axis=0)
        samples = []
        for p, q in zip(a, b):
            k = max(1, int(np.linalg.norm(q - p) / (self.pixel_m / 2)))
            samples.append(p + (np.arange(k) / k)[:, None] * (q - p))
        pts = np.vstack(samples)
        if dash_m:
            s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
            pts = pts[(s % dash_m) < dash_m / 2]
        rows, cols = self.rgb.shape[:2]
        col = ((pts[:, 0] - self.origin[0]) / self.pixel_m).astype(int)
        row = rows - 1 - ((pts[:, 1] - self.origin[1]) / self.pixel_m).astype(int)
        r = max(0, int(round(width_m / self.pixel_m / 2)))
        for dr in range(-r, r + 1):
            for dc in range(-r, r + 1):
                self.rgb[np.clip(row + dr, 0, rows - 1), np.clip(col + dc, 0, cols - 1)] = rgb


def edge_lines(track: Track) -> list[np.ndarray]:
    """The white edge lines, EDGE_LINE_INSET_M inside every wall: along each side of the centre
    line, each point's half width less the inset from it (where that folds into a hairpin's
    inner edge or runs past a wall midway, it stops); a map's walls, followed inwards."""
    import shapely

    if track.area is not None or track.extra_area:
        inner = track.region.buffer(-EDGE_LINE_INSET_M, join_style="round")
        parts = getattr(inner, "geoms", [inner])
        return [np.asarray(ring.coords)[:-1] for part in parts if not part.is_empty
                for ring in (part.exterior, *part.interiors)]
    inset = np.clip(track.half_widths - EDGE_LINE_INSET_M, 0.0, None)
    lines = [track.centerline + inset[:, :1] * track.normals, track.centerline - inset[:, 1:] * track.normals]
    keep = track.region.buffer(-EDGE_LINE_INSET_M / 2)
    return [line if shapely.contains_xy(keep, line[:, 0], line[:, 1]).all() else
            line[shapely.contains_xy(keep, line[:, 0], line[:, 1])] for line in lines]


def add_floor(track: Track, client: int) -> int:
    """Add the painted floor (visual only: the car drives on the plane below) and return its body."""
    vertices, uvs, indices, png = _floor_kit(track)
    visual = pb.createVisualShape(pb.GEOM_MESH, vertices=vertices, indices=indices, uvs=uvs,
                                  normals=[[0, 0, 1]] * len(vertices), physicsClientId=client)
    body = pb.createMultiBody(0, -1, visual, [0, 0, 0], physicsClientId=client)
    texture = pb.loadTexture(str(png), physicsClientId=client)  # PyBullet loads textures from files
    pb.changeVisualShape(body, -1, textureUniqueId=texture, physicsClientId=client)
    return body


_TEXTURES: tempfile.TemporaryDirectory | None = None  # removed when the process ends


def _floor_kit(track: Track) -> tuple[list, list, list, Path]:
    """(vertices, uvs, indices, texture PNG) of a track's floor, made once per track shape: a
    new world of the same track (every Gym reset) only loads them."""
    return per_shape("floor", track, lambda: _make_floor_kit(track))


def _make_floor_kit(track: Track) -> tuple[list, list, list, Path]:
    global _TEXTURES
    image = FloorImage(track)
    cell_m = max(CELL_M, float(image.extent.max()) / MAX_CELLS)  # [m]
    nx, ny = (np.ceil(image.extent / cell_m)).astype(int)
    x0, y0 = image.origin
    w, h = image.extent
    vertices, uvs, indices = [], [], []
    for j in range(ny + 1):
        for i in range(nx + 1):
            vertices.append([x0 + w * i / nx, y0 + h * j / ny, FLOOR_Z_M])
            uvs.append([i / nx, j / ny])
    for j in range(ny):
        for i in range(nx):
            a = j * (nx + 1) + i
            indices += [a, a + 1, a + nx + 2, a, a + nx + 2, a + nx + 1]
    from PIL import Image  # here: only a car with a camera needs the floor's paint

    _TEXTURES = _TEXTURES or tempfile.TemporaryDirectory(prefix="roar-floor-")
    png = Path(_TEXTURES.name) / f"{track.fingerprint.hex()[:16]}.png"
    Image.fromarray(image.rgb).save(png)
    return vertices, uvs, indices, png
