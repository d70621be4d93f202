"""The IARRC drag race's strip: a straight lane, `length` m from the start line (x = 0) to the
finish line, then a stop zone ending in a wall across the road; a wall behind the start too.

    drag:40                      # 40 m to the finish, 1.2 m wide, a 6 m stop zone
    drag:60,width=1.5,stop=8

The strip is a Track whose driving area is the rectangle itself (its edges are the walls). A
Track's centre line is a closed loop, so the strip's goes on past the end wall and comes back
well clear of it; only its first straight lies on the road, and only there is it painted.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from roar.checks import number
from roar.tracks.seeds import split_options
from roar.tracks.track import Track, TrackError

LENGTH_RANGE_M = (10.0, 100.0)  # [m] start to finish
WIDTH_RANGE_M = (0.8, 3.0)  # [m]
STOP_RANGE_M = (2.0, 20.0)  # [m] finish line to end wall
DEFAULT_LENGTH_M, DEFAULT_WIDTH_M, DEFAULT_STOP_M = 40.0, 1.2, 6.0  # [m]
BEHIND_M = 1.5  # [m] of road behind the start line, to the wall there
RETURN_RADIUS_M = 3.0  # [m] of the centre line's turns off the road, out of every sensor's way
SPACING_M = 0.1  # [m] between centre-line points
USAGE = "drag:LENGTH[,width=M,stop=M], e.g. drag:40"


@dataclass(frozen=True)
class StripSpec:
    length_m: float = DEFAULT_LENGTH_M  # [m] start line to finish line
    width_m: float = DEFAULT_WIDTH_M  # [m] wall to wall
    stop_m: float = DEFAULT_STOP_M  # [m] finish line to the end wall

    @property
    def end_m(self) -> float:
        """[m] x of the end wall's face."""
        return self.length_m + self.stop_m


def parse(name: str) -> StripSpec:
    """The strip a `drag:LENGTH[,width=,stop=]` name describes; TrackError (one line) otherwise."""
    length, values = split_options(name, "drag:", USAGE, ("width", "stop"))
    try:
        return StripSpec(number("length", _float(length.strip()), *LENGTH_RANGE_M, "m"),
                         number("width", _float(values.get("width", DEFAULT_WIDTH_M)), *WIDTH_RANGE_M, "m"),
                         number("stop", _float(values.get("stop", DEFAULT_STOP_M)), *STOP_RANGE_M, "m"))
    except ValueError as e:
        raise TrackError(f"{name!r}: {e} ({USAGE})") from None


def _float(text) -> float | str:
    try:
        return float(text)
    except ValueError:
        return str(text)


def generate(spec: StripSpec, name: str | None = None) -> Track:
    """The strip as a Track (its start pose at the start line, facing the finish)."""
    import shapely

    r, end = RETURN_RADIUS_M, spec.end_m + 2 * RETURN_RADIUS_M  # the loop turns back well past the wall
    out = np.arange(0.0, end, SPACING_M)
    turn = np.linspace(-math.pi / 2, math.pi / 2, max(8, int(math.pi * r / SPACING_M)), endpoint=False)
    back = np.arange(end, -BEHIND_M - 2 * r, -SPACING_M)
    points = [np.column_stack([out, np.zeros_like(out)]),
              np.column_stack([end + r * np.cos(turn), r + r * np.sin(turn)]),
              np.column_stack([back, np.full_like(back, 2 * r)]),
              np.column_stack([back[-1] - r * np.cos(turn), r - r * np.sin(turn)])]
    tail = np.arange(back[-1], 0.0, SPACING_M)
    points.append(np.column_stack([tail, np.zeros_like(tail)]))
    centre = np.vstack(points)
    gaps = np.linalg.norm(np.roll(centre, -1, axis=0) - centre, axis=1)
    centre = centre[gaps > SPACING_M / 2]  # where two pieces meet, one point
    road = shapely.box(-BEHIND_M, -spec.width_m / 2, spec.end_m, spec.width_m / 2)
    return Track(name or f"drag:{spec.length_m:g}", centre, spec.width_m, area=road)
