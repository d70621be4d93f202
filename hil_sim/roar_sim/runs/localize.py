"""A simulated car that knows only what a real one measures: its odometry (a wheel encoder and a
gyro, roar_sim.sensors.odometry) and its lidar's scans (roar_sim.sensors.lidar.Lidar), fed to the
particle filter (roar.localization) on the world's map. Its observe() is the filter's pose, so
any agent drives on it; the simulator's own pose is kept only to score the filter.

    car = LocalizedCar(robot, grid, seed=1)            # grid: the known map (roar.tracks.occupancy_map)
    Runner(car, agent, PERIOD_S).run(...)
    car.errors                                         # (t, position error [m], heading error [rad]) per period
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from roar.autopilot import Command, Observation
from roar.localization import Odometry, ParticleFilter
from roar.autopilot.open_way import OpenWay
from roar.localization.local_grid import LocalGrid
from roar.tracks.occupancy_map import OccupancyMap
from roar.tracks.track import Track
from roar_sim.core.lockstep import CONTROL_PERIOD_S
from roar_sim.robots import Robot
from roar_sim.sensors.lidar import Lidar
from roar_sim.sensors.odometry import WheelOdometry
from roar_sim.world.scene import world_map

SCAN_PERIOD_S = 0.04  # [s] the lidar's scans at 25 Hz (a UST-10LX gives 40 Hz)
SCAN_BEAMS = 1080  # the lidar's beams (the filter uses `beams` of them)
PARTICLES = 1000  # the filter's particles in a race (the benchmark measures 2,500)
BEAMS = 60  # beams of each scan the filter weighs
SCORED_ERROR_M = 0.3  # [m] a global start has converged once the error stays below this


@dataclass
class LocalizationLog:
    """What the filter did in a run, against the simulator's truth (for scoring only)."""

    times_s: list[float] = field(default_factory=list)
    position_error_m: list[float] = field(default_factory=list)
    heading_error_rad: list[float] = field(default_factory=list)
    estimated: list[tuple[float, float, float]] = field(default_factory=list)
    true: list[tuple[float, float, float]] = field(default_factory=list)
    odometry: list[tuple[float, float, float]] = field(default_factory=list)
    fit: list[float] = field(default_factory=list)  # share of the last scan's beams agreeing with the map
    localized: list[bool] = field(default_factory=list)  # whether the filter said it was localized
    particles: np.ndarray | None = None  # (P, 3) at the end
    count: int = 0  # the filter's particles
    beams: int = 0  # beams a scan it weighed
    global_start: bool = False
    converged_at_s: float | None = None  # [s] when the filter first declared itself localized (a global start)
    skipped_beams: int = 0  # beams no measurement (NaN, negative, below the minimum range)
    restarts: int = 0  # global restarts after the filter found itself lost
    unsure: str = ""  # the last time it would have been localized but a look-alike place fitted as well: why
    challenges: int = 0  # times that happened
    odometry_scale: float = 1.0  # the odometry's scale the filter learnt (its distances times this)

    def rms_position_m(self, after_s: float = 0.0) -> float:
        e = np.array([e for t, e in zip(self.times_s, self.position_error_m) if t >= after_s])
        return float(np.sqrt(np.mean(e ** 2))) if e.size else math.nan

    def rms_heading_rad(self, after_s: float = 0.0) -> float:
        e = np.array([e for t, e in zip(self.times_s, self.heading_error_rad) if t >= after_s])
        return float(np.sqrt(np.mean(e ** 2))) if e.size else math.nan

    def max_position_m(self, after_s: float = 0.0) -> float:
        e = [e for t, e in zip(self.times_s, self.position_error_m) if t >= after_s]
        return max(e) if e else math.nan

    def first_within(self, error_m: float, after_s: float = 0.0) -> float | None:
        """[s] the first time at or after after_s from which the position error stays below
        error_m to the end of the run (None: it never does)."""
        last_bad = None
        for t, e in zip(self.times_s, self.position_error_m):
            if t >= after_s and e >= error_m:
                last_bad = t
        later = [t for t in self.times_s if t >= after_s and (last_bad is None or t > last_bad)]
        return later[0] if later else None


    def summary(self) -> str:
        """The filter's error in a line (or two), for the race's report."""
        if not self.times_s:
            return "localization: no estimate"
        odo, true = np.array(self.odometry), np.array(self.true)
        drift = float(np.hypot(*(odo[-1, :2] - true[-1, :2])))
        after = 0.0
        start = "started at the start pose"
        if self.global_start:
            after = self.first_within(SCORED_ERROR_M) or math.inf
            start = (f"global start, within {SCORED_ERROR_M:g} m from {after:.2f} s on" if math.isfinite(after) else
                     f"global start, never within {SCORED_ERROR_M:g} m for good")
        line = (f"localization ({self.count} particles x {self.beams} beams, lidar at {1 / SCAN_PERIOD_S:.0f} Hz, "
                f"{start}): position error RMS {self.rms_position_m(after):.3f} m, max "
                f"{self.max_position_m(after):.3f} m; heading RMS {math.degrees(self.rms_heading_rad(after)):.2f} deg; "
                f"odometry alone ended {drift:.2f} m off (scale learnt {self.odometry_scale:.3f})")
        if self.restarts:
            line += f"; lost and restarted over the whole map {self.restarts} times"
        if self.challenges:
            line += f"; unsure {self.challenges} times ({self.unsure})"
            if self.localized and not self.localized[-1]:
                line += ", still at the end"
        if self.skipped_beams:
            line += f"; {self.skipped_beams} beams skipped (no measurement)"
        return line

    def draw(self, ax) -> None:
        """The true and estimated paths and the last particles on a track's axes."""
        est, true = np.array(self.estimated), np.array(self.true)
        ax.plot(true[:, 0], true[:, 1], color="black", lw=0.8, label="true path")
        ax.plot(est[:, 0], est[:, 1], color="tab:red", lw=0.8, ls="--", label="filter's path")
        if self.particles is not None and len(self.particles):
            p = self.particles[:: max(1, len(self.particles) // 500)]
            ax.scatter(p[:, 0], p[:, 1], s=2, color="tab:orange", label="particles (end)", zorder=5)


@dataclass(frozen=True)
class Localize:
    """How a race localizes: the known map is the track's world's (roar_sim.world.scene.world_map:
    its walls only), the filter's particles and beams, a global start, the sensors' seed."""

    track: Track
    particles: int = PARTICLES
    beams: int = BEAMS
    global_start: bool = False
    seed: int = 1

    def car(self, robot: Robot) -> LocalizedCar:
        return LocalizedCar(robot, world_map(self.track), self.seed, self.particles, self.beams,
                            start=None if self.global_start else "true")


class LocalizedCar:
    """The robot as the Runner drives it, its pose the filter's. start: the pose the filter
    starts round (None: a global start, anywhere in the free space). local_grid: a grid each
    scan is added to, from the lidar's pose by the filter (what the map lacks, round the car).
    oracle: the pose is the simulator's own (no filter runs; the local grid is fed from the true
    lidar pose): the same stack with a perfect localization, to compare against. explore: set by
    a driver that has lost its way, the car heads for the open way as while not localized; towards:
    a world point [m] the open way is sought nearest to (the course's direction), else ahead.
    others: the plants of the other cars in its world, which its lidar meets by their footprints."""

    def __init__(self, robot: Robot, grid: OccupancyMap, seed: int | None = None, particles: int = PARTICLES,
                 beams: int = BEAMS, start: tuple[float, float, float] | None | str = "true",
                 local_grid: LocalGrid | None = None, oracle: bool = False) -> None:
        self.robot = robot
        self.sensors = WheelOdometry(robot.plant, seed)
        self.lidar = Lidar(robot.plant, None if seed is None else seed + 1, SCAN_BEAMS)
        self.others: list = []
        s = robot.state()
        profile = getattr(robot.plant, "profile", None)  # encoders on the front wheels, the pose at the rear axle
        self.odometry = Odometry((s.x, s.y, s.yaw), profile.wheelbase_m if profile is not None else 0.0)
        self.filter = ParticleFilter(grid, particles, beams, sensor=robot.plant.lidar_mount(), seed=seed)
        self.setup = {"particles": particles, "beams": beams, "seed": seed, "sensor": list(robot.plant.lidar_mount()),
                      "start": None}  # what a replay needs to run the same filter (roar.replay.localize)
        if start is None:
            self.filter.start_global()
        else:
            self.setup["start"] = list((s.x, s.y, s.yaw) if start == "true" else start)
            self.filter.start_at(tuple(self.setup["start"]))
        self.local_grid = local_grid
        self.oracle = oracle
        self.explore = False
        self.towards: tuple[float, float] | None = None
        self.log = LocalizationLog(count=particles, beams=beams, global_start=start is None)
        self.exploring = start is None  # creeping along the open way until the filter is localized
        self._next_scan_s = 0.0
        self._last: tuple[float, float] | None = None  # (t [s], travelled [m])
        self.scan = None  # the last scan
        self._speed = 0.0  # [m/s] by the odometry
        self._open_way = OpenWay()  # drives while exploring
        self.odo, self.scanned = None, False

    @property
    def time_s(self) -> float:
        return self.robot.time_s

    def observe(self) -> Observation:
        t = self.robot.time_s
        travelled, rate = self.sensors.read(t)
        odo = self.odometry.update(t, travelled, rate)
        self.odo, self.scanned = odo, False  # what the filter was given this period
        truth = self.robot.state()
        if not self.oracle:
            self.filter.predict(odo)
        if t + 1e-9 >= self._next_scan_s:
            self.scan = self.lidar.scan(t, self.others)
            if self.oracle:
                self.filter.start_at((truth.x, truth.y, truth.yaw))
            else:
                self.filter.correct(self.scan)
                self.scanned = True
            if self.local_grid is not None:
                self.local_grid.update(self.scan, self.filter.sensor_pose())
            self._next_scan_s = t + SCAN_PERIOD_S
        speed = 0.0 if self._last is None or t <= self._last[0] else (travelled - self._last[1]) / (t - self._last[0])
        self._last, self._speed = (t, travelled), abs(speed)
        x, y, yaw = (truth.x, truth.y, truth.yaw) if self.oracle else self.filter.pose
        log = self.log
        log.times_s.append(t)
        log.position_error_m.append(math.hypot(x - truth.x, y - truth.y))
        log.heading_error_rad.append(abs(math.remainder(yaw - truth.yaw, math.tau)))
        log.estimated.append((x, y, yaw))
        log.true.append((truth.x, truth.y, truth.yaw))
        log.odometry.append(odo)
        log.fit.append(self.filter.fit)
        log.localized.append(self.filter.localized)
        log.particles = self.filter.poses
        log.skipped_beams = self.filter.skipped_beams
        self.exploring = self.explore or not (self.oracle or self.filter.localized)
        if self.filter.localized and log.converged_at_s is None:
            log.converged_at_s = t
        log.restarts = self.filter.restarts
        log.odometry_scale = self.filter.odometry_scale
        log.challenges, log.unsure = self.filter.challenges, self.filter.unsure or log.unsure
        return Observation(t, x, y, yaw, abs(speed), rate)

    def send(self, command: Command) -> None:
        """The driver's command; while the filter is not localized (a global start, or lost), the
        car instead heads for the open way ahead (roar.autopilot.open_way: its pose means nothing
        yet), towards the course's next point once the pose is good enough for that."""
        if self.exploring and self.scan is not None:
            want = 0.0
            if self.towards is not None and self.filter.localized:
                x, y, yaw = self.filter.sensor_pose()
                want = math.remainder(math.atan2(self.towards[1] - y, self.towards[0] - x) - yaw, math.tau)
            command = self._open_way.command(self.scan, self._speed, want)
        else:
            self._open_way.reset()
        self.robot.send(command)

    def wait(self, seconds: float) -> None:
        self.robot.wait(seconds)


def kidnap(robot: Robot, pose: tuple[float, float, float]) -> None:
    """Carry the car to `pose` (x, y, yaw) in the simulator, at rest, without telling anyone."""
    from roar_sim.world.bullet import pb

    c = robot.plant.client
    x, y, yaw = pose
    z = pb.getBasePositionAndOrientation(robot.plant.car, physicsClientId=c)[0][2]
    pb.resetBasePositionAndOrientation(robot.plant.car, [x, y, z], pb.getQuaternionFromEuler([0, 0, yaw]),
                                       physicsClientId=c)
    pb.resetBaseVelocity(robot.plant.car, [0, 0, 0], [0, 0, 0], physicsClientId=c)




@dataclass
class KidnapRun:
    log: LocalizationLog
    at_s: float  # [s] when the car was carried off
    ahead_m: float  # [m] how far along the track
    wall_contacts: int = 0  # control periods touching a wall
    done: bool = False  # carried off yet

    def relocalized_after_s(self, within_m: float = SCORED_ERROR_M) -> float | None:
        """[s] after the kidnap until the error stays below within_m (None: it never does)."""
        t = self.log.first_within(within_m, self.at_s)
        return None if t is None else t - self.at_s


def kidnap_run(track: Track, at_s: float = 6.0, ahead_m: float = 5.0, seconds: float = 20.0, seed: int = 1,
               particles: int = PARTICLES, robot: str = "esc") -> KidnapRun:
    """The robot laps `track` on the filter's pose; at at_s it is carried ahead_m further along
    the centre line (on it, facing along it, at rest) without a word to the filter."""
    from roar.autopilot import Runner
    from roar_sim import robots

    with robots.get(robot)(track) as bot:
        bot.arm()
        car = Localize(track, particles, seed=seed).car(bot)
        run = KidnapRun(car.log, at_s, ahead_m)

        def on_step(obs: Observation, command: Command) -> None:
            run.wall_contacts += bot.touching_wall()
            if obs.t_s >= at_s and not run.done:
                s = bot.state()
                _, along, _ = track.project((s.x, s.y), heading=s.yaw)
                kidnap(bot, track.pose_at(along + ahead_m))
                run.done = True

        Runner(car, bot.agent(track.centerline, 0.9), CONTROL_PERIOD_S).run(until=lambda obs: obs.t_s >= seconds,
                                                                            on_step=on_step)
    return run
