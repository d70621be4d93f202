"""The racing agent: follow a closed line of waypoints with pure pursuit at the speed the
line's curvature allows.

    perception  Passthrough: the car reports its pose and speed
    planning    LoopWaypointFollower -> goal point l_d ahead + target speed from the profile
    control     PurePursuit -> curvature; CurvatureTracker (the gyro) -> steering;
                SpeedController (PID, brakes through the FSM) -> throttle
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from roar.autopilot.agent import Agent, Command, Module, Observation, Passthrough
from roar.autopilot.curvature_tracking import CurvatureTracker
from roar.autopilot.longitudinal import SpeedController, SpeedSetpoint
from roar.autopilot.pid import PID
from roar.autopilot.pure_pursuit import PurePursuit, goal_on_path
from roar.autopilot.speed_profile import CarLimits, speed_profile
from roar.autopilot.waypoints import LoopWaypointFollower


@dataclass(frozen=True)
class CarModel:
    wheelbase_m: float  # [m]
    max_steer_rad: float  # [rad] front-wheel angle at steering = +-1
    limits: CarLimits

    @property
    def min_turn_radius_m(self) -> float:
        """[m] the tightest circle it can drive: at full steering, wheelbase / tan(angle)."""
        return self.wheelbase_m / math.tan(self.max_steer_rad)


@dataclass(frozen=True)
class DiffDriveModel:
    """A robot steered by its two wheels' speeds (the ROAR Junior)."""

    track_width_m: float  # [m] between the wheels' contact points
    limits: CarLimits
    min_turn_radius_m: float = 0.0  # [m] it turns on the spot


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


class HeadingController:
    """Lateral PID: steer to turn the heading error to the goal point to zero (the seed's
    lateral PID), an alternative to pure pursuit's geometry."""

    def __init__(self, max_steer_rad: float, kp: float = 1.2, ki: float = 0.0, kd: float = 0.08) -> None:
        self.pid = PID(kp=kp, ki=ki, kd=kd, out_min=-max_steer_rad, out_max=max_steer_rad)

    def reset(self) -> None:
        self.pid.reset()

    def steering_angle(self, obs: Observation, goal: tuple[float, float], dt_s: float) -> float:
        """[rad] left positive."""
        error = math.atan2(goal[1] - obs.y, goal[0] - obs.x) - obs.yaw
        error = (error + math.pi) % (2 * math.pi) - math.pi
        return self.pid.step(error, dt_s)


class RaceController(Module[tuple[Observation, Plan], Command]):
    """Steering from pure pursuit (default) or the heading PID; throttle from the speed controller.
    Pure pursuit's curvature goes through `tracker` (default: a CurvatureTracker; None: steer by
    the kinematic bicycle alone), which adds what the gyro says the car turns short of it."""

    def __init__(self, car: CarModel, pursuit: PurePursuit, speed: SpeedController | SpeedSetpoint, period_s: float,
                 heading: HeadingController | None = None, tracker: CurvatureTracker | None = None) -> None:
        self.car, self.pursuit, self.speed, self.period_s, self.heading = car, pursuit, speed, period_s, heading
        self.tracker = tracker

    def setup(self) -> None:
        self.speed.reset()
        if self.heading is not None:
            self.heading.reset()
        if self.tracker is not None:
            self.tracker.reset()

    def step(self, value: tuple[Observation, Plan]) -> Command:
        obs, plan = value
        if self.heading is not None:
            angle = self.heading.steering_angle(obs, plan.goal, self.period_s)
        else:
            asked = self.pursuit.curvature(obs.x, obs.y, obs.yaw, plan.goal)
            if self.tracker is not None:
                asked = self.tracker.step(asked, obs.speed, obs.yaw_rate, self.period_s)
            angle = math.atan(self.car.wheelbase_m * asked)
        steering = max(-1.0, min(1.0, -angle / self.car.max_steer_rad))  # left angle = negative command
        throttle = self.speed.step(plan.target_speed_m_s, obs.speed, self.period_s)
        if self.tracker is not None and throttle > 0:
            # the tyres slide: less drive, none in a full slide (a wheel spun up takes the grip the
            # bend needs), as a driver lifts off
            throttle *= self.tracker.drive_share
        return Command(throttle, steering)


def race_agent(points: np.ndarray, car: CarModel, period_s: float, margin: float = 0.9,
               pursuit: PurePursuit | None = None, follower: LoopWaypointFollower | None = None,
               lateral: str = "pursuit", speed: SpeedController | SpeedSetpoint | None = None) -> Agent:
    """An agent that laps `points` (a closed line, (N, 2+)) at `margin` of the car's grip,
    steering by pure pursuit or, with lateral="pid", by the heading PID; its throttle from
    `speed` (default: a SpeedController for a car whose ESC has no brake; a SpeedSetpoint for a
    car that holds a speed itself)."""
    if lateral not in ("pursuit", "pid"):
        raise ValueError(f"lateral must be 'pursuit' or 'pid', got {lateral!r}")
    xy = np.asarray(points, dtype=float)[:, :2]
    pursuit = pursuit or PurePursuit(car.wheelbase_m)
    follower = follower or LoopWaypointFollower(xy)
    speeds = speed_profile(xy, car.limits.with_margin(margin))
    planner = RacePlanner(xy, speeds, follower, pursuit)
    heading = HeadingController(car.max_steer_rad) if lateral == "pid" else None
    speed = speed or SpeedController(car.limits.max_speed_m_s, max_reverse=car.limits.max_reverse)
    tracker = CurvatureTracker() if lateral == "pursuit" else None
    controller = RaceController(car, pursuit, speed, period_s, heading, tracker)
    return Agent(Passthrough(), planner, controller)


class DiffDriveController(Module[tuple[Observation, Plan], Command]):
    """Pure pursuit's curvature kappa as wheel speeds v (1 -/+ kappa b / 2), sent as the Command
    that roar.junior.smooth_mix turns back into those wheel duties: throttle v / v_max (feed-forward
    plus a proportional correction on the measured speed), steering -kappa b / 2."""

    def __init__(self, robot: DiffDriveModel, kp: float = 0.8) -> None:
        self.robot, self.kp = robot, kp

    def step(self, value: tuple[Observation, Plan]) -> Command:
        obs, plan = value
        kappa = PurePursuit.curvature(obs.x, obs.y, obs.yaw, plan.goal)
        v_max = self.robot.limits.max_speed_m_s
        throttle = plan.target_speed_m_s / v_max + self.kp * (plan.target_speed_m_s - obs.speed) / v_max
        steering = -kappa * self.robot.track_width_m / 2
        return Command(max(0.02, min(1.0, throttle)), max(-1.0, min(1.0, steering)))


def diff_drive_agent(points: np.ndarray, robot: DiffDriveModel, margin: float = 0.9,
                     pursuit: PurePursuit | None = None, k_dd_s: float = 0.5) -> Agent:
    """An agent that laps `points` with a differential-drive robot at `margin` of its limits
    (pure pursuit's look-ahead k_dd_s [s] per m/s, unless `pursuit` is given)."""
    xy = np.asarray(points, dtype=float)[:, :2]
    pursuit = pursuit or PurePursuit(wheelbase_m=robot.track_width_m, k_dd_s=k_dd_s, min_lookahead_m=0.35)
    speeds = speed_profile(xy, robot.limits.with_margin(margin))
    planner = RacePlanner(xy, speeds, LoopWaypointFollower(xy), pursuit)
    return Agent(Passthrough(), planner, DiffDriveController(robot))
