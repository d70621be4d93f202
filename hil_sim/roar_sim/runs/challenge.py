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
import shapely

from roar.autopilot import Command
from roar.localization.local_grid import LocalGrid
from roar.localization.pose_history import PoseHistory
from roar.planning import Footprint
from roar.planning.course_driver import CourseDriver
from roar.tracks.track import Track, TrackError
from roar.tracks.tunnel import MARKER_SIZE_M
from roar_sim.world.scene import world_map
from roar.vision.geometry import SIMULATED_CAR_CAMERA
from roar.vision.tracking import CONFIRM_HITS
from roar.vision.view import CameraView
from roar_sim.core.lockstep import CONTROL_PERIOD_S
from roar_sim.runs.localize import PARTICLES, LocalizedCar
from roar_sim.sensors.camera_noise import ShakyCamera

CONE_PENALTY_S = 5.0  # [s] added per cone touched
MARKER_BONUS_S = 2.0  # [s] taken off per marker driven over
FINISH_M = 0.5  # [m] the car's reference point this near the goal: finished
CAMERA_SIZE = (320, 240)  # [px]
CAMERA_FPS = 10.0  # [Hz]
CAMERA_LATENCY_S = 0.3  # [s] from a frame's capture to its arrival
SEEN_WITHIN_M = 4.0  # [m] detection is scored on the objects that came this near the camera in its view, no wall
# between, in as many of the frames the detector received as the tracker needs to confirm an object
PLAN_LATENCY_S = 0.15  # [s] from a plan's start to its path reaching the follower
MAX_SECONDS = 150.0  # [s] of simulated time before the run is given up
TEAM_GAP_S = 2.0  # [s] between one team's start and the next one's, run concurrently
MAX_TEAMS = 4
START_CLEAR_M = 1.0  # [m] a car's reference point this far from the start at least before the next car starts there
PARKED_M = 3.0  # [m] a car waiting for its start stands this far beyond the course's bounds (and from the next)


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
    # within SEEN_WITHIN_M of the camera in its view, no wall between, in enough of the frames received
    paths: list = field(default_factory=list)  # the planner's paths (poses (N, 3)) as they arrived
    tree: np.ndarray | None = None  # (n, 3) the last tree's nodes
    plans: int = 0
    failed_plans: int = 0
    lost_s: float = 0.0  # [s] spent heading for open space without a path
    back_ups: int = 0  # times the car backed off something it was stuck against
    late_brakes: int = 0  # times the car braked for a way shut ahead rather than swerve round at its speed
    guard_stops: int = 0  # times the car braked because the way its wheels pointed met a known cone
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
                 f"{pr['marker'][0]:.2f} recall {pr['marker'][1]:.2f} (objects within "
                 f"{SEEN_WITHIN_M:g} m in view in {CONFIRM_HITS}+ frames received); plans {self.plans}, failed {self.failed_plans}; lost "
                 f"{self.lost_s:.1f} s; backed up {self.back_ups} times; braked for a way shut ahead "
                 f"{self.late_brakes} times, for a cone about to be touched {self.guard_stops}; wall contact {self.wall_contacts * CONTROL_PERIOD_S:.2f} s"]
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


@dataclass
class TeamsResult:
    """The challenge run concurrently: each team's own result (its times from its own start),
    when each started, and the car-to-car contacts (time [s], car a, car b: 0 the first)."""
    track: str
    teams: list[ChallengeResult] = field(default_factory=list)
    starts_s: list[float] = field(default_factory=list)  # [s] each car's start, in the world's time
    contacts: list[tuple[float, int, int]] = field(default_factory=list)

    def report(self, teams: int) -> str:
        lines = []
        for i in range(teams):
            if i >= len(self.teams):
                lines.append(f"car {i + 1}: never started (the start was not clear of the cars before it)")
                continue
            lines.append(f"car {i + 1}, started at {self.starts_s[i]:.2f} s: " + self.teams[i].report())
        lines += [f"car-to-car contact at {t:.2f} s between car {a + 1} and car {b + 1}" for t, a, b in self.contacts]
        if not self.contacts:
            lines.append("no car-to-car contact")
        return "\n".join(lines)


def route_to_goal(track: Track, goal_m: float | None = None) -> np.ndarray:
    """The centre line from the start to the course's goal (or goal_m along it)."""
    course = track.course
    s_goal = track.project(course.goal[:2])[1] if goal_m is None else float(goal_m)
    n = max(2, int(s_goal / 0.1))
    return np.array([track.pose_at(s)[:2] for s in np.linspace(0.0, s_goal, n)])


def _marker_polygons(course):
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
              progress=None, log=None, serve_port: int | None = None) -> ChallengeResult:
    """Run the challenge (see the module's text). goal_m: finish that far along the route instead
    of at the course's goal (a short run). progress(t_s, along_m, route_m) is called each second.
    log: an MCAP file the run is recorded into (roar_sim.links.sim_log: the firmware's side, the
    filter, the camera's frames, the detections, the plans, their trees and the local grid);
    serve_port: the same served live (Foxglove WebSocket on 127.0.0.1)."""
    from roar_sim import robots

    route = _route(track, goal_m)
    with robots.get(robot)(track) as bot:
        bot.arm()
        team = _Team(track, bot, route, oracle, seed, scoring, latency_s, fps, max_seconds, particles)
        sim_log = _sim_log(bot, log, serve_port, "challenge")
        next_report = 1.0
        try:
            while not team.period(sim_log):
                bot.wait(CONTROL_PERIOD_S)
                if progress is not None and bot.time_s >= next_report:
                    progress(bot.time_s, team.driver.mission.progress_m, team.driver.mission.length_m)
                    next_report += 1.0
            bot.send(Command(0.0, 0.0))
        finally:
            if sim_log is not None:
                sim_log.close()
        return team.finish()


def challenge_teams(track: Track, teams: int = 2, behind_s: float = TEAM_GAP_S, oracle: bool = False, seed: int = 1,
                    scoring: Scoring = Scoring(), latency_s: float = CAMERA_LATENCY_S, fps: float = CAMERA_FPS,
                    goal_m: float | None = None, max_seconds: float = MAX_SECONDS, particles: int = PARTICLES,
                    progress=None, log=None, serve_port: int | None = None) -> TeamsResult:
    """The challenge run concurrently (the MIT challenge's second round): `teams` ESC cars in one
    world, from the same start, each behind_s [s] after the one before (and once the start is clear
    of it), each with its own localization, detection and planning: to each the others are unmapped
    things that move, seen by its lidar and camera as any obstacle. Cones and markers are shared (a
    marker counts for each car that drives over it); every car is scored on its own, from its own
    start. Until its start a car waits, at neutral, off the course; at its end (the finish, or out of
    time) it is lifted off the course, as a team takes its car away. log/serve_port: car 1's channels
    as challenge() records them, the others' on /race/car_N/...; progress(t_s, along_m, route_m):
    the last car's."""
    from roar_sim.runs.fleet import Fleet
    from roar_sim.runs.localize import kidnap

    if not 1 <= teams <= MAX_TEAMS:
        raise ValueError(f"teams must be 1..{MAX_TEAMS}, got {teams}")
    route = _route(track, goal_m)
    start = track.start_pose
    minx, miny, maxx, maxy = track.region.bounds
    parked = [(maxx + PARKED_M * (i + 1), maxy + PARKED_M, 0.0) for i in range(teams - 1)]  # off the course
    lifted = [(maxx + PARKED_M * (i + 1), miny - PARKED_M, 0.0) for i in range(teams)]  # where each goes at its end
    result = TeamsResult(track.name)
    with Fleet(track, poses=[start, *parked]) as fleet:
        cars = fleet.cars
        for car in cars:
            car.drive(0.0, 0.0)  # each boots latched until it hears neutral
        fleet.run(CONTROL_PERIOD_S)
        sim_log = _sim_log(cars[0], log, serve_port, "challenge --teams")
        running: list[_Team] = []
        touching: set[tuple[int, int]] = set()
        next_report = 1.0
        try:
            while True:
                t = fleet.time_s
                if len(running) < teams and t >= len(running) * behind_s and _clear(cars[:len(running)], start):
                    car = cars[len(running)]
                    if running:  # to the start, at rest, as if it had just been put there
                        kidnap(car, start)
                        fleet.run(CONTROL_PERIOD_S)
                    running.append(_Team(track, car, route, oracle, seed + 100 * len(running), scoring, latency_s,
                                         fps, max_seconds, particles, started_s=fleet.time_s))
                    running[-1].car.others = [other.plant for other in cars if other is not car]  # to its lidar
                    result.starts_s.append(fleet.time_s)
                done = [team.period(sim_log if i == 0 else None) for i, team in enumerate(running)]
                if sim_log is not None:
                    for i, car in enumerate(cars[1:len(running)], 1):
                        sim_log.other(f"car_{i + 1}", car)
                if all(done) and (len(running) == teams or t >= max_seconds):
                    break  # every car finished or out of time (a car whose start never cleared: not started)
                for i, team in enumerate(running):
                    if done[i] and not team.lifted:  # finished or out of time: lifted off the course, as a
                        team.bot.send(Command(0.0, 0.0))  # team takes its car away (a car at the goal would
                        kidnap(team.bot, lifted[i])  # stand where the next one must finish)
                        team.lifted = True
                fleet.run(CONTROL_PERIOD_S)
                now = fleet.touching_pairs(len(running))
                result.contacts += [(fleet.time_s, a, b) for a, b in sorted(now - touching)]  # each as it starts
                touching = now
                if progress is not None and fleet.time_s >= next_report:
                    last = running[-1].driver.mission
                    progress(fleet.time_s, last.progress_m, last.length_m)
                    next_report += 1.0
        finally:
            if sim_log is not None:
                sim_log.close()
        result.teams = [team.finish() for team in running]
    return result


def _route(track: Track, goal_m: float | None) -> np.ndarray:
    if track.course is None:
        raise TrackError(f"{track.name}: the challenge needs a tunnel world (tunnel:SEED): this track has no course")
    return route_to_goal(track, goal_m)


def _sim_log(bot, log, serve_port: int | None, driver: str):
    if log is None and serve_port is None:
        return None
    from roar_sim.links.sim_log import SimLog

    return SimLog(bot, log, {"driver": driver}, serve_port)


def _clear(cars, start) -> bool:
    """No car within START_CLEAR_M of the start."""
    for car in cars:
        s = car.state()
        if math.hypot(s.x - start[0], s.y - start[1]) < START_CLEAR_M:
            return False
    return True


class _Team:
    """One car running the challenge: its localization, camera, driver and referee, stepped one
    control period at a time by whoever moves the world (challenge() alone, challenge_teams() in
    a fleet). Times are its own, from started_s."""

    def __init__(self, track: Track, bot, route, oracle: bool, seed: int, scoring: Scoring, latency_s: float,
                 fps: float, max_seconds: float, particles: int, started_s: float = 0.0) -> None:
        course = track.course
        self.bot, self.oracle, self.latency_s, self.fps = bot, oracle, latency_s, fps
        self.max_seconds, self.started_s = max_seconds, started_s
        self.goal_xy = tuple(route[-1])
        self.result = result = ChallengeResult(track.name, oracle, scoring, course=course)
        known = world_map(track)
        self.local = LocalGrid(10.0, known.resolution_m, known)
        cam_model = SIMULATED_CAR_CAMERA.model(*CAMERA_SIZE)
        self.car = LocalizedCar(bot, known, seed, 10 if oracle else particles, start="true", local_grid=self.local,
                                oracle=oracle)
        result.localization = self.car.log
        model = bot.model
        self.driver = CourseDriver(known, route, cam_model, self.local, wheelbase_m=model.wheelbase_m,
                                   max_steer_rad=model.max_steer_rad, max_speed_m_s=model.limits.max_speed_m_s,
                                   bonus_s=scoring.marker_bonus_s, seed=seed, plan_latency_s=PLAN_LATENCY_S)
        result.events = self.driver.events  # the driver's and the referee's, in time order
        self.camera = ShakyCamera(bot.plant, *CAMERA_SIZE, seed + 2)
        self.referee = _Referee(track, bot, cam_model, result)
        self.frames: deque = deque()  # (arrives at [s], captured at [s], rgb, depth)
        self.true_history = PoseHistory()
        self.next_frame = started_s  # [s] the next frame's capture
        self.done = False
        self.lifted = False  # taken off the course at its end (challenge_teams)

    def period(self, sim_log=None) -> bool:
        """Sense, decide and send this control period's command; True once finished or out of
        time (nothing more is sent)."""
        if self.done:
            return True
        car, result, driver = self.car, self.result, self.driver
        obs = car.observe()
        t = obs.t_s
        truth = self.bot.state()
        self.true_history.add(t, (truth.x, truth.y, truth.yaw))
        self.referee.watch(t, truth, driver)
        if math.hypot(truth.x - self.goal_xy[0], truth.y - self.goal_xy[1]) <= FINISH_M:
            result.finished, result.time_s, self.done = True, t - self.started_s, True
            return True
        if t - self.started_s >= self.max_seconds:
            result.time_s, self.done = t - self.started_s, True
            return True
        # the camera: a frame now, delivered latency_s later with its capture time
        if t + 1e-9 >= self.next_frame:
            rgb, depth = self.camera()
            self.frames.append((t + self.latency_s, t, rgb, depth))
            if sim_log is not None:
                sim_log.image(rgb)
            self.next_frame += 1.0 / self.fps
        arrived = []
        while self.frames and self.frames[0][0] <= t + 1e-9:
            _, taken, rgb, depth = self.frames.popleft()
            self.referee.frame_received(self.true_history.at(taken) or (truth.x, truth.y, truth.yaw))
            arrived.append((rgb, depth, taken))
        command = driver.step(t, (obs.x, obs.y, obs.yaw), obs.speed, arrived)
        car.explore, car.towards = driver.exploring, driver.towards
        car.send(command)
        if sim_log is not None:
            sim_log.step()
            if not self.oracle:
                sim_log.localization(car)
            sim_log.planning(driver, self.local)
        return False

    def finish(self) -> ChallengeResult:
        result, driver = self.result, self.driver
        result.detections = {kind: driver.objects(kind) for kind in ("cone", "marker")}
        result.tree = driver.planner.tree.poses() if driver.planner.tree is not None else None
        for name in ("plans", "failed_plans", "lost_s", "back_ups", "late_brakes", "guard_stops", "paths"):
            setattr(result, name, getattr(driver, name))
        return result


class _Referee:
    """Scoring by the simulator's truth: walls and cones touched (each with a line saying when,
    where, how fast and what the car was doing), markers driven over, and which objects the camera
    had in view in the frames the detector received."""

    def __init__(self, track: Track, bot, camera, result: ChallengeResult) -> None:
        self.bot, self.result = bot, result
        self.course = track.course
        self.markers = _marker_polygons(self.course)
        self.open_floor = track.region.buffer(0.02)
        self.cone_bodies = list(bot.plant.world.cones)
        self.view = CameraView(camera, None, near_m=0.5, far_m=SEEN_WITHIN_M, fov_share=0.9)  # the geometry
        self.in_frames = {"cone": {}, "marker": {}}  # kind -> index -> frames received with it in view
        self.touched_wall = False
        self.outline = Footprint(margin_m=0.0).corners()  # [m] the car's, about its rear axle
        result.seen_within = {"cone": set(), "marker": set()}

    def watch(self, t: float, truth, driver: CourseDriver) -> None:
        """One control period of the run, by the truth."""
        r, course = self.result, self.course
        r.true_path.append((truth.x, truth.y))
        touching = self.bot.touching_wall()
        if touching and not self.touched_wall:
            r.events.append(f"{t:.2f} s: touched a wall at ({truth.x:.2f}, {truth.y:.2f}) at {truth.speed:.2f} m/s, "
                            f"{driver.doing(t)}")
        self.touched_wall = touching
        r.wall_contacts += touching
        for i, body in enumerate(self.cone_bodies):
            if i not in r.cones_touched and self.bot.touching([body]):
                r.cones_touched.add(i)
                cx, cy = course.cones[i][:2]
                seen = any(math.hypot(x - cx, y - cy) < 0.4 for x, y in driver.objects("cone"))
                r.events.append(f"{t:.2f} s: touched the cone at ({cx:.2f}, {cy:.2f}) at {truth.speed:.2f} m/s, "
                                f"{driver.doing(t)}; the camera {'had' if seen else 'had not'} found it")
        c, s = math.cos(truth.yaw), math.sin(truth.yaw)
        car = shapely.Polygon([(truth.x + c * u - s * v, truth.y + s * u + c * v)
                               for u, v in self.outline])
        for i, poly in enumerate(self.markers):
            if i not in r.markers_taken and car.intersects(poly):
                r.markers_taken.add(i)

    def frame_received(self, true_pose) -> None:
        """A frame reached the detector, taken from true_pose: count the objects it had in view."""
        for kind, objects in (("cone", self.course.cones), ("marker", self.course.markers)):
            for i, o in enumerate(objects):
                if self._in_view(true_pose, o[0], o[1]):
                    self.in_frames[kind][i] = self.in_frames[kind].get(i, 0) + 1
                    if self.in_frames[kind][i] >= CONFIRM_HITS:
                        self.result.seen_within[kind].add(i)

    def _in_view(self, pose, x: float, y: float) -> bool:
        """Whether the camera at the true pose sees (x, y): in its field of view, within
        SEEN_WITHIN_M, no wall of the world (the truth, not the map) between."""
        if not self.view.sees(pose, x, y):
            return False
        return self.open_floor.contains(shapely.LineString([self.view.camera_xy(pose), (x, y)]))


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


def parser():
    from roar.cli.sdk import (ArgumentParser, add_foxglove_option, int_option, number_option, path_option,
                              seed_option)
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
    p.add_argument("--teams", type=int_option(1, MAX_TEAMS), default=1, metavar="N",
                   help=f"run N cars concurrently (1-{MAX_TEAMS}), as the challenge's second round: from the same "
                        f"start, each {TEAM_GAP_S:g} s after the one before, each with its own localization, "
                        f"detection and planning; the others are moving obstacles to it; each scored on its own")
    p.add_argument("--plot", type=path_option, metavar="PNG", help="draw the run into this PNG")
    p.add_argument("--log", type=path_option, metavar="MCAP",
                   help="record the run into this MCAP file: the firmware's side, the filter, the camera's frames, the "
                        "cones and markers found, the plans and their trees, the local grid (Foxglove, roar replay)")
    add_foxglove_option(p, "the same channels")
    return p


def main(argv: list[str] | None = None) -> int:

    from roar.cli.sdk import ExitStatus, UserError
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
    from roar_sim.runs.progress import bar as progress_bar

    bar = progress_bar(total=1.0, desc=f"challenge {track.name}",
                       bar_format="{desc}: {bar} {percentage:3.0f}% of the route [{elapsed}]")

    def progress(t_s: float, along_m: float, route_m: float) -> None:
        bar.n = min(1.0, along_m / max(route_m, 1e-9))
        bar.refresh()

    options = dict(oracle=args.oracle, seed=args.seed, scoring=Scoring(args.cone_penalty, args.marker_bonus),
                   latency_s=args.latency, fps=args.fps, goal_m=args.to, max_seconds=args.seconds, progress=progress,
                   log=args.log, serve_port=args.foxglove)
    try:
        if args.teams > 1:
            teams = challenge_teams(track, args.teams, **options)
        else:
            result = challenge(track, robot=args.robot, **options)
    finally:
        bar.close()
    if args.teams > 1:
        print(teams.report(args.teams))
        results = teams.teams
    else:
        print(result.report())
        results = [result]
    if args.plot:
        def draw():
            fig, ax = plotting.subplots(figsize=(9, 7))
            ax.fill(*np.asarray(track.region.exterior.xy), color="0.92", zorder=0)
            for ring in track.region.interiors:
                ax.fill(*np.asarray(ring.xy), color="white", zorder=0)
            plotting.draw_track(ax, track)
            results[0].draw(ax)
            for i, other in enumerate(results[1:], 2):
                path = np.array(other.true_path)
                ax.plot(path[:, 0], path[:, 1], color=f"C{i}", lw=1.0, label=f"car {i} driven")
            ax.set_aspect("equal")
            ax.set_xlabel("x [m]")
            ax.set_ylabel("y [m]")
            ax.set_title(f"{track.name}: score " + ", ".join(f"{r.score:.2f} s" for r in results))
            ax.legend(fontsize=7, loc="best")
            return fig

        if not plotting.save(draw, args.plot):  # (it says where the plot went)
            return ExitStatus.ERROR
    finished = len(results) == args.teams and all(r.finished for r in results)
    return ExitStatus.OK if finished else ExitStatus.SHORT


if __name__ == "__main__":
    import sys

    from roar.cli.sdk import run_command

    sys.exit(run_command("roar challenge", main))
