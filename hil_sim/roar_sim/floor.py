"""The track's floor as the camera sees it: asphalt with white edge lines and a dashed yellow
centre line, painted into a texture and laid on a tessellated quad over the track.

TinyRenderer (the headless renderer) drops whole triangles that cross the camera's near plane,
so the floor is a grid of small cells rather than two huge triangles.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import matplotlib.image
import numpy as np
from roar_sim.quiet_pybullet import pb

from roar_sim.track import Track

ASPHALT_RGB = (64, 64, 69)
EDGE_LINE_RGB = (240, 240, 240)
CENTRE_LINE_RGB = (230, 200, 40)
PIXEL_M = 0.01  # [m] texture resolution
MARGIN_M = 0.5  # [m] floor beyond the walls
EDGE_LINE_INSET_M = 0.1  # [m] from the wall to the middle of the edge line
EDGE_LINE_WIDTH_M = 0.05  # [m]
CENTRE_LINE_WIDTH_M = 0.03  # [m]
CENTRE_DASH_M = 0.4  # [m] one dash plus one gap
CELL_M = 0.25  # [m] floor mesh cell
FLOOR_Z_M = 0.001  # [m] above the collision plane, so it is drawn on top of it


class FloorImage:
    """The painted floor: an RGB image whose pixel (row, col) covers world point
    (origin_x + col * PIXEL_M, origin_y + (rows - 1 - row) * PIXEL_M)."""

    def __init__(self, track: Track) -> None:
        left, right = track.edges()
        corners = np.vstack([left, right])
        self.origin = corners.min(axis=0) - MARGIN_M  # [m] world (x, y) of the bottom-left pixel
        self.extent = corners.max(axis=0) + MARGIN_M - self.origin  # [m]
        cols, rows = (np.ceil(self.extent / PIXEL_M)).astype(int)
        self.rgb = np.empty((rows, cols, 3), np.uint8)
        self.rgb[:] = ASPHALT_RGB
        inset = 1.0 - EDGE_LINE_INSET_M / (track.width_m / 2)
        for edge in (left, right):
            self._paint(track.centerline + inset * (edge - track.centerline), EDGE_LINE_RGB, EDGE_LINE_WIDTH_M)
        self._paint(track.centerline, CENTRE_LINE_RGB, CENTRE_LINE_WIDTH_M, dash_m=CENTRE_DASH_M)

    def pixel(self, xy) -> tuple[int, int]:
        """(row, col) of a world point."""
        col, up = ((np.asarray(xy, dtype=float) - self.origin) / PIXEL_M).astype(int)
        return int(self.rgb.shape[0] - 1 - up), int(col)

    def _paint(self, polyline: np.ndarray, rgb: tuple[int, int, int], width_m: float,
               dash_m: float | None = None) -> None:
        """Stamp a closed polyline, sampled every half pixel, with a square brush."""
        a, b = polyline, np.roll(polyline, -1, axis=0)
        samples = []
        for p, q in zip(a, b):
            k = max(1, int(np.linalg.norm(q - p) / (PIXEL_M / 2)))
            samples.append(p + (np.arange(k) / k)[:, None] * (q - p))
        pts = np.vstack(samples)
        if dash_m:
            s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
            pts = pts[(s % dash_m) < dash_m / 2]
        rows, cols = self.rgb.shape[:2]
        col = ((pts[:, 0] - self.origin[0]) / PIXEL_M).astype(int)
        row = rows - 1 - ((pts[:, 1] - self.origin[1]) / PIXEL_M).astype(int)
        r = max(0, int(round(width_m / PIXEL_M / 2)))
        for dr in range(-r, r + 1):
            for dc in range(-r, r + 1):
                self.rgb[np.clip(row + dr, 0, rows - 1), np.clip(col + dc, 0, cols - 1)] = rgb


def add_floor(track: Track, client: int) -> int:
    """Add the painted floor (visual only: the car drives on the plane below) and return its body."""
    image = FloorImage(track)
    nx, ny = (np.ceil(image.extent / CELL_M)).astype(int)
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
    visual = pb.createVisualShape(pb.GEOM_MESH, vertices=vertices, indices=indices, uvs=uvs,
                                  normals=[[0, 0, 1]] * len(vertices), physicsClientId=client)
    body = pb.createMultiBody(0, -1, visual, [0, 0, 0], physicsClientId=client)
    with tempfile.TemporaryDirectory(prefix="roar-floor-") as tmp:  # PyBullet loads textures from files
        path = Path(tmp) / "floor.png"
        matplotlib.image.imsave(path, image.rgb)
        texture = pb.loadTexture(str(path), physicsClientId=client)
    pb.changeVisualShape(body, -1, textureUniqueId=texture, physicsClientId=client)
    return body

