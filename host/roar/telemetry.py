"""What the car tells the host, with the same names over every link:

- its reply lines as typed events (CarEvent: ready, armed, failsafe, error with its reason);
- its state (VehicleState), each field None where the link cannot provide it. The simulator
  provides them all; a BLE car its speed (the velocity characteristic) and the throttle pulse it
  outputs (the state characteristic); a ROAR Junior over http:// its ultrasonic range; a serial
  car nothing.

    with Vehicle("sim://oval") as car:
        car.wait_for(EventKind.ARMED, timeout_s=2)
        s = car.state()        # VehicleState(time_s=.., x_m=.., speed_m_s=.., ...)
        scan = car.lidar()     # distances [m], right to left over 270 degrees, or None
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

from roar.protocol import spec


class EventKind(Enum):
    READY = "ready"  # the car booted (latched); detail: its protocol version
    ARMED = "armed"  # a neutral command released the failsafe latch
    FAILSAFE = "failsafe"  # the failsafe tripped (or a command arrived while latched)
    ERROR = "error"  # a message was rejected; detail: the reason (syntax, range, too_long, ...)


_WORDS = {spec.SERIAL_REPLY_READY: EventKind.READY, spec.SERIAL_REPLY_ARMED: EventKind.ARMED,
          spec.SERIAL_REPLY_FAILSAFE: EventKind.FAILSAFE, spec.SERIAL_REPLY_ERROR: EventKind.ERROR}


@dataclass(frozen=True)
class CarEvent:
    kind: EventKind
    detail: str | None  # the rest of the line (READY's version, ERR's reason), None when empty
    line: str  # the line as the car sent it
    at_s: float  # time.monotonic() when the host received it


def parse_event(line: str, at_s: float) -> CarEvent | None:
    """The event a reply line reports, or None for a line that is not one of the protocol's."""
    word, _, rest = line.strip().partition(" ")
    kind = _WORDS.get(word)
    return CarEvent(kind, rest or None, line, at_s) if kind else None


@dataclass(frozen=True)
class VehicleState:
    """The car as the link reports it right now; None where the link cannot tell."""

    time_s: float | None = None  # [s] the car's (or the simulator's) clock
    x_m: float | None = None  # [m] position
    y_m: float | None = None  # [m]
    yaw_rad: float | None = None  # [rad] heading, anticlockwise from +x
    speed_m_s: float | None = None  # [m/s] along the heading, negative in reverse
    yaw_rate_rad_s: float | None = None  # [rad/s]
    wheel_encoder_counts: int | None = None  # rear wheel encoder, signed
    throttle_out_us: float | None = None  # [us] the throttle pulse the car outputs now
    range_m: float | None = None  # [m] the ultrasonic range ahead (a Junior); inf: no echo within 4 m
    battery_v: float | None = None  # [V] (a car that sends telemetry lines: the IARRC car)
    battery_low: bool | None = None  # below the car's low-voltage warning (it cuts the motor lower still)
    distance_m: float | None = None  # [m] driven since the car booted, by its wheel encoder, signed
    mode: str | None = None  # the controller's mode: a word of roar.protocol.spec.IarrcMode (autonomous, ...)
    failsafe: str | None = None  # why it failed safe: a word of roar.protocol.spec.IarrcFailsafe
    setpoint_m_s: float | None = None  # [m/s] the speed the car is holding (autonomous)


MODES = {str(m) for m in spec.IarrcMode}  # the words a TEL line may carry
FAILSAFES = {str(f) for f in spec.IarrcFailsafe}


def parse_telemetry(line: str) -> dict | None:
    """The fields of a telemetry line ("TEL ..." in protocol/PROTOCOL.md) as VehicleState fields and
    the PID gains, or None for any other line or a malformed one."""
    words = line.split()
    names = spec.TELEMETRY_FIELDS.split()
    if len(words) != len(names) + 1 or words[0] != spec.TELEMETRY_REPLY:
        return None
    raw = dict(zip(names, words[1:]))
    if raw["mode"] not in MODES or raw["failsafe"] not in FAILSAFES:
        return None
    try:  # decimal integers only: a NaN or an infinity is no number here
        numbers = {k: int(v) for k, v in raw.items() if k not in ("mode", "failsafe")}
    except ValueError:
        return None
    return {"mode": raw["mode"], "failsafe": raw["failsafe"], "battery_v": numbers["battery_mv"] / 1000,
            "battery_low": bool(numbers["battery_low"]),
            "distance_m": numbers["distance_mm"] / 1000, "speed_m_s": numbers["speed_mm_s"] / 1000,
            "setpoint_m_s": numbers["setpoint_mm_s"] / 1000, "throttle_out_us": float(numbers["throttle_us"]),
            "steering_out_us": float(numbers["steering_us"]),
            "yaw_rate_rad_s": math.radians(numbers["yaw_rate_mdeg_s"] / 1000),
            "pid_gains_pm": (numbers["kp_pm"], numbers["ki_pm"], numbers["kd_pm"], numbers["ff_pm"]),
            "overruns": numbers["overruns"]}


UNKNOWN = VehicleState()
