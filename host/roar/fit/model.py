"""The car model a fit adjusts, with the structure of a hobby car's drive, driven by the pulses
the car was sent:

    pulses --(delays)-> servo: target = trim + gain * (1500 - pulse) / 500, lagged (first order)
                                 yaw rate = speed tan(angle) / (wheelbase + understeer speed^2),
                                   at most lateral / speed
                        ESC:   a dead band about 1500 us; above it forward, a fraction of full:
                                 the wheels' speed top * fraction, reached at drive * fraction +
                                 coast m/s^2 (at most traction); below it, once the board's
                                 brake/reverse sequence has passed (PROTOCOL.md 2.3: neutral, tap,
                                 neutral), the motor reversed at reverse * fraction of that, which
                                 is how the car brakes; within the dead band the car coasts

Each channel has its own delay: a servo's lag shows mostly as delay beside the lag of the car's
own yaw, and the ESC's shows the link's and the board's alone.

Speed is predicted over short windows from the speed measured at each window's start (so an
error does not build up over a minute), the steering over the whole record (the servo does not
depend on the car's motion). Pulses between two messages are ramped over the messages' period:
a frame takes the newest pulse at its start, and frames fall anywhere in that period.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from roar.compiled import compiled
from roar.protocol import spec

N = spec.CONTROL_NEUTRAL_US  # [us]
HALF_RANGE_US = (spec.CONTROL_MAX_US - spec.CONTROL_MIN_US) / 2  # [us]
STEP_S = 0.01  # [s] the model's time step
WINDOW_S = 1.0  # [s] each speed prediction's span
WINDOW_EVERY_S = 0.5  # [s] between window starts
# [s] a reverse pulse after forward drives only after the board's sequence: neutral, tap, neutral,
# each at least a step and a frame
SEQUENCE_S = 3 * max(spec.TIMING_BRAKE_STEP_US, spec.TIMING_SERVO_FRAME_US) / 1e6


@dataclass(frozen=True)
class Param:
    name: str
    unit: str
    low: float
    high: float
    start: float
    what: str


# What a fit finds, each within bounds wide enough for any 1/10 to 1/8 hobby car, from a start
# that is a typical car's, except the two limits: they start low, where they bind (a limit that
# binds nowhere has no slope for the fit to follow)
PARAMS = (
    Param("trim_deg", "deg", -10.0, 10.0, 0.0, "the wheels' angle at a 1500 us pulse, left positive"),
    Param("gain_rad", "rad", 0.1, 0.7, 0.35, "the wheels' angle at full steering (500 us off neutral)"),
    Param("understeer_s2_m", "s^2/m", 0.0, 0.1, 0.01, "more wheel angle per m/s^2 sideways than the geometry's"),
    Param("lag_s", "s", 0.0, 0.3, 0.03, "the steering's first-order lag: the servo's and the tyres' together"),
    Param("steer_delay_s", "s", 0.0, 0.3, 0.04, "from a message sent to the steering acting on it"),
    Param("delay_s", "s", 0.0, 0.3, 0.04, "from a message sent to the ESC acting on it"),
    Param("deadband_us", "us", 0.0, 150.0, 20.0, "throttle pulses this near 1500 us are neutral"),
    Param("top_m_s", "m/s", 0.5, 20.0, 3.0, "the wheels' speed at full throttle"),
    Param("drive_m_s2", "m/s^2", 0.5, 100.0, 8.0, "acceleration per unit throttle fraction, before traction"),
    Param("coast_m_s2", "m/s^2", 0.01, 5.0, 0.3, "deceleration coasting"),
    Param("reverse", "", 0.1, 1.0, 0.6, "the ESC's reverse power, a share of forward"),
    Param("traction_m_s2", "m/s^2", 0.5, 20.0, 1.0, "the most the driven wheels accelerate or brake the car"),
    Param("lateral_m_s2", "m/s^2", 0.5, 20.0, 1.5, "the most sideways acceleration the tyres hold"),
)
NAMES = tuple(p.name for p in PARAMS)


@dataclass(frozen=True)
class Car:
    """One value per PARAMS entry."""

    trim_deg: float
    gain_rad: float
    understeer_s2_m: float
    lag_s: float
    steer_delay_s: float
    delay_s: float
    deadband_us: float
    top_m_s: float
    drive_m_s2: float
    coast_m_s2: float
    reverse: float
    traction_m_s2: float
    lateral_m_s2: float

    @classmethod
    def start(cls) -> Car:
        return cls(*(p.start for p in PARAMS))

    def vector(self) -> np.ndarray:
        return np.array([getattr(self, f.name) for f in fields(self)])


class Inputs:
    """The pulses a record sent, on the model's time grid, shifted by a delay."""

    def __init__(self, pulse_t: np.ndarray, throttle_us: np.ndarray, steering_us: np.ndarray, end_s: float) -> None:
        self.pulse_t, self.throttle_us, self.steering_us = pulse_t, throttle_us, steering_us
        self.t = np.arange(pulse_t[0], end_s + STEP_S, STEP_S)
        self.esc_us = through_sequence(pulse_t, throttle_us)

    def at_delay(self, car: Car) -> tuple[np.ndarray, np.ndarray]:
        """(throttle [us], steering [us]) acting at each grid time: as sent each channel's delay before."""
        return (np.interp(self.t - car.delay_s, self.pulse_t, self.esc_us, left=N),
                np.interp(self.t - car.steer_delay_s, self.pulse_t, self.steering_us, left=N))


def steering_angle(car: Car, steering_us: np.ndarray) -> np.ndarray:
    """[rad] the wheels' angle at each grid time, left positive, for the steering pulses acting then."""
    frac = np.clip((steering_us - N) / HALF_RANGE_US, -1.0, 1.0)
    target = np.clip(math.radians(car.trim_deg) - frac * car.gain_rad, -car.gain_rad, car.gain_rad)
    if car.lag_s <= 1e-4:
        return target
    from scipy.signal import lfilter

    keep = math.exp(-STEP_S / car.lag_s)  # a first-order lag, exact for a step held over STEP_S
    return lfilter([1 - keep], [1, -keep], target, zi=[keep * target[0]])[0]


def yaw_rate(car: Car, angle: np.ndarray, speed: np.ndarray, wheelbase_m: float) -> np.ndarray:
    """[rad/s] the yaw rate of a car at `speed` with its wheels at `angle`, within its grip."""
    # a car understeers: a turn at sideways acceleration a takes the geometry's angle plus
    # understeer x a, so at speed v the yaw rate is v tan(angle) / (wheelbase + understeer v^2).
    # Left and right turns at different speeds would otherwise be read as a trim
    rate = speed * np.tan(angle) / (wheelbase_m + car.understeer_s2_m * speed**2)
    most = car.lateral_m_s2 / np.maximum(np.abs(speed), 0.05)
    return np.clip(rate, -most, most)


def through_sequence(pulse_t: np.ndarray, throttle_us: np.ndarray) -> np.ndarray:
    """[us] the throttle pulses as the board passes them on: a reverse pulse after forward is
    neutral until the brake/reverse sequence (SEQUENCE_S) has run (its tap, 50 us below neutral
    for one frame, is taken as neutral: within or near any ESC's dead band)."""
    out = throttle_us.astype(float)
    ready, began = True, None  # reverse passes straight through; when the sequence began
    for k, (t, p) in enumerate(zip(pulse_t.tolist(), throttle_us.tolist())):
        if p > N:
            ready, began = False, None
        elif p == N:
            began = None if not ready else began
        elif not ready:
            began = t if began is None else began
            if t - began >= SEQUENCE_S:
                ready = True
            else:
                out[k] = N
    return out


def esc_fraction(car: Car, throttle_us: np.ndarray) -> np.ndarray:
    """The motor's drive for each throttle pulse the ESC takes: -1..1 of full forward (reverse
    scaled by the ESC's reverse share), 0 within the dead band."""
    off = throttle_us - N
    span = HALF_RANGE_US - car.deadband_us
    forward = np.clip((off - car.deadband_us) / span, 0.0, 1.0)
    reverse = np.clip((-off - car.deadband_us) / span, 0.0, 1.0) * car.reverse
    return forward - reverse


def speeds(car: Car, throttle_us: np.ndarray, starts: np.ndarray, v0: np.ndarray, steps: int) -> np.ndarray:
    """[m/s] speed over `steps` grid steps from each start index (rows: windows), from v0 there,
    for the throttle pulses the ESC takes at each grid step (after the board's sequence): the
    motor pushes towards its wheels' speed (top * fraction) and never past it, a car faster than
    its wheels (same direction) coasts down to them, and within the dead band it coasts to rest
    (roar.fit.speed_kernel, compiled)."""
    drive = esc_fraction(car, throttle_us)
    idx = np.minimum(starts[:, None] + np.arange(steps)[None, :], len(throttle_us) - 1)
    out = np.empty(idx.shape)
    _speed_kernel()(np.ascontiguousarray(drive[idx]), np.asarray(v0, dtype=float), float(car.top_m_s),
                    float(car.drive_m_s2), float(car.coast_m_s2), float(car.traction_m_s2), STEP_S, out)
    return out


def _speed_kernel():
    return compiled("the fit's speed model", _build_speed_kernel, "fit")


def _build_speed_kernel(nb):
    from roar.fit.speed_kernel import speeds as kernel

    return kernel
