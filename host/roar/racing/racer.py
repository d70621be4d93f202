"""A driver that races other cars: it laps its racing line at its pace and, for a car ahead in its
way (sensed, roar.racing.opponents), either passes it or follows it at a gap.

A pass: on a lane beside the racing line (an offset line, roar.racing.lanes) that keeps a car's
width and PASS_SIDE_M clear of the car ahead, checked against every car it senses, predicted along
the track, and the walls, for as long as the pass takes (closing at the lane's speed less the
car's); it commits, drives the lane until it is DONE_AHEAD_M clear ahead, and merges back onto the
racing line. A pass that another car closes before the two are side by side is given up. With no
safe pass it follows: FOLLOW_GAP_M bumper to bumper plus TIME_GAP_S of the car's speed. Whatever it
does, no car ahead in its path is closed on faster than it can stop for.

    racer = Racer(track, racing_points, model, period_s, pace=0.9)
    racer.sense(opponents)            # each control period: the cars it senses now
    command = racer.step(observation)
    racer.mode                        # "race", "follow" or "pass"
"""

from __future__ import annotations

import math
from bisect import bisect_right
from dataclasses import dataclass, replace

import numpy as np

from roar.autopilot.agent import Command, Module, Observation
from roar.autopilot.curvature_tracking import CurvatureTracker
from roar.autopilot.longitudinal import SpeedController
from roar.autopilot.pure_pursuit import PurePursuit, goal_on_path
from roar.autopilot.race_agent import CarModel
from roar.racing.lanes import CLEARANCE_M, Lanes, Line, segment_at
from roar.racing.opponents import Opponent
from roar.tracks.track import Track

CAR_LENGTH_M = 0.55  # [m] bumper to bumper (the ESC car; opponents are taken as long)
CAR_WIDTH_M = 0.3  # [m] side to side
LENGTH_MARGIN_M = 0.2  # [m] along the track, added to a car's length where two could meet
PASS_SIDE_M = 0.15  # [m] between the two cars' sides while passing
FOLLOW_GAP_M = 0.5  # [m] bumper to bumper behind a car it cannot pass, at standstill
TIME_GAP_S = 0.25  # [s] of the car's speed added to the gap
K_GAP = 1.5  # [1/s] closing speed per m of gap beyond the wanted one
HORIZON_S = 5.0  # [s] a pass must be done within this (a pass begun is given up only for a car in its lane,
# or when it would take twice this)
LOOK_AHEAD_S = 1.5  # [s] a car this far ahead (at the car's speed, at least LOOK_AHEAD_MIN_M) is raced
LOOK_AHEAD_MIN_M = 2.5  # [m]
DONE_AHEAD_M = 0.9  # [m] centre to centre ahead of the passed car before merging back
LANE_STEP_M = 0.1  # [m] between the lanes a pass may take
PREVIEW_S = 0.3  # [s] of the speed profile ahead the speed is planned for
CHECK_DT_S = 0.1  # [s] time step of a pass's check
RELAX_S = 1.0  # [s] a sensed car's offset from the racing line fades with this in predictions
KEEP_CONFLICTS_S = 1.5  # [s] a pass begun is given up for a car predicted in its lane this soon (further
# ahead the predictions are checked again as they come nearer)
SAFETY_S = 1.0  # [s] a car predicted on its line this soon, ahead or beside, is followed (slowed for)
YIELD_M_S = 0.5  # [m/s] slower than the car beside while dropping back behind it
SWERVE_S_PER_M = 1.5  # [s] a pass's cost per m the car must move across to reach its lane (speed lost swerving)
REPASS_S = 1.0  # [s] after a pass is given up, before another is tried (no swerving from side to side)
SEARCH_EVERY_S = 0.1  # [s] after a search for a pass found no safe lane, before the next search


def follow_speed(gap_m: float, ahead_m_s: float, brake_m_s2: float) -> float:
    """[m/s] the speed that keeps the wanted gap behind a car gap_m [m] ahead (centre to centre,
    along the track) going ahead_m_s [m/s], or closes on it no faster than a car braking at
    brake_m_s2 [m/s^2] can stop within the gap there is."""
    bumper = gap_m - CAR_LENGTH_M
    ahead = max(ahead_m_s, 0.0)
    closing = K_GAP * (bumper - (FOLLOW_GAP_M + TIME_GAP_S * ahead))
    stop = math.sqrt(2 * brake_m_s2 * max(bumper - FOLLOW_GAP_M, 0.0))
    return max(0.0, min(ahead + closing, ahead + stop))


@dataclass(frozen=True)
class Pass:
    target: int  # the passed car's track id
    lane: int  # index into Racer.lanes
    side: str  # "left" or "right"
    yielding: bool = False  # given up beside the car: dropping back behind it in the lane


class Racer(Module[Observation, Command]):
    def __init__(self, track: Track, racing_points: np.ndarray, model: CarModel, period_s: float,
                 pace: float = 0.9, half_width_m: float = CAR_WIDTH_M / 2, clearance_m: float = CLEARANCE_M) -> None:
        """clearance_m: [m] from the car's side to the walls' faces on any lane (pure pursuit cuts
        inside a bend by up to TRACKING_MARGIN_M; the walls' faces stand in from the track's edges)."""
        self.track, self.model, self.period_s = track, model, period_s
        self.space = Lanes(track, half_width_m, model.limits.with_margin(pace), clearance_m)
        self.racing: Line = self.space.line(self.space.offsets_of(racing_points))
        # lanes beside the racing line, shaped as it is (a car on the line stays as far beside them
        # through the bends), squeezed against the walls where there is no room
        room = float(self.space.left_room.max() + self.space.right_room.max())
        steps = int(room / LANE_STEP_M)
        self.lanes: list[Line] = [self.space.line(self.racing.offsets + k * LANE_STEP_M)
                                  for k in range(-steps, steps + 1) if k]
        self.pursuit = PurePursuit(model.wheelbase_m)
        self.speed = SpeedController(model.limits.max_speed_m_s, max_reverse=model.limits.max_reverse)
        self.tracker = CurvatureTracker()
        self.spacing_m = float(np.mean(track.segment_lengths))
        self.opponents: list[Opponent] = []
        self.mode = "race"
        self.passing: Pass | None = None
        self.passes = 0  # passes started
        self.events: list[tuple[float, str]] = []  # (time [s], what it decided and why)
        self._t_s = 0.0
        self._d = 0.0  # [m] the car's offset from the centre line now
        self._hint: int | None = None
        self._why_not = ""
        self._no_pass_until = 0.0  # [s] no new pass before this (one given up: back behind first)
        self._arc = track.arc_start.tolist()  # [m] where each centre-line segment starts (bisected in the checks)
        self._times = np.arange(0.0, 2 * HORIZON_S + 2 * CHECK_DT_S, CHECK_DT_S)  # [s] the checks' steps
        self._forecasts: dict[int, tuple[list[float], list[float]]] | None = None  # this period's, by car id

    def setup(self) -> None:
        self.speed.reset()
        self.tracker.reset()
        self._hint = None

    def sense(self, opponents: list[Opponent]) -> None:
        """The cars it senses now (roar.racing.opponents.Opponents.update's)."""
        self.opponents = list(opponents)
        self._forecasts = None

    # --- each control period --------------------------------------------------------------------

    def step(self, obs: Observation) -> Command:
        seg, s, d = self.track.project((obs.x, obs.y), self._hint, heading=obs.yaw if self._hint is None else None)
        self._t_s, self._d = obs.t_s, d
        self._hint = seg
        v = max(obs.speed, 0.0)
        reach = max(LOOK_AHEAD_MIN_M, LOOK_AHEAD_S * v)
        near = sorted((o for o in self.opponents if -CAR_LENGTH_M < self._gap(s, o) < reach),
                      key=lambda o: self._gap(s, o))  # ahead, or beside and not clear behind
        if self.passing is not None:
            self._keep_passing(s, v)
        if self.passing is None:
            blocking = next((o for o in near if self._gap(s, o) > 0 and self._in_path(self.racing, o)), None)
            if blocking is not None and obs.t_s >= self._no_pass_until and not self._start_pass(s, v, blocking):
                self._no_pass_until = obs.t_s + SEARCH_EVERY_S
            self.mode = "race" if blocking is None else ("pass" if self.passing else "follow")
        line = self.lanes[self.passing.lane] if self.passing else self.racing
        goal = goal_on_path(line.points, seg + 1, self.pursuit.lookahead_m(v))
        window = np.arange(seg, seg + int(math.ceil(PREVIEW_S * max(v, 0.5) / self.spacing_m)) + 2)
        target = float(line.speeds[window % len(line.speeds)].min())
        for o in near:  # never close on a car in its path, ahead or beside, faster than it can stop for
            if self._meets(line, s, max(target, v), o, SAFETY_S):
                target = min(target, self._follow_speed(s, o))
        if self.passing is not None and self.passing.yielding:
            target = min(target, max(0.0, self._target_seen[1].speed_m_s - YIELD_M_S))
        curvature = self.pursuit.curvature(obs.x, obs.y, obs.yaw, goal)
        curvature = self.tracker.step(curvature, obs.speed, obs.yaw_rate, self.period_s)
        angle = math.atan(self.model.wheelbase_m * curvature)
        steering = max(-1.0, min(1.0, -angle / self.model.max_steer_rad))
        throttle = self.speed.step(target, obs.speed, self.period_s)
        if throttle > 0:
            throttle *= self.tracker.drive_share
        return Command(throttle, steering)

    # --- racing others ------------------------------------------------------------------------

    def _gap(self, s: float, o: Opponent) -> float:
        """[m] centre to centre along the track from the car to o (negative: o is behind)."""
        return float(self.track.arc_delta(s, o.s_m))

    def _in_path(self, line: Line, o: Opponent) -> bool:
        """Whether o is on `line` (less than a car's width and PASS_SIDE_M beside it)."""
        return abs(float(line.offsets[segment_at(self.track, o.s_m)]) - o.d_m) < CAR_WIDTH_M + PASS_SIDE_M

    def _meets(self, line: Line, s: float, speed: float, o: Opponent, within_s: float) -> bool:
        """Whether driving `line` from s at `speed` [m/s] comes side by side with o (predicted)
        within within_s [s]: less than a car's length and a margin apart along the track and a car's
        width and PASS_SIDE_M across it."""
        s_ego = s
        so, do = self._forecast()[o.id]
        for k in range(int(within_s / CHECK_DT_S + 1e-9) + 1):
            seg = self._segment(s_ego)
            if abs(self.track.arc_delta(s_ego, so[k])) < CAR_LENGTH_M + LENGTH_MARGIN_M and \
                    abs(float(line.offsets[seg]) - do[k]) < CAR_WIDTH_M + PASS_SIDE_M:
                return True
            s_ego += speed * CHECK_DT_S / float(line.stretch[seg])
        return False

    def _find(self, id_: int) -> Opponent | None:
        return next((o for o in self.opponents if o.id == id_), None)

    def _follow_speed(self, s: float, o: Opponent) -> float:
        return follow_speed(self._gap(s, o), o.speed_m_s, self.space.limits.max_brake_m_s2)

    def _start_pass(self, s: float, v: float, target: Opponent) -> bool:
        """Choose the lane round `target` that is clear for the whole pass and done soonest; commit to it."""
        seg = segment_at(self.track, target.s_m)
        best = None
        for k, lane in enumerate(self.lanes):
            if abs(float(lane.offsets[seg]) - target.d_m) < CAR_WIDTH_M + PASS_SIDE_M:
                continue
            done_in = self._clear(lane, s, v, target)
            if done_in is None:
                continue
            cost = done_in + SWERVE_S_PER_M * abs(float(lane.offsets[segment_at(self.track, s)]) - self._d)
            if best is None or cost < best[0]:
                best = (cost, k)
        if best is None:
            return False
        k = best[1]
        side = "left" if self.lanes[k].offsets[seg] > target.d_m else "right"
        self.passing = Pass(target.id, k, side)
        self._target_seen = (self._t_s, target)
        self.passes += 1
        self.events.append((self._t_s, f"passes car #{target.id} on its {side} ({self._gap(s, target):.1f} m ahead, "
                                       f"{target.speed_m_s:.2f} m/s)"))
        self.mode = "pass"
        return True

    def _segment(self, s_m: float) -> int:
        """segment_at(self.track, s_m), by bisecting a list (the checks ask it thousands of times a period)."""
        return bisect_right(self._arc, s_m % self.track.length_m) - 1

    def _forecast(self) -> dict[int, tuple[list[float], list[float]]]:
        """Each car sensed now, by id: its (s [m], d [m]) at every check step (self._times), as
        _predict gives them; worked out once a period, for every step at once."""
        if self._forecasts is None:
            track, times = self.track, self._times
            self._forecasts = {}
            for o in self.opponents:
                s_then = (o.s_m + max(0.0, o.speed_m_s) * times) % o.length_m
                segs = np.searchsorted(track.arc_start, s_then % track.length_m, side="right") - 1
                now = float(self.racing.offsets[segment_at(track, o.s_m)])
                d_then = self.racing.offsets[segs] + (o.d_m - now) * np.exp(-times / RELAX_S)
                self._forecasts[o.id] = (s_then.tolist(), d_then.tolist())
        return self._forecasts

    def _predict(self, o: Opponent, dt_s: float) -> tuple[float, float]:
        """(s [m], d [m]) of o in dt_s [s]: on at its speed along the track, its offset from the
        racing line fading with RELAX_S (a car racing heads back to the line)."""
        s_now, _ = o.predict(dt_s)
        line_now = float(self.racing.offsets[segment_at(self.track, o.s_m)])
        line_then = float(self.racing.offsets[segment_at(self.track, s_now)])
        return s_now, line_then + (o.d_m - line_now) * math.exp(-dt_s / RELAX_S)

    def _clear(self, lane: Line, s: float, v: float, target: Opponent, horizon_s: float = HORIZON_S,
               conflicts_s: float = HORIZON_S) -> float | None:
        """[s] until driving `lane` from s at its speed has passed target DONE_AHEAD_M clear, within
        horizon_s and without coming side by side with any car it senses (each predicted along the
        track); None where it does not (the reason in _why_not). The lane's progress along the track
        is its speed over its stretch: outside a bend it goes further for the same progress."""
        n = len(lane.speeds)
        s_ego, t, k = s, 0.0, 0
        speed = max(v, 0.5)
        forecasts = [(o.id, *self._forecast()[o.id]) for o in self.opponents]
        near_m, beside_m = CAR_LENGTH_M + LENGTH_MARGIN_M, CAR_WIDTH_M + PASS_SIDE_M
        length, half = self.track.length_m, self.track.length_m / 2
        while t < horizon_s:
            seg = self._segment(s_ego)
            speed = min(float(lane.speeds[seg]), speed + self.space.limits.max_accel_m_s2 * CHECK_DT_S)
            if t < conflicts_s:
                offset = float(lane.offsets[seg % n])
                for id_, so, do in forecasts:
                    if abs((so[k] - s_ego + half) % length - half) < near_m and abs(offset - do[k]) < beside_m:
                        self._why_not = f"car #{id_} in the lane in {t:.1f} s"
                        return None
            s_target = target.predict(t)[0]
            if self.track.arc_delta(s_target, s_ego) >= DONE_AHEAD_M:
                return t
            s_ego += speed * CHECK_DT_S / float(lane.stretch[seg % n])
            t += CHECK_DT_S
            k += 1
        self._why_not = f"not past within {horizon_s:g} s"
        return None

    def _keep_passing(self, s: float, v: float) -> None:
        """Go on with the pass, merge back once past, or give it up: before the two are side by
        side, for a car predicted in the lane soon; beside it, by dropping back behind it in the
        lane (yielding) before taking the racing line again."""
        p = self.passing
        target = self._find(p.target)
        if target is not None:
            self._target_seen = (self._t_s, target)
        else:  # out of sight (behind, beyond the lidar's field of view): where it would be by now
            seen_t, seen = self._target_seen
            target = replace(seen, s_m=self._predict(seen, self._t_s - seen_t)[0])
        if self._gap(s, target) <= -DONE_AHEAD_M:  # passed: merge back
            self.events.append((self._t_s, f"merges back: {-self._gap(s, target):.1f} m ahead of car #{p.target}"))
            self.passing, self.mode = None, "race"
            return
        gap = self._gap(s, target)
        if p.yielding:
            if gap >= CAR_LENGTH_M + FOLLOW_GAP_M:  # back behind it: follow on the racing line
                self.events.append((self._t_s, f"back behind car #{p.target}"))
                self.passing, self._no_pass_until = None, self._t_s + REPASS_S
            return
        if self._clear(self.lanes[p.lane], s, v, target, 2 * HORIZON_S, KEEP_CONFLICTS_S) is not None:
            return
        if gap >= CAR_LENGTH_M:  # not yet beside it: back to the racing line behind it
            self.events.append((self._t_s, f"gives up the pass: {self._why_not}"))
            self.passing, self._no_pass_until = None, self._t_s + REPASS_S
        else:
            self.events.append((self._t_s, f"yields beside car #{p.target}: {self._why_not}"))
            self.passing = Pass(p.target, p.lane, p.side, yielding=True)
        self.mode = "follow"
