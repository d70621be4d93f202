"""The track's walls and paint drawn in square tiles, so that the camera's software renderer draws
only what lies near enough to be in a frame.

TinyRenderer transforms and clips every triangle of every shape it is given, for each frame: a
272 m circuit's walls (0.15 m boxes: 49,500 triangles) and paint (20,000) cost 17.4 ms a 320x240
frame from the car's camera along the lap, 13.2 with the tiles out of reach skipped (160x120: 8.7
and 4.5; the ground alone costs 9.9 and 2.5: TinyRenderer fills its pixels). Each tile is a body of its own with only a visual shape (the
walls' collision mesh stays one body); before a TinyRenderer frame, `show_near` makes a tile
transparent when none of it can be inside the camera's frustum (PyBullet's renderers skip a
shape whose alpha is 0), and shows it again when it can. A frame is the same either way: only
what lies beyond the far plane, or behind the camera, is left out. EGL draws every tile (a GPU
pays little per triangle), and so does a GUI world's window.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from collections.abc import Sequence

import numpy as np

from roar_sim.world.bullet import pb
from roar_sim.world.renderer import mesh_file

TILE_M = 8.0  # [m] a tile's side
BEHIND_MARGIN_M = 1.0  # [m] a tile counts as behind the camera only this far behind its plane (the camera
# looks down: the floor just behind it in plan is in front of its image plane)


def split(vertices: np.ndarray, triangles: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """The mesh cut into tiles: [(vertices (N, 3), triangles (M, 3))], each triangle in the tile
    that holds its centroid in plan, each tile's vertices its own."""
    vertices, triangles = np.asarray(vertices, float), np.asarray(triangles, np.int64).reshape(-1, 3)
    if not len(triangles):
        return []
    cells = np.floor(vertices[triangles].mean(axis=1)[:, :2] / TILE_M).astype(np.int64)
    _, tile_of = np.unique(cells, axis=0, return_inverse=True)
    pieces = []
    for tile in range(int(tile_of.max()) + 1):
        own = triangles[tile_of.ravel() == tile]
        used, local = np.unique(own, return_inverse=True)
        pieces.append((vertices[used], local.reshape(-1, 3)))
    return pieces


@dataclass
class Tiles:
    """One mesh's tiles in a client: their bodies, the circle [m] round each in plan, its colour."""

    client: int
    rgba: tuple[float, float, float, float]
    bodies: list[int] = field(default_factory=list)
    centres: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    radii: np.ndarray = field(default_factory=lambda: np.zeros(0))
    shown: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))

    @classmethod
    def add(cls, client: int, files: Sequence[tuple[str, Sequence[float], float]],
            rgba: Sequence[float]) -> Tiles:
        """Bodies for tile files [(OBJ path, centre (x, y) [m], radius [m])] in one colour."""
        tiles = cls(client, tuple(float(c) for c in rgba))
        for path, _, _ in files:
            visual = pb.createVisualShape(pb.GEOM_MESH, fileName=path, rgbaColor=list(tiles.rgba),
                                          physicsClientId=client)
            tiles.bodies.append(pb.createMultiBody(0, -1, visual, [0, 0, 0], physicsClientId=client))
        tiles.centres = np.array([c for _, c, _ in files], float).reshape(-1, 2)
        tiles.radii = np.array([r for _, _, r in files], float)
        tiles.shown = np.ones(len(files), bool)
        return tiles

    def show_near(self, position: Sequence[float], yaw: float, reach_m: float) -> None:
        """Show the tiles that may hold something within reach_m [m] of the camera at `position`
        facing `yaw` [rad] in plan, and not wholly behind it; hide the rest."""
        offset = self.centres - np.asarray(position[:2], float)
        near = np.hypot(offset[:, 0], offset[:, 1]) - self.radii <= reach_m
        ahead = offset @ np.array([math.cos(yaw), math.sin(yaw)]) >= -(self.radii + BEHIND_MARGIN_M)
        want = near & ahead
        for k in np.flatnonzero(want != self.shown):
            colour = [*self.rgba[:3], self.rgba[3] if want[k] else 0.0]
            pb.changeVisualShape(self.bodies[k], -1, rgbaColor=colour, physicsClientId=self.client)
        self.shown = want


def tile_files(vertices, triangles) -> list[tuple[str, tuple[float, float], float]]:
    """The mesh's tiles written as OBJ files: [(path, centre (x, y) [m], radius [m] in plan)]."""
    files = []
    for v, t in split(vertices, triangles):
        lo, hi = v[:, :2].min(axis=0), v[:, :2].max(axis=0)
        files.append((mesh_file(v.tolist(), t.ravel().tolist()), (float(lo[0] + hi[0]) / 2, float(lo[1] + hi[1]) / 2),
                      float(np.hypot(*(hi - lo))) / 2))
    return files


def frustum_reach_m(far_m: float, fov_deg: float, aspect: float) -> float:
    """[m] the farthest a point within the camera's frustum can be from it: the far plane's
    corner (PyBullet's field of view is the vertical one)."""
    half_v = math.tan(math.radians(fov_deg) / 2)
    return far_m * math.sqrt(1 + half_v ** 2 * (1 + aspect ** 2))
