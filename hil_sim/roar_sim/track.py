"""Tracks: a closed centre line of waypoints plus a width, with walls along both edges.

Track file format (JSON), documented in hil_sim/README.md:

    {"name": "my-track", "width_m": 1.2,
     "centerline": [[x0, y0], [x1, y1], ...]}

The centre line is a closed loop (the last point connects back to the first), in metres, with
at least 8 points, consecutive points between 1 cm and 2 m apart, and width between 0.4 m and
5 m. The car starts at the first point facing the second.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from roar.user_files import read_parsed

MIN_POINTS = 8
MIN_SPACING_M = 0.01  # [m]
MAX_SPACING_M = 2.0  # [m]
MIN_WIDTH_M, MAX_WIDTH_M = 0.4, 5.0  # [m]


class TrackError(ValueError):
    """An invalid track or track file; str() is one line."""


@dataclass(frozen=True)
class Track:
    name: str
    centerline: np.ndarray  # (N, 2) [m] closed loop, no repeated last point
    width_m: float  # [m] wall to wall

    def __post_init__(self) -> None:
        pts = np.asarray(self.centerline, dtype=float)
        if pts.ndim != 2 or pts.shape[1] != 2 or not np.all(np.isfinite(pts)):
            raise TrackError(f"track {self.name!r}: centerline must be a list of finite [x, y] pairs")
        if len(pts) < MIN_POINTS:
            raise TrackError(f"track {self.name!r}: centerline needs at least {MIN_POINTS} points, has {len(pts)}")
        gaps = np.linalg.norm(np.roll(pts, -1, axis=0) - pts, axis=1)
        bad = int(np.argmax((gaps < MIN_SPACING_M) | (gaps > MAX_SPACING_M)))
        if not MIN_SPACING_M <= gaps[bad] <= MAX_SPACING_M:
            raise TrackError(f"track {self.name!r}: points {bad} and {(bad + 1) % len(pts)} are {gaps[bad]:.3f} m "
                             f"apart (allowed {MIN_SPACING_M}..{MAX_SPACING_M} m)")
        if not (isinstance(self.width_m, (int, float)) and MIN_WIDTH_M <= self.width_m <= MAX_WIDTH_M):
            raise TrackError(f"track {self.name!r}: width_m must be {MIN_WIDTH_M}..{MAX_WIDTH_M}, got {self.width_m!r}")
        object.__setattr__(self, "centerline", pts)

    # --- geometry ------------------------------------------------------------------------------

    # The track is immutable, so its derived geometry is computed once (project() runs at 50 Hz).
    @cached_property
    def segment_lengths(self) -> np.ndarray:
        return np.linalg.norm(np.roll(self.centerline, -1, axis=0) - self.centerline, axis=1)

    @cached_property
    def arc_start(self) -> np.ndarray:
        """[m] arc length from the first point to the start of each segment."""
        return np.concatenate([[0.0], np.cumsum(self.segment_lengths)[:-1]])

    @cached_property
    def length_m(self) -> float:
        return float(self.segment_lengths.sum())

    @property
    def start_pose(self) -> tuple[float, float, float]:
        """(x, y, yaw) at the first point, facing the second."""
        (x0, y0), (x1, y1) = self.centerline[0], self.centerline[1]
        return float(x0), float(y0), math.atan2(y1 - y0, x1 - x0)

    def edges(self) -> tuple[np.ndarray, np.ndarray]:
        """(left, right) boundary polylines, width/2 either side of the centre line."""
        pts = self.centerline
        tangent = np.roll(pts, -1, axis=0) - np.roll(pts, 1, axis=0)
        tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
        normal = np.stack([-tangent[:, 1], tangent[:, 0]], axis=1)
        half = self.width_m / 2
        return pts + half * normal, pts - half * normal

    def project(self, xy, hint: int | None = None, window: int = 40) -> tuple[int, float, float]:
        """(segment index, arc-length position [m], signed cross-track error [m], left positive) of a
        point. With `hint` (the previous index) only nearby segments are searched, so progress is
        followed through a figure-eight crossing."""
        pts = self.centerline
        n = len(pts)
        idx = np.arange(n) if hint is None else (np.arange(hint - window, hint + window + 1) % n)
        a, b = pts[idx], pts[(idx + 1) % n]
        ab = b - a
        p = np.asarray(xy, dtype=float)
        t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.einsum("ij,ij->i", ab, ab), 0.0, 1.0)
        closest = a + t[:, None] * ab
        d = np.linalg.norm(closest - p, axis=1)
        k = int(np.argmin(d))
        seg = int(idx[k])
        s = float(self.arc_start[seg] + t[k] * self.segment_lengths[seg])
        cross = ab[k, 0] * (p[1] - a[k, 1]) - ab[k, 1] * (p[0] - a[k, 0])
        return seg, s, float(math.copysign(d[k], cross))

    # --- files -----------------------------------------------------------------------------------

    def to_json(self) -> str:
        return json.dumps({"name": self.name, "width_m": self.width_m,
                           "centerline": [[round(float(x), 4), round(float(y), 4)] for x, y in self.centerline]})

    @classmethod
    def load(cls, path: str | Path) -> Track:
        path = Path(path)
        data = read_parsed(path, json.loads, TrackError, "JSON")
        if not isinstance(data, dict) or not {"width_m", "centerline"} <= set(data):
            raise TrackError(f"{path}: a track file needs 'width_m' and 'centerline' (and optionally 'name')")
        unknown = set(data) - {"name", "width_m", "centerline"}
        if unknown:
            raise TrackError(f"{path}: unknown keys {sorted(unknown)}")
        cl = data["centerline"]
        if not isinstance(cl, list) or not all(isinstance(p, list) and len(p) == 2 and
                                               all(isinstance(v, (int, float)) for v in p) for p in cl):
            raise TrackError(f"{path}: centerline must be a list of [x, y] number pairs")
        return cls(str(data.get("name", path.stem)), np.array(cl, dtype=float), data["width_m"])


def oval(straight_m: float = 4.0, radius_m: float = 1.5, width_m: float = 1.2, spacing_m: float = 0.1) -> Track:
    """Two straights joined by half circles, driven anticlockwise, starting mid-straight."""
    pts = []
    n_straight = max(2, int(straight_m / spacing_m))
    n_arc = max(4, int(math.pi * radius_m / spacing_m))
    half = straight_m / 2
    for i in range(n_straight):  # bottom straight, left to right, from the middle
        pts.append((-half + straight_m * i / n_straight, -radius_m))
    for i in range(n_arc):
        a = -math.pi / 2 + math.pi * i / n_arc
        pts.append((half + radius_m * math.cos(a), radius_m * math.sin(a)))
    for i in range(n_straight):
        pts.append((half - straight_m * i / n_straight, radius_m))
    for i in range(n_arc):
        a = math.pi / 2 + math.pi * i / n_arc
        pts.append((-half + radius_m * math.cos(a), radius_m * math.sin(a)))
    pts = np.array(pts)
    start = n_straight // 2
    return Track("oval", np.roll(pts, -start, axis=0), width_m)


def figure_eight(radius_m: float = 2.0, width_m: float = 1.2, spacing_m: float = 0.1) -> Track:
    """A lemniscate of Gerono-like loop: two circles of radius_m touching at the origin crossing."""
    n = max(16, int(2 * 2 * math.pi * radius_m / spacing_m))
    t = np.linspace(0, 2 * math.pi, n, endpoint=False)
    # Bernoulli lemniscate scaled so each lobe is about radius_m wide.
    a = 2.2 * radius_m
    x = a * np.cos(t) / (1 + np.sin(t) ** 2)
    y = a * np.sin(t) * np.cos(t) / (1 + np.sin(t) ** 2)
    return Track("figure-eight", np.stack([x, y], axis=1), width_m)


BUILTIN = {"oval": oval, "figure-eight": figure_eight}


def get(name_or_path: str) -> Track:
    """A built-in track by name, or a track file by path."""
    if name_or_path in BUILTIN:
        return BUILTIN[name_or_path]()
    if name_or_path.endswith(".json") or Path(name_or_path).exists():
        return Track.load(name_or_path)
    raise TrackError(f"unknown track {name_or_path!r}: use {', '.join(BUILTIN)} or a .json track file")
