"""A race against other cars: the ego (roar.racing.Racer: its racing line, passing what it
senses) and 1-5 opponents in one world, each car its own firmware board loop and serial link
(roar_sim.runs.fleet), from a staggered grid with the ego at the back. The ego knows the others
only through its lidar (roar.racing.detection and opponents); the simulator's truth only scores.

    result = head_to_head(get("random:3,width=2.2"), [Rival(pace=0.85)] * 2, laps=2)
    print(report(result))          # positions, laps, gaps, overtakes, contacts and who caused them

The opponents the race puts up (line followers at a pace) keep their gap to a car ahead in their
path (GapKeeping: the simulator tells them where the others are; they are the field, not the car
under test), so a faster opponent waits behind a slower one instead of driving through it.

Rules and scoring. Positions: laps, then distance. A car-to-car contact (a period of touching
between two cars) is attributed when it starts: to the car that moved sideways toward the other
by SIDEWAYS_M or more in the SIDEWAYS_S before; else to the car behind along the track if it was
closing; else to neither (a racing incident). Wall contacts are counted per car in control
periods. An overtake is the ego going from behind a car to ahead of it in distance raced.
"""

from __future__ import annotations

import contextlib
import math
from collections import deque
from dataclasses import dataclass, field, replace

import numpy as np

from roar.autopilot.agent import Module
from roar.autopilot.race_agent import CarModel, Plan, race_agent
from roar.autopilot.waypoints import LoopWaypointFollower
from roar.racing.detection import CarDetector
from roar.racing.lanes import segment_at
from roar.racing.opponents import Opponents
from roar.racing.racer import CAR_WIDTH_M, LOOK_AHEAD_MIN_M, LOOK_AHEAD_S, PASS_SIDE_M, Racer, follow_speed
from roar.tracks import Track, TrackError
from roar_sim.core.lockstep import CONTROL_PERIOD_S as PERIOD_S
from roar_sim.robots.esc import EscCar
from roar_sim.runs.fleet import FLEET_ROBOTS, Fleet
from roar_sim.runs.progress import laps_bar

MAX_OPPONENTS = 5
LINES = ("centre", "racing", "defensive")
GRID_GAP_M = 2.0  # [m] along the track between one grid slot and the next
GRID_SIDE_M = 0.25  # [m] each slot this far left or right of the centre line, alternately (staggered)
SIDEWAYS_M = 0.1  # [m] moved toward the other car in the SIDEWAYS_S before a contact: that car caused it
SIDEWAYS_S = 0.5  # [s]
CLOSING_M_S = 0.05  # [m/s] the car behind closing faster than this caused a contact
MERGE_M = 0.3  # [m] a car ahead this much further across than a car's width is still taken as in the way: line
# followers merge onto their line (from a staggered grid, out of a bend) without looking
TIMEOUT_PER_LAP_S = 8.0  # [s] on top of 3x the limit laps


@dataclass(frozen=True)
class Rival:
    pace: float = 0.85  # fraction of its limits it races at
    line: str = "racing"  # centre, racing (minimum curvature) or defensive (covers the inside before bends)
    driver: object = None  # a class: driver(track=, line=, model=, period_s=, pace=) -> a Module; None: line following
    robot: str = "esc"  # which robot it is (roar_sim.runs.fleet.FLEET_ROBOTS): the ESC car, or the IARRC car by speed


@dataclass
class Contact:
    t_s: float
    cars: tuple[int, int]
    caused_by: int | None  # the car that caused it (0: the ego), None: a racing incident
    why: str


@dataclass
class CarResult:
    name: str
    travelled_m: float = 0.0
    lap_times_s: list[float] = field(default_factory=list)
    wall_contacts: int = 0  # control periods touching a wall
    path: list[tuple[float, float]] = field(default_factory=list)


@dataclass
class HeadToHead:
    track: Track
    laps: int
    cars: list[CarResult]
    contacts: list[Contact] = field(default_factory=list)
    overtakes: int = 0  # by the ego
    passes_started: int = 0
    times_s: list[float] = field(default_factory=list)
    positions: list[list[int]] = field(default_factory=list)  # per period, each car's position (1 = leading)
    modes: list[str] = field(default_factory=list)  # the ego's: race, follow, pass
    gaps_ahead_m: list[float] = field(default_factory=list)  # [m] bumper to bumper, ego to the car ahead of it
    events: list[tuple[float, str]] = field(default_factory=list)  # (time [s], what the ego decided and why)

    def order(self) -> list[int]:
        """Car indices, leader first: laps, then distance."""
        return sorted(range(len(self.cars)), key=lambda i: -self.cars[i].travelled_m)

    def caused_by(self, car: int) -> list[Contact]:
        return [c for c in self.contacts if c.caused_by == car]


class GapKeeping(Module):
    """A line-following opponent's planner that keeps its gap to the nearest car ahead in its path
    (racer.follow_speed): `ahead` is set each period to (gap [m] centre to centre along the track,
    that car's speed [m/s]), or None when the way is clear."""

    def __init__(self, planner: Module, brake_m_s2: float) -> None:
        self.planner, self.brake_m_s2 = planner, brake_m_s2
        self.ahead: tuple[float, float] | None = None

    def setup(self) -> None:
        self.planner.setup()

    def step(self, value) -> Plan:
        plan = self.planner.step(value)
        if self.ahead is None:
            return plan
        limit = follow_speed(*self.ahead, self.brake_m_s2)
        return replace(plan, target_speed_m_s=min(plan.target_speed_m_s, limit))


def car_ahead(track: Track, now: list[tuple[float, float, float]], i: int) -> tuple[float, float] | None:
    """(gap [m] along the track, speed [m/s]) of the nearest car ahead of car i in its path (less
    than a car's width, PASS_SIDE_M and MERGE_M beside it, within LOOK_AHEAD_S of it at its speed),
    from each car's (s, d, speed) now; None: none is."""
    s, d, speed = now[i]
    reach = max(LOOK_AHEAD_MIN_M, LOOK_AHEAD_S * speed)
    gaps = [(float(track.arc_delta(s, sj)), vj) for j, (sj, dj, vj) in enumerate(now)
            if j != i and abs(dj - d) < CAR_WIDTH_M + PASS_SIDE_M + MERGE_M]
    ahead = [g for g in gaps if 0.0 < g[0] < reach]
    return min(ahead) if ahead else None


def grid(track: Track, cars: int, half_width_m: float) -> list[tuple[float, float, float]]:
    """Start poses, the first car at the track's start, each next GRID_GAP_M behind, alternately
    left and right of the centre line; TrackError in one line where the grid does not fit."""
    if (cars - 1) * GRID_GAP_M > track.length_m / 3:
        raise TrackError(f"a grid of {cars} cars is {(cars - 1) * GRID_GAP_M:.1f} m long: more than a third of "
                         f"track {track.name!r} ({track.length_m:.1f} m)")
    poses = []
    for i in range(cars):
        s = -i * GRID_GAP_M
        side = GRID_SIDE_M if i % 2 == 0 else -GRID_SIDE_M
        left, right = track.half_widths_at(segment_at(track, s))
        if side + half_width_m > left or half_width_m - side > right:
            raise TrackError(f"the grid does not fit track {track.name!r}: slot {i + 1}, {abs(side):g} m "
                             f"{'left' if side > 0 else 'right'} of its centre line, is wider than the track there")
        poses.append(track.pose_at(s, side))
    return poses


def check_race_track(track: Track) -> None:
    """Races with opponents are run on tracks that do not cross themselves (a crossing has cars
    meet side on): TrackError in one line otherwise."""
    import shapely

    if not shapely.LinearRing(track.centerline).is_simple:
        raise TrackError(f"track {track.name!r} crosses itself: races with opponents need a track that does not "
                         f"(try oval, course, random:SEED or circuit:SEED)")


def head_to_head(track: Track, rivals: list[Rival], laps: int = 2, pace: float = 0.9, timeout_s: float | None = None,
                 progress: bool = False, seed: int = 0, log=None, serve_port: int | None = None,
                 realtime: bool = False) -> HeadToHead:
    """The ego (car 0, at the back of the grid) races len(rivals) opponents for `laps` laps (the
    race ends when the ego has driven them, or at timeout_s). log: an MCAP file of the race
    (race_log: the ego's channels as a race alone records them, what it sensed and decided, and
    every opponent's); serve_port: the same channels served live to Foxglove; realtime: kept to
    the wall clock."""
    from roar.racing.lanes import Lanes
    from roar.localization.odometry import compose
    from roar_sim.runs.race_result import TRACKING_MARGIN_M, optimal_line
    from roar_sim.sensors.lidar import Lidar
    from roar_sim.world.scene import WALL_THICKNESS_M, world_map

    if not 1 <= len(rivals) <= MAX_OPPONENTS:
        raise ValueError(f"opponents must be 1..{MAX_OPPONENTS}, got {len(rivals)}")
    for r in rivals:
        if not (isinstance(r.pace, (int, float)) and math.isfinite(r.pace) and 0.3 <= r.pace <= 1.0):
            raise ValueError(f"an opponent's pace is a fraction of its limits, 0.3..1, got {r.pace!r}")
        if r.line not in LINES:
            raise ValueError(f"an opponent's line is one of {', '.join(LINES)}, got {r.line!r}")
        if r.robot not in FLEET_ROBOTS:
            raise ValueError(f"an opponent is one of the robots {', '.join(FLEET_ROBOTS)} (the Junior keeps a world of "
                             f"its own), got {r.robot!r}")
    check_race_track(track)
    EscCar.check_track(track)
    n = len(rivals) + 1
    poses = grid(track, n, EscCar.half_width_m)
    racing_points = optimal_line(track).points
    result = HeadToHead(track, laps, [CarResult("ego")] + [CarResult(f"car {i}") for i in range(1, n)])
    timeout_s = timeout_s or laps * (3 * track.length_m / 2.0 + TIMEOUT_PER_LAP_S)
    robots = ["esc"] + [r.robot for r in rivals]
    with Fleet(track, poses=list(reversed(poses)), robots=robots) as fleet:  # the ego at the back of the grid
        fleet.realtime = realtime
        cars = fleet.cars
        ego_car = cars[0]
        with contextlib.ExitStack() as stack:  # a recording finished whatever ends the race
            recording = stack.enter_context(RaceLog(ego_car, log, serve_port, n)) \
                if log is not None or serve_port is not None else None
            clearance = WALL_THICKNESS_M / 2 + TRACKING_MARGIN_M  # as the racing line keeps from the walls
            lanes = Lanes(track, EscCar.half_width_m, ego_car.model.limits, clearance)
            lines = {"centre": track.centerline, "racing": racing_points,
                     "defensive": lanes.line(lanes.defensive_offsets()).points}
            ego = Racer(track, racing_points, ego_car.model, PERIOD_S, pace=pace, clearance_m=clearance)
            drivers = [ego]
            keeping: dict[int, GapKeeping] = {}  # the line followers' planners, by car
            for car, rival in zip(cars[1:], rivals):
                line = lines[rival.line]
                if rival.driver is not None:
                    drivers.append(rival.driver(track=track, line=line, model=car.model, period_s=PERIOD_S,
                                                pace=rival.pace))
                else:
                    model = paced(car.model, rival.pace)
                    agent = race_agent(line, model, PERIOD_S, margin=1.0,
                                       follower=LoopWaypointFollower(line, skip_at_start=ahead_of(line, car)),
                                       speed=car.speed_control())
                    agent.planner = GapKeeping(agent.planner, model.limits.max_brake_m_s2)
                    keeping[len(drivers)] = agent.planner
                    drivers.append(agent)
            lidar = Lidar(ego_car.plant, seed)
            sensed = Opponents(track, CarDetector(world_map(track)))
            for car in cars:
                car.drive(0.0, 0.0)
            fleet.run(PERIOD_S)
            for d in drivers:
                d.setup()
            mount = ego_car.plant.lidar_mount()  # (x ahead, y left, yaw) on the car
            hints: list[int | None] = [None] * n
            lap_start = [0.0] * n
            history: deque = deque(maxlen=round(SIDEWAYS_S / PERIOD_S) + 1)  # per period: [(s, d, speed)] per car
            touching: set[tuple[int, int]] = set()
            behind_of = None  # ego behind each car (by distance raced) last period
            bar = laps_bar(laps, f"racing {track.name} against {n - 1} car(s)") if progress else None
            # the ego starts behind everyone: distance raced counts from each car's own grid slot
            start_s = [track.project(p[:2], None, heading=p[2])[1] for p in reversed(poses)]
            offset = [track.arc_delta(start_s[0], s) for s in start_s]
            travelled = [offset[i] for i in range(n)]
            s_prev = list(start_s)
            while fleet.time_s < timeout_s and len(result.cars[0].lap_times_s) < laps:
                t = fleet.time_s
                observed = [car.observe() for car in cars]
                sensor = compose((observed[0].x, observed[0].y, observed[0].yaw), mount)
                scan = lidar.scan(t, [car.plant for car in cars[1:]])
                seen = sensed.update(scan, sensor, t)
                ego.sense(seen)
                for i, planner in keeping.items():
                    if history:
                        planner.ahead = car_ahead(track, history[-1], i)
                for car, driver, obs in zip(cars, drivers, observed):
                    car.send(driver.step(obs))
                fleet.run(PERIOD_S)
                now = []
                for i, car in enumerate(cars):
                    st = car.state()
                    hints[i], s_now, d_now = track.project((st.x, st.y), hints[i], heading=st.yaw)
                    travelled[i] += track.arc_delta(s_prev[i], s_now)
                    s_prev[i] = s_now
                    r = result.cars[i]
                    r.travelled_m = travelled[i]
                    r.path.append((st.x, st.y))
                    r.wall_contacts += car.touching_wall()
                    if travelled[i] - offset[i] >= track.length_m * (len(r.lap_times_s) + 1):
                        r.lap_times_s.append(fleet.time_s - lap_start[i])
                        lap_start[i] = fleet.time_s
                    now.append((s_now, d_now, st.speed))
                history.append(now)
                now_touching = fleet.touching_pairs()
                for a, b in sorted(now_touching - touching):  # each contact as it starts
                    result.contacts.append(attribute(track, history, travelled, a, b, fleet.time_s))
                touching = now_touching
                behind = [travelled[0] < travelled[j] for j in range(n)]
                if behind_of is not None:
                    result.overtakes += sum(1 for j in range(1, n) if behind_of[j] and not behind[j])
                    result.overtakes -= sum(1 for j in range(1, n) if not behind_of[j] and behind[j])
                behind_of = behind
                order = result.order()
                result.times_s.append(fleet.time_s)
                result.positions.append([order.index(i) + 1 for i in range(n)])
                result.modes.append(ego.mode)
                ahead = [travelled[j] - travelled[0] for j in range(1, n) if travelled[j] > travelled[0]]
                result.gaps_ahead_m.append(min(ahead) - 0.55 if ahead else math.inf)
                if recording is not None:
                    recording.period(result, scan, seen, cars, ego)
                if bar:
                    bar.update(max(0.0, min(laps, (travelled[0]) / track.length_m) - bar.n))
            if bar:
                bar.close()
    result.passes_started = ego.passes
    result.events = ego.events
    return result


class RaceLog:
    """A race on the record (roar_sim.links.sim_log): the ego's channels as a race alone records
    them (every control message, line, state, firmware output and contact), the scan it was given
    (/lidar), the cars it tracks (/racing/tracked) and its mode (/autopilot/state); each
    opponent's pose, state, firmware and contacts (/race/car_N/...); the standings each period
    (/race/standings), each car-to-car contact with who caused it (/race/contacts), and each of
    the ego's decisions (/race/events)."""

    def __init__(self, ego_car, path, serve_port: int | None, cars: int) -> None:
        from roar_sim.links.sim_log import SimLog

        self.log = SimLog(ego_car, path, {"driver": "racer", "cars": str(cars)}, serve_port=serve_port)
        self._contacts = self._events = 0

    def period(self, result: HeadToHead, scan, seen, cars, ego) -> None:
        from roar_sim.links.sim_log import DRIVER_STATE, RACE, TRACKED

        log, track = self.log, result.track
        log.step()
        log.fields(DRIVER_STATE, {"state": ego.mode}, "roar.DriverState")
        log.scan(scan)
        log.poses(TRACKED, [(o.x, o.y, track.pose_at(o.s_m, o.d_m)[2] + (math.pi if o.speed_m_s < 0 else 0.0))
                            for o in seen])
        for i, car in enumerate(cars[1:], 1):
            log.other(f"car_{i}", car)
        log.fields(f"{RACE}/standings", {"positions": result.positions[-1],
                                         "laps": [len(c.lap_times_s) for c in result.cars],
                                         "raced_m": [round(c.travelled_m, 3) for c in result.cars]},
                   "roar_sim.Standings")
        for c in result.contacts[self._contacts:]:
            log.fields(f"{RACE}/contacts", {"cars": [result.cars[i].name for i in c.cars],
                                            "caused_by": None if c.caused_by is None else result.cars[c.caused_by].name,
                                            "why": c.why}, "roar_sim.CarContact")
        self._contacts = len(result.contacts)
        for t_s, what in ego.events[self._events:]:
            log.fields(f"{RACE}/events", {"time_s": t_s, "what": what}, "roar_sim.RaceEvent")
        self._events = len(ego.events)

    def __enter__(self) -> RaceLog:
        return self

    def __exit__(self, *exc) -> None:
        self.log.close()


def paced(model: CarModel, pace: float) -> CarModel:
    """The car driven at `pace` of its limits: its grip and its top speed (a rival at 85 % is
    slower on the straights too, where a grip margin alone leaves it flat out)."""
    limits = model.limits.with_margin(pace)
    return replace(model, limits=replace(limits, max_speed_m_s=model.limits.max_speed_m_s * pace))


def ahead_of(line: np.ndarray, car, ahead_m: float = 0.5) -> int:
    """The index of the first point of a closed line at least ahead_m [m] ahead of a car, among
    those near it (where a line following car on a grid slot beside the line first heads)."""
    s = car.state()
    offsets = line[:, :2] - (s.x, s.y)
    along = offsets @ (math.cos(s.yaw), math.sin(s.yaw))
    distance = np.linalg.norm(offsets, axis=1)
    candidates = np.flatnonzero((along >= ahead_m) & (distance < 3.0))
    return int(candidates[np.argmin(distance[candidates])]) if len(candidates) else 0


def attribute(track: Track, history, travelled: list[float], a: int, b: int, t_s: float) -> Contact:
    """Who caused a contact between cars a and b starting now (see the module's rules)."""
    then, now = history[0], history[-1]
    toward = {}
    for me, other in ((a, b), (b, a)):
        side = math.copysign(1.0, now[other][1] - now[me][1])
        toward[me] = (now[me][1] - then[me][1]) * side  # [m] it moved toward the other
    movers = [car for car in (a, b) if toward[car] >= SIDEWAYS_M]
    if len(movers) == 1:
        return Contact(t_s, (a, b), movers[0], f"moved {toward[movers[0]]:.2f} m sideways toward the other "
                                               f"in the {SIDEWAYS_S:g} s before")
    back, front = (a, b) if travelled[a] < travelled[b] else (b, a)
    closing = now[back][2] - now[front][2]
    if closing > CLOSING_M_S:
        return Contact(t_s, (a, b), back, f"behind and closing at {closing:.2f} m/s")
    return Contact(t_s, (a, b), None, "side by side, neither moved across: a racing incident")


def report(result: HeadToHead) -> str:
    names = [c.name for c in result.cars]
    lines = [f"{result.track.name}: {len(result.cars) - 1} opponent(s), {result.laps} lap(s)",
             "pos  car     laps  distance   best lap   walls  contacts caused"]
    for pos, i in enumerate(result.order(), 1):
        c = result.cars[i]
        best = f"{min(c.lap_times_s):7.2f} s" if c.lap_times_s else "      - "
        lines.append(f"{pos:>3}  {names[i]:<6} {len(c.lap_times_s):>5}  {c.travelled_m:7.1f} m  {best}  "
                     f"{c.wall_contacts:>5}  {len(result.caused_by(i)):>8}")
    lines.append(f"the ego: {result.overtakes} overtake(s) ({result.passes_started} pass(es) started), "
                 f"time following {100 * result.modes.count('follow') / max(1, len(result.modes)):.0f} %, "
                 f"passing {100 * result.modes.count('pass') / max(1, len(result.modes)):.0f} %")
    for c in result.contacts:
        who = "nobody" if c.caused_by is None else names[c.caused_by]
        lines.append(f"contact at {c.t_s:.2f} s between {names[c.cars[0]]} and {names[c.cars[1]]}: caused by "
                     f"{who} ({c.why})")
    if not result.contacts:
        lines.append("no car-to-car contact")
    return "\n".join(lines)


def plot(result: HeadToHead):
    """Paths coloured per car beside each car's position over time (a matplotlib Figure)."""
    import matplotlib.pyplot as plt

    fig, (ax, pos) = plt.subplots(1, 2, figsize=(13, 5.5), gridspec_kw={"width_ratios": [1.2, 1]})
    for wall in result.track.walls:
        closed = np.vstack([wall, wall[:1]])
        ax.plot(closed[:, 0], closed[:, 1], color="0.3", lw=1)
    colours = plt.get_cmap("tab10")
    for i, c in enumerate(result.cars):
        p = np.asarray(c.path)
        if len(p):
            ax.plot(p[:, 0], p[:, 1], color=colours(i), lw=2.2 if i == 0 else 1.0, label=c.name)
    for contact in result.contacts:
        x, y = result.cars[contact.cars[0]].path[min(len(result.cars[0].path) - 1,
                                                     int(contact.t_s / PERIOD_S))]
        ax.plot(x, y, "rx", ms=10)
    ax.set_aspect("equal")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(f"{result.track.name}: paths (x: car-to-car contacts)")
    positions = np.asarray(result.positions)
    for i, c in enumerate(result.cars):
        if len(positions):
            pos.step(result.times_s, positions[:, i], color=colours(i), lw=2.2 if i == 0 else 1.0, label=c.name)
    pos.invert_yaxis()
    pos.set_yticks(range(1, len(result.cars) + 1))
    pos.set_xlabel("time [s]")
    pos.set_ylabel("position")
    pos.set_title(f"positions; the ego overtook {result.overtakes}")
    fig.tight_layout()
    return fig

