"""The MIT challenge's stack above localization, as one object a car's computer runs: given the
pose (a particle filter's, on the known map), the local grid, and the camera's frames as they
arrive (late, with their capture time), it finds and counts cones and markers, picks goals along
the course, plans arc-RRT paths round what it knows, follows them, and says what to send.

    driver = CourseDriver(known_map, route, camera_model, local_grid, wheelbase_m=0.325,
                          max_steer_rad=0.4, max_speed_m_s=5.0, bonus_s=2.0)
    command = driver.step(t_s, pose, speed_m_s, frames=[(rgb, depth, captured_s), ...])
    # each control period, with the camera frames that arrived since: a roar.autopilot.Command
    driver.exploring, driver.towards              # no plan for a while: head for the open way (roar.autopilot.open_way)

What it does each period, in order:
- a plan every REPLAN_S, and at once when the path ahead is shut (a cone seen late) or the
  follower has no path; from a start nearer a wall than CLEARANCE_M, with the bare rectangle;
- a way round a cone seen late that bends too sharply for the car's speed is refused when braking
  stops the car short of the cone (PathFollower.brake_rather): it brakes and plans from rest;
- it brakes whenever, steering as it does, it would touch a known cone within its braking
  distance (GUARD_M more);
- touching something (its rectangle on a blocked cell), or standing still without a plan, it
  backs off straight, stopping where its rear would touch something;
- it stands until the camera has delivered CONFIRM_HITS + 1 frames (what is ahead confirmed).
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from roar.autopilot.agent import Command
from roar.autopilot.longitudinal import SpeedController
from roar.localization.pose_history import PoseHistory
from roar.planning.arcs import arc_poses
from roar.planning.follower import BRAKE_M_S2, FollowerState, PathFollower, Steer
from roar.planning.footprint import Footprint
from roar.planning.grid import NoPath, PlanningGrid
from roar.planning.mission import Mission
from roar.planning.rrt import ArcRRT
from roar.tracks.tunnel import CONE_RADIUS_M
from roar.vision.objects import ObjectDetector
from roar.vision.tracking import CONFIRM_HITS, Tracker
from roar.vision.view import CameraView

CAMERA_RANGE_M = 4.5  # [m] the detector places nothing farther
REPLAN_S = 0.3  # [s] between plans (and at once when the way ahead is blocked or the follower is not following;
# a plan that failed is tried again REPLAN_S later). Kept paths drift: a path of long smoothed arcs followed for
# seconds leaves the car on the outside of a bend, a new plan from where it is does not
PLAN_SAMPLES = 1000  # samples a plan may draw before it gives up (~0.1 s here; counted, not timed, so that a
# run is the same on any machine and under any load)
PLAN_IMPROVE = 300  # samples more after a first path, for a cheaper one (a first RRT path may loop)
STOP_ROOM_M = 0.25  # [m] a plan ends where the car fits this much further on: it coasts past its stop (the ESC
# has no brake that holds; below 0.3 m/s the speed controller stops braking lest the car reverse)
CRUISE_M_S = 1.5  # [m/s] the follower's top speed
CONE_CLEARANCE_M = 0.1  # [m] a detected cone is blocked this far beyond its radius (its placement's error, and
# the follower's cut inside a tight bend round it)
ROOM_M = 0.3  # [m] less room than this beside the car costs the planner extra: of two gaps round a cone it takes the
# wider unless it is much longer (the filter's error and the follower's cut have room there)
CLEARANCE_M = 0.08  # [m] the planner keeps the car's rectangle this far from walls and cones: the follower's and
# the filter's errors together (3 cm each is typical, a swerve round a cone twice that)
MAX_REVERSE_M = 1.2  # [m] a plan reverses at most this far in a row, counting what the car has just reversed:
# there is no camera behind, and an unseen cone is found by touching it (a K-turn's leg is shorter)
R_MIN_SLACK = 1.05  # the planner's turning radius over the car's tightest: the servo's slew
LOST_AFTER_S = 1.5  # [s] without a path: head for open space in the course's direction
BACK_UP_S = (0.5, 2.0)  # [s] reversing, straight, when the car is stuck (its rectangle touches something, or it
# has not moved for STUCK_S without a path): at least the first, until its rectangle is clear, at most the second
BACK_UP_THROTTLE = -0.45
BEHIND_M = 0.1  # [m] backing off stops when the car's rectangle would touch something within this behind it
GUARD_M = 0.1  # [m] the car brakes when, steering as it does, it would touch a known cone within its braking
# distance and this (the follower cut inside a bend round it, or the pose was off)
STUCK_S = 1.0  # [s]
REVERSE_M_S = 0.5  # [m/s] the speed along a path's reversing stretch
REVERSE_THROTTLE, REVERSE_GAIN = 0.3, 0.4  # reverse throttle, and more per m/s short of REVERSE_M_S
DEFAULT_PERIOD_S = 0.02  # [s] the control period assumed at the first step


class CourseDriver:
    def __init__(self, known, route, camera, local, *, wheelbase_m: float, max_steer_rad: float,
                 max_speed_m_s: float, bonus_s: float = 2.0, seed: int = 1, plan_latency_s: float = 0.0) -> None:
        """known: the map (OccupancyMap); route: (N, 2) [m] the course's centre line from the start
        to the finish; camera: its CameraModel; local: the LocalGrid the lidar updates; the car's
        wheelbase [m], full-lock wheel angle [rad] and the speed controller's top speed [m/s];
        bonus_s: what a marker is worth; plan_latency_s: a path reaches the follower this long
        after its plan began (the simulator's stand-in for planning time)."""
        self.local, self.wheelbase_m, self.max_steer_rad = local, wheelbase_m, max_steer_rad
        self.plan_latency_s = plan_latency_s
        self.base = PlanningGrid.from_map(known)
        self.mission = Mission(route, bonus_s, CRUISE_M_S)
        self.footprint = Footprint(margin_m=CLEARANCE_M)
        self.bare = Footprint(margin_m=0.0)
        self.behind = Footprint(self.bare.rear_m + BEHIND_M, 0.0, self.bare.half_width_m, 0.0)  # backing onto
        self.r_min_m = wheelbase_m / math.tan(max_steer_rad) * R_MIN_SLACK  # [m] the tightest turn planned
        options = dict(r_min_m=self.r_min_m, seed=seed, smooth=True, improve=PLAN_IMPROVE,
                       stop_room_m=STOP_ROOM_M, max_reverse_m=MAX_REVERSE_M, room_m=ROOM_M)
        self.planner = ArcRRT(self.base, self.footprint, **options)
        self.close_planner = ArcRRT(self.base, self.bare, **options)  # from a start nearer a wall than the clearance
        self.follower = PathFollower(max_speed_m_s=CRUISE_M_S)
        self.speed = SpeedController(max_speed_m_s)
        self.detector = ObjectDetector(camera, CAMERA_RANGE_M)
        self.view = CameraView(camera, known)  # where a tracker's miss counts: in view, not round a bend
        self.tracker = Tracker()
        self.history = PoseHistory()
        self.frames = 0  # received
        self.events: list[str] = []  # what it did that a person would ask about, when and where
        self.paths: list[np.ndarray] = []  # the planner's paths (poses (N, 3)) as they reached the follower
        self.plans = self.failed_plans = self.back_ups = self.late_brakes = self.guard_stops = 0
        self.lost_s = 0.0  # [s] without a path, heading for open space
        self.exploring = False  # heading for the open way: the caller drives by roar.autopilot.open_way
        self.towards: tuple[float, float] | None = None  # ... towards this point of the course
        self.steer = Steer(FollowerState.WAITING)
        self._pending: deque = deque()  # (reaches the follower at [s], path, the old way shut this far ahead [m])
        self._next_plan = self._next_try = 0.0
        self._last_path_s = 0.0
        self._backing_since = self._still_since = -10.0
        self._grid, self._grid_of = None, None
        self._guarding = False
        self._reversed_m, self._last_pose, self._last_t = 0.0, None, None

    # -- what the camera gives ------------------------------------------------------------------

    def _frame(self, rgb: np.ndarray, depth: np.ndarray, captured_s: float) -> None:
        """A camera frame (RGB, depth [m]) taken at captured_s, placed by the pose then."""
        then = self.history.at(captured_s) or self._last_pose
        self.frames += 1
        self.tracker.update(self.detector.detect(rgb, depth, then, captured_s), captured_s,
                            in_view=lambda x, y: self.view.sees(then, x, y))

    def objects(self, kind: str) -> list[tuple[float, float]]:
        """[m] where the confirmed cones or markers stand."""
        return [o.position for o in self.tracker.objects(kind)]

    def doing(self, t_s: float) -> str:
        """What the car is doing, for an event's line."""
        if t_s - self._backing_since < BACK_UP_S[1]:
            return "backing off"
        return f"{self.follower.state.value}{', reversing' if self.steer.direction < 0 else ''}"

    # -- each control period --------------------------------------------------------------------

    def step(self, t_s: float, pose, speed_m_s: float, frames=()) -> Command:
        """What to send now, at pose (x, y, yaw) [m, m, rad] and speed [m/s]; frames: the camera's
        (rgb, depth [m], captured at [s]) that arrived since the last step."""
        t = t_s
        dt = DEFAULT_PERIOD_S if self._last_t is None else max(1e-6, t - self._last_t)
        self._last_t = t
        self.history.add(t, pose)
        self._count_reversing(pose)
        for rgb, depth, captured_s in frames:
            self._frame(rgb, depth, captured_s)
        markers, cones = self.objects("marker"), self.objects("cone")
        self.mission.update(pose, markers)
        grid = self._planning_grid(cones)
        self._plan(t, pose, grid, markers)
        self._take_paths(t, speed_m_s)
        steer = self.steer = self.follower.step(pose, speed_m_s)
        lost = steer.state != FollowerState.FOLLOWING and t - self._last_path_s > LOST_AFTER_S
        self._still_since = t if speed_m_s > 0.05 or self._still_since < 0 else self._still_since
        if lost and t - self._still_since > STUCK_S and t - self._backing_since > BACK_UP_S[1] + STUCK_S:
            self._backing_since = t
            self.back_ups += 1
        if lost:
            self.lost_s += dt
        if self.frames < CONFIRM_HITS + 1:  # the first frames are on their way: stand until what is ahead is seen
            self.speed.reset()
            return Command(0.0, 0.0)
        backing = t - self._backing_since
        if backing < BACK_UP_S[1] and not self.behind.fits(grid, [pose]):  # a wall or a known cone behind: stop
            self._backing_since = t - BACK_UP_S[1]
            backing = BACK_UP_S[1]
        if backing < BACK_UP_S[0] or (backing < BACK_UP_S[1] and not self.footprint.fits(grid, [pose])):
            self.exploring = False
            self.speed.reset()
            return Command(BACK_UP_THROTTLE, 0.0)
        self.exploring = lost
        self.towards = self.mission.point_at(self.mission.progress_m + self.mission.horizon_m)
        target = steer.speed_m_s if steer.state == FollowerState.FOLLOWING else 0.0
        if steer.direction > 0 and speed_m_s > 0.1 and cones and self._about_to_touch(pose, speed_m_s, cones):
            target = 0.0
        if steer.direction < 0 and steer.state == FollowerState.FOLLOWING:  # reversing: slowly, the ESC brakes first
            self.speed.reset()
            throttle = -min(0.6, REVERSE_THROTTLE + REVERSE_GAIN * max(0.0, REVERSE_M_S - speed_m_s))
        else:
            throttle = self.speed.step(target, speed_m_s, dt)
        angle = math.atan(self.wheelbase_m * steer.curvature)
        return Command(throttle, max(-1.0, min(1.0, -angle / self.max_steer_rad)))

    def _count_reversing(self, pose) -> None:
        """Metres driven backwards in a row, by the pose's moves along its heading (no camera behind)."""
        last = self._last_pose
        if last is not None:
            moved = (pose[0] - last[0]) * math.cos(pose[2]) + (pose[1] - last[1]) * math.sin(pose[2])
            r = self._reversed_m
            self._reversed_m = r - moved if moved < -1e-4 else (0.0 if moved > 1e-4 else r)
        self._last_pose = tuple(pose)

    def _planning_grid(self, cones) -> PlanningGrid:
        if (self.local.time_s, cones) != self._grid_of:  # a new scan or a cone moved: the planning grid again
            self._grid_of = (self.local.time_s, cones)
            self._grid = self.base.with_local(self.local).with_discs(cones, CONE_RADIUS_M + CONE_CLEARANCE_M)
        return self._grid

    def _plan(self, t: float, pose, grid: PlanningGrid, markers) -> None:
        """A plan when one is due, or at once when the way ahead is shut or there is no path."""
        follower = self.follower
        shut_at = -1 if follower.path is None else self.footprint.first_collision(
            grid, follower.path.poses[follower.index:][::4])  # where the way ahead is shut (a cone seen late)
        blocked = shut_at >= 0
        wanted = blocked or follower.state != FollowerState.FOLLOWING or t + 1e-9 >= self._next_plan
        if not wanted or self._pending or t + 1e-9 < self._next_try:
            return
        self._next_plan = t + REPLAN_S
        goal, why = self.mission.goal(pose, grid, markers)  # always afresh: a goal reached is the next one
        self.plans += 1
        path = None
        for rrt in (self.planner, self.close_planner):
            try:
                path = rrt.replan(pose, goal, grid, max_iterations=PLAN_SAMPLES, t_s=t, reversed_m=self._reversed_m)
                break
            except NoPath as e:
                if "in collision" not in str(e) or rrt is self.close_planner:
                    break
        if path is not None:
            shut_m = None if not blocked else float(np.sum(np.hypot(*np.diff(
                follower.path.poses[follower.index:][:shut_at * 4 + 1, :2], axis=0).T)))
            self._pending.append((t + self.plan_latency_s, path, shut_m))
            self._last_path_s = t
            return
        self.failed_plans += 1
        self._next_try = t + REPLAN_S  # not again at once: the world needs to change first
        if why == "marker":  # no way to it: the route instead
            self.mission.abandon()
            self._next_try = self._next_plan = t
        if blocked:
            follower.set_path(None)  # brake: the way ahead is shut and no way round is known yet
        if not self.footprint.fits(grid, [pose]) and not self.bare.fits(grid, [pose]) and \
                t - self._backing_since > BACK_UP_S[1]:
            self._backing_since = t  # touching a wall or a cone: back off
            self.back_ups += 1

    def _take_paths(self, t: float, speed_m_s: float) -> None:
        """The paths whose time has come, to the follower; a way round what shut the path that is
        too sharp to take at this speed is refused: brake, then plan from rest."""
        follower, fp = self.follower, self.footprint
        while self._pending and self._pending[0][0] <= t + 1e-9:
            _, path, shut_m = self._pending.popleft()
            self.paths.append(path.poses)
            if shut_m is not None and follower.brake_rather(path, speed_m_s, shut_m, fp.front_m + fp.margin_m):
                follower.set_path(None)
                self.late_brakes += 1
                self.events.append(f"{t:.2f} s: braked at {speed_m_s:.2f} m/s for what shut the way {shut_m:.2f} m "
                                   f"ahead (the way round it allows {follower.entry_speed(path):.2f} m/s)")
                continue
            follower.set_path(path)

    def _about_to_touch(self, pose, speed_m_s: float, cones) -> bool:
        """Whether, steering as it does, the car would touch a known cone within its braking distance."""
        k = max(-1 / self.r_min_m, min(1 / self.r_min_m, self.steer.curvature))  # [1/m] the way the wheels go
        reach = speed_m_s ** 2 / (2 * BRAKE_M_S2) + GUARD_M
        radius = 1 / k if abs(k) > 1e-6 else math.inf
        touching = self.bare.touches_discs(arc_poses(*pose, radius, reach / radius, reach, 1, 0.05), cones,
                                           CONE_RADIUS_M)
        self.guard_stops += touching and not self._guarding
        self._guarding = touching
        return touching
