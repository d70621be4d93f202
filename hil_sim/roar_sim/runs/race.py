"""Race a simulated robot: the autopilot's racing agent (roar.autopilot) drives N laps through
the firmware logic (commands at 50 Hz, lockstep), measured against the track's physical-limit
lap time for that robot.

    roar race [--junior] [--track oval|figure-eight|course|FILE.json] [--laps 2] [--waypoints FILE]
              [--margin 0.9] [--k-dd S] [--steering pursuit|pid] [--driver line|lane] [--start-lights SEED]
              [--boxes N] [--avoid] [--record DIR] [--plot out/race.png] [--realtime] [--gui]

The ESC car (default) hears control messages on its serial link. The ROAR Junior (--junior)
is driven as a user's script drives it: pure pursuit's curvature becomes wheel duties, each
period one GET of its control route over a kept-alive loopback HTTP connection (the http://
transport), answered by the Junior's firmware loop.

Prints lap times, their ratio to the physical limit, the maximum and RMS cross-track error and
wall contacts, and plots the driven path coloured by speed beside the speed along the track.

Exit status: 0 when every lap was driven; 1 for bad input (track, waypoints, options) or a
simulator that cannot start, with a one-line error; 2 when the race ran but completed fewer
laps than asked, with a one-line reason (time limit, wall contacts, distance covered).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from roar.autopilot import (Agent, CarLimits, Command, Observation, Runner, WaypointError, diff_drive_agent,
                            lap_time, load_waypoints, race_agent, speed_profile)
from roar.autopilot.pure_pursuit import PurePursuit
from roar.calibration import Calibration
from roar.protocol import spec
from roar_sim.world import plotting
from roar_sim.plants.esc_servo import EscMode
from roar_sim.robots.car_limits import SIMULATED_CAR
from roar_sim.core.library import CoreLoadError
from roar_sim.robots.esc import SimCar, SimConfig, SimError
from roar_sim.world.obstacles import MIN_GAP_M, box_course, place_boxes, touching
from roar_sim.world.start_lights import StartLights, green_moment
from roar_sim.sensors.tfmini import Tfmini
from roar_sim.world.track import Track, TrackError, get

PERIOD_S = spec.TIMING_HOST_SEND_PERIOD_US / 1e6  # [s] 50 Hz, like a real host
ROBOTS = ("car", "junior")
MARGIN_RANGE = (0.3, 1.0)  # fraction of the robot's limits a race may be driven at
K_DD_RANGE_S = (0.05, 2.0)  # [s] pure pursuit's look-ahead per m/s a race may use
LANE_CAMERA = (320, 240)  # [px] the camera the lane driver sees through


def observation(t_s: float, s) -> Observation:
    """What the autopilot observes of a simulated robot's state `s` at t_s [s]."""
    return Observation(t_s, s.x, s.y, s.yaw, abs(s.speed), s.yaw_rate)


class LockstepIO:
    """A simulated robot in lockstep as the runner's car: observed from the simulator, time moved
    by wait(); subclasses say how a command travels and which agent drives."""

    limits: CarLimits

    def __init__(self, sim, calibration: Calibration | None = None) -> None:
        self.sim, self.calibration = sim, calibration or Calibration()

    def observe(self) -> Observation:
        return observation(self.sim.time_s, self.sim.state())

    def send(self, command: Command) -> None:
        raise NotImplementedError

    def wait(self, seconds: float) -> None:
        self.sim.run(seconds)

    def agent(self, line: np.ndarray, margin: float, lateral: str, k_dd_s: float | None = None) -> Agent:
        """The driver; k_dd_s: pure pursuit's look-ahead per m/s [s] (None: the autopilot's default)."""
        raise NotImplementedError

    def touching_wall(self) -> bool:
        return self.sim.plant.wall_contacts() > 0

    def braking(self) -> bool:
        return False

    def signed_speed(self) -> float:
        return self.sim.state().speed


class SimIO(LockstepIO):
    """The ESC car: commands as control messages on its serial link; `lights`, the start lights
    beside the track, `boxes` on it, and its TFmini `laser`, if any."""

    limits = SIMULATED_CAR.limits

    def __init__(self, sim, calibration: Calibration | None = None, lights: StartLights | None = None,
                 boxes: list[int] | None = None, laser=None, record: Path | None = None) -> None:
        super().__init__(sim, calibration)
        self.lights, self.boxes, self.laser, self.record = lights, boxes or [], laser, record
        self._frames = 0

    def camera(self) -> tuple[np.ndarray, np.ndarray]:
        """The lane driver's frame (RGB, depth); with record, also written as NNNNNN.png and
        NNNNNN_depth.npy (metres), the folder `roar vision` reads."""
        rgb, depth = self.sim.plant.camera(*LANE_CAMERA)
        if self.record is not None:
            from roar.vision.geometry import cv2

            name = f"{self._frames:06d}"
            cv2().imwrite(str(self.record / f"{name}.png"), np.ascontiguousarray(rgb[:, :, ::-1]))
            np.save(self.record / f"{name}_depth.npy", depth)
            self._frames += 1
        return rgb, depth

    def send(self, command: Command) -> None:
        self.sim.write(self.calibration.message(command.throttle, command.steering))

    def agent(self, line: np.ndarray, margin: float, lateral: str, k_dd_s: float | None = None) -> Agent:
        if lateral == "lane":  # the camera alone: the line (and the pose) stay out of the control path
            from roar.autopilot.lane_agent import lane_agent
            from roar.vision.geometry import BirdsEye
            from roar.vision.lanes import LaneDetector
            from roar_sim.plants.racecar import camera_model

            w, h = LANE_CAMERA
            detector = LaneDetector(BirdsEye(camera_model(w, h)))
            start = None
            if self.lights is not None:
                from roar.vision.start_lights import StartLightDetector

                start = StartLightDetector()
            return lane_agent(self.camera, detector, SIMULATED_CAR, PERIOD_S, margin,
                              depth_camera=camera_model(w, h), start=start,
                              laser=self.laser.read if self.laser is not None else None)
        pursuit = None if k_dd_s is None else PurePursuit(SIMULATED_CAR.wheelbase_m, k_dd_s=k_dd_s)
        return race_agent(line, SIMULATED_CAR, PERIOD_S, margin=margin, lateral=lateral, pursuit=pursuit)

    def braking(self) -> bool:
        return self.sim.esc_mode in (EscMode.BRAKE, EscMode.REVERSE)

    def touching_box(self) -> bool:
        return touching(self.sim.plant, self.boxes) > 0


@dataclass
class RaceResult:
    track: Track
    limit_speeds: np.ndarray  # [m/s] the physical-limit speed at each centre-line point
    lap_times_s: list[float] = field(default_factory=list)
    cross_track_m: list[float] = field(default_factory=list)
    path: list[tuple[float, float, float, float, float]] = field(default_factory=list)  # (x, y, speed, arc length, t)
    robot: str = "car"  # "car" (the ESC car) or "junior"
    wall_contacts: int = 0  # control periods with the car touching a wall
    travelled_m: float = 0.0  # [m] net progress along the track, all laps
    braking_periods: int = 0  # control periods the ESC spent braking or reversing the motor
    slowest_m_s: float = 0.0  # [m/s] signed: negative if the car ever rolled backwards
    green_at_s: float | None = None  # [s] when the start lights turned green (None: no start lights)
    moved_at_s: float | None = None  # [s] when the car first asked for throttle
    green_frames: int = 0  # camera frames that showed green up to and including the one it moved on
    boxes: int = 0  # boxes on the track
    box_contacts: int = 0  # control periods with the car touching a box

    @property
    def false_start(self) -> bool:
        return self.green_at_s is not None and self.moved_at_s is not None and self.moved_at_s < self.green_at_s

    @property
    def max_cross_track_m(self) -> float:
        return max((abs(e) for e in self.cross_track_m), default=0.0)

    @property
    def rms_cross_track_m(self) -> float:
        return float(np.sqrt(np.mean(np.square(self.cross_track_m)))) if self.cross_track_m else 0.0

    @property
    def limit_lap_s(self) -> float:
        """[s] the physical-limit lap time of the track's centre line."""
        return lap_time(self.track.centerline, self.limit_speeds)

    def shortfall(self, laps: int, timeout_s: float) -> str | None:
        """Why fewer than `laps` laps were completed (one line), or None when all were."""
        done = len(self.lap_times_s)
        if done >= laps:
            return None
        reasons = [f"it touched a wall in {self.wall_contacts} control periods"] if self.wall_contacts else []
        if self.travelled_m < 0:
            reasons.append("it drove against the track's direction")
        return (f"{done} of {laps} laps within the {timeout_s:.0f} s time limit ({'; '.join(reasons) or 'too slow'}): "
                f"the car covered {max(0.0, self.travelled_m):.1f} m of the {laps * self.track.length_m:.1f} m asked")

    @property
    def best_ratio(self) -> float:
        """Best lap over the physical-limit lap (1.0 would be driving at the limit)."""
        return min(self.lap_times_s) / self.limit_lap_s if self.lap_times_s else float("inf")


def check_line(track: Track, line: np.ndarray) -> None:
    """A waypoint line must lie on the track and run its way round (the car starts on the centre
    line's first point facing the second); WaypointError with a one-line reason otherwise."""
    half = track.width_m / 2
    hint, positions = None, []
    for i, point in enumerate(line):
        hint, s_along, cte = track.project(point, None if hint is None else hint)
        if abs(cte) > half:
            raise WaypointError(f"waypoint {i + 1} at ({point[0]:.2f}, {point[1]:.2f}) is {abs(cte):.2f} m from "
                                f"the centre line, outside the track (half width {half:g} m)")
        positions.append(s_along)
    steps = (np.diff(positions + positions[:1]) + track.length_m / 2) % track.length_m - track.length_m / 2
    if steps.sum() < 0:
        raise WaypointError(f"the waypoints run against the track's direction (the car starts facing along the "
                            f"centre line from its first point): reverse their order")


def race(track: Track, laps: int = 2, waypoints: np.ndarray | None = None, margin: float = 0.9,
         config: SimConfig | None = None, progress: bool = False, timeout_s: float | None = None,
         lateral: str = "pursuit", robot: str = "car", start_lights: int | None = None,
         boxes: Sequence[tuple[float, float]] = (), avoid: bool = False, record: Path | None = None,
         k_dd_s: float | None = None) -> RaceResult:
    """Race `robot` ("car": the ESC car; "junior": the ROAR Junior over HTTP) round `track`.
    config's realtime and gui apply to either robot. The lane driver only: start_lights (a
    seed) -- start lights turn green at a moment drawn from the seed, and the car waits for
    them; avoid -- the car carries a TFmini and keeps to a lane, changing lanes for what is
    ahead; record -- a folder the driver's frames are written to. boxes: (distance along the
    centre line, offset to its left) [m] of each box. k_dd_s: pure pursuit's look-ahead per m/s
    [s] (None: the autopilot's default)."""
    if robot not in ROBOTS:
        raise ValueError(f"robot must be one of {', '.join(ROBOTS)}, got {robot!r}")
    if (start_lights is not None or avoid or record) and (robot != "car" or lateral != "lane"):
        raise ValueError("start lights, the TFmini and recording are for the lane driver (the ESC car driving by "
                         "its camera)")
    line = track.centerline if waypoints is None else np.asarray(waypoints)[:, :2]
    if waypoints is not None:
        check_line(track, line)
    config = config or SimConfig()
    bar = None
    car = _open_car(track, config, start_lights, boxes, avoid, record) if robot == "car" else \
        _open_junior(track, config)
    with car as io:
        result = RaceResult(track, speed_profile(track.centerline, io.limits), robot=robot, boxes=len(boxes))
        lights = getattr(io, "lights", None)
        result.green_at_s = lights.green_at_s if lights else None
        timeout_s = timeout_s or race_timeout_s(result, laps) + (result.green_at_s or 0.0)
        lap = {"hint": None, "s": 0.0, "travelled": 0.0, "start": 0.0}

        def record(obs: Observation, command: Command) -> None:
            if result.green_at_s is not None and result.moved_at_s is None:
                result.green_frames += obs.t_s >= result.green_at_s
                if command.throttle > 0:  # the race starts now: the first lap is timed from here
                    result.moved_at_s = lap["start"] = obs.t_s
            hint, s_now, cte = track.project((obs.x, obs.y), lap["hint"])
            ds = (s_now - lap["s"] + track.length_m / 2) % track.length_m - track.length_m / 2
            lap.update(hint=hint, s=s_now, travelled=lap["travelled"] + ds)
            result.travelled_m = lap["travelled"]
            result.cross_track_m.append(cte)
            result.path.append((obs.x, obs.y, obs.speed, s_now, obs.t_s))
            result.wall_contacts += io.touching_wall()
            result.box_contacts += bool(boxes) and io.touching_box()
            result.braking_periods += io.braking()
            result.slowest_m_s = min(result.slowest_m_s, io.signed_speed())
            if lap["travelled"] >= track.length_m * (len(result.lap_times_s) + 1):
                result.lap_times_s.append(obs.t_s - lap["start"])
                lap["start"] = obs.t_s
            if bar:
                bar.update(max(0.0, min(laps, lap["travelled"] / track.length_m) - bar.n))

        bar = _progress_bar(laps, track.name) if progress else None  # once the simulator is up
        io.send(Command(0.0, 0.0))  # arm: the ESC car boots latched until it hears neutral
        io.wait(PERIOD_S)
        Runner(io, io.agent(line, margin, lateral, k_dd_s), PERIOD_S).run(
            until=lambda obs: len(result.lap_times_s) >= laps or obs.t_s >= timeout_s, on_step=record)
        io.wait(PERIOD_S)
    if bar:
        bar.close()
    return result


@contextmanager
def _open_car(track: Track, config: SimConfig, start_seed: int | None = None,
              boxes: Sequence[tuple[float, float]] = (), avoid: bool = False, record: Path | None = None):
    with SimCar(track, config) as sim:
        lights = None
        if start_seed is not None:
            lights = StartLights(sim.plant.world, track, green_moment(start_seed))
            sim.plant.props.append(lights)
        laser = Tfmini(sim.plant) if avoid else None
        if record is not None:
            record.mkdir(parents=True, exist_ok=True)
        yield SimIO(sim, lights=lights, boxes=place_boxes(sim.plant.world, track, boxes), laser=laser, record=record)


@contextmanager
def _open_junior(track: Track, config: SimConfig):
    from roar_sim.runs.junior_race import JuniorIO

    with JuniorIO.serving(track, realtime=config.realtime, gui=config.gui) as io:
        yield io


def race_timeout_s(result: RaceResult, laps: int) -> float:
    """[s] how long a race may take: four times the physical-limit laps, plus 10 s."""
    return 4 * laps * result.limit_lap_s + 10


def _progress_bar(laps: int, name: str):
    from tqdm import tqdm

    return tqdm(total=laps, desc=f"racing {name}", unit="lap", mininterval=0.5, file=sys.stderr,
                bar_format="{desc}: {bar} {n:.2f}/{total} laps [{elapsed}]")


def report(result: RaceResult) -> str:
    tr = result.track
    who = "ROAR Junior (over HTTP)" if result.robot == "junior" else "ESC car"
    lines = [f"{who} on track {tr.name}: {tr.length_m:.1f} m, width {tr.width_m:.1f} m; "
             f"physical-limit lap {result.limit_lap_s:.2f} s"]
    for i, t in enumerate(result.lap_times_s, 1):
        lines.append(f"  lap {i}: {t:6.2f} s  ({tr.length_m / t:.2f} m/s average, "
                     f"{t / result.limit_lap_s:.2f} x the limit)")
    if result.green_at_s is not None:
        moved = ("never moved" if result.moved_at_s is None else "FALSE START" if result.false_start else
                 f"moved on the {result.green_frames}. frame that showed green "
                 f"({result.moved_at_s - result.green_at_s:.3f} s)")
        lines.append(f"start lights: green at {result.green_at_s:.2f} s; {moved}")
    lines.append(f"laps completed: {len(result.lap_times_s)}, total {sum(result.lap_times_s):.2f} s (simulated)")
    lines.append(f"cross-track error: max {result.max_cross_track_m:.3f} m, RMS {result.rms_cross_track_m:.3f} m")
    lines.append(f"wall contacts: {result.wall_contacts}")
    if result.boxes:
        lines.append(f"box contacts: {result.box_contacts} (control periods touching one of the {result.boxes} boxes)")
    if result.robot == "car":
        lines.append(f"braking: {result.braking_periods * PERIOD_S:.2f} s through the firmware's brake/reverse "
                     f"sequence (the ESC has no brake)")
    return "\n".join(lines)


def plot(result: RaceResult):
    """Left: the track and the driven path coloured by speed. Right: speed along the track for
    every lap against the physical-limit profile."""
    fig, (ax, ax_v) = plotting.subplots(ncols=2, figsize=(13, 5.5), gridspec_kw={"width_ratios": [1.2, 1]})
    plotting.draw_track(ax, result.track)
    p = np.array(result.path)
    plotting.draw_path(fig, ax, p[:, 0], p[:, 1], p[:, 2])
    ax.legend(loc="upper right", fontsize=8)
    ax_v.plot(result.track.arc_start, result.limit_speeds, color="black", lw=1.5, label="physical limit")
    ax_v.scatter(p[:, 3], p[:, 2], c=p[:, 2], s=3, cmap="viridis", label="driven")
    ax_v.set_xlabel("distance along the track [m]")
    ax_v.set_ylabel("speed [m/s]")
    ax_v.set_ylim(bottom=0)
    ax_v.legend(loc="lower right", fontsize=8)
    times = ", ".join(f"{t:.2f} s" for t in result.lap_times_s)
    who = "ROAR Junior" if result.robot == "junior" else "ESC car"
    fig.suptitle(f"{who}, {result.track.name}: laps {times} (limit {result.limit_lap_s:.2f} s, best "
                 f"{result.best_ratio:.2f} x); max cross-track {result.max_cross_track_m:.2f} m, "
                 f"wall contacts {result.wall_contacts}", fontsize=10)
    return fig


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="roar race", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--junior", action="store_true",
                        help="race the ROAR Junior (differential drive, over HTTP) instead of the ESC car")
    parser.add_argument("--seconds", type=float, default=None, metavar="S",
                        help="time limit in simulated seconds (default: 4 x the physical-limit laps + 10)")
    parser.add_argument("--track", default="oval", help="oval, figure-eight, course (long straights, for boxes), or a track .json file (default: oval)")
    parser.add_argument("--laps", type=int, default=2, help="laps to drive (default: 2)")
    parser.add_argument("--waypoints", type=Path, metavar="FILE",
                        help="follow this closed line (x,y,z per line) instead of the centre line")
    parser.add_argument("--margin", type=float, default=0.9,
                        help="fraction of the car's limits to drive at (default 0.9)")
    parser.add_argument("--k-dd", type=float, default=None, metavar="S",
                        help="pure pursuit's look-ahead per m/s of speed [s] (default 0.35 for the car, 0.5 for the "
                             "Junior; `roar sweep` tunes it)")
    parser.add_argument("--steering", choices=["pursuit", "pid"], default="pursuit",
                        help="lateral control: pure pursuit (default) or the heading-error PID")
    parser.add_argument("--driver", choices=["line", "lane"], default="line",
                        help="line: follow the known centre line by the car's pose (default); lane: drive by "
                             "the camera alone (lane lines, no pose; the pose only scores)")
    parser.add_argument("--start-lights", type=int, metavar="SEED",
                        help="with --driver lane: start lights beside the track turn green at a moment drawn "
                             "from SEED; the car waits for green")
    parser.add_argument("--boxes", type=int, default=0, metavar="N",
                        help="with --driver lane: N boxes on straight road, alternately in the right and the left "
                             "lane (--track course has room for 3 a lap)")
    parser.add_argument("--avoid", action="store_true",
                        help="with --driver lane: the car carries a TFmini laser, keeps to the right lane and "
                             "changes lanes for what is ahead in it (IARRC's rule)")
    parser.add_argument("--record", type=Path, metavar="DIR",
                        help="with --driver lane: write every frame the driver sees (PNG and depth .npy) to DIR, "
                             "for `roar vision DIR`")
    parser.add_argument("--plot", type=Path, metavar="PNG", help="write the path and speed plot to this PNG")
    parser.add_argument("--realtime", action="store_true", help="pace the simulation to the wall clock")
    parser.add_argument("--gui", action="store_true", help="open the PyBullet window (needs a display)")
    args = parser.parse_args(argv)
    if not 1 <= args.laps <= 100:
        parser.error("--laps must be 1..100")
    if args.seconds is not None and not 1 <= args.seconds <= 36_000:
        parser.error("--seconds must be 1..36000")
    if not MARGIN_RANGE[0] <= args.margin <= MARGIN_RANGE[1]:
        parser.error(f"--margin must be {MARGIN_RANGE[0]:g}..{MARGIN_RANGE[1]:g}")
    if args.k_dd is not None and not K_DD_RANGE_S[0] <= args.k_dd <= K_DD_RANGE_S[1]:
        parser.error(f"--k-dd must be {K_DD_RANGE_S[0]:g}..{K_DD_RANGE_S[1]:g} s")
    if args.k_dd is not None and (args.steering != "pursuit" or args.driver != "line"):
        parser.error("--k-dd tunes pure pursuit: it needs the line driver steering by pursuit")
    if args.junior and args.steering != "pursuit":
        parser.error("--junior steers by pure pursuit only (its wheel speeds set the curvature)")
    if args.driver == "lane" and (args.junior or args.waypoints):
        parser.error("--driver lane drives the ESC car by its camera: no --junior, no --waypoints")
    if args.start_lights is not None and args.driver != "lane":
        parser.error("--start-lights needs --driver lane (the car sees the lights through its camera)")
    if (args.boxes or args.avoid or args.record) and args.driver != "lane":
        parser.error("--boxes, --avoid and --record need --driver lane (the car drives by its camera and laser)")
    if not 0 <= args.boxes <= 20:
        parser.error("--boxes must be 0..20")
    plotting.check_png_argument(parser, args.plot)
    if args.record is not None:
        try:
            args.record.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            parser.error(f"--record {args.record}: {e.strerror or e}")
    try:
        track = get(args.track)
        waypoints = load_waypoints(args.waypoints) if args.waypoints else None
        boxes = box_course(track, args.boxes)
        if len(boxes) < args.boxes:
            raise TrackError(f"track {track.name!r} has straight road for {len(boxes)} boxes (each needs "
                             f"{MIN_GAP_M:g} m from the next), not {args.boxes}: try --track course")
        result = race(track, args.laps, waypoints, args.margin, SimConfig(realtime=args.realtime, gui=args.gui),
                      progress=True, lateral="lane" if args.driver == "lane" else args.steering,
                      timeout_s=args.seconds, robot="junior" if args.junior else "car",
                      start_lights=args.start_lights, boxes=boxes, avoid=args.avoid, record=args.record,
                      k_dd_s=args.k_dd)
    except (TrackError, WaypointError, CoreLoadError, SimError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    print(report(result))
    if result.path and args.plot and not plotting.save(lambda: plot(result), args.plot):
        return 1
    shortfall = result.shortfall(args.laps, args.seconds or race_timeout_s(result, args.laps))
    if shortfall:
        print(f"race incomplete: {shortfall}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
