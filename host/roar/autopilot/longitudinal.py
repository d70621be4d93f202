"""Speed control for a hobby car whose ESC has no brake, the ROAR seed's way: PID on speed with
a feed-forward, and braking by commanding reverse. The firmware's brake/reverse FSM turns the
first reverse after forward into neutral -> brake tap -> neutral -> reverse, which the ESC
takes as braking and then as reverse torque, slowing the car; the controller stops asking
before the car would roll backwards. A speedometer gives only the speed's size, so the direction
of travel is taken from the recent throttle history."""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

from roar.autopilot.pid import PID


@dataclass
class DirectionEstimator:
    """+1 (forward) or -1 (reverse) from the sign of the recent throttle commands."""

    window: int = 25  # control periods (0.5 s at 50 Hz)
    _history: deque = field(default_factory=deque, init=False, repr=False)

    def update(self, throttle: float) -> int:
        self._history.append(throttle)
        while len(self._history) > self.window:
            self._history.popleft()
        return self.direction

    @property
    def direction(self) -> int:
        return -1 if sum(self._history) < 0 else 1


@dataclass
class SpeedController:
    max_speed_m_s: float  # [m/s] at full throttle: feed-forward = target / max
    deadband: float = 0.05  # throttle the ESC ignores around neutral (its deadband / half range)
    pid: PID = field(default_factory=lambda: PID(kp=0.6, ki=0.4, kd=0.0, out_min=0.0, out_max=1.0))
    brake_margin_m_s: float = 0.2  # [m/s] faster than the target by more than this: brake
    brake_gain: float = 1.5  # reverse throttle per m/s over the target
    stop_speed_m_s: float = 0.3  # [m/s] below this never brake (the next step would be reversing)
    direction: DirectionEstimator = field(default_factory=DirectionEstimator)

    def reset(self) -> None:
        self.pid.reset()

    def step(self, target_m_s: float, speed_m_s: float, dt_s: float) -> float:
        """Throttle in [-1, 1] to reach target_m_s (>= 0) from speed_m_s (a magnitude)."""
        moving_forward = self.direction.direction > 0
        excess = speed_m_s - target_m_s
        if moving_forward and excess > self.brake_margin_m_s and speed_m_s > self.stop_speed_m_s:
            throttle = -min(1.0, self.brake_gain * excess)
            self.pid.reset()
        else:
            ff = target_m_s / self.max_speed_m_s
            drive = self.pid.step(target_m_s - speed_m_s, dt_s, feed_forward=ff)
            throttle = 0.0 if drive <= 0 else self.deadband + (1 - self.deadband) * drive
        self.direction.update(throttle)
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
