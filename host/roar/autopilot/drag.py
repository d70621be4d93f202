"""The IARRC drag race's driver: a straight lane run flat out, then a hard stop before the wall.

The IARRC car's report: the lane by camera, the gyro "securing a straight ride" as a guard on the
vision system, and the laser distance sensor for braking hard before the end.

    perception  DragPerception: the camera frame -> lane lines (roar.vision); the gyro's yaw rate
                integrated into a heading; the laser's range ahead
    planning    DragPlanner: while the lane fit is sure, steer to the lane's centre ahead and learn
                the strip's direction in the gyro's frame (heading less the car's angle to the
                lane); while it is not (a blanked or glaring frame, a line out of view), hold that
                heading by the gyro alone. Flat out until the laser's range is what stopping from
                this speed needs, then brake to a stop and stay stopped; a reading taken while
                the car points so far off the strip's direction that the beam would meet a side
                wall first is not the end.
    control     DragController: pure pursuit to the goal, plus the steering that keeps the car
                straight, learnt while the lane is sure (its integral: a servo is never quite
                centred, and the heading hold must not drift by its offset); the speed as a
                setpoint (the car's own PID holds it and brakes for zero)
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum

from roar.autopilot.agent import Agent, Command, Module, Observation
from roar.autopilot.pure_pursuit import PurePursuit
from roar.autopilot.race_agent import CarModel
from roar.vision.lanes import Lanes, LaneDetector

SURE = 0.5  # share of the detector's bands a line must be found in for the lane to steer by
LOOKAHEAD_S = 0.4  # [s] of travel to the goal point
MIN_LOOKAHEAD_M, MAX_LOOKAHEAD_M = 0.8, 1.6  # [m]
AXIS_WEIGHT = 0.05  # of a sure frame's strip direction in the one kept (the gyro drifts slowly)
LATENCY_S = 0.1  # [s] from a range reading to the car braking: a control period, the PID's reaction
STOP_MARGIN_M = 0.6  # [m] planned between the nose and the end wall when stopped
STILL_M_S = 0.05  # [m/s] braking ends (stopped) below this
BEAM_HALF_RAD = math.radians(2.3) / 2  # [rad] half the TFmini's cone: its edge meets a side wall first
SIDE_MARGIN_M = 0.2  # [m] kept off the edge line by the beam, for a reading to be the end (the car drifts unseen meanwhile)
CONFIRM = 3  # control periods in a row the laser must say "stop now" (a glimpse of a side wall in a swerve does not)
TRIM_GAIN = 1.0  # [1/s] the straight-ahead steering learnt per second per rad of pure pursuit's correction
MAX_TRIM_RAD = 0.1  # [rad] the most steering that may be learnt as straight ahead
LEARN_SPEED_M_S = 0.5  # [m/s] slower than this, nothing is learnt


class DragState(Enum):
    LANE = "following the lane"
    HOLD = "holding the heading by the gyro"
    BRAKE = "braking for the end"
    STOPPED = "stopped"


@dataclass(frozen=True)
class DragSeen:
    lanes: Lanes
    speed: float  # [m/s] the encoder's
    heading_rad: float  # [rad] the gyro's yaw rate integrated since the start
    range_m: float | None  # [m] the laser's reading from the nose (None: nothing in range)
    half_width_m: float  # [m] the lane's centre to an edge line, as the detector measured it


@dataclass(frozen=True)
class DragPlan:
    state: DragState
    goal: tuple[float, float]  # [m] in the car's frame
    target_speed_m_s: float


def lane_is_sure(lanes: Lanes) -> bool:
    """Whether the lane fit can steer: a centre found from the yellow line or both edges, each
    line it came from seen in at least SURE of the bands."""
    if lanes.near is None or lanes.source not in ("yellow", "edges"):
        return False
    used = [lanes.yellow] if lanes.source == "yellow" else [lanes.left, lanes.right]
    return all(line is not None and line.confidence >= SURE for line in used)


class DragPerception(Module[Observation, DragSeen]):
    def __init__(self, camera: Callable[[], tuple], detector: LaneDetector, laser: Callable[[], float | None],
                 period_s: float) -> None:
        self.camera, self.detector, self.laser, self.period_s = camera, detector, laser, period_s
        self.heading_rad = 0.0

    def setup(self) -> None:
        self.detector.reset()
        self.heading_rad = 0.0

    def step(self, value: Observation) -> DragSeen:
        rgb, _ = self.camera()
        self.heading_rad += (value.yaw_rate or 0.0) * self.period_s
        lanes = self.detector.detect(rgb)
        return DragSeen(lanes, value.speed, self.heading_rad, self.laser(), self.detector.half_width_m)


class DragPlanner(Module[DragSeen, DragPlan]):
    """top_speed_m_s: the run's speed; brake_m_s2: the deceleration it plans the stop with;
    period_s: the control period."""

    def __init__(self, top_speed_m_s: float, brake_m_s2: float, period_s: float) -> None:
        self.top_speed_m_s, self.brake_m_s2, self.period_s = top_speed_m_s, brake_m_s2, period_s
        self.state = DragState.LANE
        self.axis_rad: float | None = None  # [rad] the strip's direction in the gyro's frame
        self._stop_calls = 0  # control periods in a row the laser has said "stop now"
        self.offset_m = 0.0  # [m] the car left of the lane's centre, when the lane was last sure

    def setup(self) -> None:
        self.state, self.axis_rad, self._stop_calls, self.offset_m = DragState.LANE, None, 0, 0.0

    def stopping_m(self, speed: float) -> float:
        """[m] of range the car needs to stop from `speed` with STOP_MARGIN_M to spare (the
        reading confirmed CONFIRM times first)."""
        delay_s = LATENCY_S + (CONFIRM - 1) * self.period_s
        return speed * delay_s + speed * speed / (2 * self.brake_m_s2) + STOP_MARGIN_M

    def _end_ahead(self, value: DragSeen) -> bool:
        """Whether the laser's reading can be the end of the strip: turned from the strip's
        direction (a bump, a swerve), its beam meets a side wall, nearer than the end; it is
        the end only where the beam is still inside the lane at that range."""
        if value.range_m is None:
            return False
        turned = 0.0 if self.axis_rad is None else abs(_wrapped(value.heading_rad - self.axis_rad))
        offset = abs(value.lanes.offset_m) if value.lanes.offset_m is not None else abs(self.offset_m)
        return value.range_m * math.sin(turned + BEAM_HALF_RAD) < value.half_width_m - offset - SIDE_MARGIN_M

    def step(self, value: DragSeen) -> DragPlan:
        ahead = min(MAX_LOOKAHEAD_M, max(MIN_LOOKAHEAD_M, LOOKAHEAD_S * value.speed))
        sure = lane_is_sure(value.lanes)
        if sure:
            direction = value.heading_rad - value.lanes.heading_rad
            self.axis_rad = direction if self.axis_rad is None else \
                self.axis_rad + AXIS_WEIGHT * _wrapped(direction - self.axis_rad)
            goal = (ahead, float(value.lanes.centre.y(ahead)))
            self.offset_m = value.lanes.offset_m
        else:  # along the strip's direction, as the gyro knows it (straight ahead before any)
            error = 0.0 if self.axis_rad is None else _wrapped(self.axis_rad - value.heading_rad)
            goal = (ahead * math.cos(error), ahead * math.sin(error))
        if self.state in (DragState.BRAKE, DragState.STOPPED):
            if value.speed < STILL_M_S:
                self.state = DragState.STOPPED
            return DragPlan(self.state, goal, 0.0)
        stop_now = self._end_ahead(value) and value.range_m <= self.stopping_m(value.speed)
        self._stop_calls = self._stop_calls + 1 if stop_now else 0
        if self._stop_calls >= CONFIRM:
            self.state = DragState.BRAKE
            return DragPlan(self.state, goal, 0.0)
        self.state = DragState.LANE if sure else DragState.HOLD
        return DragPlan(self.state, goal, self.top_speed_m_s)


class DragController(Module[tuple[DragSeen, DragPlan], Command]):
    """Pure pursuit to the goal plus the learnt straight-ahead steering; the target speed as a
    setpoint of full_scale_m_s (a command's throttle of 1 asks the car for it)."""

    def __init__(self, car: CarModel, full_scale_m_s: float, period_s: float) -> None:
        self.car, self.full_scale_m_s, self.period_s = car, full_scale_m_s, period_s
        self.trim_rad = 0.0  # [rad] the steering that keeps the car straight, left +

    def setup(self) -> None:
        self.trim_rad = 0.0

    def step(self, value: tuple[DragSeen, DragPlan]) -> Command:
        seen, plan = value
        correction = math.atan(self.car.wheelbase_m * PurePursuit.curvature(0.0, 0.0, 0.0, plan.goal))  # car frame
        if plan.state is DragState.LANE and seen.speed >= LEARN_SPEED_M_S:
            self.trim_rad = max(-MAX_TRIM_RAD, min(MAX_TRIM_RAD, self.trim_rad + TRIM_GAIN * correction * self.period_s))
        angle = correction + self.trim_rad
        steering = max(-1.0, min(1.0, -angle / self.car.max_steer_rad))  # left angle = negative command
        return Command(max(0.0, min(1.0, plan.target_speed_m_s / self.full_scale_m_s)), steering)


def drag_agent(camera: Callable[[], tuple], detector: LaneDetector, laser: Callable[[], float | None],
               car: CarModel, period_s: float, top_speed_m_s: float, full_scale_m_s: float,
               brake_m_s2: float | None = None) -> Agent:
    """The drag race's driver for a car that holds a speed setpoint itself (the IARRC car):
    camera() -> (RGB, depth or None), laser() -> [m] ahead of the nose or None; it plans its stop
    with brake_m_s2 (default: the car's measured braking)."""
    brake = brake_m_s2 if brake_m_s2 is not None else car.limits.max_brake_m_s2
    return Agent(DragPerception(camera, detector, laser, period_s), DragPlanner(top_speed_m_s, brake, period_s),
                 DragController(car, full_scale_m_s, period_s))


def _wrapped(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi
