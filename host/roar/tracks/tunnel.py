"""Tunnel worlds from a seed, the MIT challenge's kind of course: `tunnel:SEED` wherever a track is
named, with optional parameters

    tunnel:3                        corridors 2 m wide, cones, markers and people as drawn
    tunnel:3,width=1.6,cones=8,markers=4,people=6

Corridors with square corners run round a loop of building blocks (a random set of grid cells
whose outline has no holes nor pinches), with one or two features off them: a junction (a
dead-end side corridor) or a wide hall. In them stand orange cones (in the driving area: to
avoid, each leaving room to pass), green floor markers (flat rectangles: to drive over), and
people (tall cylinders standing by the walls). The map a car is given (track_map, map YAML) holds
only the walls: cones and people are for its sensors to find. The route (the centre line) starts
in the middle of the longest corridor; the goal is the pose about half way round.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from roar.checks import printable
from roar.tracks.random_track import rounded_polygon
from roar.tracks.seeds import seeded
from roar.tracks.track import Track, TrackError

PREFIX = "tunnel:"
WIDTH_RANGE_M = (1.2, 3.0)  # [m] corridor widths a tunnel may be asked for
CELL_RANGE_M = (6.0, 9.0)  # [m] side of the grid cells whose outline the corridors follow
GRID = (4, 3)  # cells across and up the grid the blocks are drawn on
CORNER_RADIUS = 0.6  # of the corridor width: the route's radius round a corner
CONE_RADIUS_M, CONE_HEIGHT_M = 0.1, 0.3  # [m]
PERSON_RADIUS_M, PERSON_HEIGHT_M = 0.2, 1.7  # [m]
MARKER_SIZE_M = (0.5, 0.3)  # [m] along and across the route
PASSAGE_M = 0.6  # [m] of free corridor a cone leaves beside it, at least
FIRST_M = 3.0  # [m] along the route from the start before the first cone, marker or person
SPACING_M = {("cones", "cones"): 3.0, ("cones", "people"): 2.0, ("people", "people"): 2.0}  # [m] along the route
OTHER_SPACING_M = 1.2  # [m] along the route between a marker and anything else
STRAIGHT_M = 1.5  # [m] of straight corridor before and after a cone or a person
MAX_COUNT = 40  # cones, markers or people a tunnel may be asked for
MAX_DRAWS = 200


@dataclass(frozen=True)
class Course:
    """What stands in a tunnel world, none of it in the map: cones (x, y) [m], markers (x, y, yaw)
    [m, rad] of MARKER_SIZE_M, people (x, y) [m]; start and goal poses (x, y, yaw)."""

    cones: tuple = ()
    markers: tuple = ()
    people: tuple = ()
    start: tuple = (0.0, 0.0, 0.0)
    goal: tuple = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class TunnelSpec:
    seed: int
    width_m: float = 2.0  # [m] corridor width
    cones: int | None = None  # None: one per 10 m of route
    markers: int | None = None  # None: one per 15 m
    people: int | None = None  # None: one per 15 m
    features: tuple = field(default=(), compare=False)

    @property
    def name(self) -> str:
        parts = [f"{PREFIX}{self.seed}"]
        if self.width_m != 2.0:
            parts.append(f"width={self.width_m:g}")
        parts += [f"{key}={getattr(self, key)}" for key in ("cones", "markers", "people") if getattr(self, key) is not None]
        return ",".join(parts)


def parse(name: str) -> TunnelSpec:
    usage = "tunnel:SEED[,width=M][,cones=N][,markers=N][,people=N]"
    seed, options = seeded(name, PREFIX, usage, ("width", "cones", "markers", "people"))
    values: dict = {"seed": seed}
    for key, text in options.items():
        if key == "width":
            try:
                values["width_m"] = float(text)
            except ValueError:
                raise TrackError(f"{printable(name)!r}: width needs a number, got {printable(text)!r}") from None
            if not WIDTH_RANGE_M[0] <= values["width_m"] <= WIDTH_RANGE_M[1]:
                raise TrackError(f"{printable(name)!r}: width must be {WIDTH_RANGE_M[0]:g}..{WIDTH_RANGE_M[1]:g} m")
        else:
            if not text.strip().isdigit() or int(text) > MAX_COUNT:
                raise TrackError(f"{printable(name)!r}: {key} must be a whole number 0..{MAX_COUNT}, got "
                                 f"{printable(text)!r}")
            values[key] = int(text)
    return TunnelSpec(**values)


def generate(spec: TunnelSpec) -> Track:
    """The tunnel world a spec names (see the module's text): a Track whose course holds its
    cones, markers, people, start and goal."""
    rng = np.random.Generator(np.random.PCG64(spec.seed))
    last = "no outline drawn"
    for _ in range(MAX_DRAWS):
        corners = _outline(rng)
        if corners is None:
            continue
        cell = rng.uniform(*CELL_RANGE_M)
        corners = corners * cell
        route = rounded_polygon(corners, CORNER_RADIUS * spec.width_m)
        start = _longest_straight_middle(corners, route)
        route = np.round(np.roll(route, -start, axis=0), 6)
        try:
            plain = Track(spec.name, route, spec.width_m)
        except TrackError as e:
            last = str(e)
            continue
        extra = [_square_corner(c, spec.width_m) for c in corners]
        extra += _features(rng, plain, corners, spec.width_m)
        track = Track(spec.name, route, spec.width_m, extra_area=tuple(extra))
        if len(track.walls) != 2:
            last = "its corridors meet"
            continue
        return Track(spec.name, route, spec.width_m, extra_area=tuple(extra), course=_course(rng, track, spec))
    raise TrackError(f"{spec.name}: no tunnel in {MAX_DRAWS} draws ({last})")


def _outline(rng: np.random.Generator) -> np.ndarray | None:
    """Corners (in cells) of the outline of a random set of grid cells, anticlockwise; None when
    the set has a hole or touches itself at a corner only."""
    import shapely

    nx, ny = GRID
    cells = {(int(rng.integers(nx)), int(rng.integers(ny)))}
    target = int(rng.integers(3, nx * ny - 3))
    for _ in range(200):
        if len(cells) >= target:
            break
        x, y = list(cells)[int(rng.integers(len(cells)))]
        dx, dy = [(1, 0), (-1, 0), (0, 1), (0, -1)][int(rng.integers(4))]
        if 0 <= x + dx < nx and 0 <= y + dy < ny:
            cells.add((x + dx, y + dy))
    shape = shapely.union_all([shapely.box(x, y, x + 1, y + 1) for x, y in sorted(cells)])
    if shape.geom_type != "Polygon" or shape.interiors or not shape.is_valid:
        return None
    shape = shapely.Polygon(shapely.simplify(shape.exterior, 0.0).coords)
    ring = np.asarray(shapely.geometry.polygon.orient(shape, 1.0).exterior.coords)[:-1]
    if len(ring) < 4 or _pinched(ring):
        return None
    return ring


def _pinched(ring: np.ndarray) -> bool:
    """Whether the outline passes through the same grid point twice (cells touching diagonally)."""
    return len({tuple(np.round(p, 6)) for p in ring}) < len(ring)


def _square_corner(corner: np.ndarray, width_m: float) -> np.ndarray:
    """A square of the corridor's width round a corner: the walls meet at right angles there."""
    h = width_m / 2
    x, y = corner
    return np.array([[x - h, y - h], [x + h, y - h], [x + h, y + h], [x - h, y + h]])


def _longest_straight_middle(corners: np.ndarray, route: np.ndarray) -> int:
    sides = np.roll(corners, -1, axis=0) - corners
    i = int(np.argmax(np.linalg.norm(sides, axis=1)))
    middle = corners[i] + sides[i] / 2
    return int(np.argmin(np.linalg.norm(route - middle, axis=1)))


def _features(rng: np.random.Generator, plain: Track, corners: np.ndarray, width_m: float) -> list[np.ndarray]:
    """One or two junctions (a dead-end side corridor) or halls (a wide stretch), each on a side
    of the loop where it stays clear of every other corridor."""
    import shapely

    out = []
    sides = np.roll(corners, -1, axis=0) - corners
    order = rng.permutation(len(corners))
    wanted = int(rng.integers(1, 3))
    for i in order:
        if len(out) >= wanted:
            break
        length = float(np.linalg.norm(sides[i]))
        if length < 4 * width_m:
            continue
        along = sides[i] / length
        across = np.array([-along[1], along[0]])  # left of the route: the loop's inside
        mid = corners[i] + along * length * rng.uniform(0.35, 0.65)
        h = width_m / 2
        if rng.uniform() < 0.5:  # a junction: a side corridor out of the loop or into it
            reach = rng.uniform(2.5, 5.0)
            side = across if rng.uniform() < 0.5 else -across
            a, b = mid - along * h, mid + along * h
            piece = np.array([a, b, b + side * (h + reach), a + side * (h + reach)])
        else:  # a hall: the corridor widened on both sides over a stretch
            half_len = rng.uniform(1.5, 2.5) * width_m / 2 + 1.0
            wide = rng.uniform(1.8, 2.6) * h
            piece = np.array([mid - along * half_len - across * wide, mid + along * half_len - across * wide,
                              mid + along * half_len + across * wide, mid - along * half_len + across * wide])
        polygon = shapely.Polygon(piece)
        others = shapely.union_all([shapely.LineString([corners[j], corners[(j + 1) % len(corners)]])
                                    for j in range(len(corners)) if j != i])
        if polygon.distance(others) < width_m:  # too close to another corridor
            continue
        out.append(piece)
    return out


def _course(rng: np.random.Generator, track: Track, spec: TunnelSpec) -> Course:
    length = track.length_m
    asked = {"cones": spec.cones, "markers": spec.markers, "people": spec.people}
    counts = {"cones": int(length / 10), "markers": int(length / 15), "people": int(length / 15)}
    counts.update({kind: n for kind, n in asked.items() if n is not None})
    straight = _straight_stretches(track)
    taken: list[tuple[float, str]] = []
    placed: dict[str, list] = {key: [] for key in counts}
    h = spec.width_m / 2
    for kind in ("cones", "people", "markers"):
        for _ in range(counts[kind] * 30):
            if len(placed[kind]) >= counts[kind]:
                break
            s = rng.uniform(FIRST_M, length - 1.0)
            if kind != "markers" and not straight(s):
                continue
            if any(abs(track.arc_delta(s, t)) < SPACING_M.get(tuple(sorted((kind, other))), OTHER_SPACING_M)
                   for t, other in taken):
                continue
            if kind == "cones":
                offset = rng.uniform(-1, 1) * max(0.0, h - PASSAGE_M - 2 * CONE_RADIUS_M - 0.1)
            elif kind == "people":
                offset = (1 if rng.uniform() < 0.5 else -1) * (h - PERSON_RADIUS_M - 0.08)
            else:
                offset = rng.uniform(-1, 1) * max(0.0, h - 0.5)
            x, y, yaw = track.pose_at(s, offset)
            placed[kind].append((round(x, 4), round(y, 4), round(yaw, 4)) if kind == "markers" else
                                (round(x, 4), round(y, 4)))
            taken.append((s, kind))
        if len(placed[kind]) < counts[kind] and asked[kind] is not None:
            raise TrackError(f"{spec.name}: room for {len(placed[kind])} {kind}, not {counts[kind]} (apart from each "
                             f"other and from the rest, on straight corridor)")
    goal = track.pose_at(length * rng.uniform(0.45, 0.6))
    return Course(tuple(placed["cones"]), tuple(placed["markers"]), tuple(placed["people"]),
                  tuple(round(v, 4) for v in track.start_pose), tuple(round(v, 4) for v in goal))


def _straight_stretches(track: Track):
    """s -> whether the route is straight STRAIGHT_M before and after the point s [m] along it."""
    pts = track.centerline
    heading = np.unwrap(np.arctan2(*(np.roll(pts, -1, axis=0) - pts).T[::-1]))

    def straight(s: float) -> bool:
        window = np.linspace(s - STRAIGHT_M, s + STRAIGHT_M, 12) % track.length_m
        turns = heading[np.searchsorted(track.arc_start, window, side="right") - 1]
        return float(np.ptp(turns)) < 0.02

    return straight


def describe(track: Track) -> str:
    """One line: what stands in a tunnel world."""
    c = track.course
    return (f"{len(c.cones)} cones, {len(c.markers)} markers, {len(c.people)} people; start "
            f"({c.start[0]:.2f}, {c.start[1]:.2f}), goal ({c.goal[0]:.2f}, {c.goal[1]:.2f})")



COURSE_NOTE = ("start and goal poses [x m, y m, yaw rad]; hidden: what stands in the world and is not in its map "
               "(cones [x, y], markers [x, y, yaw] of 0.5 x 0.3 m, people [x, y]): for scoring, not for the car")


def course_yaml(course: Course) -> str:
    """A course as NAME_course.yaml beside a tunnel's map."""
    import yaml

    return yaml.safe_dump({"note": COURSE_NOTE, "start": list(course.start), "goal": list(course.goal),
                           "hidden": {"cones": [list(c) for c in course.cones],
                                      "markers": [list(m) for m in course.markers],
                                      "people": [list(p) for p in course.people]}}, sort_keys=False)


def load_course(path) -> Course:
    """A course file (course_yaml's); TrackError naming the file for anything else."""
    import math
    from pathlib import Path

    import yaml

    from roar.user_files import read_text

    path = Path(path)
    try:
        data = yaml.safe_load(read_text(path, TrackError))
    except yaml.YAMLError:
        raise TrackError(f"{path}: not valid YAML") from None

    def points(value, size: int, what: str) -> tuple:
        if not isinstance(value, list) or not all(
                isinstance(v, list) and len(v) == size and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                                               and math.isfinite(x) for x in v) for v in value):
            raise TrackError(f"{path}: {what} must be a list of [{', '.join('x y yaw'.split()[:size])}] numbers")
        return tuple(tuple(float(x) for x in v) for v in value)

    if not isinstance(data, dict) or not {"start", "goal"} <= set(data):
        raise TrackError(f"{path}: a course file has start, goal and hidden (cones, markers, people)")
    hidden = data.get("hidden") or {}
    if not isinstance(hidden, dict):
        raise TrackError(f"{path}: hidden must hold cones, markers and people")
    start, goal = points([data["start"]], 3, "start")[0], points([data["goal"]], 3, "goal")[0]
    return Course(points(hidden.get("cones", []), 2, "cones"), points(hidden.get("markers", []), 3, "markers"),
                  points(hidden.get("people", []), 2, "people"), start, goal)
