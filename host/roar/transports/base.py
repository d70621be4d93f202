"""The one small interface every transport implements."""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any, ClassVar

from roar.checks import number
from roar.errors import RoarError
from roar.telemetry import VehicleState


class TransportError(RoarError):
    """The link to the car cannot be opened or used. str() is one line a user can act on."""


class LinkLost(TransportError):
    """A link that was open has gone (cable pulled, car out of range). Reopening may work."""


class Transport(ABC):
    """Bytes to the car, reply lines from it.

    Subclasses set `scheme`, build themselves from a URL in from_url(), and implement open(),
    write() and close(); read_lines() is optional (links without a back channel return [] and
    leave `replies` False). open/write/read_lines/close are called from one thread at a time
    (the Vehicle's sender); state(), lidar() and camera() may be called from the user's thread
    at any time and return None where the link cannot tell."""

    scheme: ClassVar[str]
    min_period_s: ClassVar[float] = 0.002  # [s] fastest the link takes one control message
    replies: ClassVar[bool] = False  # the link carries the car's reply lines (READY, ARMED, ...)

    url: str = ""

    @classmethod
    @abstractmethod
    def from_url(cls, target: str, options: dict[str, str]) -> Transport:
        """Build from the part after "scheme://" (without the query) and the query options.
        Pop every option you understand; leftovers are reported as unknown."""

    @abstractmethod
    def open(self) -> None:
        """Connect. Raises TransportError with a one-line reason."""

    @abstractmethod
    def write(self, data: bytes) -> None:
        """Send bytes now. Raises LinkLost when the link has gone."""

    def read_lines(self) -> list[str]:
        """Reply lines received since the last call (without line ends)."""
        return []

    @abstractmethod
    def close(self) -> None:
        """Release the link; safe to call twice and after a LinkLost."""

    def state(self) -> VehicleState | None:
        """The car's state as this link reports it now, or None."""
        return None

    def lidar(self) -> Any:
        """A 2D scan (distances [m], right to left) if the car has one on this link, else None."""
        return None

    def camera(self, width: int, height: int) -> Any:
        """(RGB uint8 HxWx3, depth float32 HxW [m] or None) if the car has a camera on this link, else None."""
        return None

    def camera_stream(self) -> Any:
        """An iterator of RGB frames if the car streams video on this link, else None."""
        return None

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.url}>"


def pop_option(options: dict[str, str], name: str, kind: type, default):
    """Take one query option, converted to `kind`; one-line TransportError when it does not parse."""
    if name not in options:
        return default
    raw = options.pop(name)
    try:
        if kind is bool:
            if raw.lower() in ("1", "true", "yes", "on"):
                return True
            if raw.lower() in ("0", "false", "no", "off"):
                return False
            raise ValueError
        return kind(raw)
    except ValueError:
        raise TransportError(f"option {name}={raw!r} is not a valid {kind.__name__}") from None


def pop_number(options: dict[str, str], name: str, default: float, low: float, high: float, unit: str = "",
               low_open: bool = False) -> float:
    """Take one numeric query option, finite and within low..high; one-line TransportError if not."""
    value = pop_option(options, name, float, default)
    try:
        return number(name, value, low, high, unit, low_open)
    except ValueError as e:
        raise TransportError(str(e)) from None


def unit_command(data: bytes, scheme: str) -> tuple[float, float]:
    """(throttle, steering), each in [-1, 1], of a control message the Vehicle wrote, for a link
    whose car takes fractions rather than pulses (the Junior's duties, a phone's floats)."""
    from roar.protocol import ControlError, decode, spec

    try:
        command = decode(bytes(data).strip())
    except ControlError as e:
        raise TransportError(f"{scheme}:// carries control messages only: {e}") from None
    half_range_us = (spec.CONTROL_MAX_US - spec.CONTROL_MIN_US) / 2
    return ((command.throttle_us - spec.CONTROL_NEUTRAL_US) / half_range_us,
            (command.steering_us - spec.CONTROL_NEUTRAL_US) / half_range_us)
