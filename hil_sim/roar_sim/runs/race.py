"""Race a simulated robot: its default driver (roar.autopilot) laps a track through its firmware
(commands at 50 Hz, lockstep), measured against the track's physical-limit lap time for that
robot.

    roar race [--robot esc|iarrc|junior] [--track NAME|FILE] [--laps 2]
              [--line centre|optimal|RACELINE.csv] [--waypoints FILE] [--margin 0.9] [--k-dd S] [--steering pursuit|pid] [--driver line|lane]
              [--start-lights SEED] [--boxes N] [--avoid] [--frames DIR] [--shaky-camera SEED]
              [--renderer tiny|rays|egl] [--plot out/race.png]
              [--realtime] [--gui]

Every command reaches the robot as a host's does (roar_sim.robots): the ESC car hears control
messages on its serial port; the IARRC car speed setpoints (its own PID holds them); the ROAR
Junior one GET of its control route each, pure pursuit's curvature mixed into wheel duties.

Prints lap times, their ratio to the physical limits (the centre line's and the minimum-curvature
racing line's, roar.autopilot.racing_line), the maximum and RMS cross-track error and wall contacts, and plots the driven path coloured by speed beside the speed along the track.

Exit status: 0 when every lap was driven; 1 for bad input (track, waypoints, options) or a
simulator that cannot start, with a one-line error; 2 when the race ran but completed fewer
laps than asked, with a one-line reason (time limit, wall contacts, distance covered).
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from contextlib import ExitStack
from pathlib import Path

import numpy as np

from roar.autopilot import Command, Observation, Runner, WaypointError, load_waypoints, speed_profile
from roar.cli.sdk import (ArgumentParser, ExitStatus, add_foxglove_option, number_option, path_option, run_command,
                          seed_option)
from roar.tracks import Track, TrackError, get
from roar.tracks.track_files import load_raceline_csv
from roar.user_files import unusable_folder
from roar_sim import robots
from roar_sim.core.lockstep import CONTROL_PERIOD_S as PERIOD_S
from roar_sim.runs.lane_course import LaneCourse
from roar_sim.runs.localize import PARTICLES as LOCALIZE_PARTICLES
from roar_sim.runs.localize import Localize
from roar_sim.runs.progress import laps_bar
from roar_sim.runs.race_result import (TRACKING_MARGIN_M, RaceResult, Stop, optimal_line, plot,  # noqa: F401
                                      race_timeout_s, report)  # (importable here too)
from roar_sim.world import plotting
from roar_sim.world import renderer as renderers
from roar_sim.world.obstacles import MIN_GAP_M, box_course
from roar_sim.world.start_lights import GREEN_AFTER_S

MARGIN_RANGE = (0.3, 1.0)  # fraction of the robot's limits a race may be driven at
K_DD_RANGE_S = (0.05, 2.0)  # [s] pure pursuit's look-ahead per m/s a race may use
DRAG_TOP_SPEED_M_S = 4.0  # [m/s] the drag race's speed unless asked (the IARRC car's limit is 4.51)
TOP_SPEED_RANGE_M_S = (0.5, 4.5)  # [m/s] what a drag race may ask for
STEERING = {"pursuit": "pure pursuit", "pid": "the heading PID"}  # a robot's laterals, in words
STILL_M_S = 0.05  # [m/s] slower than this, a stopped car stands where it is
MAX_PARTICLES = 100_000  # the filter's particles a race may ask for


def check_line(track: Track, line: np.ndarray) -> None:
    """A waypoint line must lie on the track and run its way round (the car starts on the centre
    line's first point facing the second); WaypointError with a one-line reason otherwise."""
    segments, positions, ctes = track.follow(line)
    for i, (point, seg, cte) in enumerate(zip(line, segments, ctes)):
        half = track.half_widths_at(int(seg))[0 if cte > 0 else 1]
        if abs(cte) > half:
            raise WaypointError(f"waypoint {i + 1} at ({point[0]:.2f}, {point[1]:.2f}) is {abs(cte):.2f} m from "
                                f"the centre line, outside the track (its wall is {half:.2f} m from it there)")
    if track.arc_delta(positions, np.roll(positions, -1)).sum() < 0:
        raise WaypointError("the waypoints run against the track's direction (the car starts facing along the "
                            "centre line from its first point): reverse their order")


def race(track: Track, laps: int = 2, waypoints: np.ndarray | None = None, margin: float = 0.9, robot: str = "esc",
         realtime: bool = False, gui: bool = False, progress: bool = False, timeout_s: float | None = None,
         lateral: str = "pursuit", start_lights: int | None = None, boxes: Sequence[tuple[float, float]] = (),
         avoid: bool = False, frames: Path | None = None, k_dd_s: float | None = None,
         profile: str | None = None, renderer: str | None = None, shaky_camera: int | None = None,
         green_span_s: tuple[float, float] = GREEN_AFTER_S, localize: Localize | None = None,
         log: Path | None = None, serve_port: int | None = None, plan_profile=None) -> RaceResult:
    """Race `robot` (a name of roar_sim.robots) round `track`, its commands as a host sends them.
    lateral: its steering ("pursuit", "pid" where it has it), or "lane": the ESC car driving by
    its camera alone, and with it start_lights (a seed: start lights turn green at a moment drawn
    from it, and the car waits for them), avoid (a TFmini on its nose, keeping to a lane and
    changing lanes for what is ahead), frames (a folder the driver's frames are written to).
    boxes: (distance along the centre line, offset to its left) [m] of each box. k_dd_s: pure
    pursuit's look-ahead per m/s [s] (None: the robot's default). profile: the robot's profile
    (a racecar's: roar_sim.plants.car_profile; the Junior's: roar_sim.plants.junior_profile; a
    name or a .toml; None: the robot's default). renderer: what draws the
    camera's frames ("rays", "egl", "tiny"; None: roar_sim.world.renderer.wanted()). shaky_camera: a seed:
    the lane driver's camera mount shakes and its sensor adds noise (roar_sim.sensors.camera_noise).
    green_span_s: [s] the span the start lights' green moment is drawn from. localize: the driver
    drives on the particle filter's pose (roar_sim.runs.localize: odometry and lidar on the
    track's map) instead of the simulator's; the simulator's pose then only scores. log: an MCAP
    file the run is recorded into (roar_sim.links.sim_log: what the host sent and heard, the
    firmware's outputs, contacts, and the particle filter's pose and particles where it drives);
    serve_port: the same channels served live (Foxglove WebSocket on 127.0.0.1). plan_profile:
    the profile the autopilot plans its speeds and steering by (None: the car's own), e.g. a
    fitted one driving the car it was fitted to; the physical limits scored against stay the car's."""
    kind = robots.get(robot)
    if lateral == "lane" and not kind.lane_driving:
        raise ValueError(f"the {kind.title} does not drive by its camera: lane driving is the ESC car's")
    if lateral not in (*kind.laterals, "lane"):
        raise ValueError(f"the {kind.title} steers by {' or '.join(STEERING[k] for k in kind.laterals)} only, "
                         f"not {lateral!r}")
    if localize is not None and (lateral == "lane" or not kind.has_lidar):
        raise ValueError(f"--localize drives by a lidar's pose on the map: the line driver of a car with a lidar "
                         f"(the ESC or IARRC car), not the {'lane driver' if lateral == 'lane' else kind.title}")
    if (start_lights is not None or avoid or frames or shaky_camera is not None) and lateral != "lane":
        raise ValueError("start lights, the TFmini, writing frames and a shaky camera are for the lane driver (the ESC car "
                         "driving by its camera)")
    kind.check_track(track, profile)  # a bend it cannot turn: one line, before anything is built
    line = track.centerline if waypoints is None else np.asarray(waypoints)[:, :2]
    if waypoints is not None:
        check_line(track, line)
    bar = None
    with ExitStack() as stack:
        stack.enter_context(renderers.chosen(renderer))
        car = stack.enter_context(kind(track, realtime=realtime, gui=gui, **({"profile": profile} if profile else {})))
        world = car.plant.world
        sim_log = None
        if log is not None or serve_port is not None:
            from roar_sim.links.sim_log import SimLog

            sim_log = SimLog(car, log, {"driver": lateral}, serve_port)
            stack.callback(sim_log.close)  # finished however the race ends
        course = (LaneCourse(car, start_lights, boxes, avoid, frames, shaky_camera, green_span_s)
                  if lateral == "lane" else None)
        if course is not None:
            course.log = sim_log
        result = RaceResult(track, speed_profile(track.centerline, car.limits), robot=robot, boxes=len(boxes),
                            racing_limit_lap_s=optimal_line(track, robot).lap_time_s(car.limits))
        if waypoints is not None:
            result.line, result.line_speeds = line, speed_profile(line, car.limits)
        lights = course.lights if course else None
        result.green_at_s = lights.green_at_s if lights else None
        timeout_s = timeout_s or race_timeout_s(result, laps) + (result.green_at_s or 0.0)
        lap = {"hint": None, "s": 0.0, "travelled": 0.0, "start": 0.0}

        def on_step(obs: Observation, command: Command) -> None:
            if result.green_at_s is not None and result.moved_at_s is None:
                result.green_frames += obs.t_s >= result.green_at_s
                if command.throttle > 0:  # the race starts now: the first lap is timed from here
                    result.moved_at_s = lap["start"] = obs.t_s
            if localized is not None:  # the race is scored on where the car truly is
                truth = car.state()
                obs = Observation(obs.t_s, truth.x, truth.y, truth.yaw, abs(truth.speed), truth.yaw_rate)
            hint, s_now, cte = track.project((obs.x, obs.y), lap["hint"], heading=obs.yaw)
            lap.update(hint=hint, s=s_now, travelled=lap["travelled"] + track.arc_delta(lap["s"], s_now))
            result.travelled_m = lap["travelled"]
            result.cross_track_m.append(cte)
            result.path.append((obs.x, obs.y, obs.speed, max(0.0, lap["travelled"]) % track.length_m, obs.t_s))
            result.wall_contacts += car.touching_wall()
            result.box_contacts += bool(boxes) and course.touching_box()
            result.cone_contacts += car.touching(world.cones)
            result.people_contacts += car.touching(world.people)
            result.braking_periods += car.braking()
            result.slowest_m_s = min(result.slowest_m_s, car.state().speed)
            if lap["travelled"] >= track.length_m * (len(result.lap_times_s) + 1):
                result.lap_times_s.append(obs.t_s - lap["start"])
                lap["start"] = obs.t_s
            if bar:
                bar.update(max(0.0, min(laps, lap["travelled"] / track.length_m) - bar.n))
            if sim_log is not None:
                sim_log.step()
                if localized is not None:
                    sim_log.localization(localized)

        bar = laps_bar(laps, f"racing {track.name}") if progress else None  # once the simulator is up
        if plan_profile is not None:
            car.plan_by(plan_profile)
        car.arm()
        agent = course.agent(margin) if course else car.agent(line, margin, lateral, k_dd_s)
        localized = localize.car(car) if localize is not None else None
        result.localization = localized.log if localized is not None else None
        if course:
            planner = agent.planner

            def on_lane_step(obs: Observation, command: Command) -> None:
                on_step(obs, command)
                if sim_log is not None:
                    sim_log.driver_state(planner.state.value)
                stopped = planner.state.name in ("STOPPED", "OBSTACLE")
                open_stop = result.stops and result.stops[-1].until_s is None
                if stopped and not open_stop:
                    result.stops.append(Stop(planner.state.value, lap["s"], obs.t_s))
                elif open_stop and not stopped:
                    result.stops[-1].until_s = obs.t_s
                elif open_stop and abs(obs.speed) > STILL_M_S:  # still rolling to a stop: it stands further on
                    result.stops[-1].at_m = lap["s"]
        Runner(localized or car, agent, PERIOD_S).run(
            until=lambda obs: len(result.lap_times_s) >= laps or obs.t_s >= timeout_s,
            on_step=on_lane_step if course else on_step)
        car.wait(PERIOD_S)
    if bar:
        bar.close()
    return result


def parser() -> argparse.ArgumentParser:
    p = ArgumentParser(prog="roar race", description=__doc__)
    p.add_argument("--robot", choices=robots.names(), default="esc",
                   help="which robot races: the ESC car (default), the IARRC car (by speed), the ROAR Junior (over "
                        "its HTTP control route)")
    p.add_argument("--seconds", type=float, default=None, metavar="S",
                   help="time limit in simulated seconds (default: 4 x the physical-limit laps + 10)")
    p.add_argument("--track", default=None,
                   help="oval, figure-eight, course (long straights, for boxes), random:SEED[,length=MIN-MAX,width=M,radius=M,"
                        "straightness=0..1], circuit:SEED[,length=MIN-MAX,width=M] (a real circuit's shape, 260-490 m), "
                        "tunnel:SEED[,width=M,cones=N,markers=N,people=N], drag:LENGTH[,width=M,"
                        "stop=M] (a drag strip), or a file: .json, an F1TENTH/TUM centre-line .csv, a map .yaml "
                        "(default: oval; drag:40 for --event drag)")
    p.add_argument("--event", choices=["circuit", "drag"], default="circuit",
                   help="circuit: laps of the track (default); drag: the IARRC drag race, a straight lane flat out by "
                        "camera and gyro, then a stop before the end wall by the TFmini (--robot iarrc)")
    p.add_argument("--top-speed", type=number_option(*TOP_SPEED_RANGE_M_S, "m/s"), default=DRAG_TOP_SPEED_M_S,
                   metavar="M/S", help=f"with --event drag: the run's speed (default {DRAG_TOP_SPEED_M_S:g} m/s)")
    p.add_argument("--laps", type=int, default=2, help="laps to drive (default: 2)")
    p.add_argument("--line", default="centre", metavar="centre|optimal|FILE",
                   help="the line the driver follows: the centre line (default), the minimum-curvature racing line "
                        "(optimal), or a race line CSV in TUM's format (s_m; x_m; y_m; psi_rad; kappa_radpm; "
                        "vx_mps; ax_mps2)")
    p.add_argument("--waypoints", type=path_option, metavar="FILE",
                   help="follow this closed line (ROAR's waypoint file: x,y,z per line) instead of the centre line")
    p.add_argument("--margin", type=float, default=0.9, help="fraction of the robot's limits to drive at (default 0.9)")
    p.add_argument("--k-dd", type=float, default=None, metavar="S",
                   help="pure pursuit's look-ahead per m/s of speed [s] (default 0.35 for the cars, 0.5 for the "
                        "Junior; `roar sweep` tunes it)")
    p.add_argument("--steering", choices=["pursuit", "pid"], default="pursuit",
                   help="lateral control: pure pursuit (default) or the heading-error PID (not the Junior)")
    p.add_argument("--driver", choices=["line", "lane"], default="line",
                   help="line: follow the known centre line by the robot's pose (default); lane: the ESC car drives "
                        "by its camera alone (lane lines, no pose; the pose only scores)")
    p.add_argument("--start-lights", type=seed_option, metavar="SEED",
                   help="with --driver lane: start lights beside the track turn green at a moment drawn from SEED; "
                        "the car waits for green")
    p.add_argument("--boxes", type=int, default=0, metavar="N",
                   help="with --driver lane: N boxes on straight road, alternately in the right and the left lane "
                        "(--track course has room for 3 a lap)")
    p.add_argument("--avoid", action="store_true",
                   help="with --driver lane: the car carries a TFmini laser, keeps to the right lane and changes "
                        "lanes for what is ahead in it (IARRC's rule)")
    p.add_argument("--follow", action="store_true",
                   help="with --driver lane --avoid: ROAR's combined driver; a leader drives ahead (by its pose, "
                        "round the boxes) and tells its position over V2V; the camera car keeps its lane, changes "
                        "lanes round boxes, and keeps its gap to the leader while it is ahead in its lane; the "
                        "states and their transitions are printed (and plotted with --plot)")
    p.add_argument("--frames", type=path_option, metavar="DIR",
                   help="with --driver lane: write every frame the driver sees (PNG and depth .npy) to DIR, for "
                        "`roar vision DIR`")
    p.add_argument("--log", type=path_option, metavar="MCAP",
                   help="record the race into this MCAP file: every control message and line, the car's state, "
                        "the firmware's outputs, contacts, and with --localize the filter's pose and particles; "
                        "with --opponents also its scan, the cars it tracked, every opponent's pose, firmware and "
                        "contacts, the standings and who caused each contact "
                        "(open it in Foxglove, or `roar replay`)")
    add_foxglove_option(p, "the same channels", when="(the race then runs in real time, to be watched) ")
    p.add_argument("--car-profile", metavar="NAME|FILE",
                   help="the robot's own numbers: for the ESC and IARRC cars roar (the ESC car's), iarrc (the "
                        "IARRC car's), f1tenth (about 8 m/s) or a .toml (roar_sim/plants/car_profiles/, roar fit); "
                        "for the Junior junior or a .toml of its motors' strength and dead band "
                        "(roar_sim/plants/junior_profiles/); its limits are measured on first use")
    p.add_argument("--shaky-camera", type=seed_option, metavar="SEED",
                   help="with --driver lane: the camera's mount shakes (0.5 degrees a frame) and its sensor adds "
                        "noise, drawn from SEED, as on a real car")
    p.add_argument("--renderer", choices=renderers.RENDERERS, default=None,
                   help="what draws the lane driver's camera frames: rays (the default: each pixel's ray cast on "
                        "the paint, walls and solids, ~6x faster than tiny at 320x240; TinyRenderer where another "
                        "car is in the world), tiny (PyBullet's TinyRenderer) or egl (OpenGL without a window: 2.7x "
                        "faster than tiny at 640x480; tiny where it cannot start); also the environment's "
                        "ROAR_RENDERER")
    p.add_argument("--localize", action="store_true",
                   help="drive on the particle filter's pose instead of the simulator's: the car's odometry (wheel "
                        "encoders and gyro, with their errors) and its lidar's scans on the track's map "
                        "(roar.localization); prints the filter's error beside the lap times, and --plot draws its "
                        "particles and the estimated and true paths")
    p.add_argument("--particles", type=int, default=None, metavar="N",
                   help=f"with --localize: the filter's particles (default {LOCALIZE_PARTICLES})")
    p.add_argument("--global-start", action="store_true",
                   help="with --localize: the filter starts not knowing where the car is (particles over the whole "
                        "map) instead of at the start pose")
    p.add_argument("--opponents", type=int, default=None, metavar="N",
                   help="race N (1-5) other cars from a staggered grid, the ego at the back: it senses them by "
                        "its lidar alone, follows or passes them; prints positions, overtakes and each car-to-car "
                        "contact with the car that caused it (docs/racing.md)")
    p.add_argument("--opponent-pace", type=float, default=0.85, metavar="F",
                   help="with --opponents: the fraction of their limits (grip and top speed) they race at, 0.3-1 "
                        "(default 0.85)")
    p.add_argument("--opponent-line", choices=["centre", "racing", "defensive"], default="racing",
                   help="with --opponents: the line they follow: the centre line, the racing line (default), or a "
                        "defensive line that covers the inside before each bend")
    p.add_argument("--opponent-robot", default="esc", metavar="ROBOT[,ROBOT...]",
                   help="with --opponents: which robot each opponent is, esc (default) or iarrc (the IARRC car, driven "
                        "by speed setpoints its own PID holds); a list is given to the opponents in turn "
                        "(esc,iarrc: every other one an IARRC car)")
    p.add_argument("--opponent-driver", metavar="MODULE:CLASS",
                   help="with --opponents: drive them by your own class, called as CLASS(track=, line=, model=, "
                        "period_s=, pace=) and stepped as a roar.autopilot Module (setup(), step(observation) -> "
                        "Command)")
    p.add_argument("--plot", type=path_option, metavar="PNG", help="write the path and speed plot to this PNG")
    p.add_argument("--realtime", action="store_true", help="pace the simulation to the wall clock")
    p.add_argument("--gui", action="store_true", help="open the PyBullet window (needs a display)")
    return p


def main(argv: list[str] | None = None) -> int:
    p = parser()
    args = p.parse_args(argv)
    if args.event == "drag":
        return _drag(p, args)
    if args.top_speed != DRAG_TOP_SPEED_M_S:
        p.error("--top-speed is the drag race's: it needs --event drag")
    args.track = "oval" if args.track is None else args.track
    kind = robots.get(args.robot)
    if not 1 <= args.laps <= 100:
        p.error("--laps must be 1..100")
    if args.seconds is not None and not 1 <= args.seconds <= 36_000:
        p.error("--seconds must be 1..36000")
    if not MARGIN_RANGE[0] <= args.margin <= MARGIN_RANGE[1]:
        p.error(f"--margin must be {MARGIN_RANGE[0]:g}..{MARGIN_RANGE[1]:g}")
    if args.k_dd is not None and not K_DD_RANGE_S[0] <= args.k_dd <= K_DD_RANGE_S[1]:
        p.error(f"--k-dd must be {K_DD_RANGE_S[0]:g}..{K_DD_RANGE_S[1]:g} s")
    if args.k_dd is not None and (args.steering != "pursuit" or args.driver != "line"):
        p.error("--k-dd tunes pure pursuit: it needs the line driver steering by pursuit")
    if args.steering not in kind.laterals:
        p.error(f"--robot {args.robot} steers by {' or '.join(STEERING[k] for k in kind.laterals)} only")
    if args.driver == "lane" and (not kind.lane_driving or args.waypoints or args.line != "centre"):
        p.error("--driver lane drives the ESC car by its camera: no other --robot, no --waypoints or --line")
    if args.waypoints and args.line != "centre":
        p.error("--waypoints and --line both give the line to follow: choose one")
    if args.start_lights is not None and args.driver != "lane":
        p.error("--start-lights needs --driver lane (the car sees the lights through its camera)")
    if args.follow and (args.driver != "lane" or not args.avoid):
        p.error("--follow is ROAR's combined driver: it needs --driver lane --avoid")
    if args.follow and (args.start_lights is not None or args.frames or args.shaky_camera is not None or args.renderer
                        or args.foxglove):
        p.error("--follow runs two cars: not with --start-lights, --frames, --shaky-camera, --renderer or --foxglove")
    if args.shaky_camera is not None and args.driver != "lane":
        p.error("--shaky-camera shakes the lane driver's camera: it needs --driver lane")
    if args.renderer and args.driver != "lane":  # (the drag race's camera is the IARRC car's)
        p.error("--renderer draws the lane driver's camera: it needs --driver lane")
    if (args.boxes or args.avoid or args.frames) and args.driver != "lane":
        p.error("--boxes, --avoid and --frames need --driver lane (the car drives by its camera and laser)")
    if not 0 <= args.boxes <= 20:
        p.error("--boxes must be 0..20")
    if (args.particles is not None or args.global_start) and not args.localize:
        p.error("--particles and --global-start set up the particle filter: they need --localize")
    if args.particles is not None and not 1 <= args.particles <= MAX_PARTICLES:
        p.error(f"--particles must be 1..{MAX_PARTICLES}")
    if args.localize and (args.driver == "lane" or not kind.has_lidar):
        p.error(f"--localize drives the line driver by its lidar on the map: not with --driver lane, and a robot "
                f"with a lidar ({', '.join(n for n in robots.names() if robots.get(n).has_lidar)})")
    plotting.check_png_argument(p, args.plot)
    problem = args.frames is not None and unusable_folder(args.frames)
    if problem:
        p.error(f"--frames {problem}")
    if args.car_profile is not None:  # a bad profile fails here, in one line, before anything runs
        robots.get(args.robot).profile_of(args.car_profile)
    opponent_options = {"--opponent-pace": args.opponent_pace != 0.85,
                        "--opponent-line": args.opponent_line != "racing",
                        "--opponent-driver": args.opponent_driver is not None,
                        "--opponent-robot": args.opponent_robot != "esc"}
    if args.opponents is None and any(opponent_options.values()):
        p.error(f"{next(k for k, v in opponent_options.items() if v)} sets up the opponents: it needs --opponents N")
    if args.opponents is not None:
        from roar_sim.runs.head_to_head import MAX_OPPONENTS

        if not 1 <= args.opponents <= MAX_OPPONENTS:
            p.error(f"--opponents must be 1..{MAX_OPPONENTS}")
        if not (math.isfinite(args.opponent_pace) and 0.3 <= args.opponent_pace <= 1.0):
            p.error("--opponent-pace must be 0.3..1 (a fraction of their limits)")
        from roar_sim.runs.fleet import FLEET_ROBOTS

        wrong = [r for r in args.opponent_robot.split(",") if r not in FLEET_ROBOTS]
        if wrong:
            p.error(f"--opponent-robot: {wrong[0]!r} cannot race here: give {' or '.join(FLEET_ROBOTS)}, or a list of "
                    f"them (the Junior keeps a world of its own)")
        others = {"--robot": args.robot != "esc", "--driver lane": args.driver == "lane",
                  "--line": args.line != "centre",
                  "--waypoints": args.waypoints is not None, "--localize": args.localize,
                  "--car-profile": args.car_profile is not None,
                  "--steering pid": args.steering != "pursuit", "--k-dd": args.k_dd is not None, "--gui": args.gui}
        given = [k for k, v in others.items() if v]
        if given:
            p.error(f"{given[0]} is not for races with --opponents yet (the ego is the ESC car racing its racing line)")
    track = get(args.track)
    waypoints = None
    if args.line == "optimal":
        waypoints = optimal_line(track, args.robot).points
    elif args.line not in ("centre", "center"):
        waypoints = load_raceline_csv(args.line).points
        try:
            check_line(track, waypoints)
        except WaypointError as e:
            raise TrackError(f"{args.line}: {e}") from None
    if args.waypoints:
        waypoints = load_waypoints(args.waypoints)
        try:
            check_line(track, waypoints[:, :2])
        except WaypointError as e:  # name the file the waypoints came from
            raise WaypointError(f"{args.waypoints}: {e}") from None
    boxes = box_course(track, args.boxes)
    if len(boxes) < args.boxes:
        raise TrackError(f"track {track.name!r} has straight road for {len(boxes)} boxes (each needs {MIN_GAP_M:g} m "
                         f"from the next), not {args.boxes}: try --track course")
    if args.follow:
        return _combined(args, track, boxes)
    if args.foxglove is not None:  # a race run faster than real time would be over before a viewer connects
        args.realtime = True
        print(f"serving the race live in real time: Foxglove, Open connection, ws://127.0.0.1:{args.foxglove}",
              flush=True)
    if args.opponents is not None:
        return _head_to_head(args, track)
    result = race(track, args.laps, waypoints, args.margin, args.robot, args.realtime, args.gui, progress=True,
                  timeout_s=args.seconds, lateral="lane" if args.driver == "lane" else args.steering,
                  start_lights=args.start_lights, boxes=boxes, avoid=args.avoid, frames=args.frames, k_dd_s=args.k_dd,
                  profile=args.car_profile, renderer=args.renderer, shaky_camera=args.shaky_camera,
                  localize=Localize(track, args.particles or LOCALIZE_PARTICLES, global_start=args.global_start)
                  if args.localize else None, log=args.log, serve_port=args.foxglove)
    print(report(result))
    if result.path and args.plot and not plotting.save(lambda: plot(result), args.plot):
        return ExitStatus.ERROR
    shortfall = result.shortfall(args.laps, args.seconds or race_timeout_s(result, args.laps))
    if shortfall:
        print(f"race incomplete: {shortfall}", file=sys.stderr)
        return ExitStatus.SHORT
    return ExitStatus.OK


def _combined(args, track: Track, boxes) -> int:
    """roar race --driver lane --avoid --follow: the combined driver behind a leader."""
    from roar_sim.runs import combined

    result = combined.combined_race(track, args.laps, boxes, timeout_s=args.seconds, margin=args.margin, progress=True,
                                    log=args.log)
    print(combined.report(result))
    if args.plot and result.t and not plotting.save(lambda: combined.plot(result), args.plot):
        return ExitStatus.ERROR
    contacts = result.box_contacts + result.car_contacts + result.wall_contacts
    if result.laps < args.laps or contacts:
        print(f"combined run incomplete: {result.laps} of {args.laps} laps, {contacts} control periods in contact",
              file=sys.stderr)
        return ExitStatus.SHORT
    return ExitStatus.OK


def _head_to_head(args, track: Track) -> int:
    """roar race --opponents N: the ego against N other cars."""
    from roar_sim.runs import head_to_head as h2h

    driver = None
    if args.opponent_driver:
        driver = load_driver(args.opponent_driver)
    kinds = args.opponent_robot.split(",")
    rivals = [h2h.Rival(args.opponent_pace, args.opponent_line, driver, kinds[i % len(kinds)])
              for i in range(args.opponents)]
    result = h2h.head_to_head(track, rivals, args.laps, pace=args.margin, timeout_s=args.seconds, progress=True,
                              log=args.log, serve_port=args.foxglove, realtime=args.realtime)
    print(h2h.report(result))
    if args.plot and result.times_s and not plotting.save(lambda: h2h.plot(result), args.plot):
        return ExitStatus.ERROR
    laps = len(result.cars[0].lap_times_s)
    if laps < args.laps:
        print(f"race incomplete: the ego drove {laps} of {args.laps} laps", file=sys.stderr)
        return ExitStatus.SHORT
    return ExitStatus.OK


def load_driver(spec: str):
    """A user's driver class from "module:Class" (importable from the current folder too);
    UserError in one line where there is none."""
    import importlib
    import os

    from roar.cli.sdk import UserError

    module_name, _, class_name = spec.partition(":")
    if not module_name or not class_name:
        raise UserError(f"--opponent-driver {spec!r}: give MODULE:CLASS, e.g. my_driver:Cautious")
    if os.getcwd() not in sys.path:
        sys.path.insert(0, os.getcwd())
    try:
        module = importlib.import_module(module_name)
    except ImportError as e:
        raise UserError(f"--opponent-driver: cannot import {module_name!r}: {e}") from None
    except Exception as e:  # its own code failed on import: say where, in one line
        raise UserError(f"--opponent-driver: importing {module_name!r} failed: {type(e).__name__}: {e}") from None
    driver = getattr(module, class_name, None)
    if not callable(driver):
        raise UserError(f"--opponent-driver: {module_name!r} has no class {class_name!r}")
    return driver


def _drag(p, args) -> int:
    """roar race --event drag: one run of the IARRC car down a drag strip."""
    from roar_sim.runs import drag

    if args.robot != "iarrc":
        p.error("--event drag is the IARRC car's (its speed PID, encoder, gyro and TFmini): add --robot iarrc")
    lane_only = {"--driver lane": args.driver == "lane", "--start-lights": args.start_lights is not None,
                 "--boxes": bool(args.boxes), "--avoid": args.avoid, "--frames": args.frames is not None,
                 "--foxglove": args.foxglove is not None,
                 "--shaky-camera": args.shaky_camera is not None, "--waypoints": args.waypoints is not None,
                 "--line": args.line != "centre", "--k-dd": args.k_dd is not None,
                 "--car-profile": args.car_profile is not None, "--follow": args.follow}
    given = [name for name, on in lane_only.items() if on]
    if given:
        p.error(f"{given[0]} is not for the drag race (--event drag drives the strip by its own driver)")
    plotting.check_png_argument(p, args.plot)
    track = get("drag:40" if args.track is None else args.track)
    if not track.name.startswith("drag:"):
        raise TrackError(f"--event drag runs on a drag strip: --track drag:LENGTH[,width=M,stop=M], not {track.name!r}")
    result = drag.drag_race(track, args.top_speed, timeout_s=args.seconds, renderer=args.renderer, log=args.log)
    print(drag.report(result))
    if args.plot and result.x and not plotting.save(lambda: drag.plot(result), args.plot):
        return ExitStatus.ERROR
    if result.strip_time_s is None or not result.in_stop_zone:
        print("drag race incomplete: " + ("no finish" if result.strip_time_s is None else "it did not stop in the "
                                           "stop zone"), file=sys.stderr)
        return ExitStatus.SHORT
    return ExitStatus.OK


if __name__ == "__main__":
    sys.exit(run_command("roar race", main))
