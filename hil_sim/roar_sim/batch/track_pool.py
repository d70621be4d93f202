"""The tracks a batch drives on, shared by all its cars: each track's walls as a distance field on
a grid (what the lidar marches on and the footprint is checked against) and its centre line
(what progress is measured along).

    pool = TrackPool(["oval", "random:3"])    # names, or roar.tracks.Track objects
    pool.tracks[1].length_m, pool.bytes        # the tracks; the memory the pool holds [bytes]

A wall is the simulator's (roar_sim.world.scene): a box WALL_THICKNESS_M thick along each piece of a
wall polyline, half a thickness longer at each end; the field holds the distance to those boxes (each
node's to the boxes of the pieces of its nearest samples, SAMPLE_M apart along them).
"""

from __future__ import annotations

import numpy as np

from roar.tracks import Track, TrackError, get
from roar_sim.world.scene import WALL_THICKNESS_M

RES_M = 0.025  # [m] the distance field's cell (at 5 cm a beam grazing a wall's end erred 2-4 cm, 1 time in 100)
SAMPLE_M = 0.01  # [m] between the points each wall is sampled at
MARGIN_M = 0.5  # [m] the field reaches this far beyond the walls
MAX_TRACKS = 64  # a pool's most
NEAREST = 4  # samples whose pieces each node's distance is measured to


def wall_segments(track: Track) -> tuple[np.ndarray, np.ndarray]:
    """(segments [S, 2, 2] [m]: every wall polyline's pieces, start and end; points [M, 3]: (x, y,
    its segment) along each piece, SAMPLE_M apart at most)."""
    segments, points = [], []
    for wall in track.walls:
        for p, q in zip(wall, np.roll(wall, -1, axis=0)):
            k = max(1, int(np.ceil(np.hypot(*(q - p)) / SAMPLE_M)))
            along = p + np.outer(np.arange(k) / k, q - p)
            points.append(np.column_stack([along, np.full(k, len(segments))]))
            segments.append((p, q))
    return np.array(segments), np.concatenate(points)


def distance_field(track: Track, res_m: float = RES_M) -> tuple[np.ndarray, tuple[float, float, int, int]]:
    """(field float32 [nx, ny] [m] to the nearest wall's face (negative inside a wall), (x0, y0, nx,
    ny)): the grid's first node at (x0, y0), res_m apart. Each node's distance is to the boxes of the
    pieces of its nearest few samples, exactly."""
    from scipy.spatial import cKDTree

    segments, points = wall_segments(track)
    low, high = points[:, :2].min(axis=0) - MARGIN_M, points[:, :2].max(axis=0) + MARGIN_M
    nx, ny = (np.ceil((high - low) / res_m).astype(int) + 1).tolist()
    gx, gy = np.meshgrid(low[0] + res_m * np.arange(nx), low[1] + res_m * np.arange(ny), indexing="ij")
    nodes = np.column_stack([gx.ravel(), gy.ravel()])
    _, nearest = cKDTree(points[:, :2]).query(nodes, k=NEAREST, workers=-1)
    best = np.full(len(nodes), np.inf)
    half_width = WALL_THICKNESS_M / 2
    for j in range(NEAREST):  # each candidate piece's box, as the simulator builds it: signed distance to it
        a, b = segments[points[nearest[:, j], 2].astype(int)].transpose(1, 0, 2)
        d = b - a
        length = np.maximum(np.hypot(*d.T), 1e-12)
        ux, uy = d[:, 0] / length, d[:, 1] / length
        rx, ry = nodes[:, 0] - (a[:, 0] + b[:, 0]) / 2, nodes[:, 1] - (a[:, 1] + b[:, 1]) / 2
        qx = np.abs(rx * ux + ry * uy) - (length / 2 + half_width)
        qy = np.abs(-rx * uy + ry * ux) - half_width
        box = np.hypot(np.maximum(qx, 0.0), np.maximum(qy, 0.0)) + np.minimum(np.maximum(qx, qy), 0.0)
        best = np.minimum(best, box)
    return best.astype(np.float32).reshape(nx, ny), (float(low[0]), float(low[1]), nx, ny)


class TrackPool:
    """K tracks (1..MAX_TRACKS) laid out for the kernels (roar_sim.batch.kernels)."""

    def __init__(self, tracks, res_m: float = RES_M) -> None:
        tracks = [tracks] if isinstance(tracks, (str, Track)) else list(tracks)
        if not 1 <= len(tracks) <= MAX_TRACKS:
            raise ValueError(f"a track pool holds 1..{MAX_TRACKS} tracks, got {len(tracks)}")
        self.tracks: list[Track] = []
        for t in tracks:
            if not isinstance(t, (str, Track)):
                raise ValueError(f"a track is a Track or a track's name, got {t!r}")
            try:
                self.tracks.append(t if isinstance(t, Track) else get(t))
            except TrackError as e:
                raise ValueError(str(e)) from None
        fields, meta, at = [], [], 0
        for track in self.tracks:
            field, (x0, y0, nx, ny) = distance_field(track, res_m)
            fields.append(field.ravel())
            meta.append((x0, y0, res_m, nx, ny, at))
            at += field.size
        self.field = np.concatenate(fields)  # float32: every track's grid, one after another
        self.meta = np.array(meta, dtype=np.float64)  # [K, 6]: x0, y0, cell, nx, ny, first index
        lines = [t.centerline for t in self.tracks]
        self.line = np.ascontiguousarray(np.concatenate(lines))  # [sum N, 2] every centre line's points
        self.arc = np.concatenate([t.arc_start for t in self.tracks])  # [m] each point's position along
        self.seg_len = np.concatenate([t.segment_lengths for t in self.tracks])  # [m] to the next point
        self.half_widths = np.concatenate([t.half_widths for t in self.tracks])  # [m] left, right of each point
        counts = np.array([len(x) for x in lines])
        self.line_at = np.column_stack([np.concatenate([[0], np.cumsum(counts)[:-1]]), counts]).astype(np.int64)
        self.lengths = np.array([t.length_m for t in self.tracks])  # [m]
        self.shortest_segment_m = float(self.seg_len.min())

    @property
    def bytes(self) -> int:
        return sum(a.nbytes for a in (self.field, self.meta, self.line, self.arc, self.seg_len, self.half_widths,
                                            self.line_at))
