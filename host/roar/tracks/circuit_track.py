"""Circuit-like tracks from a seed: `circuit:SEED` wherever a track is named, with the shape of the
real 1:10 circuits (the F1TENTH collection, measured: roar.tracks.circuit_track.shape)

    circuit:7                       260-490 m long, 2.2 m wide
    circuit:7,length=300-320,width=2.2

A closed polygon of 10 to 18 corners round a centre, whose longest side (30-90 m) is the main
straight and ends in the lap's slowest bend (0.9-2 m radius); one or two other long sides carry a
chicane (a sideways jog of 1.5-3 m: four short bends, left-right-right-left); every other corner is
rounded by an arc drawn between 3 and 20 m (as much as its sides leave room for). A draw whose
shape falls outside the real circuits' figures (SHAPE: 10-27 bends under 10 m a lap, their median
radius 4-7 m, the tightest 0.9-2 m, the longest straight 30-90 m into a bend under 3 m) is redrawn
from the same generator, so a seed names one circuit, the same on every machine. The car starts in
the middle of the main straight, as on a real grid.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from roar.checks import printable
from roar.tracks.random_track import (LENGTH_RANGE_M, corner_arcs, corner_turns, drop_straight_corners, first_drawn,
                                      middle_of_longest_straight, perimeter, sample_arcs)
from roar.tracks.seeds import seeded
from roar.tracks.track import MAX_WIDTH_M, MIN_WIDTH_M, Track, TrackError

PREFIX = "circuit:"
USAGE = "circuit:SEED[,length=MIN-MAX][,width=M]"
MAX_DRAWS = 400  # polygons drawn before a seed's parameters are called impossible
CORNERS = (10, 18)  # corners of the polygon, before chicanes
SLOWEST_RADIUS_M = (0.9, 2.0)  # [m] the bend at the end of the main straight
OTHER_RADIUS_M = (3.0, 20.0)  # [m] other corners: log-uniform within
CHICANE_RADIUS_M = (2.0, 5.0)  # [m]
CHICANE_JOG_M = (1.5, 3.0)  # [m] sideways
CHICANE_RUN_M = 4.0  # [m] along the side, for each of the jog's three legs
CHICANE_SIDE_M = 25.0  # [m] a side this long may carry a chicane
BEND_RADIUS_M = 10.0  # [m] a bend: the centre line tighter than this
STRAIGHT_RADIUS_M = 50.0  # [m] a straight: the centre line straighter than this
OTHER, CHICANE, SLOW = 0, 1, 2  # kinds of corner


@dataclass(frozen=True)
class Shape:
    """The figures a circuit is drawn to, each (low, high)."""

    bends: tuple[int, int] = (10, 27)  # bends under BEND_RADIUS_M a lap
    median_radius_m: tuple[float, float] = (4.0, 7.0)  # [m] of those bends' tightest points
    tightest_m: tuple[float, float] = (0.9, 2.0)  # [m] the lap's tightest bend
    straight_m: tuple[float, float] = (30.0, 90.0)  # [m] the longest straight
    into_m: tuple[float, float] = (0.9, 3.0)  # [m] the bend the longest straight ends in


SHAPE = Shape()


@dataclass(frozen=True)
class Figures:
    """What a track's shape measures (shape())."""

    bends: int
    median_radius_m: float  # [m] median of the bends' tightest radii (inf: no bend)
    tightest_m: float  # [m]
    straight_m: float  # [m] the longest straight
    into_m: float  # [m] the tightest radius of the bend that follows it
    chicanes: int  # bends turning the other way within CHICANE_RUN_M * 2 of the previous one, pairs

    def problem(self, shape: Shape = SHAPE) -> str | None:
        """Which figure falls outside a shape, in words; None when all are inside."""
        for key in ("bends", "median_radius_m", "tightest_m", "straight_m", "into_m"):
            low, high = getattr(shape, key)
            if not low <= getattr(self, key) <= high:
                return f"{key.replace('_', ' ').removesuffix(' m')} {getattr(self, key):.3g} is not {low:g}-{high:g}"
        return None


@dataclass(frozen=True)
class CircuitSpec:
    seed: int
    length_m: tuple[float, float] = (260.0, 490.0)  # [m]
    width_m: float = 2.2  # [m]

    @property
    def name(self) -> str:
        defaults = CircuitSpec(self.seed)
        parts = [f"{PREFIX}{self.seed}"]
        if self.length_m != defaults.length_m:
            parts.append(f"length={self.length_m[0]:g}-{self.length_m[1]:g}")
        if self.width_m != defaults.width_m:
            parts.append(f"width={self.width_m:g}")
        return ",".join(parts)


def parse(name: str) -> CircuitSpec:
    """`circuit:SEED[,length=MIN-MAX][,width=M]` -> its spec; TrackError (one line) otherwise."""
    seed, options = seeded(name, PREFIX, USAGE, ("length", "width"))
    values: dict = {"seed": seed}
    for key, text in options.items():
        try:
            if key == "length":
                low, _, high = text.partition("-")
                values["length_m"] = (float(low), float(high or low))
            else:
                values["width_m"] = float(text)
        except ValueError:
            raise TrackError(f"{printable(name)!r}: {printable(key)} needs a number, got {printable(text)!r} "
                             f"({USAGE})") from None
    spec = CircuitSpec(**values)
    low, high = spec.length_m
    lowest = 200.0  # [m] below this the straights and bends of a circuit do not fit
    if not (math.isfinite(low) and math.isfinite(high) and lowest <= low <= high <= LENGTH_RANGE_M[1]):
        raise TrackError(f"{printable(name)!r}: length must be MIN-MAX within {lowest:g}-{LENGTH_RANGE_M[1]:g} m, "
                         f"MIN <= MAX ({USAGE})")
    if not MIN_WIDTH_M <= spec.width_m <= 3.0:
        raise TrackError(f"{printable(name)!r}: width must be {MIN_WIDTH_M:g}..3 m ({USAGE})")
    assert MAX_WIDTH_M >= 3.0
    return spec


def generate(spec: CircuitSpec) -> Track:
    """The circuit a spec names (see the module's text)."""
    return first_drawn(spec.name, spec.width_m, lambda rng: _draw(rng, spec), spec.seed, MAX_DRAWS, "circuit",
                       "the default length", lambda track: shape(track).problem())


def shape(track: Track) -> Figures:
    """A track's shape in the figures real circuits are described by (the centre line's radius
    over Track.bend_radii's chord): its bends (runs tighter than BEND_RADIUS_M), straights (runs
    straighter than STRAIGHT_RADIUS_M), chicanes."""
    radii = track.bend_radii()
    lengths = track.segment_lengths
    runs = _runs(radii < BEND_RADIUS_M)
    tightest = [float(radii[run].min()) for run in runs]
    straights = _runs(radii > STRAIGHT_RADIUS_M)
    straight_m, into_m = 0.0, math.inf
    if straights:
        longest = max(straights, key=lambda run: float(lengths[run].sum()))
        straight_m = float(lengths[longest].sum())
        after = (longest[-1] + 1) % len(radii)
        following = [k for k, run in enumerate(runs) if _arc(after, run[0], len(radii)) >= 0]
        if following:
            k = min(following, key=lambda k: _arc(after, runs[k][0], len(radii)))
            into_m = tightest[k]
    turn = _turns_along(track)
    signs = [float(np.sign(turn[run].sum())) for run in runs]
    s = track.arc_start
    gaps = [float(track.arc_delta(s[runs[k - 1][-1]], s[runs[k][0]])) for k in range(len(runs))]
    chicanes = sum(1 for k in range(len(runs)) if signs[k] != signs[k - 1] and gaps[k] < 2 * CHICANE_RUN_M)
    return Figures(bends=len(runs), median_radius_m=float(np.median(tightest)) if tightest else math.inf,
                   tightest_m=min(tightest, default=math.inf), straight_m=straight_m, into_m=into_m,
                   chicanes=chicanes // 2)


def _runs(mask: np.ndarray) -> list[np.ndarray]:
    """The indices of each run of True in a closed sequence (a run may wrap round its end)."""
    n = len(mask)
    if mask.all():
        return [np.arange(n)]
    first = int(np.argmin(mask))  # a False: no run wraps past it
    order = (np.arange(n) + first) % n
    runs, current = [], []
    for i in order:
        if mask[i]:
            current.append(i)
        elif current:
            runs.append(np.array(current))
            current = []
    if current:
        runs.append(np.array(current))
    return runs


def _arc(a: int, b: int, n: int) -> int:
    """Points from a forward to b on a closed line."""
    return (b - a) % n


def _turns_along(track: Track) -> np.ndarray:
    """[rad] the centre line's signed turn at each point (anticlockwise positive)."""
    d = np.roll(track.centerline, -1, axis=0) - track.centerline
    heading = np.arctan2(d[:, 1], d[:, 0])
    return (np.roll(heading, -1) - heading + math.pi) % (2 * math.pi) - math.pi


def _draw(rng: np.random.Generator, spec: CircuitSpec) -> np.ndarray | None:
    """One candidate centre line, or None where its corners cannot be rounded."""
    length = rng.uniform(*spec.length_m)
    n = int(rng.integers(CORNERS[0], CORNERS[1] + 1))
    gaps = rng.gamma(2.0, size=n)  # uneven angles round the centre: long sides and short ones
    angles = np.cumsum(gaps / gaps.sum() * 2 * math.pi)
    radii = rng.uniform(0.4, 1.0, n)
    polygon = drop_straight_corners(np.stack([radii * np.cos(angles), radii * np.sin(angles)], axis=1))
    if polygon is None:
        return None
    polygon *= length / perimeter(polygon)
    sides = np.linalg.norm(np.roll(polygon, -1, axis=0) - polygon, axis=1)  # corner i to i+1
    main = int(np.argmax(sides))
    if not SHAPE.straight_m[0] + 5 <= sides[main] <= SHAPE.straight_m[1]:
        return None
    polygon, kind = _with_chicanes(polygon, sides, main, rng)
    radius = _radii(polygon, kind, rng)
    if radius is None:
        return None
    path = sample_arcs(corner_arcs(polygon, radius))
    path *= length / perimeter(path)
    start = middle_of_longest_straight(path)
    return np.round(np.roll(path, -start, axis=0), 6)


def _with_chicanes(polygon: np.ndarray, sides: np.ndarray, main: int,
                   rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """The polygon with a chicane on one or two of its long sides (never the main straight), and
    each corner's kind: SLOW (the one the main straight ends in), CHICANE or OTHER."""
    long_sides = [i for i in range(len(polygon)) if i != main and sides[i] >= CHICANE_SIDE_M]
    chosen = set(rng.permutation(long_sides)[:int(rng.integers(1, 3))].tolist()) if long_sides else set()
    corners, kind = [], []
    for i, corner in enumerate(polygon):
        corners.append(corner)
        kind.append(SLOW if i == (main + 1) % len(polygon) else OTHER)
        if i not in chosen:
            continue
        a, b = corner, polygon[(i + 1) % len(polygon)]
        along = (b - a) / sides[i]
        left = np.array([-along[1], along[0]]) * rng.choice([-1.0, 1.0])
        jog = rng.uniform(*CHICANE_JOG_M)
        start = rng.uniform(0.35, 0.65) * sides[i] - 1.5 * CHICANE_RUN_M
        for k, offset in enumerate((0.0, jog, jog, 0.0)):
            corners.append(a + along * (start + k * CHICANE_RUN_M) + left * offset)
            kind.append(CHICANE)
    return np.array(corners), np.array(kind)


def _radii(polygon: np.ndarray, kind: np.ndarray, rng: np.random.Generator) -> np.ndarray | None:
    """[m] each corner's arc radius (see the module's text), each within the room its sides leave;
    None when a corner cannot be rounded at SLOWEST_RADIUS_M's low end."""
    turns = corner_turns(polygon)
    if np.any(np.abs(turns) > math.radians(170)):
        return None
    sides = np.linalg.norm(np.roll(polygon, -1, axis=0) - polygon, axis=1)
    room = np.minimum(sides, np.roll(sides, 1)) / 2
    biggest = room / np.tan(np.abs(turns) / 2) * 0.98
    wanted = np.exp(rng.uniform(*np.log(OTHER_RADIUS_M), len(polygon)))
    wanted = np.where(kind == CHICANE, rng.uniform(*CHICANE_RADIUS_M, len(polygon)), wanted)
    wanted = np.where(kind == SLOW, rng.uniform(*SLOWEST_RADIUS_M, len(polygon)), wanted)
    radius = np.minimum(wanted, biggest)
    if np.any(radius < SLOWEST_RADIUS_M[0]):
        return None
    return radius
