"""Waypoint files and the loop waypoint follower.

File format, one waypoint per line (as the ROAR seed records them):

    x,y,z               metres
    x,y,z,roll,pitch,yaw   metres and degrees (orientation is kept but not used for following)

Blank lines and lines starting with # are ignored. Coordinates are finite and within 10 km of
the origin. A point that repeats the one before it (a car recording while standing still) is
dropped; the rest must be at least 3 distinct waypoints spanning a loop of at least 1 m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from roar.autopilot.agent import Module, Observation
from roar.errors import WaypointError
from roar.user_files import read_text

MIN_WAYPOINTS = 3
MAX_COORDINATE_M = 10_000.0  # [m]
SAME_POINT_M = 0.001  # [m] a point this close to the one before repeats it
MIN_LOOP_M = 1.0  # [m] the shortest loop worth following


def load_waypoints(path: str | Path) -> np.ndarray:
    """(N, 3) array of x, y, z [m] from a waypoint file."""
    path = Path(path)
    text = read_text(path, WaypointError)
    rows = []
    for number, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        fields = [f.strip() for f in line.split(",")]
        try:
            values = [float(f) for f in fields]
        except ValueError:
            values = []
        if len(fields) not in (3, 6) or len(values) != len(fields) or not all(map(math.isfinite, values)):
            raise WaypointError(f"{path}:{number}: expected x,y,z or x,y,z,roll,pitch,yaw (finite numbers), "
                                f"got {line[:60]!r}")
        if max(abs(v) for v in values[:3]) > MAX_COORDINATE_M:
            raise WaypointError(f"{path}:{number}: a coordinate beyond {MAX_COORDINATE_M:g} m: {line[:60]!r}")
        if rows and math.dist(rows[-1][:2], values[:2]) < SAME_POINT_M:
            continue  # the same point again
        rows.append(values[:3])
    if len(rows) > 1 and math.dist(rows[0][:2], rows[-1][:2]) < SAME_POINT_M:
        rows.pop()  # the loop closes by itself
    if len(rows) < MIN_WAYPOINTS:
        raise WaypointError(f"{path}: needs at least {MIN_WAYPOINTS} distinct waypoints, has {len(rows)}")
    points = np.array(rows)
    loop = float(np.linalg.norm(np.roll(points[:, :2], -1, axis=0) - points[:, :2], axis=1).sum())
    if loop < MIN_LOOP_M:
        raise WaypointError(f"{path}: the waypoints span a loop of {loop:.3f} m; at least {MIN_LOOP_M:g} m is needed")
    return points


def save_waypoints(path: str | Path, points: np.ndarray) -> None:
    """x,y,z per line (z = 0 for 2D points)."""
    pts = np.asarray(points, dtype=float)
    if pts.shape[1] == 2:
        pts = np.hstack([pts, np.zeros((len(pts), 1))])
    Path(path).write_text("".join(f"{x:.4f},{y:.4f},{z:.4f}\n" for x, y, z in pts[:, :3]), encoding="utf-8")


@dataclass
class LoopWaypointFollower(Module[Observation, int]):
    """The index of the next waypoint to head for on a closed loop.

    Each step skips every waypoint closer than `closeness_m` (ROAR's closeness_threshold), and
    also one the car has already passed (behind it, within `passed_m`): the seed waited to come
    close to each waypoint, which stalls when the car runs wide of one. At the start the first `skip_at_start` are skipped; after the last waypoint it wraps to
    `wrap_to` (the ROAR seed uses 0 + 10 on its CARLA maps, so the car does not aim back at the
    start line). A pose that jumps -- a localization's correction, a filter that found itself
    after a global start, a car carried off -- leaves the next waypoint far behind or ahead:
    beyond `reacquire_m` the follower goes on from the waypoint nearest the car. step() returns
    the index; `laps` counts wraps."""

    points: np.ndarray  # (N, 2+) [m]
    closeness_m: float = 0.3  # [m]
    passed_m: float = 1.0  # [m]
    reacquire_m: float = 3.0  # [m] a next waypoint further than this: the pose jumped; go on from the nearest
    skip_at_start: int = 0
    wrap_to: int = 0
    index: int = field(default=0, init=False)
    laps: int = field(default=0, init=False)
    steps: int = field(default=0, init=False)  # since setup(): the first keeps skip_at_start however far it is

    def __post_init__(self) -> None:
        n = len(self.points)
        if n < MIN_WAYPOINTS:
            raise ValueError(f"need at least {MIN_WAYPOINTS} waypoints, got {n}")
        if not (0 <= self.skip_at_start < n and 0 <= self.wrap_to < n):
            raise ValueError(f"skip_at_start and wrap_to must be waypoint indices 0..{n - 1}")
        if not self.closeness_m > 0:
            raise ValueError(f"closeness_m must be positive, got {self.closeness_m}")

    def setup(self) -> None:
        self.index, self.laps, self.steps = self.skip_at_start, 0, 0

    def step(self, value: Observation) -> int:
        xy = np.array([value.x, value.y])
        heading = np.array([np.cos(value.yaw), np.sin(value.yaw)])
        if self.steps and float(np.linalg.norm(self.points[self.index, :2] - xy)) > self.reacquire_m:
            self.index = int(np.argmin(np.linalg.norm(self.points[:, :2] - xy, axis=1)))
        self.steps += 1
        for _ in range(len(self.points)):  # never spin forever, even if every point is close
            offset = self.points[self.index, :2] - xy
            distance = float(np.linalg.norm(offset))
            behind = float(offset @ heading) < 0
            if distance >= self.closeness_m and not (behind and distance < self.passed_m):
                break
            self.index += 1
            if self.index >= len(self.points):
                self.index, self.laps = self.wrap_to, self.laps + 1
        return self.index
