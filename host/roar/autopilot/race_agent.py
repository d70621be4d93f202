"""The racing agent: follow a closed line of waypoints with pure pursuit at the speed the
line's curvature allows.

    perception  Passthrough: the car reports its pose and speed
    planning    LoopWaypointFollower -> goal point l_d ahead + target speed from the profile
    control     PurePursuit -> steering; SpeedController (PID, brakes through the FSM) -> throttle
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from roar.autopilot.agent import Agent, Command, Module, Observation, Passthrough
from roar.autopilot.longitudinal import SpeedController
from roar.autopilot.pure_pursuit import PurePursuit, goal_on_path
from roar.autopilot.speed_profile import CarLimits, speed_profile
from roar.autopilot.waypoints import LoopWaypointFollower


@dataclass(frozen=True)
class CarModel:
    wheelbase_m: float  # [m]
    max_steer_rad: float  # [rad] front-wheel angle at steering = +-1
    limits: CarLimits


@dataclass(frozen=True)
class Plan:
    index: int  # next waypoint
    goal: tuple[float, float]  # [m] pure-pursuit goal point
    target_speed_m_s: float  # [m/s]


class RacePlanner(Module[Observation, Plan]):
    def __init__(self, points: np.ndarray, speeds: np.ndarray, follower: LoopWaypointFollower,
                 pursuit: PurePursuit, preview_s: float = 0.3) -> None:
        self.points, self.speeds, self.follower, self.pursuit = points, speeds, follower, pursuit
        self.preview_s = preview_s  # [s] look ahead on the speed profile: the car needs time to respond
        self.spacing_m = float(np.mean(np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1)))

    def setup(self) -> None:
        self.follower.setup()

    def step(self, value: Observation) -> Plan:
        i = self.follower.step(value)
        goal = goal_on_path(self.points, i, self.pursuit.lookahead_m(value.speed))
        ahead = int(math.ceil(self.preview_s * max(value.speed, 0.5) / self.spacing_m))
        window = self.speeds[(np.arange(i, i + ahead + 1)) % len(self.speeds)]
        return Plan(i, goal, float(window.min()))


class RaceController(Module[tuple[Observation, Plan], Command]):
    def __init__(self, car: CarModel, pursuit: PurePursuit, speed: SpeedController, period_s: float) -> None:
        self.car, self.pursuit, self.speed, self.period_s = car, pursuit, speed, period_s

    def setup(self) -> None:
        self.speed.reset()

    def step(self, value: tuple[Observation, Plan]) -> Command:
        obs, plan = value
        angle = self.pursuit.steering_angle(obs.x, obs.y, obs.yaw, plan.goal)
        steering = max(-1.0, min(1.0, -angle / self.car.max_steer_rad))  # left angle = negative command
        throttle = self.speed.step(plan.target_speed_m_s, obs.speed, self.period_s)
        return Command(throttle, steering)


def race_agent(points: np.ndarray, car: CarModel, period_s: float, margin: float = 0.9,
               pursuit: PurePursuit | None = None, follower: LoopWaypointFollower | None = None) -> Agent:
    """An agent that laps `points` (a closed line, (N, 2+)) at `margin` of the car's limits."""
    xy = np.asarray(points, dtype=float)[:, :2]
    pursuit = pursuit or PurePursuit(car.wheelbase_m)
    follower = follower or LoopWaypointFollower(xy)
    speeds = speed_profile(xy, car.limits.with_margin(margin))
    planner = RacePlanner(xy, speeds, follower, pursuit)
    controller = RaceController(car, pursuit, SpeedController(car.limits.max_speed_m_s), period_s)
    return Agent(Passthrough(), planner, controller)
