"""The high-level planner of the MIT challenge: which goal the local planner (RRT) is given next.

- Goals run along the course's route (a polyline from the start to the finish, on the known map),
  horizon_m ahead of the car's progress on it; the finish when it is that near.
- A floor marker seen ahead is pursued only when its bonus beats the time the detour costs
  (the extra distance over the car's speed): bonus_s > (|car-marker| + |marker-goal| - |car-goal|) / speed.
- A goal that lands on a wall or an obstacle is moved to the nearest free point round it.

    mission = Mission(route, bonus_s=2.0, speed_m_s=1.5)
    goal, why = mission.goal(pose, grid, markers=[(x, y), ...])
    mission.update(pose)          # progress, and markers driven over
"""

from __future__ import annotations

import math

import numpy as np

from roar.planning.grid import PlanningGrid

HORIZON_M = 4.0  # [m] ahead along the route
TAKEN_M = 0.5  # [m] a marker the car's reference point came this near is taken (the car is on it: its body reaches
# 0.41 m ahead); more than a planner's goal tolerance (0.3 m), or a car that stops on reaching it would wait for ever
NUDGE_M = (0.15, 0.3, 0.45, 0.6, 0.8)  # [m] rings searched round a blocked goal


class Mission:
    def __init__(self, route, bonus_s: float = 2.0, speed_m_s: float = 1.5, horizon_m: float = HORIZON_M) -> None:
        route = np.asarray(route, dtype=float)
        if route.ndim != 2 or route.shape[1] != 2 or len(route) < 2 or not np.isfinite(route).all():
            raise ValueError("a mission's route is 2 or more finite (x, y) points")
        self.route = route
        self._s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(route, axis=0), axis=1))])
        self.length_m = float(self._s[-1])
        self.bonus_s, self.speed_m_s, self.horizon_m = bonus_s, speed_m_s, horizon_m
        self.progress_m = 0.0  # along the route
        self.taken: list[tuple[float, float]] = []
        self.skipped: list[tuple[float, float]] = []  # markers whose detour cost more than their bonus
        self.abandoned: list[tuple[float, float]] = []  # markers the local planner found no way to
        self.pursuing: tuple[float, float] | None = None  # the marker the last goal was

    def along(self, xy) -> float:
        """[m] along the route of its point nearest xy, searched near the progress so far."""
        window = (self._s >= self.progress_m - 2.0) & (self._s <= self.progress_m + 2 * self.horizon_m)
        idx = np.flatnonzero(window)
        d = np.hypot(self.route[idx, 0] - xy[0], self.route[idx, 1] - xy[1])
        if d.min() > 2.0:  # far from the route near the progress so far: anywhere on it
            idx = np.arange(len(self.route))
            d = np.hypot(self.route[:, 0] - xy[0], self.route[:, 1] - xy[1])
        return float(self._s[idx[np.argmin(d)]])

    def point_at(self, s_m: float) -> tuple[float, float]:
        s = min(max(s_m, 0.0), self.length_m)
        return (float(np.interp(s, self._s, self.route[:, 0])), float(np.interp(s, self._s, self.route[:, 1])))

    def update(self, pose, markers=()) -> None:
        self.progress_m = max(self.progress_m, self.along(pose[:2]))
        for m in markers:
            if math.hypot(m[0] - pose[0], m[1] - pose[1]) <= TAKEN_M and not self._known(m, self.taken):
                self.taken.append((float(m[0]), float(m[1])))

    @staticmethod
    def _known(m, among) -> bool:
        return any(math.hypot(m[0] - a[0], m[1] - a[1]) < 0.4 for a in among)

    def abandon(self, marker=None) -> None:
        """Pursue this marker (default: the one the last goal was) no more: no way to it was found."""
        marker = self.pursuing if marker is None else marker
        if marker is not None and not self._known(marker, self.abandoned):
            self.abandoned.append((float(marker[0]), float(marker[1])))

    @property
    def finish(self) -> tuple[float, float]:
        return tuple(self.route[-1])

    def goal(self, pose, grid: PlanningGrid | None = None, markers=()) -> tuple[tuple[float, float], str]:
        """(goal (x, y), why: 'route', 'finish' or 'marker') for the car at pose."""
        s_car = self.along(pose[:2])
        s_goal = s_car + self.horizon_m
        why = "finish" if s_goal >= self.length_m else "route"
        goal = self.point_at(s_goal)
        best, gain = None, 0.0
        for m in markers:
            if self._known(m, self.taken) or self._known(m, self.abandoned):
                continue
            s_m = self.along(m[:2])
            if not s_car + 0.3 < s_m < s_goal + 1.0:
                continue
            detour = (math.hypot(m[0] - pose[0], m[1] - pose[1]) + math.hypot(goal[0] - m[0], goal[1] - m[1])
                      - math.hypot(goal[0] - pose[0], goal[1] - pose[1]))
            net = self.bonus_s - detour / self.speed_m_s
            if net > gain:
                best, gain = (float(m[0]), float(m[1])), net
            elif not self._known(m, self.skipped):
                self.skipped.append((float(m[0]), float(m[1])))
        self.pursuing = best
        if best is not None:
            goal, why = best, "marker"
        return (goal if grid is None else free_near(grid, goal)), why


def free_near(grid: PlanningGrid, xy) -> tuple[float, float]:
    """xy if its cell is free, else the nearest free point on rings round it (xy if none)."""
    if not grid.blocked_at([xy])[0]:
        return (float(xy[0]), float(xy[1]))
    for r in NUDGE_M:
        a = np.linspace(0, 2 * math.pi, 16, endpoint=False)
        ring = np.stack([xy[0] + r * np.cos(a), xy[1] + r * np.sin(a)], axis=1)
        ok = ~grid.blocked_at(ring)
        if ok.any():
            p = ring[np.flatnonzero(ok)[0]]
            return (float(p[0]), float(p[1]))
    return (float(xy[0]), float(xy[1]))
