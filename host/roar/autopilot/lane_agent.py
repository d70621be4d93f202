"""The lane-following agent: the car drives by its camera alone -- no pose, no map.

    perception  LanePerception: the camera frame -> lane lines in the car's frame (roar.vision);
                with start lights, whether they have turned green; with a TFmini, its range
    planning    LanePlanner: wait for green; a goal point on the road's centre ahead, a speed
                from its curvature, and the ROAR lane states: following, one line lost (slower),
                both lost (slow, keep the last steering to search), lost too long (stop); with a
                depth camera, stop for an obstacle in the car's path (the ground-plane occupancy
                grid); with a TFmini, the IARRC rule: keep to one lane, and switch to the other
                when the laser finds something ahead in this one; with a leader (ROAR's combined
                driver), keep the gap to it while it is ahead in the lane kept, instead of
                passing it
    control     LaneController: pure pursuit to the goal in the car's frame; the speed controller
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum

from roar.autopilot.agent import Agent, Command, Module, Observation
from roar.autopilot.longitudinal import SpeedController
from roar.autopilot.pure_pursuit import PurePursuit
from roar.autopilot.race_agent import CarModel
from roar.vision.lanes import Lanes, LaneDetector
from roar.vision.occupancy import Occupancy, occupancy
from roar.vision.start_lights import StartLightDetector

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

LANE_OFFSET_M = 0.25  # [m] a lane's middle from the road's centre (the edges are a half-width out)
SWITCH_M = 2.0  # [m] ahead of the nose: something this close in the car's lane makes it change lanes
LANE_BAND_M = 0.12  # [m] something this close to the kept lane's middle is in it (a wall is 0.35 m out)
LANE_PATH_HALF_M = 0.18  # [m] keeping to a lane, obstacles this close to its middle are in the way
AVOID_MAX_SPEED_M_S = 1.3  # [m/s] keeping to a lane, with lane changes to make
SWITCH_HOLD_S = 1.0  # [s] after a lane change, no other for this long
# A lane change is a ramp laid ahead of the car: the followed line moves across SHIFT_SLOPE metres
# per metre along (a lane, 0.5 m, in 2.5 m: ~11 degrees). Planned on distance, not time, the swerve
# is as gentle slow as fast, the goal point rides the ramp, and what stands where the car will no
# longer be -- the box it changes lanes for -- is not in its path (it no longer stops for it). On
# the course, 0.2 keeps the car 14 cm off the walls under either renderer; 0.3 overshot the new
# lane by 10 cm and left 2 cm.
SHIFT_SLOPE = 0.2  # [m/m] across per metre along
CREEP_M_S = 0.5  # [m/s] stopped or crawling, the ramp still advances as if the car moved this fast
FOLLOW_RANGE_M = 4.0  # [m] a leader ahead in the lane kept, this close (reference points, along the road), is followed
FOLLOW_GAP_M = 2.0  # [m] kept to a leader (its rear 1.5 m from the camera: the lines beside it stay in view)
FOLLOW_GAIN_PER_S = 1.0  # [1/s] m/s of speed per metre of gap error
IN_LANE_M = LANE_OFFSET_M  # [m] a leader nearer the middle of the lane kept than the other lane's is in it


class LaneState(Enum):
    WAITING = "waiting for green"
    FOLLOWING = "following"
    CHANGING = "changing lanes"
    BEHIND_LEADER = "keeping the gap to the leader"
    ONE_LINE = "one line lost"
    SEARCHING = "both lost"
    STOPPED = "lines lost too long"
    OBSTACLE = "obstacle ahead"


@dataclass(frozen=True)
class Seen:
    lanes: Lanes
    speed: float  # [m/s] the speedometer
    grid: Occupancy | None = None  # from the depth image, when there is one
    go: bool = True  # False while start lights have not turned green
    laser_m: float | None = None  # [m] the TFmini's reading from the car's nose (None: nothing in range)
    leader: Leader | None = None  # where the leader is (None: none heard)


@dataclass(frozen=True)
class Leader:
    """A lead car as the follower knows it (V2V positions on a map): how far ahead along the road,
    how far left of the road's centre, and how fast."""

    ahead_m: float  # [m] reference point to reference point, along the road
    left_m: float  # [m] of the road's centre line
    speed: float  # [m/s]


@dataclass(frozen=True)
class LanePlan:
    state: LaneState
    goal: tuple[float, float] | None  # [m] in the car's frame
    target_speed_m_s: float


class LanePerception(Module[Observation, Seen]):
    """camera() -> (RGB frame, metric depth or None); only the observation's speed is read (a
    speedometer). With depth_camera (the depth image's CameraModel), the floor's occupancy is
    mapped; with start (a StartLightDetector), the lights are watched; laser() -> the TFmini's
    reading [m] or None."""

    def __init__(self, camera: Callable[[], tuple], detector: LaneDetector, depth_camera=None,
                 start: StartLightDetector | None = None, laser: Callable[[], float | None] | None = None,
                 leader: Callable[[Observation], Leader | None] | None = None) -> None:
        self.camera, self.detector, self.depth_camera, self.start = camera, detector, depth_camera, start
        self.laser, self.leader = laser, leader

    def setup(self) -> None:
        self.detector.reset()
        if self.start is not None:
            self.start.reset()

    def step(self, value: Observation) -> Seen:
        rgb, depth = self.camera()
        go = self.start is None or self.start.update(rgb)
        lanes = self.detector.detect(rgb)
        grid = occupancy(depth, self.depth_camera) if depth is not None and self.depth_camera is not None else None
        return Seen(lanes, value.speed, grid, go, self.laser() if self.laser is not None else None,
                    self.leader(value) if self.leader is not None else None)


class LanePlanner(Module[Seen, LanePlan]):
    def __init__(self, car: CarModel, period_s: float, margin: float = 0.9, lookahead_s: float = LOOKAHEAD_S,
                 min_lookahead_m: float = MIN_LOOKAHEAD_M, max_lookahead_m: float = MAX_LOOKAHEAD_M,
                 max_speed_m_s: float = MAX_SPEED_M_S, keep_lane: bool = False) -> None:
        self.car, self.period_s, self.margin = car, period_s, margin
        self.max_speed_m_s = min(max_speed_m_s, AVOID_MAX_SPEED_M_S) if keep_lane else max_speed_m_s
        self.lookahead_s, self.min_lookahead_m, self.max_lookahead_m = lookahead_s, min_lookahead_m, max_lookahead_m
        self.keep_lane = keep_lane
        self.setup()

    def setup(self) -> None:
        self.state = LaneState.FOLLOWING
        self.lost_s = 0.0
        self._last_goal: tuple[float, float] | None = None
        self._clear_s: float | None = None  # stopped for an obstacle: how long the path has been clear
        self._stopped_for_m: float | None = None  # [m] stopped for an obstacle: how far ahead it was
        self.side = -1 if self.keep_lane else 0  # the lane kept: -1 right, +1 left, 0 the road's centre
        self.offset_m = self.side * LANE_OFFSET_M  # [m] the followed line from the road's centre, moving to side's
        self.switches = 0  # lane changes for obstacles
        self._since_switch_s = SWITCH_HOLD_S  # [s] since the last lane change

    def _path(self, lanes: Lanes, kept_lane: bool = False):
        """(y(x) of the line the car follows -- with kept_lane, the middle of the lane it keeps to,
        not the ramp there -- and how far ahead it is known [m])."""
        if lanes.centre is None:
            return None, STRAIGHT_REACH_M
        seen = [line.points[:, 0].max() for line in (lanes.yellow, lanes.left, lanes.right)
                if line is not None and len(line.points)]
        offset = (lambda x: self.side * LANE_OFFSET_M) if kept_lane else self._offset_at
        return (lambda x: lanes.centre.y(x) + offset(x)), max(seen, default=STRAIGHT_REACH_M)

    def _offset_at(self, x_m: float) -> float:
        """[m] the followed line from the road's centre x_m ahead: the lane change's ramp."""
        left, reach = self.side * LANE_OFFSET_M - self.offset_m, SHIFT_SLOPE * max(0.0, x_m)
        return self.offset_m + max(-reach, min(reach, left))

    def _obstacle_m(self, value: Seen, half_width_m: float | None = None, kept_lane: bool = False) -> float | None:
        """[m] to the nearest occupied cell on the car's path, as far as the lane was seen (with
        no lane seen, in a bend mostly, only what is right ahead of the front counts); stopped
        for an obstacle, at least as far as it was (it may hide the lines beyond it)."""
        if value.grid is None:
            return None
        path, reach = self._path(value.lanes, kept_lane)
        if self._stopped_for_m is not None:
            reach = max(reach, self._stopped_for_m + STOP_MARGIN_M)
        if half_width_m is None:
            half_width_m = LANE_PATH_HALF_M if self.keep_lane else PATH_HALF_WIDTH_M
        # things in the road, not the walls beside it (across a bend the outer wall fills the view)
        return value.grid.nearest_ahead(half_width_m, path, reach, things_only=True)

    def _leader_ahead(self, value: Seen) -> Leader | None:
        """The leader, when it is ahead in the lane kept within FOLLOW_RANGE_M."""
        leader = value.leader
        if leader is None or not 0.0 < leader.ahead_m <= FOLLOW_RANGE_M:
            return None
        return leader if abs(leader.left_m - self.side * LANE_OFFSET_M) <= IN_LANE_M else None

    def _switch_lanes(self, value: Seen) -> None:
        """The IARRC rule: something ahead within SWITCH_M in the lane the car keeps to sends it
        to the other lane -- what the laser hits within LANE_BAND_M of the lane's middle (as the
        camera sees the road there), or, where the laser looks past it (leaving a bend), what
        the depth camera finds on the lane's path. Not again within SWITCH_HOLD_S: an obstacle
        in both lanes is one to stop for."""
        self._since_switch_s += self.period_s
        centre = value.lanes.centre
        if not self.keep_lane or centre is None or self._since_switch_s < SWITCH_HOLD_S:
            return
        if self._leader_ahead(value) is not None:  # what is ahead is the leader: follow it, do not pass it
            return
        by_laser = False
        if value.laser_m is not None and value.laser_m <= SWITCH_M:
            lane_middle = float(centre.y(FRONT_M + value.laser_m)) + self.side * LANE_OFFSET_M
            by_laser = abs(lane_middle) <= LANE_BAND_M  # the hit is straight ahead of the car, at y = 0
        by_depth = self._obstacle_m(value, LANE_BAND_M, kept_lane=True)
        if by_laser or (by_depth is not None and by_depth - FRONT_M <= SWITCH_M):
            self.side, self.switches, self._since_switch_s = -self.side, self.switches + 1, 0.0

    def _blocked(self, obstacle_m: float | None, speed: float, limits) -> bool:
        """Stop for an obstacle within braking distance; once stopped, stay until the path has
        been clear for CLEAR_S (close up, the obstacle may hide below the camera's view)."""
        if self._clear_s is not None:
            self._clear_s = 0.0 if obstacle_m is not None else self._clear_s + self.period_s
            if self._clear_s < CLEAR_S:
                return True
            self._clear_s = self._stopped_for_m = None
        if obstacle_m is None:
            return False
        braking_m = speed ** 2 / (2 * BRAKING_SHARE * limits.max_brake_m_s2)
        if obstacle_m - FRONT_M < braking_m + STOP_MARGIN_M:
            self._clear_s, self._stopped_for_m = 0.0, obstacle_m
            return True
        return False

    def step(self, value: Seen) -> LanePlan:
        plan = self._plan(value)
        self.state = plan.state  # what the driver does now, for whoever reports the run
        return plan

    def _plan(self, value: Seen) -> LanePlan:
        lanes, limits = value.lanes, self.car.limits.with_margin(self.margin)
        if not value.go:
            return LanePlan(LaneState.WAITING, None, 0.0)
        self._switch_lanes(value)
        self.offset_m = self._offset_at(max(value.speed, CREEP_M_S) * self.period_s)  # along the ramp as it moves
        if lanes.centre is not None:
            lookahead = min(self.max_lookahead_m, max(self.min_lookahead_m, self.lookahead_s * value.speed))
            seen_from = _nearest_seen(lanes)
            if seen_from is not None:  # not nearer than the line was seen: a fit holds where its points are
                lookahead = max(lookahead, min(seen_from, 2 * self.max_lookahead_m))
            self._last_goal = (lookahead, float(lanes.centre.y(lookahead)) + self._offset_at(lookahead))
        goal = self._last_goal
        obstacle_m = self._obstacle_m(value)
        if self._blocked(obstacle_m, value.speed, limits):  # before anything else: it may hide the lines
            return LanePlan(LaneState.OBSTACLE, goal, 0.0)
        if lanes.centre is None:
            self.lost_s += self.period_s
            if self.lost_s > SEARCH_S:
                return LanePlan(LaneState.STOPPED, None, 0.0)
            return LanePlan(LaneState.SEARCHING, goal, SEARCH_SPEED_M_S)
        self.lost_s = 0.0
        # the bend ahead, or the arc to the goal where the line is seen too little to show its bend
        curvature = max(lanes.centre.curvature(), abs(PurePursuit.curvature(0.0, 0.0, 0.0, goal)))
        speed = min(self.max_speed_m_s, float(limits.corner_speed(max(curvature, 1e-3))))
        state = LaneState.FOLLOWING if lanes.source in ("yellow", "edges") else LaneState.ONE_LINE
        if state is LaneState.ONE_LINE:
            speed *= ONE_LINE_FACTOR
        elif abs(self.offset_m - self.side * LANE_OFFSET_M) > 1e-6:  # [m]
            state = LaneState.CHANGING
        leader = self._leader_ahead(value)
        if leader is not None:  # its speed, in any state; changing lanes behind it is still changing lanes
            state = LaneState.BEHIND_LEADER if state is LaneState.FOLLOWING else state
            speed = max(0.0, min(speed, leader.speed + FOLLOW_GAIN_PER_S * (leader.ahead_m - FOLLOW_GAP_M)))
        if obstacle_m is not None:  # no faster than it can still stop short of it
            room = max(0.0, obstacle_m - FRONT_M - STOP_MARGIN_M)
            speed = min(speed, math.sqrt(2 * BRAKING_SHARE * limits.max_brake_m_s2 * room))
        return LanePlan(state, goal, speed)


def _nearest_seen(lanes: Lanes) -> float | None:
    """[m] ahead where the line the centre came from was first seen (a wide road's edges come
    into view only a metre or more ahead)."""
    line = {"yellow": lanes.yellow, "left": lanes.left, "right": lanes.right}.get(lanes.source)
    if line is None or not len(line.points):
        return None
    return float(line.points[:, 0].min())


class LaneController(Module[tuple[Seen, LanePlan], Command]):
    def __init__(self, car: CarModel, speed: SpeedController, period_s: float) -> None:
        self.car, self.speed, self.period_s = car, speed, period_s

    def setup(self) -> None:
        self.speed.reset()

    def step(self, value: tuple[Seen, LanePlan]) -> Command:
        seen, plan = value
        if plan.state is LaneState.OBSTACLE:  # full brake (reverse torque) until nearly still, then neutral,
            self.speed.reset()  # steering on along the road (straightened in a bend, it would lose the obstacle)
            return Command(-1.0 if seen.speed > HOLD_SPEED_M_S else 0.0, self._steering(plan.goal))
        if plan.state is LaneState.WAITING:  # at neutral: the ESC car stays armed, nothing rolls
            self.speed.reset()
            return Command(0.0, 0.0)
        if plan.state is LaneState.STOPPED or plan.goal is None:
            return Command(self.speed.step(0.0, seen.speed, self.period_s), 0.0)
        return Command(self.speed.step(plan.target_speed_m_s, seen.speed, self.period_s), self._steering(plan.goal))

    def _steering(self, goal: tuple[float, float] | None) -> float:
        """Pure pursuit to the goal in the car's frame (straight ahead without one)."""
        if goal is None:
            return 0.0
        angle = math.atan(self.car.wheelbase_m * PurePursuit.curvature(0.0, 0.0, 0.0, goal))
        return max(-1.0, min(1.0, -angle / self.car.max_steer_rad))  # left angle = negative command


def lane_agent(camera: Callable[[], tuple], detector: LaneDetector, car: CarModel, period_s: float,
               margin: float = 0.9, depth_camera=None, start: StartLightDetector | None = None,
               laser: Callable[[], float | None] | None = None,
               leader: Callable[[Observation], Leader | None] | None = None) -> Agent:
    """An agent that follows the road's centre by camera at `margin` of the car's grip; camera()
    gives (RGB, depth or None); with depth_camera it stops for obstacles in its path, with start
    it waits for the start lights' green; with laser (the TFmini's reading) it keeps to the right
    lane and changes lanes for what the laser finds ahead; with leader(observation) -> Leader or
    None, it keeps FOLLOW_GAP_M behind a leader ahead in its lane rather than changing lanes
    for it (ROAR's combined driver: lane following, avoidance, platooning)."""
    return Agent(LanePerception(camera, detector, depth_camera, start, laser, leader),
                 LanePlanner(car, period_s, margin, keep_lane=laser is not None),
                 LaneController(car, SpeedController(car.limits.max_speed_m_s, max_reverse=car.limits.max_reverse), period_s))
