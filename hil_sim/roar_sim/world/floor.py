"""The track's floor as the camera sees it: the asphalt ground with white edge lines (inside every
wall) and a dashed yellow centre line on it -- or, in a tunnel, green markers and no lane paint.

The paint is geometry, thin strips of triangles just above the ground, not a texture: OpenGL
(the EGL renderer) filters a texture seen at a grazing angle through its mipmaps, which wiped out
a 5 cm line a few metres ahead, while TinyRenderer samples texels as they are; triangles look the
same to both. TinyRenderer drops whole triangles that cross the camera's near plane, so no strip
piece is longer than PIECE_M.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from roar.tracks import Track
from roar_sim.world.cache import per_shape
from roar_sim.world.tiles import Tiles, tile_files

ASPHALT_RGB = (64, 64, 69)  # the ground's colour (roar_sim.world.scene)
EDGE_LINE_RGB = (240, 240, 240)
CENTRE_LINE_RGB = (230, 200, 40)
MARKER_RGB = (40, 180, 60)  # a tunnel's floor markers: green
EDGE_LINE_INSET_M = 0.1  # [m] from the wall to the middle of the edge line
EDGE_LINE_WIDTH_M = 0.05  # [m]
CENTRE_LINE_WIDTH_M = 0.05  # [m] (2-inch tape, as the edge lines)
CENTRE_DASH_M = 0.4  # [m] one dash plus one gap
PIECE_M = 0.1  # [m] longest piece of a strip along its line
FLOOR_Z_M = 0.001  # [m] the paint above the ground


@dataclass(frozen=True)
class Paint:
    """One colour of paint on the floor: triangles (vertices (N, 3) [m], indices (M, 3))."""

    rgb: tuple[int, int, int]
    vertices: np.ndarray
    triangles: np.ndarray

    def covers(self, xy) -> np.ndarray:
        """Whether each point (x, y) [m] of an (K, 2) array lies on this paint."""
        p = np.atleast_2d(np.asarray(xy, dtype=float))[:, None, :]  # (K, 1, 2)
        a, b, c = (self.vertices[self.triangles[:, k], :2][None] for k in range(3))  # (1, M, 2)

        def side(u, v, w):
            return (v[..., 0] - u[..., 0]) * (w[..., 1] - u[..., 1]) - (v[..., 1] - u[..., 1]) * (w[..., 0] - u[..., 0])

        d1, d2, d3 = side(a, b, p), side(b, c, p), side(c, a, p)
        inside = ~(((d1 < 0) | (d2 < 0) | (d3 < 0)) & ((d1 > 0) | (d2 > 0) | (d3 > 0)))
        return inside.any(axis=1)


def colour_at(track: Track, xy) -> tuple[int, int, int]:
    """The floor's colour at one point (x, y) [m]: a paint's, else the asphalt's."""
    for paint in paints(track):
        if paint.covers(xy)[0]:
            return paint.rgb
    return ASPHALT_RGB


def paints(track: Track) -> list[Paint]:
    """The track's paint, one Paint a colour, made once per track shape."""
    return per_shape("floor paint", track, lambda: _make_paints(track))


def _make_paints(track: Track) -> list[Paint]:
    import shapely

    if track.course is not None:  # a tunnel: a bare floor with its green markers
        return [_joined(MARKER_RGB, [_rectangle(x, y, yaw) for x, y, yaw in track.course.markers])]
    edges = [_strip(run, EDGE_LINE_WIDTH_M, closed) for line in edge_lines(track) for run, closed in _runs(line)]
    dashes = [_strip(dash, CENTRE_LINE_WIDTH_M, False) for dash in _dashes(track.centerline)
              if shapely.contains_xy(track.region, dash[:, 0], dash[:, 1]).all()]  # on the road only (a drag strip's)
    return [_joined(EDGE_LINE_RGB, edges), _joined(CENTRE_LINE_RGB, dashes)]


def edge_lines(track: Track) -> list[np.ndarray]:
    """The white edge lines, EDGE_LINE_INSET_M inside every wall: along each side of the centre
    line, each point's half width less the inset from it (where that folds into a hairpin's
    inner edge or runs past a wall midway, it stops: its points there are NaN); a map's walls,
    followed inwards."""
    import shapely

    if track.area is not None or track.extra_area:
        inner = track.region.buffer(-EDGE_LINE_INSET_M, join_style="round")
        parts = getattr(inner, "geoms", [inner])
        return [np.asarray(ring.coords)[:-1] for part in parts if not part.is_empty
                for ring in (part.exterior, *part.interiors)]
    inset = np.clip(track.half_widths - EDGE_LINE_INSET_M, 0.0, None)
    lines = [track.centerline + inset[:, :1] * track.normals, track.centerline - inset[:, 1:] * track.normals]
    keep = track.region.buffer(-EDGE_LINE_INSET_M / 2)
    return [np.where(shapely.contains_xy(keep, line[:, 0], line[:, 1])[:, None], line, np.nan) for line in lines]


def _runs(line: np.ndarray) -> list[tuple[np.ndarray, bool]]:
    """(points, closed) of each unbroken run of a closed line whose missing points are NaN."""
    ok = np.isfinite(line).all(axis=1)
    if ok.all():
        return [(line, True)]
    start = int(np.argmin(ok))  # a missing point: runs are cut there, none wraps round
    ordered, good = np.roll(line, -start, axis=0), np.roll(ok, -start)
    cuts = np.flatnonzero(np.diff(good.astype(int)) != 0) + 1
    return [(part, False) for part, flags in zip(np.split(ordered, cuts), np.split(good, cuts))
            if flags[0] and len(part) >= 2]


def _dashes(centreline: np.ndarray) -> list[np.ndarray]:
    """The dashes of the centre line: its first half of every CENTRE_DASH_M along it."""
    closed = np.vstack([centreline, centreline[:1]])
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))])
    starts = np.arange(0.0, s[-1] - CENTRE_DASH_M / 4, CENTRE_DASH_M)
    dashes = []
    for s0 in starts:
        along = np.linspace(s0, min(s0 + CENTRE_DASH_M / 2, s[-1]), 3)
        dashes.append(np.column_stack([np.interp(along, s, closed[:, 0]), np.interp(along, s, closed[:, 1])]))
    return dashes


def _strip(points: np.ndarray, width_m: float, closed: bool) -> tuple[np.ndarray, np.ndarray]:
    """(vertices, triangles) of a band width_m wide along a polyline, in pieces of at most PIECE_M."""
    points = _refined(points, closed)
    ahead = np.roll(points, -1, axis=0) - np.roll(points, 1, axis=0)  # central differences
    if not closed:
        ahead[0], ahead[-1] = points[1] - points[0], points[-1] - points[-2]
    normals = np.column_stack([-ahead[:, 1], ahead[:, 0]]) / np.maximum(np.linalg.norm(ahead, axis=1), 1e-12)[:, None]
    half = normals * width_m / 2
    n = len(points)
    vertices = np.vstack([np.column_stack([points + half, np.full(n, FLOOR_Z_M)]),
                          np.column_stack([points - half, np.full(n, FLOOR_Z_M)])])
    i = np.arange(n if closed else n - 1)
    j = (i + 1) % n
    triangles = np.vstack([np.column_stack([i + n, j + n, j]), np.column_stack([i + n, j, i])])  # facing up
    return vertices, triangles


def _refined(points: np.ndarray, closed: bool) -> np.ndarray:
    """The polyline with points added so that no segment is longer than PIECE_M."""
    ends = np.roll(points, -1, axis=0) if closed else points[1:]
    starts = points if closed else points[:-1]
    out = []
    for a, b in zip(starts, ends):
        k = max(1, int(np.ceil(np.linalg.norm(b - a) / PIECE_M)))
        out.append(a + (np.arange(k) / k)[:, None] * (b - a))
    if not closed:
        out.append(points[-1:])
    return np.vstack(out)


def _rectangle(x: float, y: float, yaw: float) -> tuple[np.ndarray, np.ndarray]:
    """(vertices, triangles) of a marker: MARKER_SIZE_M, its long side along yaw, centred on (x, y),
    as a grid of pieces no longer than PIECE_M."""
    from roar.tracks.tunnel import MARKER_SIZE_M

    length, width = MARKER_SIZE_M
    nu, nv = int(np.ceil(length / PIECE_M)), int(np.ceil(width / PIECE_M))
    u, v = np.meshgrid(np.linspace(-length / 2, length / 2, nu + 1), np.linspace(-width / 2, width / 2, nv + 1))
    c, s = np.cos(yaw), np.sin(yaw)
    vertices = np.column_stack([x + u.ravel() * c - v.ravel() * s, y + u.ravel() * s + v.ravel() * c,
                                np.full(u.size, FLOOR_Z_M)])
    k = (np.arange(nv)[:, None] * (nu + 1) + np.arange(nu)[None, :]).ravel()
    triangles = np.vstack([np.column_stack([k, k + 1, k + nu + 2]), np.column_stack([k, k + nu + 2, k + nu + 1])])
    return vertices, triangles


def _joined(rgb: tuple[int, int, int], meshes: list[tuple[np.ndarray, np.ndarray]]) -> Paint:
    vertices, triangles, base = [], [], 0
    for v, t in meshes:
        vertices.append(v)
        triangles.append(t + base)
        base += len(v)
    return Paint(rgb, np.vstack(vertices) if vertices else np.empty((0, 3)),
                 np.vstack(triangles).astype(int) if triangles else np.empty((0, 3), int))


def add_floor(track: Track, client: int) -> list[Tiles]:
    """Add the track's paint (visual only: the car drives on the ground below), one Tiles a colour."""
    return [Tiles.add(client, files, [*(k / 255 for k in paint.rgb), 1]) for paint, files in _paint_files(track)]


def _paint_files(track: Track) -> list[tuple[Paint, list]]:
    """Each paint with its tiles' OBJ files (roar_sim.world.tiles), written once per track shape:
    a new world of the same track (every Gym reset) only loads them."""
    return per_shape("floor paint tiles", track, lambda: [
        (paint, tile_files(paint.vertices, paint.triangles)) for paint in paints(track) if len(paint.triangles)])
