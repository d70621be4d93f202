"""The test drive a fit learns from: a figure eight laid out in the free floor around the car,
driven by pure pursuit on the car's measured pose, while the throttle and steering go through
manoeuvres that each show one part of the car: the ESC's dead band, the motor's speeds and
push, coasting, braking, the servo's steps and a sweep, and the tyres' grip.

    plan = TestDrive(Area(4.0, 6.0))               # 4 m ahead of the car and behind, 6 m across
    command = plan.step(t, pose, speed)            # -> Command(throttle_us, steering_us, phase) or None: done
    plan.stopped                                    # why it ended early ("left the area", ...), or ""

The car stands in the middle of the area. The figure eight's two circles lie to its left and
right and cross where it stands, so every lap turns both ways (a trimmed servo shows as one
circle tighter than the other). Every manoeuvre has a time cap; a car outside the area, or a
pose that stops coming, ends the drive at neutral.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from roar.errors import FitError
from roar.fit.model import HALF_RANGE_US, N

MARGIN_M = 0.6  # [m] kept free between the figure eight and the area's edge (the car's half length and some)
MIN_RADIUS_M = 1.0  # [m] a smaller figure eight is tighter than most 1/10 cars turn
LOOKAHEAD_M = 0.7  # [m] pure pursuit's
GAIN_GUESS_RAD = 0.35  # [rad] the wheels' angle at full steering assumed before the fit knows it
WHEELBASE_GUESS_M = 0.33  # [m]
POSE_SILENCE_S = 0.5  # [s] no new pose for this long ends the drive
STOPPED_M_S = 0.15  # [m/s] braking ends below this speed
SPEED_OVER_S = 0.1  # [s] the driver's speed is measured over the poses of this long


@dataclass(frozen=True)
class Area:
    ahead_m: float  # [m] the free floor's extent along the car's heading (it stands in the middle)
    across_m: float  # [m] ... and to its sides

    @classmethod
    def parse(cls, text: str) -> Area:
        """'4x6': 4 m along the car's heading, 6 m across it; FitError (one line) otherwise."""
        parts = text.lower().replace("×", "x").split("x")
        try:
            ahead, across = (float(p) for p in parts)
        except ValueError:
            raise FitError(f"--area takes AHEADxACROSS in metres, e.g. 4x6, got {text!r}") from None
        if not (math.isfinite(ahead) and math.isfinite(across) and 0 < ahead <= 1000 and 0 < across <= 1000):
            raise FitError(f"--area takes two positive sizes in metres (up to 1000), got {text!r}")
        return cls(ahead, across)

    def radius(self) -> float:
        """[m] the figure eight's circles: the largest whose eight (4 radii across, 2 ahead) keeps
        MARGIN_M from every edge; FitError when that is under MIN_RADIUS_M."""
        r = min((self.across_m - 2 * MARGIN_M) / 4, (self.ahead_m - 2 * MARGIN_M) / 2)
        if r < MIN_RADIUS_M:
            need_across, need_ahead = 4 * MIN_RADIUS_M + 2 * MARGIN_M, 2 * MIN_RADIUS_M + 2 * MARGIN_M
            raise FitError(f"an area of {self.ahead_m:g} m ahead x {self.across_m:g} m across is too small: the test "
                           f"drive's figure eight needs {need_ahead:g} m ahead and {need_across:g} m across (the car "
                           f"in the middle, facing along the shorter side)")
        return r

    def contains(self, x: float, y: float) -> bool:
        """(x, y) in the start's frame (x ahead, y left) is on the area's floor."""
        return abs(x) <= self.ahead_m / 2 and abs(y) <= self.across_m / 2


@dataclass(frozen=True)
class Manoeuvre:
    name: str
    seconds: float  # [s] its time cap
    what: str


# The drive, in order: the name of each is the phase the record carries
MANOEUVRES = (
    Manoeuvre("settle", 1.0, "neutral, standing: where the car is"),
    Manoeuvre("deadband", 6.0, "throttle rising from 1500 us in 10 us steps until the car moves"),
    Manoeuvre("speeds", 8.0, "throttle held at four rising levels: the motor's speeds and its push"),
    Manoeuvre("brake", 2.0, "reverse pulses until the car stops: braking through the ESC's sequence"),
    Manoeuvre("launch", 2.5, "a throttle step from standing: the motor's push"),
    Manoeuvre("blips", 4.0, "throttle up and down every 0.3 s: how long the ESC takes to act"),
    Manoeuvre("coast", 2.0, "neutral while moving: what slows a coasting car"),
    Manoeuvre("steps", 9.0, "steering steps on top of the path's, at a steady throttle: the servo"),
    Manoeuvre("sweep", 6.0, "steering swept faster and faster: the servo (held out of the fit, predicted)"),
    Manoeuvre("grip", 8.0, "throttle rising round one circle until the tyres let go"),
    Manoeuvre("stop", 2.0, "reverse pulses until the car stops, then neutral"),
)
HELD_OUT = "sweep"
GRIP = "grip"  # the manoeuvre the tyres' grip is measured in (roar.fit.identify)
# the manoeuvres whose speeds the fit explains: the throttle's, with the steering steady (a car
# slows as it turns, which the speed model leaves out; in the others that would bend its delay)
SPEED_MANOEUVRES = ("settle", "deadband", "speeds", "brake", "launch", "blips", "coast", "stop")
SPEED_LEVELS = (0.12, 0.2, 0.3, 0.4)  # throttle fractions of the 'speeds' manoeuvre
LAUNCH = 0.35  # throttle fraction of the launch
BLIPS, BLIP_S = (0.15, 0.4), 0.3  # throttle fractions alternated, [s] each
BRAKE = -0.35  # throttle fraction braking (reverse pulses): hard braking on the rear wheels turns a car
SLID_M = 0.2  # [m] off the path by this much in the grip manoeuvre: the tyres have let go
STEADY = 0.22  # throttle fraction while steering is stepped and swept
STEP_SHARE = 0.5  # the steering steps' size (a fraction of full) on top of the path's steering
STEP_S = 0.45  # [s] each steering step's length
DEADBAND_STEP_US, DEADBAND_STEP_S = 10, 0.5  # [us], [s]


@dataclass(frozen=True)
class Command:
    throttle_us: int
    steering_us: int
    phase: str


class TestDrive:
    """The test drive as a controller: step() with the time and the measured pose gives the next
    command. Poses are in any fixed frame; the first one fixes the area around it."""

    def __init__(self, area: Area, wheelbase_m: float = WHEELBASE_GUESS_M) -> None:
        self.area, self.radius = area, area.radius()
        self.wheelbase_m = wheelbase_m
        self.stopped = ""  # why the drive ended early
        self._origin: tuple[float, float, float] | None = None
        self._index, self._began = 0, None
        self._lap_side = 1  # +1: the left circle (anticlockwise), -1: the right one
        self._swept, self._last_angle = 0.0, None  # [rad] round this lap's circle so far, and where from
        self._last_pose_t = None
        self._moved_at: float | None = None
        self._grip_level = 0.3

    @property
    def phase(self) -> str:
        return MANOEUVRES[min(self._index, len(MANOEUVRES) - 1)].name

    def step(self, t: float, pose: tuple[float, float, float] | None, pose_t: float | None,
             speed: float) -> Command | None:
        """The command at time t [s] for the latest pose (x, y, yaw) measured at pose_t [s] and the
        speed measured [m/s]; None when the drive is over (self.stopped says why, if early)."""
        if self._index >= len(MANOEUVRES):
            return None
        if pose is None or pose_t is None:
            if self._began is not None and t - self._began > POSE_SILENCE_S:
                return self._end("no pose came for %.1f s" % POSE_SILENCE_S)
            if self._began is None:
                self._began = t
            return Command(N, N, self.phase)
        if self._last_pose_t is not None and t - pose_t > POSE_SILENCE_S:
            return self._end(f"no new pose for {t - pose_t:.1f} s")
        self._last_pose_t = pose_t
        if self._origin is None:
            self._origin = pose
        x, y, yaw = self._local(pose)
        if not self.area.contains(x, y):
            return self._end(f"the car left the area ({x:+.1f} m ahead, {y:+.1f} m to the left of the start)")
        if self._began is None:
            self._began = t
        m = MANOEUVRES[self._index]
        elapsed = t - self._began
        command = self._command(m.name, elapsed, x, y, yaw, speed)
        if command is None or elapsed >= m.seconds:
            self._index += 1
            self._began = t
            self._moved_at = None
            if self._index >= len(MANOEUVRES):
                return None
            return self.step(t, pose, pose_t, speed)
        return command

    def _end(self, why: str) -> None:
        self.stopped = why
        self._index = len(MANOEUVRES)
        return None

    def _local(self, pose: tuple[float, float, float]) -> tuple[float, float, float]:
        ox, oy, oyaw = self._origin
        dx, dy = pose[0] - ox, pose[1] - oy
        c, s = math.cos(oyaw), math.sin(oyaw)
        return c * dx + s * dy, -s * dx + c * dy, math.remainder(pose[2] - oyaw, math.tau)

    def _path_steering(self, x: float, y: float, yaw: float, switch: bool = True) -> float:
        """Pure pursuit on the figure eight: the steering fraction (-1..1, +1 right) for this
        lap's circle; once a lap has swept all the way round, back where the circles cross, the
        next lap takes the other circle (unless not `switch`: round the same one again)."""
        side = self._lap_side  # +1: the left circle, anticlockwise; -1: the right one, clockwise
        cy = side * self.radius
        angle = math.atan2(y - cy, x)  # where the car is, seen from the circle's centre
        if self._last_angle is not None:
            self._swept += side * math.remainder(angle - self._last_angle, math.tau)
        self._last_angle = angle
        if self._swept >= math.tau:  # round once: the other circle, from where the car is
            if not switch:
                self._swept -= math.tau
            else:
                self._lap_side, self._swept, self._last_angle = -side, 0.0, None
                return self._path_steering(x, y, yaw)
        ahead = angle + side * LOOKAHEAD_M / self.radius  # the lookahead point, along the circle
        dx, dy = self.radius * math.cos(ahead) - x, cy + self.radius * math.sin(ahead) - y
        along = math.cos(yaw) * dx + math.sin(yaw) * dy
        left = -math.sin(yaw) * dx + math.cos(yaw) * dy
        curvature = 2 * left / max(along * along + left * left, 1e-6)
        return max(-1.0, min(1.0, -math.atan(curvature * self.wheelbase_m) / GAIN_GUESS_RAD))

    def _off_path_m(self, x: float, y: float) -> float:
        """[m] how far the car is from this lap's circle."""
        return abs(math.hypot(x, y - self._lap_side * self.radius) - self.radius)

    def _command(self, name: str, elapsed: float, x: float, y: float, yaw: float, speed: float) -> Command | None:
        # the grip is measured on one circle: a lap's S-bend where the circles cross would shake it
        path = self._path_steering(x, y, yaw, switch=name != GRIP)
        throttle = 0.0
        steer = path
        if name == "settle":
            return Command(N, N, name)
        if name == "deadband":
            if abs(speed) > 0.1:
                self._moved_at = elapsed if self._moved_at is None else self._moved_at
                if elapsed - self._moved_at > 1.0:
                    return None
            level = N + DEADBAND_STEP_US * (1 + int(elapsed / DEADBAND_STEP_S))
            return Command(min(level, _us(0.5)), _us(steer), name)
        if name == "speeds":
            throttle = SPEED_LEVELS[min(int(elapsed / (MANOEUVRES[2].seconds / len(SPEED_LEVELS))),
                                        len(SPEED_LEVELS) - 1)]
        elif name == "launch":
            throttle = LAUNCH
        elif name == "blips":
            throttle = BLIPS[int(elapsed / BLIP_S) % 2]
        elif name == "coast":
            throttle = 0.0
        elif name in ("brake", "stop"):
            if speed < STOPPED_M_S:
                self._moved_at = elapsed if self._moved_at is None else self._moved_at
                if elapsed - self._moved_at > 0.3:
                    return None
                return Command(N, _us(steer), name)
            throttle = BRAKE
        elif name == "steps":
            throttle = STEADY
            k = int(elapsed / STEP_S)
            steer = path + STEP_SHARE * (1 if k % 2 else -1) * (0.5 + 0.5 * ((k * 7) % 3) / 2)
        elif name == "sweep":
            throttle = STEADY  # a chirp: 0.5 Hz rising by 0.5 Hz a second
            steer = path + STEP_SHARE * math.sin(2 * math.pi * (0.5 * elapsed + 0.25 * elapsed * elapsed))
        elif name == GRIP:
            if self._off_path_m(x, y) > SLID_M:
                return None  # the tyres let go: what they hold is on the record
            throttle = min(1.0, 0.3 + 0.1 * elapsed)
        return Command(_us(throttle), _us(max(-1.0, min(1.0, steer))), name)


def _us(fraction: float) -> int:
    return int(round(N + fraction * HALF_RANGE_US))


def recent_speed(poses: list) -> float:
    """[m/s] along the heading over the latest SPEED_OVER_S of poses, rows (t [s], x, y, yaw)."""
    if len(poses) < 2:
        return 0.0
    last = poses[-1]
    first = next((p for p in reversed(poses[:-1]) if p[0] <= last[0] - SPEED_OVER_S), poses[0])
    dt = last[0] - first[0]
    if dt <= 0:
        return 0.0
    return ((last[1] - first[1]) * math.cos(last[3]) + (last[2] - first[2]) * math.sin(last[3])) / dt
