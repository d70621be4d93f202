"""What a race measured (RaceResult: laps, cross-track error, contacts, the lane driver's stops,
the filter against the truth), its report in words and its plot."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from roar.autopilot import lap_time
from roar.tracks import Track
from roar.tracks.tunnel import describe
from roar_sim import robots
from roar_sim.core.lockstep import CONTROL_PERIOD_S as PERIOD_S
from roar_sim.runs.localize import LocalizationLog
from roar_sim.world import plotting


@dataclass
class Stop:
    """The lane driver standing still: why (its state), where [m along the lap], from when [s],
    until when [s] (None: still stopped when the race ended)."""

    why: str
    at_m: float
    from_s: float
    until_s: float | None = None

    def line(self, end_s: float) -> str:
        how_long = (self.until_s if self.until_s is not None else end_s) - self.from_s
        then = "then went on" if self.until_s is not None else "until the race ended"
        return f"stopped ({self.why}) {self.at_m:.1f} m into the lap at {self.from_s:.2f} s, for {how_long:.2f} s, {then}"


@dataclass
class RaceResult:
    track: Track
    limit_speeds: np.ndarray  # [m/s] the physical-limit speed at each centre-line point
    racing_limit_lap_s: float = float("nan")  # [s] the physical-limit lap of the racing line
    line: np.ndarray | None = None  # the line followed, when not the centre line (--line, --waypoints): x, y [m]
    line_speeds: np.ndarray | None = None  # [m/s] its physical-limit speed at each point
    lap_times_s: list[float] = field(default_factory=list)
    cross_track_m: list[float] = field(default_factory=list)
    # (x, y, speed, distance into the lap [m] (progress, 0 at the start line), t [s])
    path: list[tuple[float, float, float, float, float]] = field(default_factory=list)
    robot: str = "esc"  # the robot's name (roar_sim.robots)
    wall_contacts: int = 0  # control periods with the car touching a wall
    travelled_m: float = 0.0  # [m] net progress along the track, all laps
    braking_periods: int = 0  # control periods the ESC spent braking or reversing the motor
    slowest_m_s: float = 0.0  # [m/s] signed: negative if the car ever rolled backwards
    green_at_s: float | None = None  # [s] when the start lights turned green (None: no start lights)
    localization: LocalizationLog | None = None  # the particle filter against the truth, when it drove
    moved_at_s: float | None = None  # [s] when the car first asked for throttle
    green_frames: int = 0  # camera frames that showed green up to and including the one it moved on
    boxes: int = 0  # boxes on the track
    box_contacts: int = 0  # control periods with the car touching a box
    stops: list[Stop] = field(default_factory=list)  # the lane driver's stops, each explained
    cone_contacts: int = 0  # control periods with the car touching a tunnel's cone
    people_contacts: int = 0  # control periods with the car touching a person

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
        reasons = []
        if self.cone_contacts or self.people_contacts:  # a tunnel's cones and people stand in the way
            what = " and ".join(f"{kind} in {n} control periods" for kind, n in
                                (("a cone", self.cone_contacts), ("a person", self.people_contacts)) if n)
            base = self.track.name.split(",")[0]
            reasons.append(f"it ran into {what}: they stand in the way of a line driver; race {base},cones=0,people=0 "
                           f"for the walls alone, or let `roar challenge {base}` drive round them")
        if self.wall_contacts:
            reasons.append(f"it touched a wall in {self.wall_contacts} control periods")
        if self.stops and self.stops[-1].until_s is None:
            reasons.append(self.stops[-1].line(self.path[-1][4] if self.path else 0.0))
        if self.travelled_m < 0:
            reasons.append("it drove against the track's direction")
        return (f"{done} of {laps} laps within the {timeout_s:.0f} s time limit ({'; '.join(reasons) or 'too slow'}): "
                f"the car covered {max(0.0, self.travelled_m):.1f} m of the {laps * self.track.length_m:.1f} m asked")

    @property
    def best_ratio(self) -> float:
        """Best lap over the physical-limit lap (1.0 would be driving at the limit)."""
        return min(self.lap_times_s) / self.limit_lap_s if self.lap_times_s else float("inf")

    @property
    def best_racing_ratio(self) -> float:
        """Best lap over the racing line's physical-limit lap."""
        return min(self.lap_times_s) / self.racing_limit_lap_s if self.lap_times_s else float("inf")


def race_timeout_s(result: RaceResult, laps: int) -> float:
    """[s] how long a race may take: four times the physical-limit laps, plus 10 s."""
    return 4 * laps * result.limit_lap_s + 10


def report(result: RaceResult) -> str:
    tr = result.track
    lines = [f"{robots.get(result.robot).title} on track {tr.name}: {tr.length_m:.1f} m, width {tr.width_m:.1f} m; "
             f"physical-limit lap {result.limit_lap_s:.2f} s on the centre line, {result.racing_limit_lap_s:.2f} s on "
             f"the racing line"]
    for i, t in enumerate(result.lap_times_s, 1):
        lines.append(f"  lap {i}: {t:6.2f} s  ({tr.length_m / t:.2f} m/s average, "
                     f"{t / result.limit_lap_s:.2f} x the centre line's limit, {t / result.racing_limit_lap_s:.2f} x "
                     f"the racing line's)")
    if result.green_at_s is not None:
        moved = ("never moved" if result.moved_at_s is None else "FALSE START" if result.false_start else
                 f"moved on the {result.green_frames}. frame that showed green "
                 f"({result.moved_at_s - result.green_at_s:.3f} s)")
        lines.append(f"start lights: green at {result.green_at_s:.2f} s; {moved}")
    driven_s = result.path[-1][4] if result.path else 0.0  # [s] from the start of the race
    lines.append(f"laps completed: {len(result.lap_times_s)} ({sum(result.lap_times_s):.2f} s), in {driven_s:.1f} s "
                 f"of driving (simulated)")
    lines.append(f"cross-track error: max {result.max_cross_track_m:.3f} m, RMS {result.rms_cross_track_m:.3f} m")
    lines.append(f"wall contacts: {result.wall_contacts}")
    if result.localization is not None:
        lines.append(result.localization.summary())
    end_s = result.path[-1][4] if result.path else 0.0
    lines += [stop.line(end_s) for stop in result.stops]
    if result.boxes:
        lines.append(f"box contacts: {result.box_contacts} (control periods touching one of the {result.boxes} boxes)")
    if tr.course is not None:
        lines.append(f"tunnel: {describe(tr)}; control periods touching a cone: {result.cone_contacts}, a person: "
                     f"{result.people_contacts}")
    if result.braking_periods:
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
    if result.line is not None:
        closed = np.vstack([result.line, result.line[:1]])
        ax.plot(closed[:, 0], closed[:, 1], color="tab:red", lw=1, label="the line followed")
    if result.localization is not None:
        result.localization.draw(ax)
    ax.legend(loc="upper left", bbox_to_anchor=(0.0, -0.16), ncol=3, fontsize=8)  # below the track, not on it
    ax_v.plot(result.track.arc_start, result.limit_speeds, color="black", lw=1.5, label="physical limit (centre line)")
    if result.line is not None and result.line_speeds is not None:
        along = result.track.follow(result.line)[1]
        order = np.argsort(along)
        ax_v.plot(along[order], result.line_speeds[order], color="tab:red", lw=1.2,
                  label="physical limit (the line followed)")
    ax_v.scatter(p[:, 3], p[:, 2], c=p[:, 2], s=3, cmap="viridis", label="driven")
    ax_v.set_xlabel("distance along the track [m]")
    ax_v.set_ylabel("speed [m/s]")
    ax_v.set_ylim(bottom=0)
    ax_v.legend(loc="lower right", fontsize=8)
    times = ", ".join(f"{t:.2f} s" for t in result.lap_times_s)
    fig.suptitle(f"{robots.get(result.robot).title}, {result.track.name}: laps {times} (limit {result.limit_lap_s:.2f} s, best "
                 f"{result.best_ratio:.2f} x); max cross-track {result.max_cross_track_m:.2f} m, "
                 f"wall contacts {result.wall_contacts}", fontsize=10)
    return fig


TRACKING_MARGIN_M = 0.25  # [m] pure pursuit's widest miss of a line at speed (random tracks: 0.19-0.29 m)


def optimal_line(track: Track, robot: str = "esc"):
    """The minimum-curvature racing line a robot can follow round a track: its half width, half a
    wall's thickness and TRACKING_MARGIN_M from every wall (solved once per track shape and robot
    in a process: `--line optimal` follows the line the race's report measures against)."""
    from roar.autopilot.racing_line import racing_line
    from roar_sim.world.cache import per_shape
    from roar_sim.world.scene import WALL_THICKNESS_M

    clearance_m = robots.get(robot).half_width_m + WALL_THICKNESS_M / 2 + TRACKING_MARGIN_M
    return per_shape(f"racing line for {robot}", track, lambda: racing_line(track, clearance_m))
