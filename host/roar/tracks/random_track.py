"""Random tracks from a seed: `random:SEED` wherever a track is named, with optional parameters

    random:7                                  20-60 m long, 1.2 m wide, bends of radius >= 1.5 m
    random:7,length=40-80,width=2.2,radius=1,straightness=0.7

A closed polygon of 4 to 10 corners at random angles round a centre (some corners turned the
other way, so there are S-bends), each corner rounded by an arc of radius at least `radius`, the
straights between them kept; the whole scaled to a length drawn from `length` and checked as every
track is (never closer to itself than its width, never crossing itself). `straightness` (0..1) is
how much of each side the corner arcs leave straight. A draw that fails the checks is redrawn from
the same generator, so a seed names one track, the same on every machine (numpy's PCG64 stream;
points rounded to a micrometre). The car starts in the middle of the longest straight.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from roar.checks import printable
from roar.tracks.seeds import seeded
from roar.tracks.track import MAX_WIDTH_M, MIN_BEND_RADIUS_M, MIN_WIDTH_M, Track, TrackError

PREFIX = "random:"
SPACING_M = 0.1  # [m] between centre-line points
MAX_DRAWS = 400  # polygons drawn before a seed's parameters are called impossible
LENGTH_RANGE_M = (10.0, 500.0)  # [m] lengths a random track may be asked for
MAX_RADIUS_M = 20.0  # [m] tightest radius that may be asked for
MIN_CORNER_TURN_RAD = math.radians(8)  # [rad] a corner turning less is dropped


@dataclass(frozen=True)
class RandomTrackSpec:
    seed: int
    length_m: tuple[float, float] = (20.0, 60.0)  # [m] the lap's length is drawn from this range
    width_m: float = 1.2  # [m]
    radius_m: float = 1.5  # [m] tightest bend of the centre line
    straightness: float = 0.5  # 0: corners as round as they fit; 1: as tight as radius_m allows

    @property
    def name(self) -> str:
        defaults = RandomTrackSpec(self.seed)
        parts = [f"{PREFIX}{self.seed}"]
        if self.length_m != defaults.length_m:
            parts.append(f"length={self.length_m[0]:g}-{self.length_m[1]:g}")
        for key in ("width_m", "radius_m", "straightness"):
            if getattr(self, key) != getattr(defaults, key):
                parts.append(f"{key.removesuffix('_m')}={getattr(self, key):g}")
        return ",".join(parts)


def parse(name: str) -> RandomTrackSpec:
    """`random:SEED[,key=value...]` -> its spec; TrackError (one line) for anything else."""
    usage = "random:SEED[,length=MIN-MAX][,width=M][,radius=M][,straightness=0..1]"
    seed, options = seeded(name, PREFIX, usage, ("length", "width", "radius", "straightness"))
    values: dict = {"seed": seed}
    for key, text in options.items():
        try:
            if key == "length":
                low, _, high = text.partition("-")
                values["length_m"] = (float(low), float(high or low))
            else:
                values[key if key == "straightness" else f"{key}_m"] = float(text)
        except ValueError:
            raise TrackError(f"{printable(name)!r}: {printable(key)} needs a number, got {printable(text)!r} "
                             f"({usage})") from None
    spec = RandomTrackSpec(**values)
    problem = _spec_problem(spec)
    if problem:
        raise TrackError(f"{printable(name)!r}: {problem}")
    return spec


def _spec_problem(spec: RandomTrackSpec) -> str | None:
    low, high = spec.length_m
    if not (math.isfinite(low) and math.isfinite(high) and LENGTH_RANGE_M[0] <= low <= high <= LENGTH_RANGE_M[1]):
        return f"length must be MIN-MAX within {LENGTH_RANGE_M[0]:g}-{LENGTH_RANGE_M[1]:g} m, MIN <= MAX"
    if not MIN_WIDTH_M <= spec.width_m <= MAX_WIDTH_M:
        return f"width must be {MIN_WIDTH_M:g}..{MAX_WIDTH_M:g} m"
    if not MIN_BEND_RADIUS_M <= spec.radius_m <= MAX_RADIUS_M:
        return f"radius must be {MIN_BEND_RADIUS_M:g}..{MAX_RADIUS_M:g} m"
    if not 0.0 <= spec.straightness <= 1.0:
        return "straightness must be 0..1"
    return None


def generate(spec: RandomTrackSpec) -> Track:
    """The track a spec names (see the module's text)."""
    return first_drawn(spec.name, spec.width_m, lambda rng: _draw(rng, spec), spec.seed, MAX_DRAWS,
                       "track", "a longer length, a smaller radius or width")


def first_drawn(name: str, width_m: float, draw, seed: int, draws: int, what: str, hint: str,
                problem=lambda track: None) -> Track:
    """The first of up to `draws` centre lines draw(rng) gives (None: none this time) that makes
    a track with one infield (never near nor across itself) and no problem(track) (a message);
    else TrackError naming the last reason and the hint."""
    rng = np.random.Generator(np.random.PCG64(seed))
    last = "no polygon could be drawn"
    for _ in range(draws):
        points = draw(rng)
        if points is None:
            continue
        try:
            track = Track(name, points, width_m)
        except TrackError as e:
            last = str(e).split(": ", 1)[-1]
            continue
        if not (track.uniform_width and len(track.walls) == 2):
            last = "it comes within its width of itself"
            continue
        last = problem(track)
        if last is None:
            return track
    raise TrackError(f"{name}: no {what} with these parameters in {draws} draws (the last: {last}); try {hint}")


def _draw(rng: np.random.Generator, spec: RandomTrackSpec) -> np.ndarray | None:
    """One candidate centre line, or None when its corners cannot be rounded at radius_m."""
    length = rng.uniform(*spec.length_m)
    corners = int(rng.integers(4, min(10, max(5, int(length / 6))) + 1))
    angles = np.sort(rng.uniform(0, 2 * math.pi, corners))
    radii = rng.uniform(0.35, 1.0, corners)
    polygon = np.stack([radii * np.cos(angles), radii * np.sin(angles)], axis=1)
    polygon = drop_straight_corners(polygon)
    if polygon is None:
        return None
    polygon *= length / perimeter(polygon)
    arcs = _round_corners(polygon, rng, spec)
    if arcs is None:
        return None
    path = sample_arcs(arcs)
    path *= length / perimeter(path)  # the corners shortened it: back to the drawn length
    start = middle_of_longest_straight(path)
    return np.round(np.roll(path, -start, axis=0), 6)


def perimeter(points: np.ndarray) -> float:
    return float(np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1).sum())


def corner_turns(polygon: np.ndarray) -> np.ndarray:
    """[rad] signed turn at each corner (anticlockwise positive)."""
    into = polygon - np.roll(polygon, 1, axis=0)
    out = np.roll(polygon, -1, axis=0) - polygon
    return np.arctan2(into[:, 0] * out[:, 1] - into[:, 1] * out[:, 0], np.einsum("ij,ij->i", into, out))


def drop_straight_corners(polygon: np.ndarray) -> np.ndarray | None:
    while len(polygon) >= 3:
        turns = corner_turns(polygon)
        flat = int(np.argmin(np.abs(turns)))
        if abs(turns[flat]) >= MIN_CORNER_TURN_RAD:
            return polygon if len(polygon) >= 3 else None
        polygon = np.delete(polygon, flat, axis=0)
    return None


def _round_corners(polygon: np.ndarray, rng: np.random.Generator, spec: RandomTrackSpec) -> list | None:
    """Per corner (arc start, arc centre, radius, signed turn): each corner's arc as large as the
    straightness leaves room for, none below radius_m."""
    turns = corner_turns(polygon)
    sides = np.linalg.norm(np.roll(polygon, -1, axis=0) - polygon, axis=1)  # corner i to i+1
    room = np.minimum(sides, np.roll(sides, 1)) / 2  # tangent length each corner may use
    tan_half = np.tan(np.abs(turns) / 2)
    biggest = room / tan_half
    if np.any(biggest < spec.radius_m * 1.02) or np.any(np.abs(turns) > math.radians(170)):
        return None
    share = (1 - spec.straightness) * rng.uniform(0.4, 1.0, len(polygon))
    return corner_arcs(polygon, spec.radius_m * 1.02 + (biggest - spec.radius_m * 1.02) * share)


def rounded_polygon(polygon, radii_m) -> np.ndarray:
    """A closed centre line (points every SPACING_M) round a polygon's corners (anticlockwise),
    each corner an arc of its radius [m] and straights between: a track of any shape, by hand."""
    return sample_arcs(corner_arcs(np.asarray(polygon, dtype=float), np.broadcast_to(radii_m, (len(polygon),))))


def corner_arcs(polygon: np.ndarray, radius: np.ndarray) -> list:
    """Per corner (arc start, arc centre, radius, signed turn)."""
    turns = corner_turns(polygon)
    tan_half = np.tan(np.abs(turns) / 2)
    arcs = []
    for i, corner in enumerate(polygon):
        into = corner - polygon[i - 1]
        into /= np.linalg.norm(into)
        start = corner - into * radius[i] * tan_half[i]
        left = np.array([-into[1], into[0]]) * math.copysign(1.0, turns[i])
        arcs.append((start, start + left * radius[i], radius[i], turns[i]))
    return arcs


def sample_arcs(arcs: list) -> np.ndarray:
    """Points every ~SPACING_M along the arcs and the straights between them."""
    points = []
    for i, (start, centre, radius, turn) in enumerate(arcs):
        n = max(2, int(math.ceil(abs(turn) * radius / SPACING_M)))
        a0 = math.atan2(start[1] - centre[1], start[0] - centre[0])
        a = a0 + turn * np.arange(n) / n
        points.append(centre + radius * np.stack([np.cos(a), np.sin(a)], axis=1))
        end = centre + radius * np.array([math.cos(a0 + turn), math.sin(a0 + turn)])
        following = arcs[(i + 1) % len(arcs)][0]
        k = int(math.floor(np.linalg.norm(following - end) / SPACING_M))
        points.append(end + (following - end) * (np.arange(max(1, k)) / max(1, k))[:, None])
    return np.vstack(points)


def middle_of_longest_straight(path: np.ndarray) -> int:
    heading = np.roll(path, -1, axis=0) - path
    heading = np.arctan2(heading[:, 1], heading[:, 0])
    straight = np.abs((np.roll(heading, -1) - heading + math.pi) % (2 * math.pi) - math.pi) < 1e-6
    best, best_len, run_start, run = 0, -1, 0, 0
    for i in range(2 * len(path)):  # runs may wrap round the end
        if straight[i % len(path)]:
            run_start, run = (i, 1) if run == 0 else (run_start, run + 1)
            if run > best_len and run <= len(path):
                best, best_len = run_start + run // 2, run
        else:
            run = 0
    return best % len(path)
