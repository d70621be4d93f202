"""The MIT challenge on the simulated car: drive a tunnel world from its start to its goal as fast
as possible, touching no cone (a penalty each) and driving over the green floor markers worth it
(a bonus each), with the whole stack and the firmware in the loop and no simulator pose in it:

    lidar + odometry -> particle filter on the known map (roar.localization) -> local grid
    camera (frames late: latency_s at fps) -> cones and markers (roar.vision.objects), placed by
        the pose at each frame's capture time, counted once (roar.vision.tracking)
    high-level planner (roar.planning.mission) -> arc RRT on map + local grid + cones
        (roar.planning.rrt) -> path follower (roar.planning.follower) -> throttle and steering

    result = challenge(track)                # track: roar.tracks.names.get("tunnel:3")
    result.report()                          # time, cones touched, markers taken, score
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from roar.autopilot import Command
from roar.autopilot.longitudinal import SpeedController
from roar.localization.local_grid import LocalGrid
from roar.localization.pose_history import PoseHistory
from roar.planning import ArcRRT, Footprint, NoPath, PathFollower, PlanningGrid
from roar.planning.follower import FollowerState, Steer
from roar.planning.mission import Mission
from roar.tracks.occupancy_map import track_map
from roar.tracks.track import Track, TrackError
from roar.tracks.tunnel import CONE_RADIUS_M, MARKER_SIZE_M
from roar.vision.geometry import SIMULATED_CAR_CAMERA
from roar.vision.objects import ObjectDetector
from roar.vision.tracking import Tracker
from roar_sim.clock.lockstep import CONTROL_PERIOD_S
from roar_sim.runs.localize import PARTICLES, LocalizedCar
from roar_sim.sensors.camera_noise import ShakyCamera

CONE_PENALTY_S = 5.0  # [s] added per cone touched
MARKER_BONUS_S = 2.0  # [s] taken off per marker driven over
FINISH_M = 0.5  # [m] the car's reference point this near the goal: finished
CAMERA_SIZE = (320, 240)  # [px]
CAMERA_FPS = 10.0  # [Hz]
CAMERA_LATENCY_S = 0.3  # [s] from a frame's capture to its arrival
CAMERA_RANGE_M = 4.5  # [m] the detector places nothing farther
SEEN_WITHIN_M = 4.0  # [m] detection is scored on the objects that came this near the camera in its view
REPLAN_S = 0.3  # [s] between plans (and at once when the way ahead is blocked or the follower is not following;
# a plan that failed is tried again REPLAN_S later). Kept paths drift: a path of long smoothed arcs followed for
# seconds leaves the car on the outside of a bend, a new plan from where it is does not
PLAN_SAMPLES = 1000  # samples a plan may draw before it gives up (~0.1 s here; counted, not timed, so that a
# run is the same on any machine and under any load)
PLAN_IMPROVE = 300  # samples more after a first path, for a cheaper one (a first RRT path may loop)
STOP_ROOM_M = 0.25  # [m] a plan ends where the car fits this much further on: it coasts past its stop (the ESC
# has no brake that holds; below 0.3 m/s the speed controller stops braking lest the car reverse)
PLAN_LATENCY_S = 0.15  # [s] from a plan's start to its path reaching the follower
CRUISE_M_S = 1.5  # [m/s] the follower's top speed
CONE_CLEARANCE_M = 0.1  # [m] a detected cone is blocked this far beyond its radius (its placement's error, and
# the follower's cut inside a tight bend round it)
LOST_AFTER_S = 1.5  # [s] without a path: head for open space in the course's direction
CLEARANCE_M = 0.08  # [m] the planner keeps the car's rectangle this far from walls and cones: the follower's and
# the filter's errors together (3 cm each is typical, a swerve round a cone twice that)
BACK_UP_S = (0.5, 2.0)  # [s] reversing, straight, when the car is stuck (its rectangle touches something, or it
# has not moved for STUCK_S without a path): at least the first, until its rectangle is clear, at most the second
BACK_UP_THROTTLE = -0.45
STUCK_S = 1.0  # [s]
REVERSE_M_S = 0.5  # [m/s] the speed along a path's reversing stretch
REVERSE_THROTTLE, REVERSE_GAIN = 0.3, 0.4  # reverse throttle, and more per m/s short of REVERSE_M_S
MAX_SECONDS = 150.0  # [s] of simulated time before the run is given up


@dataclass(frozen=True)
class Scoring:
    cone_penalty_s: float = CONE_PENALTY_S
    marker_bonus_s: float = MARKER_BONUS_S

    def score(self, time_s: float, cones: int, markers: int) -> float:
        return time_s + self.cone_penalty_s * cones - self.marker_bonus_s * markers


@dataclass
class ChallengeResult:
    track: str
    oracle: bool
    scoring: Scoring
    finished: bool = False
    time_s: float = 0.0  # [s] to the finish (or until given up)
    cones_touched: set = field(default_factory=set)  # indices into the course's cones
    markers_taken: set = field(default_factory=set)  # indices into the course's markers
    true_path: list = field(default_factory=list)  # (x, y) per control period
    detections: dict = field(default_factory=dict)  # kind -> [(x, y)] confirmed objects at the end
    seen_within: dict = field(default_factory=dict)  # kind -> set of indices of the course's objects that came
    # within SEEN_WITHIN_M of the camera while in its view, no wall between
    paths: list = field(default_factory=list)  # the planner's paths (poses (N, 3)) as they arrived
    tree: np.ndarray | None = None  # (n, 3) the last tree's nodes
    plans: int = 0
    failed_plans: int = 0
    lost_s: float = 0.0  # [s] spent heading for open space without a path
    back_ups: int = 0  # times the car backed off something it was stuck against
    events: list = field(default_factory=list)  # what went wrong, when and where: lines for the report
    wall_contacts: int = 0  # control periods touching a wall
    localization: object = None  # LocalizationLog
    course: object = None

    @property
    def score(self) -> float:
        return self.scoring.score(self.time_s, len(self.cones_touched), len(self.markers_taken))

    def precision_recall(self, within_m: float = 0.4) -> dict[str, tuple[float, float]]:
        """kind -> (precision, recall) of the confirmed objects against the course's objects that
        came within the camera's range in its view (an object counted once: one match each)."""
        from scipy.optimize import linear_sum_assignment

        out = {}
        for kind, truth in (("cone", self.course.cones), ("marker", self.course.markers)):
            found = np.array(self.detections.get(kind, []), dtype=float).reshape(-1, 2)
            seen = sorted(self.seen_within.get(kind, set()))
            real = np.array([truth[i][:2] for i in range(len(truth))], dtype=float).reshape(-1, 2)
            matched = set()
            if len(found) and len(real):
                cost = np.linalg.norm(found[:, None, :] - real[None, :, :], axis=2)
                rows, cols = linear_sum_assignment(cost)
                matched = {(r, c) for r, c in zip(rows, cols) if cost[r, c] <= within_m}
            true_pos = len(matched)
            precision = true_pos / len(found) if len(found) else 1.0
            recall = len({c for _, c in matched} & set(seen)) / len(seen) if seen else 1.0
            out[kind] = (precision, recall)
        return out

    def report(self) -> str:
        who = "pose oracle" if self.oracle else "particle filter"
        end = f"finished in {self.time_s:.2f} s" if self.finished else f"did not finish ({self.time_s:.0f} s)"
        c, m = self.course, self.scoring
        pr = self.precision_recall()
        lines = [f"challenge {self.track} ({who}): {end}; cones touched {len(self.cones_touched)} of {len(c.cones)} "
                 f"(+{m.cone_penalty_s:g} s each), markers taken {len(self.markers_taken)} of {len(c.markers)} "
                 f"(-{m.marker_bonus_s:g} s each); score {self.score:.2f} s",
                 f"  detection: cones precision {pr['cone'][0]:.2f} recall {pr['cone'][1]:.2f}, markers precision "
                 f"{pr['marker'][0]:.2f} recall {pr['marker'][1]:.2f} (objects that came within "
                 f"{SEEN_WITHIN_M:g} m in view); plans {self.plans}, failed {self.failed_plans}; lost "
                 f"{self.lost_s:.1f} s; backed up {self.back_ups} times; wall contact {self.wall_contacts * CONTROL_PERIOD_S:.2f} s"]
        if self.localization is not None and not self.oracle:
            lines.append("  " + self.localization.summary())
        lines += [f"  {event}" for event in self.events]
        return "\n".join(lines)

    def draw(self, ax) -> None:
        """The course's truth, the detections, the last tree and the paths on a track's axes."""
        c = self.course
        if c.cones:
            ax.scatter(*np.array(c.cones).T, s=30, marker="^", color="darkorange", label="cones", zorder=4)
        if c.markers:
            ax.scatter(*np.array(c.markers)[:, :2].T, s=40, marker="s", color="green", label="markers", zorder=4)
        for kind, colour in (("cone", "red"), ("marker", "lime")):
            found = np.array(self.detections.get(kind, [])).reshape(-1, 2)
            if len(found):
                ax.scatter(*found.T, s=60, facecolors="none", edgecolors=colour, label=f"{kind}s found", zorder=5)
        if self.tree is not None and len(self.tree):
            ax.scatter(self.tree[:, 0], self.tree[:, 1], s=1, color="grey", alpha=0.5, label="last tree")
        for i, p in enumerate(self.paths[:: max(1, len(self.paths) // 40)]):
            ax.plot(p[:, 0], p[:, 1], color="tab:blue", lw=0.5, alpha=0.6, label="plans" if i == 0 else None)
        path = np.array(self.true_path)
        if len(path):
            ax.plot(path[:, 0], path[:, 1], color="black", lw=1.0, label="driven")
        ax.plot(*c.goal[:2], marker="*", markersize=14, color="gold", markeredgecolor="black", label="goal")


def _doing(follower: PathFollower, steer: Steer, backing_s: float) -> str:
    """What the car was doing, for an event's line."""
    if backing_s < BACK_UP_S[1]:
        return "backing off"
    return f"{follower.state.value}{', reversing' if steer.direction < 0 else ''}"


def route_to_goal(track: Track, goal_m: float | None = None) -> np.ndarray:
    """The centre line from the start to the course's goal (or goal_m along it)."""
    course = track.course
    s_goal = track.project(course.goal[:2])[1] if goal_m is None else float(goal_m)
    n = max(2, int(s_goal / 0.1))
    return np.array([track.pose_at(s)[:2] for s in np.linspace(0.0, s_goal, n)])


def _marker_polygons(course):
    import shapely

    a, b = MARKER_SIZE_M[0] / 2, MARKER_SIZE_M[1] / 2
    out = []
    for x, y, yaw in course.markers:
        c, s = math.cos(yaw), math.sin(yaw)
        out.append(shapely.Polygon([(x + c * u - s * v, y + s * u + c * v) for u, v in ((-a, -b), (a, -b), (a, b),
                                                                                           (-a, b))]))
    return out


def challenge(track: Track, oracle: bool = False, seed: int = 1, scoring: Scoring = Scoring(),
              latency_s: float = CAMERA_LATENCY_S, fps: float = CAMERA_FPS, goal_m: float | None = None,
              max_seconds: float = MAX_SECONDS, particles: int = PARTICLES, robot: str = "esc",
              progress=None) -> ChallengeResult:
    """Run the challenge (see the module's text). goal_m: finish that far along the route instead
    of at the course's goal (a short run). progress(t_s, along_m, route_m) is called each second."""
    import shapely

    from roar_sim import robots

    course = track.course
    if course is None:
        raise TrackError(f"{track.name}: the challenge needs a tunnel world (tunnel:SEED): this track has no course")
    route = route_to_goal(track, goal_m)
    goal_xy = tuple(route[-1])
    result = ChallengeResult(track.name, oracle, scoring, course=course)
    known = track_map(track)
    base = PlanningGrid.from_map(known)
    local = LocalGrid(10.0, known.resolution_m, known)
    mission = Mission(route, scoring.marker_bonus_s, CRUISE_M_S)
    footprint = Footprint(margin_m=CLEARANCE_M)
    with robots.get(robot)(track) as bot:
        bot.arm()
        car = LocalizedCar(bot, known, seed, 10 if oracle else particles, start="true", local_grid=local,
                           oracle=oracle)
        result.localization = car.log
        model = bot.model
        r_min = model.wheelbase_m / math.tan(model.max_steer_rad) * 1.05
        planner = ArcRRT(base, footprint, r_min_m=r_min, seed=seed, smooth=True, improve=PLAN_IMPROVE,
                         stop_room_m=STOP_ROOM_M)
        # from a start nearer a wall than the clearance (the car swerved), plan with the bare rectangle
        close_planner = ArcRRT(base, Footprint(margin_m=0.0), r_min_m=r_min, seed=seed, smooth=True,
                               improve=PLAN_IMPROVE, stop_room_m=STOP_ROOM_M)
        follower = PathFollower(max_speed_m_s=CRUISE_M_S)
        speed = SpeedController(model.limits.max_speed_m_s)
        camera = ShakyCamera(bot.plant, *CAMERA_SIZE, seed + 2)
        cam_model = SIMULATED_CAR_CAMERA.model(*CAMERA_SIZE)
        detector = ObjectDetector(cam_model, CAMERA_RANGE_M)
        tracker = Tracker()
        history = PoseHistory()
        frames: deque = deque()  # (arrives at [s], captured at [s], rgb, depth)
        pending: deque = deque()  # (arrives at [s], path)
        half_fov = math.atan(cam_model.width / 2 / cam_model.fx)
        markers_poly = _marker_polygons(course)
        open_floor = track.region.buffer(0.02)
        cone_bodies = list(bot.plant.world.cones)
        result.seen_within = {"cone": set(), "marker": set()}
        next_frame = next_plan = next_try = 0.0
        why = "route"
        steer = Steer(FollowerState.WAITING)
        last_path_s = 0.0
        backing_since = still_since = -10.0
        touched_wall = False
        settle_s = latency_s + Tracker().confirm_hits / fps  # [s] the first frame's arrival and a track's confirmation
        next_report = 1.0

        def in_view(pose, x: float, y: float, sight: bool = False, within_m: float = CAMERA_RANGE_M) -> bool:
            """Whether the camera at pose sees (x, y): in its field of view and within_m, and
            (sight) with no wall between."""
            cx = pose[0] + cam_model.x_m * math.cos(pose[2])
            cy = pose[1] + cam_model.x_m * math.sin(pose[2])
            bearing = math.remainder(math.atan2(y - cy, x - cx) - pose[2], math.tau)
            if not (abs(bearing) < half_fov * 0.9 and 0.5 < math.hypot(x - cx, y - cy) < within_m):
                return False
            return not sight or open_floor.contains(shapely.LineString([(cx, cy), (x, y)]))

        while True:
            obs = car.observe()
            t = obs.t_s
            pose = (obs.x, obs.y, obs.yaw)
            truth = bot.state()
            true_pose = (truth.x, truth.y, truth.yaw)
            history.add(t, pose)
            result.true_path.append((truth.x, truth.y))
            # scoring, by the simulator's truth
            touching = bot.touching_wall()
            if touching and not touched_wall:
                result.events.append(f"{t:.2f} s: touched a wall at ({truth.x:.2f}, {truth.y:.2f}) at {truth.speed:.2f} "
                                     f"m/s, {_doing(follower, steer, t - backing_since)}")
            touched_wall = touching
            result.wall_contacts += touching
            for i, body in enumerate(cone_bodies):
                if i not in result.cones_touched and bot.touching([body]):
                    result.cones_touched.add(i)
                    doing = _doing(follower, steer, t - backing_since)
                    seen = any(math.hypot(o.position[0] - course.cones[i][0], o.position[1] - course.cones[i][1]) < 0.4
                               for o in tracker.objects("cone"))
                    result.events.append(f"{t:.2f} s: touched the cone at ({course.cones[i][0]:.2f}, "
                                         f"{course.cones[i][1]:.2f}) at {truth.speed:.2f} m/s, {doing}; the camera "
                                         f"{'had' if seen else 'had not'} found it")
            car_poly = shapely.Polygon([(truth.x + math.cos(truth.yaw) * u - math.sin(truth.yaw) * v,
                                         truth.y + math.sin(truth.yaw) * u + math.cos(truth.yaw) * v)
                                        for u, v in Footprint(margin_m=0.0).corners()])
            for i, poly in enumerate(markers_poly):
                if i not in result.markers_taken and car_poly.intersects(poly):
                    result.markers_taken.add(i)
            for kind, objects in (("cone", course.cones), ("marker", course.markers)):
                for i, o in enumerate(objects):
                    if i not in result.seen_within[kind] and in_view(true_pose, o[0], o[1], True, SEEN_WITHIN_M):
                        result.seen_within[kind].add(i)
            if math.hypot(truth.x - goal_xy[0], truth.y - goal_xy[1]) <= FINISH_M:
                result.finished, result.time_s = True, t
                break
            if t >= max_seconds:
                result.time_s = t
                break
            # the camera: a frame now, delivered latency_s later with its capture time
            if t + 1e-9 >= next_frame:
                rgb, depth = camera()
                frames.append((t + latency_s, t, rgb, depth))
                next_frame += 1.0 / fps
            while frames and frames[0][0] <= t + 1e-9:
                _, taken, rgb, depth = frames.popleft()
                then = history.at(taken) or pose
                tracker.update(detector.detect(rgb, depth, then, taken), taken,
                               in_view=lambda x, y, then=then: in_view(then, x, y))
            markers = [o.position for o in tracker.objects("marker")]
            mission.update(pose, markers)
            # plan: every REPLAN_S, and at once when the path ahead is blocked or the follower is not following
            cones = [o.position for o in tracker.objects("cone")]
            grid = base.with_local(local).with_discs(cones, CONE_RADIUS_M + CONE_CLEARANCE_M)
            blocked = follower.path is not None and not footprint.fits(
                grid, follower.path.poses[follower.index:][::4])
            due = t + 1e-9 >= next_plan
            wanted = blocked or follower.state != FollowerState.FOLLOWING or due
            if wanted and not pending and t + 1e-9 >= next_try:
                next_plan = t + REPLAN_S
                goal, why = mission.goal(pose, grid, markers)  # always afresh: a goal reached is the next one
                result.plans += 1
                path = None
                for rrt in (planner, close_planner):
                    try:
                        path = rrt.replan(pose, goal, grid, max_iterations=PLAN_SAMPLES, t_s=t)
                        break
                    except NoPath as e:
                        if "in collision" not in str(e) or rrt is close_planner:
                            break
                if path is not None:
                    pending.append((t + PLAN_LATENCY_S, path))
                    last_path_s = t
                else:
                    result.failed_plans += 1
                    next_try = t + REPLAN_S  # not again at once: the world needs to change first
                    if why == "marker":  # no way to it: the route instead
                        mission.abandon()
                        next_try = next_plan = t
                    if blocked:
                        follower.set_path(None)  # brake: the way ahead is shut and no way round is known yet
                    if not footprint.fits(grid, [pose]) and not close_planner.footprint.fits(grid, [pose]) and \
                            t - backing_since > BACK_UP_S[1]:
                        backing_since = t  # touching a wall or a cone: back off
                        result.back_ups += 1
            while pending and pending[0][0] <= t + 1e-9:
                path = pending.popleft()[1]
                follower.set_path(path)
                result.paths.append(path.poses)
            steer = follower.step(pose, obs.speed)
            lost = follower.state != FollowerState.FOLLOWING and t - last_path_s > LOST_AFTER_S
            still_since = t if obs.speed > 0.05 or still_since < 0 else still_since
            if lost and t - still_since > STUCK_S and t - backing_since > BACK_UP_S[1] + STUCK_S:
                backing_since = t
                result.back_ups += 1
            if lost:
                result.lost_s += CONTROL_PERIOD_S
            if t < settle_s:  # the first frames are on their way: stand until the camera has seen what is ahead
                speed.reset()
                car.send(Command(0.0, 0.0))
                car.wait(CONTROL_PERIOD_S)
                continue
            backing = t - backing_since
            if backing < BACK_UP_S[0] or (backing < BACK_UP_S[1] and not footprint.fits(grid, [pose])):
                car.explore = False
                speed.reset()
                car.send(Command(BACK_UP_THROTTLE, 0.0))
                car.wait(CONTROL_PERIOD_S)
                continue
            car.explore = lost
            car.towards = mission.point_at(mission.progress_m + mission.horizon_m)
            target = steer.speed_m_s if steer.state == FollowerState.FOLLOWING else 0.0
            if steer.direction < 0 and steer.state == FollowerState.FOLLOWING:  # reversing: slowly, the ESC brakes first
                speed.reset()
                throttle = -min(0.6, REVERSE_THROTTLE + REVERSE_GAIN * max(0.0, REVERSE_M_S - obs.speed))
            else:
                throttle = speed.step(target, obs.speed, CONTROL_PERIOD_S)
            angle = math.atan(model.wheelbase_m * steer.curvature)
            car.send(Command(throttle, max(-1.0, min(1.0, -angle / model.max_steer_rad))))
            car.wait(CONTROL_PERIOD_S)
            if progress is not None and t >= next_report:
                progress(t, mission.progress_m, mission.length_m)
                next_report += 1.0
        car.send(Command(0.0, 0.0))
        result.detections = {kind: [o.position for o in tracker.objects(kind)] for kind in ("cone", "marker")}
        result.tree = planner.tree.poses() if planner.tree is not None else None
    return result


DESCRIPTION = """The MIT challenge on the simulated car: from a tunnel world's start to its goal as fast as
possible; each cone touched adds --cone-penalty seconds, each green floor marker driven over takes
off --marker-bonus seconds. The whole stack drives, with the car's firmware in the loop: the
particle filter on the known map (walls only; no simulator pose), the local grid from the lidar,
cones and markers by the camera (frames --latency seconds late at --fps), the high-level planner,
the arc RRT and the path follower. --oracle gives the same stack the simulator's pose instead, to
compare. Prints the time, cones touched, markers taken and the score; --plot draws the map, the
detections, the planner's paths and last tree, and the driven path.

  roar challenge tunnel:3
  roar challenge tunnel:5,cones=8 --oracle --plot run.png"""


def seed_option(text: str) -> int:
    """An argparse type: a whole number >= 0 (numpy's generators take no negative seed)."""
    import argparse

    if not text.strip().isdigit():
        raise argparse.ArgumentTypeError(f"must be a whole number 0 or more, got {text!r}")
    return int(text)


def parser():
    from roar.cli.errors import ArgumentParser, number_option, path_option
    from roar_sim import robots

    seconds = number_option(0, 3600, "s")
    p = ArgumentParser(prog="roar challenge", description=DESCRIPTION)
    p.add_argument("world", help="a tunnel world: tunnel:SEED[,width=M][,cones=N][,markers=N][,people=N], or a map "
                                 "YAML with its NAME_course.yaml beside it")
    p.add_argument("--oracle", action="store_true", help="drive on the simulator's pose (no particle filter)")
    p.add_argument("--cone-penalty", type=seconds, default=CONE_PENALTY_S, metavar="S",
                   help=f"seconds added per cone touched (default {CONE_PENALTY_S:g})")
    p.add_argument("--marker-bonus", type=seconds, default=MARKER_BONUS_S, metavar="S",
                   help=f"seconds taken off per marker driven over (default {MARKER_BONUS_S:g})")
    p.add_argument("--latency", type=number_option(0, 2, "s"), default=CAMERA_LATENCY_S, metavar="S",
                   help=f"the camera's frames arrive this late (default {CAMERA_LATENCY_S:g})")
    p.add_argument("--fps", type=number_option(1, 60, "frames/s"), default=CAMERA_FPS,
                   help=f"camera frames a second (default {CAMERA_FPS:g})")
    p.add_argument("--seconds", type=number_option(1, 3600, "s"), default=MAX_SECONDS, metavar="S",
                   help=f"give up after this long in the simulation (default {MAX_SECONDS:g})")
    p.add_argument("--to", type=number_option(2, 1000, "m"), default=None, metavar="M",
                   help="finish this far along the route instead of at the course's goal (a short run)")
    p.add_argument("--seed", type=seed_option, default=1, help="the sensors' noise and the planner's samples (default 1)")
    p.add_argument("--robot", choices=[n for n in robots.names() if n == "esc"], default="esc",
                   help="the car (the ESC car: the planner's arcs are a steered car's)")
    p.add_argument("--plot", type=path_option, metavar="PNG", help="draw the run into this PNG")
    return p


def main(argv: list[str] | None = None) -> int:
    import sys

    from roar.cli.errors import ExitStatus, UserError
    from roar.tracks.names import get
    from roar_sim.world import plotting

    p = parser()
    args = p.parse_args(argv)
    plotting.check_png_argument(p, args.plot)
    track = get(args.world)
    if args.to is not None and not (2.0 <= args.to <= track.length_m - 1.0):
        p.error(f"--to must be 2..{track.length_m - 1:.0f} m (the route's length), got {args.to:g}")
    if track.course is None:
        raise UserError(f"{args.world}: not a tunnel world (tunnel:SEED, or a map with its NAME_course.yaml): "
                        f"the challenge needs cones, markers and a goal")
    from tqdm import tqdm

    bar = tqdm(total=1.0, desc=f"challenge {track.name}", file=sys.stderr, mininterval=0.5,
               bar_format="{desc}: {bar} {percentage:3.0f}% of the route [{elapsed}]")

    def progress(t_s: float, along_m: float, route_m: float) -> None:
        bar.n = min(1.0, along_m / max(route_m, 1e-9))
        bar.refresh()

    try:
        result = challenge(track, oracle=args.oracle, seed=args.seed,
                           scoring=Scoring(args.cone_penalty, args.marker_bonus), latency_s=args.latency,
                           fps=args.fps, goal_m=args.to, max_seconds=args.seconds, robot=args.robot,
                           progress=progress)
    finally:
        bar.close()
    print(result.report())
    if args.plot:
        def draw():
            fig, ax = plotting.subplots(figsize=(9, 7))
            ax.fill(*np.asarray(track.region.exterior.xy), color="0.92", zorder=0)
            for ring in track.region.interiors:
                ax.fill(*np.asarray(ring.xy), color="white", zorder=0)
            plotting.draw_track(ax, track)
            result.draw(ax)
            ax.set_aspect("equal")
            ax.set_xlabel("x [m]")
            ax.set_ylabel("y [m]")
            ax.set_title(f"{track.name}: score {result.score:.2f} s")
            ax.legend(fontsize=7, loc="best")
            return fig

        if not plotting.save(draw, args.plot):
            return ExitStatus.ERROR
        print(f"plot: {args.plot}")
    return ExitStatus.OK if result.finished else ExitStatus.SHORT


if __name__ == "__main__":
    import sys

    from roar.cli.errors import run_command

    sys.exit(run_command("roar challenge", main))
