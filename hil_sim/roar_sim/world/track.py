"""Tracks: a closed centre line of waypoints plus a width, with walls along both edges.

Track file format (JSON), documented in hil_sim/README.md:

    {"name": "my-track", "width_m": 1.2,
     "centerline": [[x0, y0], [x1, y1], ...]}

The centre line is a closed loop (the last point connects back to the first, so it is not
repeated), in metres, with at least 8 points, consecutive points between 1 cm and 2 m apart,
and width between 0.4 m and 5 m. The car starts at the first point facing the second. So that
the car can drive it, the track must also:

* fit in a 200 m square within 1 km of the origin;
* never bend tighter than half its width (a smaller radius folds the inner wall);
* never run within its width of another part of itself, except where it crosses itself at an
  angle of at least 45 degrees (a figure-eight's crossing, whose walls are left open).
"""

from __future__ import annotations

import hashlib
import json
import math
import threading
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import TypeVar

import numpy as np

from roar.checks import printable, shown
from roar.errors import RoarError
from roar.user_files import read_parsed

T = TypeVar("T")

MIN_POINTS = 8
MAX_NAME_CHARS = 60  # a track's name as shown: longer ones are cut
MIN_SPACING_M = 0.01  # [m]
SMALL_WINDOW = 12  # segments each side: project() searches this few in plain floats
MAX_SPACING_M = 2.0  # [m]
MIN_WIDTH_M, MAX_WIDTH_M = 0.4, 5.0  # [m]
MAX_EXTENT_M = 200.0  # [m] side of the square the track must fit in
MAX_DISTANCE_M = 1000.0  # [m] of any point from the origin
MIN_CROSSING_DEG = 45.0  # [deg] shallowest angle at which the track may cross itself
CHECK_STEP_FRACTION = 0.25  # the shape checks look at the centre line every width/4


_SHAPES: dict[tuple[str, bytes], object] = {}
_SHAPES_LOCK = threading.RLock()


def per_shape(what: str, track: Track, make: Callable[[], T]) -> T:
    """make()'s result for `what` of this track's shape, made once per shape in this process
    (wall meshes, floor textures, ray clients: every fresh world of a track reuses them)."""
    key = (what, track.fingerprint)
    with _SHAPES_LOCK:
        if key not in _SHAPES:
            _SHAPES[key] = make()
        return _SHAPES[key]  # type: ignore[return-value]


class TrackError(RoarError, ValueError):
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
        if isinstance(self.width_m, bool) or not isinstance(self.width_m, (int, float)) or \
                not MIN_WIDTH_M <= self.width_m <= MAX_WIDTH_M:
            raise TrackError(f"track {self.name!r}: width_m must be a number {MIN_WIDTH_M}..{MAX_WIDTH_M} [m], "
                             f"got {self.width_m!r}")
        if np.array_equal(pts[0], pts[-1]):
            raise TrackError(f"track {self.name!r}: the last point repeats the first; leave it out, the centre "
                             f"line closes by itself")
        far = float(np.max(np.linalg.norm(pts, axis=1)))
        span = pts.max(axis=0) - pts.min(axis=0)
        if far > MAX_DISTANCE_M or span.max() > MAX_EXTENT_M:
            raise TrackError(f"track {self.name!r}: it must fit in a {MAX_EXTENT_M:g} m square within "
                             f"{MAX_DISTANCE_M:g} m of the origin; it spans {span[0]:.0f} x {span[1]:.0f} m and "
                             f"reaches {far:.0f} m out")
        gaps = np.linalg.norm(np.roll(pts, -1, axis=0) - pts, axis=1)
        bad = int(np.argmax((gaps < MIN_SPACING_M) | (gaps > MAX_SPACING_M)))
        if not MIN_SPACING_M <= gaps[bad] <= MAX_SPACING_M:
            raise TrackError(f"track {self.name!r}: points {bad} and {(bad + 1) % len(pts)} are {gaps[bad]:.3f} m "
                             f"apart (allowed {MIN_SPACING_M}..{MAX_SPACING_M} m)")
        object.__setattr__(self, "centerline", pts)
        problem = _shape_problem(pts, float(self.width_m))
        if problem:
            raise TrackError(f"track {self.name!r}: {problem}")

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
    def fingerprint(self) -> bytes:  # per_shape's key
        """The same for tracks of the same shape: a key for what is built from the shape alone
        (wall meshes, floor textures), built once per process."""
        return hashlib.sha256(np.float64(self.width_m).tobytes() + self.centerline.tobytes()).digest()

    @cached_property
    def length_m(self) -> float:
        return float(self.segment_lengths.sum())

    def arc_delta(self, from_s, to_s):
        """[m] the shorter way along the lap from arc-length position from_s to to_s: positive
        along the track's direction, negative against it (works on numpy arrays too)."""
        return (to_s - from_s + self.length_m / 2) % self.length_m - self.length_m / 2

    @property
    def start_pose(self) -> tuple[float, float, float]:
        """(x, y, yaw) at the first point, facing the second."""
        (x0, y0), (x1, y1) = self.centerline[0], self.centerline[1]
        return float(x0), float(y0), math.atan2(y1 - y0, x1 - x0)

    def pose_at(self, s_m: float, offset_m: float = 0.0) -> tuple[float, float, float]:
        """(x, y, yaw) of the point s_m [m] along the centre line (wrapping round the lap) and
        offset_m to its left, facing along the track."""
        s = s_m % self.length_m
        seg = int(np.searchsorted(self.arc_start, s, side="right") - 1)
        a, b = self.centerline[seg], self.centerline[(seg + 1) % len(self.centerline)]
        t = (s - self.arc_start[seg]) / self.segment_lengths[seg]
        yaw = math.atan2(b[1] - a[1], b[0] - a[0])
        x, y = a + t * (b - a)
        return float(x - offset_m * math.sin(yaw)), float(y + offset_m * math.cos(yaw)), yaw

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
        if hint is not None and window <= SMALL_WINDOW:
            return self._project_near(float(xy[0]), float(xy[1]), hint, window)
        pts, ab, ab2 = self.centerline, self._segments, self._segments_sq
        n = len(pts)
        idx = np.arange(n) if hint is None else (np.arange(hint - window, hint + window + 1) % n)
        px, py = float(xy[0]), float(xy[1])
        a, d = pts[idx], ab[idx]
        ax, ay, dx, dy = a[:, 0], a[:, 1], d[:, 0], d[:, 1]
        t = np.clip(((px - ax) * dx + (py - ay) * dy) / ab2[idx], 0.0, 1.0)
        ex, ey = ax + t * dx - px, ay + t * dy - py  # from the point to the closest point of each segment
        k = int(np.argmin(ex * ex + ey * ey))
        seg = int(idx[k])
        s = float(self.arc_start[seg] + t[k] * self.segment_lengths[seg])
        cross = dx[k] * (py - ay[k]) - dy[k] * (px - ax[k])
        return seg, s, float(math.copysign(math.hypot(ex[k], ey[k]), cross))

    def _project_near(self, px: float, py: float, hint: int, window: int) -> tuple[int, float, float]:
        """project() over a few segments, in plain floats: numpy's per-call cost is most of the
        time for so few (an environment step projects once)."""
        pts, ab, ab2 = self._plain
        n = len(pts)
        best = math.inf
        for j in range(hint - window, hint + window + 1):
            i = j % n
            ax, ay = pts[i]
            dx, dy = ab[i]
            t = min(1.0, max(0.0, ((px - ax) * dx + (py - ay) * dy) / ab2[i]))
            ex, ey = ax + t * dx - px, ay + t * dy - py
            d2 = ex * ex + ey * ey
            if d2 < best:
                best, seg, tk, e, a, d = d2, i, t, (ex, ey), (ax, ay), (dx, dy)
        s = float(self.arc_start[seg] + tk * self.segment_lengths[seg])
        cross = d[0] * (py - a[1]) - d[1] * (px - a[0])
        return seg, s, float(math.copysign(math.hypot(*e), cross))

    @cached_property
    def _plain(self) -> tuple[list, list, list]:
        return self.centerline.tolist(), self._segments.tolist(), self._segments_sq.tolist()

    @cached_property
    def _segments(self) -> np.ndarray:
        """Each centre-line segment as a vector, from its point to the next (closed)."""
        return np.roll(self.centerline, -1, axis=0) - self.centerline

    @cached_property
    def _segments_sq(self) -> np.ndarray:
        return np.einsum("ij,ij->i", self._segments, self._segments)

    # --- files -----------------------------------------------------------------------------------

    def to_json(self) -> str:
        return json.dumps({"name": self.name, "width_m": self.width_m,
                           "centerline": [[round(float(x), 4), round(float(y), 4)] for x, y in self.centerline]})

    @classmethod
    def load(cls, path: str | Path) -> Track:  # noqa: C901
        path = Path(path)
        data = read_parsed(path, json.loads, TrackError, "JSON")
        if not isinstance(data, dict) or not {"width_m", "centerline"} <= set(data):
            raise TrackError(f"{path}: a track file needs 'width_m' and 'centerline' (and optionally 'name')")
        unknown = set(data) - {"name", "width_m", "centerline"}
        if unknown:
            raise TrackError(f"{path}: unknown keys {sorted(unknown)}")
        cl = data["centerline"]
        if not isinstance(cl, list) or not all(isinstance(p, list) and len(p) == 2 and
                                               all(_is_number(v) for v in p) for p in cl):
            raise TrackError(f"{path}: centerline must be a list of [x, y] number pairs")
        if not _is_number(data["width_m"]):
            raise TrackError(f"{path}: width_m must be a number of metres, got {data['width_m']!r}")
        name = data.get("name", path.stem)
        if not isinstance(name, str):
            raise TrackError(f"{path}: name must be a string, got {shown(name)}")
        try:
            return cls(printable(name, MAX_NAME_CHARS), np.array(cl, dtype=float), data["width_m"])
        except TrackError as e:
            raise TrackError(f"{path}: {e}") from None


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _resample(pts: np.ndarray, step_m: float) -> tuple[np.ndarray, np.ndarray]:
    """(points every ~step_m along the closed polyline, their index in pts' segments)."""
    seg = np.roll(pts, -1, axis=0) - pts
    counts = np.maximum(1, np.ceil(np.linalg.norm(seg, axis=1) / step_m).astype(int))
    owner = np.repeat(np.arange(len(pts)), counts)
    frac = np.concatenate([np.arange(k) / k for k in counts])
    return pts[owner] + frac[:, None] * seg[owner], owner


def _shape_problem(pts: np.ndarray, width_m: float) -> str | None:
    """Why a car cannot drive this closed centre line at this width (one line), or None."""
    step = width_m * CHECK_STEP_FRACTION
    dense, owner = _resample(pts, step)
    # Bend: the circle through each point and its neighbours half a width away on either side.
    k = max(1, int(round(width_m / 2 / step)))
    a, b, c = np.roll(dense, k, axis=0), dense, np.roll(dense, -k, axis=0)
    ab, bc, ca = (np.linalg.norm(b - a, axis=1), np.linalg.norm(c - b, axis=1), np.linalg.norm(a - c, axis=1))
    cross = np.abs((b - a)[:, 0] * (c - b)[:, 1] - (b - a)[:, 1] * (c - b)[:, 0])
    with np.errstate(divide="ignore", invalid="ignore"):
        radius = np.where(cross > 1e-12, ab * bc * ca / (2 * cross), np.inf)
    folded = np.einsum("ij,ij->i", b - a, c - b) < 0  # turns back by more than 90 degrees
    radius[folded] = np.minimum(radius[folded], ca[folded] / 2)
    tight = int(np.argmin(radius))
    if radius[tight] < width_m / 2 * 0.98:
        return (f"it bends with a radius of {radius[tight]:.2f} m near point {owner[tight]}, tighter than half its "
                f"width ({width_m / 2:g} m): the inner wall would fold")
    # Overlap: parts of the track closer than its width, apart from deliberate crossings.
    heading = np.roll(dense, -1, axis=0) - dense
    heading /= np.linalg.norm(heading, axis=1, keepdims=True)
    # Points less than half a minimum-radius U-turn apart along the loop are neighbours, not parts.
    pairs = _close_pairs(dense, width_m * 0.95, np.pi * width_m / 2 * 1.05)

    def angle(p: int, j: int) -> float:  # [deg] between the two parts' directions, 0..90
        return float(np.degrees(np.arccos(np.clip(abs(float(heading[p] @ heading[j])), 0.0, 1.0))))

    crossings = np.array([dense[p] for p, j, d in pairs if d < step and angle(p, j) >= MIN_CROSSING_DEG])
    for p, j, d in sorted(pairs, key=lambda pair: pair[2]):  # the closest first: a crossing, if any
        if len(crossings) and np.min(np.linalg.norm(crossings - dense[p], axis=1)) < 1.5 * width_m:
            continue  # the approach to a deliberate crossing
        what = (f"crosses itself at {angle(p, j):.0f} degrees (crossings need at least {MIN_CROSSING_DEG:g})"
                if d < step else f"runs {d:.2f} m from another part of itself")
        return f"near points {owner[p]} and {owner[j]} it {what}, closer than its width ({width_m:g} m)"
    return None


def _close_pairs(points: np.ndarray, within_m: float, min_arc_m: float) -> list[tuple[int, int, float]]:
    """(i, j, distance) of points of a closed polyline closer than within_m that are more than
    min_arc_m apart along it (each pair once, i < j). Rows are done in blocks to bound memory."""
    n = len(points)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    length = arc[-1] + float(np.linalg.norm(points[0] - points[-1]))
    found: list[tuple[int, int, float]] = []
    for start in range(0, n, 256):
        rows = np.arange(start, min(n, start + 256))
        d = np.linalg.norm(points[rows, None, :] - points[None, :, :], axis=2)
        sep = np.abs(arc[rows, None] - arc[None, :])
        close = (d < within_m) & (np.minimum(sep, length - sep) > min_arc_m) & (rows[:, None] < np.arange(n))
        found += [(int(rows[r]), int(j), float(d[r, j])) for r, j in zip(*np.nonzero(close))]
    return found


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


def course() -> Track:
    """An obstacle course, IARRC's kind: an oval with long straights and wide bends, room for
    boxes to stand in either lane (roar_sim.world.obstacles.box_course)."""
    track = oval(straight_m=8.0, radius_m=2.5)
    return Track("course", track.centerline, track.width_m)


BUILTIN = {"oval": oval, "figure-eight": figure_eight, "course": course}


def get(name_or_path: str) -> Track:
    """A built-in track by name, or a track file by path."""
    if not isinstance(name_or_path, str) or not name_or_path.strip():
        raise TrackError(f"the track name is empty: use {', '.join(BUILTIN)} or a .json track file"
                         if isinstance(name_or_path, str) else
                         f"a track is a name or a .json file's path, got {shown(name_or_path)}")
    if name_or_path in BUILTIN:
        return BUILTIN[name_or_path]()
    if name_or_path.endswith(".json") or Path(name_or_path).exists():
        return Track.load(name_or_path)
    raise TrackError(f"unknown track {name_or_path!r}: use {', '.join(BUILTIN)} or a .json track file")
