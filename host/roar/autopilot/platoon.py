"""Platooning, ROAR's way: cars share their positions over V2V multicast, and a follower keeps a
gap of D metres behind its leader, measured along the track's centre line.

    leader = cruise_agent(line, car, period_s, cruise_m_s=1.0)          # laps at a steady speed
    follower = follow_agent(line, car, period_s, gap_m=1.5, leader=lambda: heard)

The follower steers by pure pursuit on the line and sets its speed to the leader's plus a
correction on the gap error, never above its own speed profile; with no word from the leader for
the V2V timeout it stops (its own failsafe: the leader may have stopped where it cannot be seen).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from roar.autopilot.agent import Agent, Module, Observation, Passthrough
from roar.autopilot.longitudinal import SpeedController
from roar.autopilot.pure_pursuit import PurePursuit
from roar.autopilot.race_agent import CarModel, Plan, RaceController, RacePlanner
from roar.autopilot.speed_profile import speed_profile
from roar.autopilot.waypoints import LoopWaypointFollower
from roar.protocol import spec

GAP_GAIN_PER_S = 1.0  # [1/s] m/s of speed per metre of gap error
TIMEOUT_S = spec.V2V_TIMEOUT_US / 1e6  # [s]


class CruisePlanner(Module[Observation, Plan]):
    """The race planner's goal, at no more than cruise_m_s."""

    def __init__(self, base: RacePlanner, cruise_m_s: float) -> None:
        self.base, self.cruise_m_s = base, cruise_m_s

    def setup(self) -> None:
        self.base.setup()

    def step(self, value: Observation) -> Plan:
        plan = self.base.step(value)
        return Plan(plan.index, plan.goal, min(plan.target_speed_m_s, self.cruise_m_s))


class FollowPlanner(Module[Observation, Plan]):
    """leader() -> the leader's newest V2V state (with .x, .y, .speed, .received_s on the
    follower's clock) or None. With measured() -> [m] the gap as the follower's own sensor sees
    it (an ArUco marker on the leader's rear by camera: roar.vision.aruco) or None, that gap is
    kept while it is seen, and the V2V positions' gap when it is not (`source` says which)."""

    def __init__(self, base: RacePlanner, points: np.ndarray, gap_m: float, leader: Callable[[], object | None],
                 gain_per_s: float = GAP_GAIN_PER_S, timeout_s: float = TIMEOUT_S,
                 measured: Callable[[], float | None] | None = None) -> None:
        self.base, self.gap_m, self.leader, self.gain, self.timeout_s = base, gap_m, leader, gain_per_s, timeout_s
        self.measured = measured
        self.source = "v2v"  # where the last gap came from: "marker" or "v2v"
        self.points = np.asarray(points, dtype=float)[:, :2]
        seg = np.linalg.norm(np.roll(self.points, -1, axis=0) - self.points, axis=1)
        self.arc = np.concatenate([[0.0], np.cumsum(seg)[:-1]])
        self.length = float(seg.sum())
        self.gap_now_m: float | None = None  # [m] the last gap measured
        self.stale = True

    def setup(self) -> None:
        self.base.setup()

    def _along(self, x: float, y: float) -> float:
        """[m] along the line to its point nearest (x, y)."""
        return float(self.arc[int(np.argmin(np.hypot(self.points[:, 0] - x, self.points[:, 1] - y)))])

    def step(self, value: Observation) -> Plan:
        plan = self.base.step(value)
        heard = self.leader()
        self.stale = heard is None or value.t_s - heard.received_s > self.timeout_s
        if self.stale:
            return Plan(plan.index, plan.goal, 0.0)
        seen = self.measured() if self.measured is not None else None
        self.source = "v2v" if seen is None else "marker"
        self.gap_now_m = seen if seen is not None else \
            (self._along(heard.x, heard.y) - self._along(value.x, value.y)) % self.length
        target = heard.speed + self.gain * (self.gap_now_m - self.gap_m)
        return Plan(plan.index, plan.goal, max(0.0, min(plan.target_speed_m_s, target)))


def _base(points: np.ndarray, car: CarModel, margin: float) -> tuple[np.ndarray, RacePlanner, PurePursuit]:
    xy = np.asarray(points, dtype=float)[:, :2]
    pursuit = PurePursuit(car.wheelbase_m)
    planner = RacePlanner(xy, speed_profile(xy, car.limits.with_margin(margin)), LoopWaypointFollower(xy), pursuit)
    return xy, planner, pursuit


def cruise_agent(points: np.ndarray, car: CarModel, period_s: float, cruise_m_s: float, margin: float = 0.9) -> Agent:
    """Laps `points` at cruise_m_s (slower where the line's curves demand it)."""
    _, planner, pursuit = _base(points, car, margin)
    return Agent(Passthrough(), CruisePlanner(planner, cruise_m_s),
                 RaceController(car, pursuit, SpeedController(car.limits.max_speed_m_s, max_reverse=car.limits.max_reverse),
                                period_s))


def follow_agent(points: np.ndarray, car: CarModel, period_s: float, gap_m: float, leader: Callable[[], object | None],
                 margin: float = 0.9, measured: Callable[[], float | None] | None = None) -> Agent:
    """Follows `points` gap_m behind the car leader() reports, by the gap measured() sees while it
    sees one; stops when the leader goes silent."""
    xy, planner, pursuit = _base(points, car, margin)
    return Agent(Passthrough(), FollowPlanner(planner, xy, gap_m, leader, measured=measured),
                 RaceController(car, pursuit, SpeedController(car.limits.max_speed_m_s, max_reverse=car.limits.max_reverse),
                                period_s))
