"""Following a planner's path as exactly as the car can, through jumping poses and late plans
(the MIT racecar's rules):

- the target is the path point lookahead_m ahead of the first point not yet passed (less when
  the car is slower: 0.3 m at rest), never beyond a change of direction (the car stops there
  and reverses);
- when the pose jumps off the path (further than off_path_m from it) the follower holds its
  target and says OFF_PATH, until the car is back;
- when the pose jumps back on, or a new path arrives late (made from where the car was), it
  fast-forwards to the first path point the car has not yet passed, never back;
- it says WAITING with no path and DONE at the path's end.

    follower = PathFollower(lookahead_m=0.6)
    follower.set_path(path)
    steer = follower.step(pose)     # .state, .curvature (left positive, 1/m), .direction, .speed_m_s
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

import numpy as np

from roar.autopilot.pure_pursuit import PurePursuit
from roar.planning.path import Path
from roar.planning.rrt import checked_pose

LOOKAHEAD_M = 0.6  # [m] at MAX_SPEED_M_S; shorter slower (the chord pure pursuit cuts grows with its square)
MIN_LOOKAHEAD_M = 0.3  # [m] at a standstill
OFF_PATH_M = 0.5  # [m] further than this from the path: off it
DONE_M = 0.25  # [m] this near the path's last point, the path is done
MAX_SPEED_M_S = 2.0  # [m/s]
LATERAL_M_S2 = 1.0  # [m/s^2] the speed on a bend is held below sqrt(this / curvature): 0.9 m/s on the tightest arcs, where
# faster the car swings 0.1 m and more off them (the servo's slew, pure pursuit's cut)
BRAKE_M_S2 = 1.5  # [m/s^2] the speed is held to stop at the path's end (or a change of direction), and to slow for
# a bend further on
ENTRY_SLACK_M_S = 0.2  # [m/s] a path entered this much faster than its bends allow is still taken (braking on it)
BEND_WINDOW_M = 1.5  # [m] the tightest bend this far ahead sets the speed at once
MIN_SPEED_M_S = 0.4  # [m/s] never asked to go slower while following (the ESC stalls below)...
CREEP_M = 0.3  # [m] ...but over the last this much before a stop (a goal by a wall: no overshoot into it)


class FollowerState(str, Enum):
    WAITING = "waiting"  # no path yet
    FOLLOWING = "following"
    OFF_PATH = "off path"  # the pose jumped away from the path: target held
    DONE = "done"  # at the path's end


@dataclass(frozen=True)
class Steer:
    state: FollowerState
    curvature: float = 0.0  # [1/m] the car's turning (steering angle = atan(wheelbase x this)), left positive
    direction: int = 1  # +1 ahead, -1 reversing
    speed_m_s: float = 0.0  # [m/s] the speed the path allows here
    target: tuple[float, float] | None = None
    index: int = 0  # the first path point not yet passed
    remaining_m: float = 0.0  # [m] to the path's end


class PathFollower:
    def __init__(self, lookahead_m: float = LOOKAHEAD_M, off_path_m: float = OFF_PATH_M, done_m: float = DONE_M,
                 max_speed_m_s: float = MAX_SPEED_M_S) -> None:
        self.lookahead_m, self.off_path_m, self.done_m = lookahead_m, off_path_m, done_m
        self.max_speed_m_s = max_speed_m_s
        self.path: Path | None = None
        self.index = 0
        self.target: tuple[float, float] | None = None
        self.state = FollowerState.WAITING
        self.fast_forwards = 0  # times the index jumped more than one point ahead

    def set_path(self, path: Path | None) -> None:
        """A new path (None: stop). The next step() fast-forwards along it to where the car is."""
        self.path, self.index, self.target = path, 0, None
        if path is not None:
            d = np.diff(path.poses[:, :2], axis=0)
            self._tangent = np.vstack([d, d[-1:]]) if len(d) else np.array([[1.0, 0.0]])
            self._s, self._kappa = along_and_curvature(path)
            cusps = np.flatnonzero(np.diff(path.direction) != 0) + 1
            self._cusps = np.concatenate([cusps, [len(path.poses) - 1]])
        self.state = FollowerState.WAITING if path is None else FollowerState.FOLLOWING

    def _segment_end(self, i: int) -> int:
        """The index of the change of direction (or the end) at or after point i."""
        return int(self._cusps[np.searchsorted(self._cusps, i)])

    def lookahead(self, speed_m_s: float | None) -> float:
        """[m] lookahead_m at max_speed_m_s (or speed unknown), MIN_LOOKAHEAD_M at rest, linear between."""
        if speed_m_s is None:
            return self.lookahead_m
        f = min(1.0, max(0.0, abs(speed_m_s) / self.max_speed_m_s))
        return min(self.lookahead_m, MIN_LOOKAHEAD_M) + f * max(0.0, self.lookahead_m - MIN_LOOKAHEAD_M)

    def step(self, pose, speed_m_s: float | None = None) -> Steer:
        """Where to steer from pose; speed_m_s (the car's, if known) shortens the lookahead when slow."""
        x, y, yaw = checked_pose("pose", pose)
        path = self.path
        if path is None:
            self.state = FollowerState.WAITING
            return Steer(self.state)
        pts = path.poses[:, :2]
        rest = np.hypot(pts[self.index:, 0] - x, pts[self.index:, 1] - y)
        nearest = self.index + int(np.argmin(rest))
        if rest.min() > self.off_path_m:  # off the path: hold the target
            self.state = FollowerState.OFF_PATH
            target = self.target or tuple(pts[self.index])
            return self._steer(x, y, yaw, target, int(path.direction[self.index]), 0.0)
        # fast-forward: from the nearest point, past every point already behind the car (never past a cusp)
        end = self._segment_end(max(self.index, nearest))
        i = max(self.index, min(nearest, end))
        while i < end and float(np.dot(pts[i] - (x, y), self._tangent[i])) <= 0.0:
            i += 1
        if i > self.index + 1:
            self.fast_forwards += 1
        self.index = i
        remaining = float(self._s[-1] - self._s[i]) + math.hypot(pts[i, 0] - x, pts[i, 1] - y)
        last = len(pts) - 1
        if (end == last and math.hypot(pts[last, 0] - x, pts[last, 1] - y) <= self.done_m) or \
                (i >= last and float(np.dot(pts[last] - (x, y), self._tangent[last])) <= 0.0):
            self.state = FollowerState.DONE
            return Steer(self.state, index=i, target=tuple(pts[last]))
        if i == end and end < last and math.hypot(pts[i, 0] - x, pts[i, 1] - y) <= self.done_m:
            self.index = i = end + 1  # at a change of direction: on to the next stretch
            end = self._segment_end(i)
        self.state = FollowerState.FOLLOWING
        # the target: lookahead_m along the path from the first point not passed, not beyond the cusp
        want = self._s[i] + max(0.0, self.lookahead(speed_m_s) - math.hypot(pts[i, 0] - x, pts[i, 1] - y))
        j = min(end, int(np.searchsorted(self._s, want)))
        self.target = (float(pts[j, 0]), float(pts[j, 1]))
        to_stop = float(self._s[end] - self._s[i]) + math.hypot(pts[i, 0] - x, pts[i, 1] - y)
        stopping = math.sqrt(2 * BRAKE_M_S2 * max(0.0, to_stop - self.done_m))
        if to_stop > self.done_m + CREEP_M:  # not yet at the end: no slower than the ESC keeps rolling
            stopping = max(MIN_SPEED_M_S, stopping)
        speed = min(self._bend_speed(i), stopping)
        return self._steer(x, y, yaw, self.target, int(path.direction[i]), speed, remaining)

    def _bend_speed(self, i: int) -> float:
        return bend_speed(self._s, self._kappa, i, self.max_speed_m_s)

    def entry_speed(self, path: Path) -> float:
        """[m/s] the fastest the car may enter path (at its first point) and still take its bends
        (a plan made at speed may begin with a bend only a slower car can follow)."""
        return bend_speed(*along_and_curvature(path), 0, self.max_speed_m_s)

    def brake_rather(self, path: Path, speed_m_s: float, shut_m: float, front_m: float) -> bool:
        """A cone seen late shut the way shut_m [m] ahead (along the old path) and `path` goes round
        it: whether braking costs less than taking it. Taking it costs the cone when the car is
        faster than its bends allow (entry_speed, ENTRY_SLACK_M_S of braking on the way allowed);
        braking costs a stop, and is chosen when the car's front (front_m ahead of its pose)
        stops short of the cone."""
        too_fast = speed_m_s > self.entry_speed(path) + ENTRY_SLACK_M_S
        return too_fast and speed_m_s ** 2 / (2 * BRAKE_M_S2) < shut_m - front_m

    def _steer(self, x: float, y: float, yaw: float, target, direction: int, speed: float,
               remaining: float = 0.0) -> Steer:
        if direction < 0:  # reversing: pursue in the car's frame turned round; the wheels turn the other way
            curvature = -PurePursuit.curvature(x, y, yaw + math.pi, target)
        else:
            curvature = PurePursuit.curvature(x, y, yaw, target)
        return Steer(self.state, curvature, direction, speed, (float(target[0]), float(target[1])), self.index,
                     remaining)


def along_and_curvature(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """([m] along the path at each point, [1/m] the size of its curvature there)."""
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path.poses[:, :2], axis=0), axis=1))])
    heading = np.unwrap(path.poses[:, 2])
    kappa = np.abs(np.gradient(heading, s)) if len(heading) > 1 and s[-1] > 0 else np.zeros(len(heading))
    return s, kappa


def bend_speed(s: np.ndarray, kappa: np.ndarray, i: int, max_speed_m_s: float) -> float:
    """[m/s] the fastest a car may be at point i of a path (s along it [m], curvature kappa [1/m])
    for the bends ahead: the tightest within BEND_WINDOW_M under LATERAL_M_S2 sideways, and every
    one further on reachable at its own speed braking at BRAKE_M_S2."""
    ahead = (s >= s[i]) & (s <= s[i] + max_speed_m_s ** 2 / (2 * BRAKE_M_S2) + BEND_WINDOW_M)
    near = s[ahead] <= s[i] + BEND_WINDOW_M
    bend = np.minimum(max_speed_m_s, np.sqrt(LATERAL_M_S2 / np.maximum(kappa[ahead], 1e-6)))
    window = float(bend[near].min()) if near.any() else max_speed_m_s
    braking = float(np.sqrt(bend ** 2 + 2 * BRAKE_M_S2 * (s[ahead] - s[i])).min()) if ahead.any() else window
    return min(window, braking)
