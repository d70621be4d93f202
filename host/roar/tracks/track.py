"""A track: a closed centre line of waypoints with a width to each side of every point, and the
driving area between its walls.

The car starts at the first point facing the second. The walls are the edges of the driving area,
which is the union of the strips between the centre line and its left and right boundaries (and of
any extra area, such as a tunnel's side corridor): where a boundary folds (a hairpin whose radius is
below its half width) the fold falls inside the area and the wall runs where the folded edges
meet, as a real hairpin's inner wall does. Refused, each in one line that says where:

* fewer than 8 points, points closer than 1 cm or further than 2 m apart, a last point that
  repeats the first;
* a half width below 0.2 m or a width above 5 m anywhere;
* a track that does not fit in a 200 m square within 1 km of the origin;
* a bend tighter than 0.3 m along the centre line (no car here turns so sharply);
* a crossing of itself at less than 45 degrees (a figure-eight's crossing, at least 45, is left
  open), or two parts too close for a wall between them (0.46 m apart).

Two parts of a track closer than their widths are parted by a wall midway between them: the half
widths on the sides facing each other are cut to it (as the real circuits' maps show).

Files: roar.tracks.track_files (the project's JSON, the F1TENTH/TUM centre-line CSV) and
roar.tracks.occupancy_map (a map YAML + image).
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from roar.errors import TrackError

MIN_POINTS = 8
MAX_NAME_CHARS = 60  # a track's name as shown: longer ones are cut
MIN_SPACING_M = 0.01  # [m]
SMALL_WINDOW = 12  # segments each side: project() searches this few in plain floats
SAME_PLACE_M = 0.1  # [m] segments this much further than the nearest are as near, for locate()
BEND_CHORD_M = 0.25  # [m] before and after a point: the circle through them is the bend's (bend_radii())
MAX_SPACING_M = 2.0  # [m]
MIN_HALF_WIDTH_M = 0.2  # [m] from the centre line to either wall
MIN_WIDTH_M, MAX_WIDTH_M = 0.4, 5.0  # [m] wall to wall
MAX_EXTENT_M = 200.0  # [m] side of the square the track must fit in
MAX_DISTANCE_M = 1000.0  # [m] of any point from the origin
MIN_CROSSING_DEG = 45.0  # [deg] shallowest angle at which the track may cross itself
MIN_BEND_RADIUS_M = 0.3  # [m] along the centre line: tighter than any car here turns
CHECK_CHORD_M = 0.3  # [m] the shape check's bend circle passes through points this far either side
CHECK_STEP_M = 0.1  # [m] the shape checks look at the centre line this often (or every width/4)
WALL_TOLERANCE_M = 0.005  # [m] walls follow the area's edge within this
WALL_GAP_M = 0.06  # [m] between two parts of a track parted by a wall (a wall box is 0.05 m thick)
MIN_HOLE_M2 = 0.1  # [m^2] a hole in the driving area smaller than this is a sliver, not an infield


@dataclass(frozen=True)
class Track:
    """name, centre line (N, 2) [m], width_m [m] wall to wall; optionally half_widths (N, 2) [m]
    to the left and to the right of each point (otherwise width_m / 2 each; with them, width_m is
    their typical total, the median), extra_area (polygons [m] of driving area beyond the strips
    along the centre line: a tunnel's side corridors and halls) and course (what stands in a
    tunnel world: roar.tracks.tunnel.Course); or area, the driving area itself (a shapely
    Polygon: a map's free space, whose edges are its walls)."""

    name: str
    centerline: np.ndarray  # (N, 2) [m] closed loop, no repeated last point
    width_m: float  # [m] wall to wall
    half_widths: np.ndarray | None = None  # (N, 2) [m] left, right of each point
    extra_area: tuple = ()  # polygons, each (M, 2) [m]
    area: object = field(default=None, compare=False)  # a shapely Polygon: the driving area as given (a map's)
    course: object = field(default=None, compare=False)

    def __post_init__(self) -> None:
        pts = np.asarray(self.centerline, dtype=float)
        if pts.ndim != 2 or pts.shape[1] != 2 or not np.all(np.isfinite(pts)):
            raise TrackError(f"track {self.name!r}: centerline must be a list of finite [x, y] pairs")
        if len(pts) < MIN_POINTS:
            raise TrackError(f"track {self.name!r}: centerline needs at least {MIN_POINTS} points, has {len(pts)}")
        if isinstance(self.width_m, bool) or not isinstance(self.width_m, (int, float, np.floating)) or \
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
        halves = np.full((len(pts), 2), self.width_m / 2) if self.half_widths is None else \
            np.asarray(self.half_widths, dtype=float)
        problem = _widths_problem(halves, len(pts))
        if problem:
            raise TrackError(f"track {self.name!r}: {problem}")
        problem, halves = _shape_problem(pts, halves)
        if problem:
            raise TrackError(f"track {self.name!r}: {problem}")
        object.__setattr__(self, "centerline", pts)
        object.__setattr__(self, "half_widths", halves)
        object.__setattr__(self, "width_m", float(self.width_m))
        object.__setattr__(self, "extra_area", tuple(np.asarray(poly, dtype=float) for poly in self.extra_area))

    @classmethod
    def with_widths(cls, name: str, centerline, half_widths, **kwargs) -> Track:
        """A track whose width varies along it: width_m is the median of the widths given."""
        halves = np.asarray(half_widths, dtype=float)
        width = float(np.median(halves.sum(axis=1))) if halves.ndim == 2 and halves.size else float("nan")
        return cls(name, centerline, min(max(width, MIN_WIDTH_M), MAX_WIDTH_M) if math.isfinite(width) else width,
                   halves, **kwargs)

    @property
    def uniform_width(self) -> bool:
        return bool(np.all(self.half_widths == self.width_m / 2)) and not self.extra_area and self.area is None

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
    def fingerprint(self) -> bytes:
        """The same for tracks of the same shape and floor markings: a key for what is built from
        them alone (wall meshes, floor textures), built once per process. A tunnel's markers are
        painted on its floor: two tunnels of one seed with other counts of things differ there."""
        parts = [np.float64(self.width_m).tobytes(), self.centerline.tobytes(), self.half_widths.tobytes(),
                 *(poly.tobytes() for poly in self.extra_area), self.area.wkb if self.area is not None else b"",
                 np.asarray(self.course.markers if self.course is not None else (), np.float64).tobytes()]
        return hashlib.sha256(b"|".join(parts)).digest()

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

    def bend_radii(self, chord_m: float = BEND_CHORD_M) -> np.ndarray:
        """[m] the radius of the centre line at each of its points: of the circle through the
        points chord_m (at least the points' median spacing) before and after it along the line.
        Over a chord, not from the next points: a kink of a few degrees in a file (or its
        rounding) is no bend a car must take, nor is the corner between two points of a file
        that has them 0.4 m apart (the F1TENTH circuits')."""
        chord_m = max(chord_m, float(np.median(self.segment_lengths)))
        s, n = self.arc_start, len(self.centerline)
        x = np.concatenate([self.centerline[:, 0]] * 3)
        y = np.concatenate([self.centerline[:, 1]] * 3)
        along = np.concatenate([s - self.length_m, s, s + self.length_m])
        a = np.column_stack([np.interp(s - chord_m, along, x), np.interp(s - chord_m, along, y)])
        c = np.column_stack([np.interp(s + chord_m, along, x), np.interp(s + chord_m, along, y)])
        b = self.centerline
        sides = np.linalg.norm(b - a, axis=1) * np.linalg.norm(c - b, axis=1) * np.linalg.norm(a - c, axis=1)
        cross = np.abs((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0])
        return np.where(cross > 1e-12, sides / np.maximum(2 * cross, 1e-12), np.inf)[:n]

    def turns_left(self) -> np.ndarray:
        """Whether the centre line turns left (anticlockwise) at each of its points."""
        before = self.centerline - np.roll(self.centerline, 1, axis=0)
        after = np.roll(self.centerline, -1, axis=0) - self.centerline
        return before[:, 0] * after[:, 1] - before[:, 1] * after[:, 0] > 0

    def tightest_bend(self) -> tuple[float, float, tuple[float, float]]:
        """(radius [m], where along the line [m], (x, y) [m]) of the centre line's tightest bend."""
        radii = self.bend_radii()
        i = int(np.argmin(radii))
        return float(radii[i]), float(self.arc_start[i]), (float(self.centerline[i, 0]), float(self.centerline[i, 1]))

    def half_widths_at(self, segment: int) -> tuple[float, float]:
        """[m] (left, right) from the centre line to the walls at a segment's start point."""
        left, right = self.half_widths[segment % len(self.centerline)]
        return float(left), float(right)

    @cached_property
    def normals(self) -> np.ndarray:
        """(N, 2) unit vectors to the left of the centre line at each point."""
        pts = self.centerline
        tangent = np.roll(pts, -1, axis=0) - np.roll(pts, 1, axis=0)
        tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
        return np.stack([-tangent[:, 1], tangent[:, 0]], axis=1)

    def edges(self) -> tuple[np.ndarray, np.ndarray]:
        """(left, right) boundary polylines, each point's half width to either side of it, before
        any fold is trimmed (the walls are region's edges)."""
        return (self.centerline + self.half_widths[:, :1] * self.normals,
                self.centerline - self.half_widths[:, 1:] * self.normals)

    @cached_property
    def region(self):
        """The driving area as a shapely Polygon: the union of the strips between the centre line
        and both boundaries, segment by segment (each strip's convex hull, so a folded boundary
        stays inside), and the extra area."""
        import shapely

        if self.area is not None:
            return self.area
        left, right = self.edges()
        c, c_next = self.centerline, np.roll(self.centerline, -1, axis=0)
        quads = np.concatenate([np.stack([c, c_next, np.roll(side, -1, axis=0), side], axis=1)
                                for side in (left, right)])
        pieces = list(shapely.convex_hull(shapely.polygons(quads)))
        pieces += [shapely.Polygon(poly).buffer(0) for poly in self.extra_area]
        area = shapely.union_all(pieces).simplify(WALL_TOLERANCE_M / 2)
        if area.geom_type != "Polygon":  # a sliver cut off where pieces barely touch: keep the body
            area = max(area.geoms, key=lambda g: g.area)
        return area

    @cached_property
    def walls(self) -> list[np.ndarray]:
        """The walls as closed polylines (M, 2) [m], no repeated last point: the driving area's
        outer edge, then its holes' (the infield of a loop, a figure-eight's two)."""
        area = self.region
        import shapely

        holes = [ring for ring in area.interiors if shapely.Polygon(ring).area >= MIN_HOLE_M2]
        return [np.asarray(ring.coords)[:-1] for ring in (area.exterior, *holes)]

    def inside(self, xy, margin_m: float = 0.0) -> bool:
        """Whether a point is in the driving area, at least margin_m from every wall."""
        import shapely

        point = shapely.Point(float(xy[0]), float(xy[1]))
        return bool(self.region.contains(point)) and self.region.exterior.distance(point) >= margin_m and \
            all(ring.distance(point) >= margin_m for ring in self.region.interiors)

    def project(self, xy, hint: int | None = None, window: int = 40,
                heading: float | None = None) -> tuple[int, float, float]:
        """(segment index, arc-length position [m], signed cross-track error [m], left positive) of a
        point. With `hint` (the previous index) only nearby segments are searched, so progress is
        followed through a figure-eight crossing; with no hint, a `heading` [rad] (the car's, the
        line's) picks the leg that runs its way where two legs cross (locate())."""
        if hint is None and heading is not None:
            hint = self.locate(xy, heading)
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

    def follow(self, line) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(segment index, arc-length position [m], signed cross-track error [m]) of every point of a
        line, followed continuously from its first point, which faces its second (as a car would
        drive it: a figure eight's crossing stays on the leg driven)."""
        line = np.asarray(line, dtype=float)
        hint, heading = None, math.atan2(line[1, 1] - line[0, 1], line[1, 0] - line[0, 0])
        rows = []
        for point in line:
            hint, s, cte = self.project(point, hint, heading=heading)
            rows.append((hint, s, cte))
        seg, s, cte = zip(*rows)
        return np.asarray(seg, dtype=int), np.asarray(s), np.asarray(cte)

    def locate(self, xy, heading: float) -> int:
        """The segment a pose (a point and a heading [rad]) is on: of the segments as near as the
        nearest (within SAME_PLACE_M), the one running most its way. Where a track crosses itself
        (a figure eight), either leg is as near; the way the car faces says which leg it drives.
        The start of every continuous tracking of progress (laps, cross-track error, line checks,
        rewards): from there each step searches near the last segment only."""
        pts, ab, ab2 = self.centerline, self._segments, self._segments_sq
        px, py = float(xy[0]), float(xy[1])
        t = np.clip(((px - pts[:, 0]) * ab[:, 0] + (py - pts[:, 1]) * ab[:, 1]) / ab2, 0.0, 1.0)
        d2 = (pts[:, 0] + t * ab[:, 0] - px) ** 2 + (pts[:, 1] + t * ab[:, 1] - py) ** 2
        near = np.sqrt(d2) <= math.sqrt(float(d2.min())) + SAME_PLACE_M  # at the crossing: both legs
        along = (ab[:, 0] * math.cos(heading) + ab[:, 1] * math.sin(heading)) / np.sqrt(ab2)  # cos of the angle
        return int(np.argmax(np.where(near, along, -np.inf)))  # of those, the one running most its way

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

def _resample(pts: np.ndarray, step_m: float) -> tuple[np.ndarray, np.ndarray]:
    """(points every ~step_m along the closed polyline, their index in pts' segments)."""
    seg = np.roll(pts, -1, axis=0) - pts
    counts = np.maximum(1, np.ceil(np.linalg.norm(seg, axis=1) / step_m).astype(int))
    owner = np.repeat(np.arange(len(pts)), counts)
    frac = np.concatenate([np.arange(k) / k for k in counts])
    return pts[owner] + frac[:, None] * seg[owner], owner


def evenly_spaced(points: np.ndarray, n: int) -> np.ndarray:
    """n points evenly spaced along a closed polyline, from its first."""
    closed = np.vstack([points, points[:1]])
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))])
    at = np.linspace(0.0, s[-1], n, endpoint=False)
    return np.stack([np.interp(at, s, closed[:, 0]), np.interp(at, s, closed[:, 1])], axis=1)


def _widths_problem(halves: np.ndarray, n: int) -> str | None:
    """Why these half widths do not fit a centre line of n points (one line), or None."""
    if halves.shape != (n, 2) or not np.all(np.isfinite(halves)):
        return f"half_widths must be {n} finite (left, right) pairs [m], one per centre-line point"
    thin = int(np.argmin(halves.min(axis=1)))
    if halves[thin].min() < MIN_HALF_WIDTH_M:
        return (f"at point {thin} a wall is {halves[thin].min():.2f} m from the centre line (at least "
                f"{MIN_HALF_WIDTH_M:g} m each side)")
    wide = int(np.argmax(halves.sum(axis=1)))
    if halves[wide].sum() > MAX_WIDTH_M:
        return f"at point {wide} it is {halves[wide].sum():.2f} m wide (at most {MAX_WIDTH_M:g} m)"
    return None


def _shape_problem(pts: np.ndarray, halves: np.ndarray) -> tuple[str | None, np.ndarray]:
    """(why a car cannot drive this closed centre line with these half widths (one line) or
    None, the half widths with parts closer than their widths parted by a wall midway)."""
    widths = halves.sum(axis=1)
    step = min(CHECK_STEP_M, float(widths.min()) / 4)
    dense, owner = _resample(pts, step)
    # Bend: the circle through each point and its neighbours CHECK_CHORD_M away on either side.
    k = max(1, int(round(CHECK_CHORD_M / step)))
    a, b, c = np.roll(dense, k, axis=0), dense, np.roll(dense, -k, axis=0)
    ab, bc, ca = (np.linalg.norm(b - a, axis=1), np.linalg.norm(c - b, axis=1), np.linalg.norm(a - c, axis=1))
    cross = np.abs((b - a)[:, 0] * (c - b)[:, 1] - (b - a)[:, 1] * (c - b)[:, 0])
    with np.errstate(divide="ignore", invalid="ignore"):
        radius = np.where(cross > 1e-12, ab * bc * ca / (2 * cross), np.inf)
    folded = np.einsum("ij,ij->i", b - a, c - b) < 0  # turns back by more than 90 degrees
    radius[folded] = np.minimum(radius[folded], ca[folded] / 2)
    tight = int(np.argmin(radius))
    if radius[tight] < MIN_BEND_RADIUS_M * 0.98:
        return (f"it bends with a radius of {radius[tight]:.2f} m near point {owner[tight]} ({dense[tight][0]:.2f}, "
                f"{dense[tight][1]:.2f}): no car here turns tighter than {MIN_BEND_RADIUS_M:g} m"), halves
    # Parts of the track closer than their widths, apart from deliberate crossings: the wall
    # between them runs midway, each side's half width cut to it.
    width = widths[owner]
    heading = np.roll(dense, -1, axis=0) - dense
    heading /= np.linalg.norm(heading, axis=1, keepdims=True)
    # Points less than half a U-turn round the widest half width apart along the loop are
    # neighbours, not parts.
    pairs = [(p, j, d) for p, j, d in _close_pairs(dense, float(width.max()), np.pi * float(halves.max()) * 1.05)
             if d < (width[p] + width[j]) / 2]

    def angle(p: int, j: int) -> float:  # [deg] between the two parts' directions, 0..90
        return float(np.degrees(np.arccos(np.clip(abs(float(heading[p] @ heading[j])), 0.0, 1.0))))

    crossings = np.array([dense[p] for p, j, d in pairs if d < step and angle(p, j) >= MIN_CROSSING_DEG])
    halves = halves.copy()
    n = len(pts)
    for p, j, d in sorted(pairs, key=lambda pair: pair[2]):  # the closest first: a crossing, if any
        if len(crossings) and np.min(np.linalg.norm(crossings - dense[p], axis=1)) < 1.5 * width[p]:
            continue  # the approach to a deliberate crossing
        where = f"near points {owner[p]} and {owner[j]} ({dense[p][0]:.2f}, {dense[p][1]:.2f})"
        if d < step:
            return (f"{where} it crosses itself at {angle(p, j):.0f} degrees (crossings need at least "
                    f"{MIN_CROSSING_DEG:g})"), halves
        half = (d - WALL_GAP_M) / 2
        if half < MIN_HALF_WIDTH_M:
            return (f"{where} it runs {d:.2f} m from another part of itself: too close for a wall between them "
                    f"(at least {2 * MIN_HALF_WIDTH_M + WALL_GAP_M:.2f} m)"), halves
        for here, there in ((p, j), (j, p)):
            toward = dense[there] - dense[here]
            side = 0 if heading[here][0] * toward[1] - heading[here][1] * toward[0] > 0 else 1  # 0: left
            for i in (owner[here], (owner[here] + 1) % n):
                halves[i, side] = min(halves[i, side], half)
    return None, halves


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
