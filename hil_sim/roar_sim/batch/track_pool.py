"""The tracks a batch drives on, shared by all its cars: each track's walls as a distance field on
a grid (roar_sim.world.wall_field: what the lidar marches on and the footprint is checked against)
and its centre line (what progress is measured along).

    pool = TrackPool(["oval", "random:3"])    # names, or roar.tracks.Track objects
    pool.tracks[1].length_m, pool.bytes        # the tracks; the memory the pool holds [bytes]
"""

from __future__ import annotations

import numpy as np

from roar.tracks import Track, TrackError, get
from roar_sim.world.wall_field import RES_M, distance_field

MAX_TRACKS = 64  # a pool's most


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
