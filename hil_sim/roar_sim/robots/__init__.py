"""The simulated robots, one module each, and their registry: every run, the Gym environment,
sim:// and the pty find a robot here by its name, the name the CLI options (--robot), the URL
query (sim://?robot=) and the Gym keyword (robot=) use.

    from roar_sim import robots
    robots.names()                            # ('esc', 'iarrc', 'junior')
    with robots.get("junior")(track) as bot:  # a Robot: the firmware and its plant, in lockstep
        bot.arm()
        bot.drive(0.5, 0.0)                   # as a host sends it: here one GET of its control route
        bot.run(1.0)

A robot module defines one Robot subclass and names it ROBOT; adding a robot is one new module
here. What each gives: its rig (its firmware core's board loop driving its plant), how a
throttle/steering command reaches its firmware (drive(), and the bytes of its host link in
write()), its measured limits, and its default agent.
"""

from __future__ import annotations

import importlib
import math
import statistics
import pkgutil
from collections.abc import Callable
from typing import ClassVar

import numpy as np

from roar.autopilot import Agent, CarLimits, Command, Observation
from roar.autopilot.limits import HOLDS_LINE, circle, fade, tracked
from roar_sim import UnknownRobot
from roar.telemetry import VehicleState
from roar_sim.core.lockstep import CONTROL_PERIOD_S, Lockstep
from roar.tracks.track import Track, TrackError

DRIVER_WIDE_M = 0.35  # [m] how far wide of a hairpin's centre line the autopilot runs, turning no tighter than it
# can (measured: 0.35 m at a 0.74 m hairpin for the ESC car's 0.77 m); Robot.too_tight() adds what it cannot turn

Pose = tuple[float, float, float]  # x [m], y [m], yaw [rad]


def names() -> tuple[str, ...]:
    """Every robot's name, from the modules of this package."""
    return tuple(sorted(m.name for m in pkgutil.iter_modules(__path__)))


def get(name: str) -> type[Robot]:
    """The Robot class called `name` (UnknownRobot, one line, if there is none)."""
    if name not in names():
        raise UnknownRobot(f"unknown robot {name!r}: use one of {', '.join(names())}")
    return importlib.import_module(f"{__name__}.{name}").ROBOT


class ReplyLines:
    """The bytes a firmware writes to its host, as the whole lines among them (a line's start
    waits for its end)."""

    def __init__(self) -> None:
        self._partial = b""
        self._lines: list[str] = []

    def add(self, data: bytes) -> None:
        if data:
            *done, self._partial = (self._partial + bytes(data)).split(b"\n")
            self._lines += [line.decode("ascii", "replace") for line in done]

    def take(self) -> list[str]:
        """The whole lines added since the last take(), without their line ends."""
        lines, self._lines = self._lines, []
        return lines


class Robot(Lockstep):
    """One simulated robot: its firmware core's board loop and its plant in lockstep, in a world
    with an optional track, at `pose` (default: the track's start) -- and, through drive(),
    observe() and wait(), the car a roar.autopilot Runner drives."""

    name: ClassVar[str]  # as --robot, sim://?robot= and robot= spell it
    title: ClassVar[str]  # as reports name it
    limits: ClassVar[CarLimits]  # measured by measure_limits(); the suite re-measures them
    half_width_m: ClassVar[float]  # [m] from its middle to its widest part: how near a wall its line may run
    links: ClassVar[tuple[str, ...]] = ()  # how programs reach it beside sim://: "serial", "http", "stream"
    laterals: ClassVar[tuple[str, ...]] = ("pursuit",)  # the steering its agent() offers
    lane_driving: ClassVar[bool] = False  # it can drive by its camera alone (roar race --driver lane)
    replies: ClassVar[bool] = False  # it answers its host with lines (READY, ERR, TEL, ...)
    has_lidar: ClassVar[bool] = False
    camera: ClassVar = None  # its camera's field of view and mount (roar.vision.geometry.CameraPreset)
    ultrasonic_max_m: ClassVar[float | None] = None  # [m] its ultrasonic ranger's reach, if it has one
    track: Track | None
    model: ClassVar  # what its driver plans with: a CarModel or DiffDriveModel (its turning radius among it)
    # its own numbers: the module its profiles load from (roar_sim.plants.car_profile for a robot
    # whose plant is the racecar, roar_sim.plants.junior_profile for the Junior), and the shipped
    # profile that is its default; any other it takes as profile=, sim://?profile=, --car-profile
    profiles: ClassVar = None
    default_profile: ClassVar[str]
    limits_version: ClassVar[int] = 1  # of how its limits are measured: a profile's kept by another are measured again

    @classmethod
    def profile_of(cls, profile=None):
        """Its profile that `profile` names (a profile, a name or a .toml; None: its default);
        ProfileError (one line) for a bad one."""
        if profile is None or isinstance(profile, str):
            return cls.profiles.load(cls.default_profile if profile is None else profile)
        return profile

    @classmethod
    def profile_ranges(cls) -> dict[str, tuple[float, float, str]]:
        """{key: (low, high, unit)} of every number its profiles hold (Race-v0's randomize= draws them)."""
        return cls.profiles.RANGES | cls.profiles.OPTIONAL_RANGES

    @classmethod
    def model_for(cls, profile, limits: CarLimits):
        """What its driver plans with, for a car `profile` describes with `limits`: a racecar's
        wheelbase and steering (a robot of another build overrides this)."""
        from roar.autopilot import CarModel

        return CarModel(profile.wheelbase_m, profile.max_steer_rad, limits)

    def plan_by(self, profile) -> None:
        """Its autopilot plans by `profile` (a profile, a name or a .toml): that car's limits and
        build, while the car driven stays this one. A fitted profile driving the car it was fitted
        to, or today's constants driving a car they do not describe."""
        plan = self.profile_of(profile)
        self.limits = profile_limits(type(self), plan, type(self).limits)
        self.model = self.model_for(plan, self.limits)

    @classmethod
    def min_turn_radius_m(cls, profile=None) -> float:
        """[m] the tightest circle the robot can drive (of the car a profile describes)."""
        car = cls.profile_of(profile)
        return car.wheelbase_m / math.tan(car.max_steer_rad)

    @classmethod
    def check_track(cls, track: Track, profile=None) -> None:
        """TrackError (one line: which bend, where, what radius) when the track bends tighter
        than the robot can take it: its driver would wedge it into the wall there, and no
        physical-limit lap exists to measure it against (too_tight())."""
        problem = cls.too_tight(track, profile)
        if problem:
            raise TrackError(f"track {track.name!r} {problem}; open the bend out or widen the track there, or race a "
                             f"robot that can take it")

    @classmethod
    def too_tight(cls, track: Track, profile=None) -> str | None:
        """Where the track's centre line bends tighter than the robot turns by more than the
        track's width lets it run wide, in words; None where it can take every bend. At full lock
        a car runs up to 2 (R - r) wide of a hairpin of radius r (R: its tightest circle), beyond
        the DRIVER_WIDE_M its driver runs wide of any hairpin and its own half width: that must
        stay inside the wall on the bend's outside (measured: the ESC car laps a 0.68 m hairpin
        2.2 m wide and a 0.74 m one 1.2 m wide, and wedges in a 0.68 m one 1.2 m wide, a 0.5 m
        one 1.6 m wide and a 0.31 m one 2.2 m wide)."""
        least = cls.min_turn_radius_m(profile)
        radii = track.bend_radii()
        if not (radii < least).any():
            return None
        left, right = track.half_widths[:, 0], track.half_widths[:, 1]
        outside = np.where(track.turns_left(), right, left)  # [m] from the centre line to the bend's outer wall
        wide = 2 * np.maximum(0.0, least - radii)
        room = outside - cls.half_width_m - DRIVER_WIDE_M
        short = wide - room
        i = int(np.argmax(short))
        if short[i] <= 0:
            return None
        x, y = track.centerline[i]
        return (f"bends with a radius of {radii[i]:.2f} m {track.arc_start[i]:.1f} m along its centre line, at "
                f"({x:.2f}, {y:.2f}): the {cls.title} turns no tighter than {least:.2f} m: running wide "
                f"there its side would reach {wide[i] + DRIVER_WIDE_M + cls.half_width_m:.2f} m out from the centre "
                f"line, and the wall is {outside[i]:.2f} m out")

    def __init__(self, track: Track | None, realtime: bool = False, speedup: float = 1.0) -> None:
        self.track, self.realtime, self.speedup = track, realtime, speedup
        self.t_us = 0
        self._last_yaw: tuple[float, float, float] | None = None  # (t [s], yaw [rad], rate [rad/s]) last reported

    # --- how a command reaches the firmware ------------------------------------------------------

    def drive(self, throttle: float, steering: float) -> None:
        """One command in [-1, 1] each (steering +1 full right), as a host sends it."""
        raise NotImplementedError

    def host_drive(self, throttle: float, steering: float) -> dict:
        """A command of its agent as the keywords of roar.Vehicle.drive() for a host driving it
        over sim:// (the same command drive() delivers)."""
        return {"throttle": throttle, "steering": steering}

    def write(self, data: bytes) -> None:
        """Bytes a host sends on the robot's link, arriving now."""
        raise NotImplementedError

    def read(self) -> list[str]:
        """Lines the robot wrote to its host since the last read."""
        return []

    def arm(self) -> None:
        """Neutral for one control period: a car that boots latched arms on it."""
        self.drive(0.0, 0.0)
        self.run(CONTROL_PERIOD_S)

    # --- what drives it ----------------------------------------------------------------------

    def agent(self, line: np.ndarray, margin: float = 0.9, lateral: str = "pursuit",
              k_dd_s: float | None = None) -> Agent:
        """The default driver round a closed line at `margin` of the limits; k_dd_s: pure
        pursuit's look-ahead per m/s [s] (None: the robot's default)."""
        raise NotImplementedError

    def speed_control(self):
        """What turns a driver's target speed into its throttle (roar.autopilot's SpeedController
        or SpeedSetpoint; None: race_agent's default, a SpeedController for its limits)."""
        return None

    def observe(self) -> Observation:
        """The car's report; its yaw rate is the gyro's over the time since the last report (a
        MEMS gyro low-passes its rate: a knock shorter than a control period is felt whole, not
        as whatever the rate happens to be at the instant of the report)."""
        s, t = self.state(), self.time_s
        last, rate = self._last_yaw, s.yaw_rate
        if last is not None and t > last[0]:
            rate = math.remainder(s.yaw - last[1], math.tau) / (t - last[0])
        elif last is not None:
            rate = last[2]
        self._last_yaw = (t, s.yaw, rate)
        return Observation(t, s.x, s.y, s.yaw, abs(s.speed), rate)

    def send(self, command: Command) -> None:
        self.drive(command.throttle, command.steering)

    def wait(self, seconds: float) -> None:
        self.run(seconds)

    # --- what it tells -----------------------------------------------------------------------

    def vehicle_state(self) -> VehicleState:
        """What a roar.Vehicle reads back from it over sim://."""
        s = self.state()
        return VehicleState(self.time_s, s.x, s.y, s.yaw, s.speed, s.yaw_rate)

    def info(self) -> dict:
        """What its firmware outputs now, for the Gym environment's info."""
        return {}

    def braking(self) -> bool:
        """Its motor is braking or reversing now (the ESC's brake sequence)."""
        return False

    def touching_wall(self) -> bool:
        return self.plant.wall_contacts() > 0

    def touching(self, bodies: list[int]) -> bool:
        """Whether it touches any of these bodies (a tunnel's cones or people) right now."""
        return bool(bodies) and self.plant.wall_contacts(bodies) > 0

    # --- its limits --------------------------------------------------------------------------

    @classmethod
    def measure_limits(cls, profile=None) -> CarLimits:
        """Drive fresh robots (of `profile`: None, its default) on an open floor and read their
        limits from the logs."""
        raise NotImplementedError

    @classmethod
    def unmeasurable_hint(cls, profile) -> str:
        """What to say of a profile whose limits could not be measured: why it may not drive."""
        from roar_sim.plants.racecar import WHEEL_RADIUS_M

        top = profile.motor.max_speed_rad_s * WHEEL_RADIUS_M * profile.scale
        return f" (its wheels' top speed is {top:.1f} m/s; a 1/10 car reaches 2-10 m/s)"

    def log_driving(self, send: Callable[[], None], seconds: float) -> list[tuple[float, object]]:
        """send() and run one control period, for `seconds`: [(time [s], state)] after each."""
        log = []
        for _ in range(round(seconds / CONTROL_PERIOD_S)):
            send()
            self.run(CONTROL_PERIOD_S)
            log.append((self.time_s, self.state()))
        return log


def grip_on_circles(make: Callable[[], Robot], steerings, speeds, drive_circle) -> tuple[float, tuple]:
    """(the most lateral acceleration [m/s^2] a robot holds on steady circles, and how it fades
    with speed: CarLimits.lateral_fade). For each steering, fresh robots from make() are driven
    faster and faster (drive_circle(robot, speed, steering) -> the log of its steady part): a
    circle within HOLDS_LINE of the slowest one's radius counts as grip (its tyres do not slide);
    the row goes on while the autopilot's curvature tracker could still hold the circle
    (roar.autopilot.limits.tracked) and the car does not spin (a circle tighter than the slowest
    by HOLDS_LINE: its rear wheels spun up lose their grip), and its last such circle is where
    that steering's grip ends."""
    peak, ends = (0.0, 0.0), []
    for steering in steerings:
        base_radius, last, slid = None, None, False
        for speed in speeds:
            with make() as robot:
                log = drive_circle(robot, speed, steering)
            radius, accel_lateral = circle(log)
            base_radius = base_radius or radius  # the slowest run: no slip
            if not tracked(base_radius, radius) or radius < base_radius / HOLDS_LINE:  # pushed wide, or spun
                if last is not None:
                    ends.append(last)
                break
            last = (statistics.median(s.speed for _, s in log), accel_lateral)
            slid = slid or radius > HOLDS_LINE * base_radius  # from here on the tyres slip
            if not slid and accel_lateral > peak[1]:
                peak = last
    return peak[1], fade(peak, ends)


class ProfileLimits:
    """A robot's `limits`: its table (`table`, measured from its default profile)
    on the class; on a robot, its own profile's, measured (or read from the user's cache) when
    first asked for, so a robot driven without an autopilot (a fit's test drive) never waits."""

    def __init__(self, table: CarLimits) -> None:
        self.table = table

    def __get__(self, robot, cls):
        if robot is None:
            return self.table
        robot.limits = profile_limits(cls, robot.profile, self.table)  # kept on the robot from now on
        return robot.limits


class ProfileModel:
    """A robot's `model`: the default's on the class; on a robot, its own profile's."""

    def __init__(self, model) -> None:
        self.model = model

    def __get__(self, robot, cls):
        if robot is None:
            return self.model
        robot.model = cls.model_for(robot.profile, robot.limits)
        return robot.model


def profile_limits(kind: type[Robot], profile, table: CarLimits) -> CarLimits:
    """A profile's limits on robot `kind`: its table for its default profile, else measured once
    (a few seconds: kind.measure_limits(profile)) and kept in the user's cache under the profile's
    fingerprint."""
    import json
    import sys

    from roar_sim import ProfileError
    from roar_sim.toolchains.native import user_cache

    if profile == kind.profile_of():
        return table
    key = (kind.name, profile.fingerprint)
    if key in _MEASURED:
        return _MEASURED[key]
    kept = user_cache("limits") / f"{kind.name}-{profile.fingerprint}-v{kind.limits_version}.json"
    try:
        limits = CarLimits(**json.loads(kept.read_text()))
    except (OSError, ValueError, TypeError):
        print(f"measuring the {profile.title}'s limits as the {kind.title} (once; kept in {kept.parent})...",
              file=sys.stderr)
        try:
            limits = kind.measure_limits(profile)
        except (StopIteration, ZeroDivisionError, ValueError, statistics.StatisticsError):
            # a run that never reached 90 % of its speed, never stopped, or never turned a circle
            raise ProfileError(f"{profile.title}: its limits cannot be measured: driving it at full throttle, braking "
                               f"and on circles gave no steady run{kind.unmeasurable_hint(profile)}") from None
        try:
            kept.parent.mkdir(parents=True, exist_ok=True)
            kept.write_text(json.dumps(vars(limits)))
        except OSError:
            pass  # measured again next time
    _MEASURED[key] = limits
    return limits


_MEASURED: dict[tuple[str, str], CarLimits] = {}
