"""The lane-following agent: the car drives by its camera alone -- no pose, no map.

    perception  LanePerception: the camera frame -> lane lines in the car's frame (roar.vision)
    planning    LanePlanner: a goal point on the road's centre ahead, a speed from its curvature,
                and the ROAR lane states: following, one line lost (slower), both lost (slow,
                keep the last steering to search), lost too long (stop); with a depth camera,
                stop for an obstacle in the car's path (the ground-plane occupancy grid)
    control     LaneController: pure pursuit to the goal in the car's frame; the speed controller
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum

import numpy as np

from roar.autopilot.agent import Agent, Command, Module, Observation
from roar.autopilot.longitudinal import SpeedController
from roar.autopilot.race_agent import CarModel
from roar.vision.lanes import Lanes, LaneDetector

SEARCH_SPEED_M_S = 0.4  # [m/s] with both lines lost
SEARCH_S = 1.0  # [s] lost this long: stop
ONE_LINE_FACTOR = 0.8  # of the speed, with one edge only
# The camera sees about 2.5 m of road, and a curve's bend only as it comes into view: the driver
# looks little more than a metre ahead and keeps below what it could brake from out of sight.
LOOKAHEAD_S = 0.35  # [s] of travel to the goal point
MIN_LOOKAHEAD_M = 0.6  # [m]
MAX_LOOKAHEAD_M = 1.1  # [m]
MAX_SPEED_M_S = 2.2  # [m/s]


PATH_HALF_WIDTH_M = 0.25  # [m] the car's path: obstacles this close to its centre line are in the way
FRONT_M = 0.5  # [m] from the car's reference point to its front
STOP_MARGIN_M = 0.3  # [m] kept between the front and an obstacle
BRAKING_SHARE = 0.5  # of the car's braking, planned with (the ESC brakes through the reverse sequence)
CLEAR_S = 1.0  # [s] stopped for an obstacle: it must be out of the path this long to go on
STRAIGHT_REACH_M = 0.8  # [m] with no lane seen (in a bend, mostly) only what is right ahead of the front counts
HOLD_SPEED_M_S = 0.15  # [m/s] braking for an obstacle ends here (more would drive it backwards)


class LaneState(Enum):
    FOLLOWING = "following"
    ONE_LINE = "one line lost"
    SEARCHING = "both lost"
    STOPPED = "stopped"
    OBSTACLE = "obstacle ahead"


@dataclass(frozen=True)
class Seen:
    lanes: Lanes
    speed: float  # [m/s] the speedometer
    obstacle_m: float | None = None  # [m] ahead to the nearest occupied cell in the car's path


@dataclass(frozen=True)
class LanePlan:
    state: LaneState
    goal: tuple[float, float] | None  # [m] in the car's frame
    target_speed_m_s: float


class LanePerception(Module[Observation, Seen]):
    """camera() -> (RGB frame, metric depth or None); only the observation's speed is read (a
    speedometer). With depth_camera (the depth image's CameraModel), obstacles are looked for."""

    def __init__(self, camera: Callable[[], tuple], detector: LaneDetector, depth_camera=None) -> None:
        self.camera, self.detector, self.depth_camera = camera, detector, depth_camera

    def setup(self) -> None:
        self.detector.reset()

    def step(self, value: Observation) -> Seen:
        rgb, depth = self.camera()
        lanes = self.detector.detect(rgb)
        obstacle = None
        if depth is not None and self.depth_camera is not None:
            from roar.vision.occupancy import occupancy

            path, reach = None, STRAIGHT_REACH_M
            if lanes.centre is not None:  # along the lane it follows, as far as its lines were seen
                seen = [line.points[:, 0].max() for line in (lanes.yellow, lanes.left, lanes.right)
                        if line is not None and len(line.points)]
                path, reach = lanes.centre.y, max(seen, default=STRAIGHT_REACH_M)
            obstacle = occupancy(depth, self.depth_camera).nearest_ahead(PATH_HALF_WIDTH_M, path, reach)
        return Seen(lanes, value.speed, obstacle)


class LanePlanner(Module[Seen, LanePlan]):
    def __init__(self, car: CarModel, period_s: float, margin: float = 0.9, lookahead_s: float = LOOKAHEAD_S,
                 min_lookahead_m: float = MIN_LOOKAHEAD_M, max_lookahead_m: float = MAX_LOOKAHEAD_M,
                 max_speed_m_s: float = MAX_SPEED_M_S) -> None:
        self.car, self.period_s, self.margin, self.max_speed_m_s = car, period_s, margin, max_speed_m_s
        self.lookahead_s, self.min_lookahead_m, self.max_lookahead_m = lookahead_s, min_lookahead_m, max_lookahead_m
        self.lost_s = 0.0
        self._last_goal: tuple[float, float] | None = None
        self._clear_s: float | None = None  # stopped for an obstacle: how long the path has been clear

    def setup(self) -> None:
        self.lost_s, self._last_goal, self._clear_s = 0.0, None, None

    def _blocked(self, value: Seen, limits) -> bool:
        """Stop for an obstacle within braking distance; once stopped, stay until the path has
        been clear for CLEAR_S (close up, the obstacle may hide below the camera's view)."""
        if self._clear_s is not None:
            self._clear_s = 0.0 if value.obstacle_m is not None else self._clear_s + self.period_s
            if self._clear_s < CLEAR_S:
                return True
            self._clear_s = None
        if value.obstacle_m is None:
            return False
        braking_m = value.speed ** 2 / (2 * BRAKING_SHARE * limits.max_brake_m_s2)
        if value.obstacle_m - FRONT_M < braking_m + STOP_MARGIN_M:
            self._clear_s = 0.0
            return True
        return False

    def step(self, value: Seen) -> LanePlan:
        lanes, limits = value.lanes, self.car.limits.with_margin(self.margin)
        if self._blocked(value, limits):  # before anything else: the obstacle may hide the lines
            return LanePlan(LaneState.OBSTACLE, self._last_goal, 0.0)
        if lanes.centre is None:
            self.lost_s += self.period_s
            if self.lost_s > SEARCH_S:
                return LanePlan(LaneState.STOPPED, None, 0.0)
            return LanePlan(LaneState.SEARCHING, self._last_goal, SEARCH_SPEED_M_S)
        self.lost_s = 0.0
        lookahead = min(self.max_lookahead_m, max(self.min_lookahead_m, self.lookahead_s * value.speed))
        goal = (lookahead, float(lanes.centre.y(lookahead)))
        self._last_goal = goal
        xs = np.linspace(0.5, 2.0, 7)
        a, b, _ = lanes.centre.coeffs
        slope = 2 * a * xs + b
        curvature = float(np.max(np.abs(2 * a) / (1 + slope ** 2) ** 1.5))
        speed = min(self.max_speed_m_s, limits.max_speed_m_s, math.sqrt(limits.max_lateral_m_s2 / max(curvature, 1e-3)))
        state = LaneState.FOLLOWING if lanes.source in ("yellow", "edges") else LaneState.ONE_LINE
        if state is LaneState.ONE_LINE:
            speed *= ONE_LINE_FACTOR
        if value.obstacle_m is not None:  # no faster than it can still stop short of it
            room = max(0.0, value.obstacle_m - FRONT_M - STOP_MARGIN_M)
            speed = min(speed, math.sqrt(2 * BRAKING_SHARE * limits.max_brake_m_s2 * room))
        return LanePlan(state, goal, speed)


class LaneController(Module[tuple[Seen, LanePlan], Command]):
    def __init__(self, car: CarModel, speed: SpeedController, period_s: float) -> None:
        self.car, self.speed, self.period_s = car, speed, period_s

    def setup(self) -> None:
        self.speed.reset()

    def step(self, value: tuple[Seen, LanePlan]) -> Command:
        seen, plan = value
        if plan.state is LaneState.OBSTACLE:  # full brake (reverse torque) until nearly still, then neutral
            self.speed.reset()
            return Command(-1.0 if seen.speed > HOLD_SPEED_M_S else 0.0, 0.0)
        if plan.state is LaneState.STOPPED or plan.goal is None:
            return Command(self.speed.step(0.0, seen.speed, self.period_s), 0.0)
        gx, gy = plan.goal
        angle = math.atan2(2 * self.car.wheelbase_m * gy, gx * gx + gy * gy)  # pure pursuit, car frame
        steering = max(-1.0, min(1.0, -angle / self.car.max_steer_rad))  # left angle = negative command
        return Command(self.speed.step(plan.target_speed_m_s, seen.speed, self.period_s), steering)


def lane_agent(camera: Callable[[], tuple], detector: LaneDetector, car: CarModel, period_s: float,
               margin: float = 0.9, depth_camera=None) -> Agent:
    """An agent that follows the road's centre by camera at `margin` of the car's grip; camera()
    gives (RGB, depth or None), and with depth_camera it stops for obstacles in its path."""
    return Agent(LanePerception(camera, detector, depth_camera), LanePlanner(car, period_s, margin),
                 LaneController(car, SpeedController(car.limits.max_speed_m_s), period_s))
