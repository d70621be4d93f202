"""Speed control for a hobby car whose ESC has no brake, the ROAR seed's way: PID on speed with
a feed-forward, and braking by commanding reverse. The firmware's brake/reverse FSM turns the
first reverse after forward into neutral -> brake tap -> neutral -> reverse, which the ESC
takes as braking and then as reverse torque, slowing the car; the controller stops asking
before the car would roll backwards. A speedometer gives only the speed's size, so the direction
of travel is taken from the recent throttle history."""

from __future__ import annotations

from dataclasses import dataclass, field

from roar.autopilot.pid import PID


@dataclass
class DirectionEstimator:
    """+1 (forward) or -1 (reverse): the way the car was last driven while it moved. A car seen
    moving after forward throttle is moving forward until it is seen (nearly) stopped, however
    long it brakes on reverse throttle; once stopped, the throttle's sign says which way it goes
    next (reverse then means backwards)."""

    stopped_m_s: float = 0.3  # [m/s] slower than this it is as good as stopped
    _last: int = field(default=1, init=False, repr=False)  # the way it last moved under power
    _moving: bool = field(default=False, init=False, repr=False)

    def update(self, throttle: float, speed_m_s: float | None = None) -> int:
        if speed_m_s is not None and speed_m_s < self.stopped_m_s:
            self._moving = False
        if not self._moving and throttle != 0:
            self._last = 1 if throttle > 0 else -1  # it will move the way it is now pushed
            self._moving = speed_m_s is None or speed_m_s >= self.stopped_m_s
        elif speed_m_s is not None and speed_m_s >= self.stopped_m_s:
            self._moving = True
        return self.direction

    @property
    def direction(self) -> int:
        return self._last


# The gains in fractions of the car's top speed, so one controller serves a 3 m/s car and an 8 m/s
# one alike (throttle 1 is its top speed): the ROAR car's (2.93 m/s) 0.6, 0.4 and 1.5 per m/s.
TUNED_TOP_M_S = 2.93  # [m/s] the top speed the gains were tuned at
KP_PER_TOP = 0.6 * TUNED_TOP_M_S  # throttle per (error / top speed)
KI_PER_TOP = 0.4 * TUNED_TOP_M_S  # throttle per (integrated error [m] / top speed), per second
BRAKE_GAIN_PER_TOP = 1.5 * TUNED_TOP_M_S  # reverse throttle per (excess / top speed)


@dataclass
class SpeedController:
    max_speed_m_s: float  # [m/s] at full throttle: feed-forward = target / max
    deadband: float = 0.05  # throttle the ESC ignores around neutral (its deadband / half range)
    pid: PID | None = None  # default: KP_PER_TOP and KI_PER_TOP for this top speed
    brake_margin_m_s: float = 0.2  # [m/s] faster than the target by more than this: brake
    brake_gain: float | None = None  # reverse throttle per m/s over the target (default: BRAKE_GAIN_PER_TOP)
    stop_speed_m_s: float = 0.3  # [m/s] below this never brake (the next step would be reversing)
    # the strongest reverse throttle when braking (CarLimits.max_reverse: a fast car's rear wheels
    # reversed at full power lose their grip and it spins; an 8 m/s car at full reverse turned 86 degrees)
    max_reverse: float = 1.0
    direction: DirectionEstimator = field(default_factory=DirectionEstimator)

    def __post_init__(self) -> None:
        if self.pid is None:
            self.pid = PID(kp=KP_PER_TOP / self.max_speed_m_s, ki=KI_PER_TOP / self.max_speed_m_s, kd=0.0,
                           out_min=0.0, out_max=1.0)
        if self.brake_gain is None:
            self.brake_gain = BRAKE_GAIN_PER_TOP / self.max_speed_m_s

    def reset(self) -> None:
        self.pid.reset()

    def step(self, target_m_s: float, speed_m_s: float, dt_s: float) -> float:
        """Throttle in [-1, 1] to reach target_m_s (>= 0) from speed_m_s (a magnitude)."""
        moving_forward = self.direction.direction > 0
        excess = speed_m_s - target_m_s
        if moving_forward and excess > self.brake_margin_m_s and speed_m_s > self.stop_speed_m_s:
            throttle = -min(self.max_reverse, self.brake_gain * excess)
            self.pid.reset()
        else:
            ff = target_m_s / self.max_speed_m_s
            drive = self.pid.step(target_m_s - speed_m_s, dt_s, feed_forward=ff)
            throttle = 0.0 if drive <= 0 else self.deadband + (1 - self.deadband) * drive
        self.direction.update(throttle, speed_m_s)
        return throttle


@dataclass
class SpeedSetpoint:
    """Speed "control" for a car that holds a speed itself (the IARRC car's PID on its wheel
    encoder): the command is a setpoint, as a fraction of full_scale_m_s, the speed a command of 1
    asks such a car for. Its own PID lags a profile's quick changes, so the setpoint leads the
    target by `lead` times the speed still missing; the car does the rest, braking included."""

    full_scale_m_s: float  # [m/s]
    lead: float = 1.0  # setpoint above the target per m/s the car is short of it

    def reset(self) -> None:
        pass

    def step(self, target_m_s: float, speed_m_s: float, dt_s: float) -> float:
        """The command in [0, 1] for target_m_s >= 0 at speed_m_s (a magnitude): never a setpoint
        backwards, the car brakes for zero by itself."""
        setpoint = target_m_s + self.lead * (target_m_s - speed_m_s)
        return max(0.0, min(1.0, setpoint / self.full_scale_m_s))
