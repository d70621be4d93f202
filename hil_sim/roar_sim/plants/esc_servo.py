"""Emulated hobby ESC and steering servo: what the pulses on the car's output pins do.

Both read one pulse per output frame (50 Hz), as the real parts do.
"""

from __future__ import annotations

import collections
import math
from dataclasses import dataclass
from enum import Enum

from roar.protocol import spec

N = spec.CONTROL_NEUTRAL_US
HALF_RANGE_US = (spec.CONTROL_MAX_US - spec.CONTROL_MIN_US) / 2  # [us]


class EscMode(Enum):
    NEUTRAL = "neutral"
    FORWARD = "forward"
    BRAKE = "brake"
    REVERSE = "reverse"


@dataclass
class EscOutput:
    mode: EscMode
    drive: float  # -1..1 fraction of the motor limit (negative = reverse); 0 when braking or neutral
    brake: float  # 0..1 brake strength


@dataclass
class HobbyEsc:
    """A forward/brake/reverse car ESC (the common Traxxas/Hobbywing default).

    * Pulses within `deadband_us` of neutral are neutral (the motor coasts).
    * Above: forward, proportional.
    * Below, after driving forward: **brake**, proportional, for as long as it is held. The ESC
      only reverses after it has seen a below-neutral pulse (brake) and then neutral again.
    * Below, from rest otherwise: reverse, limited to `reverse_limit` of full power.
    """

    deadband_us: int = 25  # [us]
    reverse_limit: float = 0.5  # fraction of forward power allowed in reverse
    mode: EscMode = EscMode.NEUTRAL
    reverse_locked: bool = False  # set by forward; cleared by brake followed by neutral
    _braked: bool = False

    def pulse(self, width_us: int) -> EscOutput:
        off = width_us - N
        if abs(off) <= self.deadband_us:
            if self._braked:
                self.reverse_locked = False
                self._braked = False
            self.mode = EscMode.NEUTRAL
            return EscOutput(EscMode.NEUTRAL, 0.0, 0.0)
        amount = min(1.0, (abs(off) - self.deadband_us) / (HALF_RANGE_US - self.deadband_us))
        if off > 0:
            self.mode, self.reverse_locked, self._braked = EscMode.FORWARD, True, False
            return EscOutput(EscMode.FORWARD, amount, 0.0)
        if self.reverse_locked:
            self.mode, self._braked = EscMode.BRAKE, True
            return EscOutput(EscMode.BRAKE, 0.0, amount)
        self.mode = EscMode.REVERSE
        return EscOutput(EscMode.REVERSE, -amount * self.reverse_limit, 0.0)


@dataclass
class SteeringServo:
    """Pulse -> steering angle. Above-neutral pulses steer right (negative angle, yaw clockwise).

    `trim_us` is the servo horn's mechanical offset, `max_angle_rad` the end-points, and
    `rate_rad_s` the slew limit (a standard servo does 60 degrees in 0.1 s). A real car's linkage
    adds `trim_rad` (its wheels' angle at a neutral pulse: a car that does not drive straight,
    within the end-points) and `lag_s` (a first-order lag behind the slew: a soft servo or a
    sloppy linkage)."""

    trim_us: int = 0  # [us]
    max_angle_rad: float = 0.4  # [rad] at 1000/2000 us
    rate_rad_s: float = math.radians(60) / 0.1  # [rad/s]
    trim_rad: float = 0.0  # [rad] left positive
    lag_s: float = 0.0  # [s] time constant
    angle_rad: float = 0.0  # [rad] current, left positive
    target_rad: float = 0.0  # [rad]

    def pulse(self, width_us: int) -> None:
        frac = (width_us - N - self.trim_us) / HALF_RANGE_US
        target = -max(-1.0, min(1.0, frac)) * self.max_angle_rad + self.trim_rad
        self.target_rad = max(-self.max_angle_rad, min(self.max_angle_rad, target))

    def advance(self, dt_s: float) -> float:
        step = self.rate_rad_s * dt_s
        error = self.target_rad - self.angle_rad
        if self.lag_s > 0.0:
            error *= -math.expm1(-dt_s / self.lag_s)  # the lag's share of the way this step
        self.angle_rad += max(-step, min(step, error))
        return self.angle_rad


def actuators(profile) -> tuple[HobbyEsc, SteeringServo]:
    """The ESC and the steering servo a car profile (roar_sim.plants.car_profile) describes."""
    return (HobbyEsc(deadband_us=profile.esc_deadband_us),
            SteeringServo(max_angle_rad=profile.max_steer_rad, rate_rad_s=profile.steer_rate_rad_s,
                          trim_rad=math.radians(profile.steering_trim_deg), lag_s=profile.servo_lag_s))


class PulseDelay:
    """A car's latency from the board's output pulses to its ESC and servo acting on them (a car
    profile's latency_s): pulses put in at a frame's start come out that much later."""

    def __init__(self, latency_s: float) -> None:
        self.latency_us = round(latency_s * 1e6)  # [us]
        self._queue: collections.deque[tuple[int, int, int]] = collections.deque()  # (due [us], throttle, steering)

    def put(self, t_us: int, throttle_us: int, steering_us: int) -> None:
        self._queue.append((t_us + self.latency_us, throttle_us, steering_us))

    def due(self, t_us: int) -> list[tuple[int, int]]:
        """(throttle, steering) [us] of every frame whose pulses act by t_us, oldest first."""
        out = []
        while self._queue and self._queue[0][0] <= t_us:
            out.append(self._queue.popleft()[1:])
        return out
