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


UNKNOWN = VehicleState()
