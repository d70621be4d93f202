"""The one small interface every transport implements."""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import Any, ClassVar

from roar.checks import number
from roar.errors import LinkLost, TransportError  # noqa: F401 (LinkLost importable from here too)
from roar.telemetry import VehicleState


LIDAR_FOV_RAD = math.radians(270)  # [rad] a Transport's lidar(): distances from right to left over this


class Transport(ABC):
    """Bytes to the car, reply lines from it.

    Subclasses set `scheme`, build themselves from a URL in from_url(), and implement open(),
    write() and close(); read_lines() is optional (links without a back channel return [] and
    leave `replies` False). open/write/read_lines/close are called from one thread at a time
    (the Vehicle's sender); state(), lidar() and camera() may be called from the user's thread
    at any time and return None where the link cannot tell.

    Signed control (transports.signing) asks every link the same things: a link whose car takes
    another form than control messages (the Junior's queries, a phone's datagrams) sets
    `signs_itself` and signs through `signer`; `signing` tells it a key signs (BLE pairs for it);
    refusal() and car_session() are how a link without reply lines says what the car answered.
    Layers over a link (transports.layer: signing, recording) keep all of this, and `link` is
    the link itself under them."""

    scheme: ClassVar[str]
    min_period_s: ClassVar[float] = 0.002  # [s] fastest the link takes one control message
    replies: ClassVar[bool] = False  # the link carries the car's reply lines (READY, ARMED, ...)
    signs_itself: ClassVar[bool] = False  # the car takes another form: this link signs it through `signer`

    url: str = ""
    signer: Any = None  # the signing layer, set by it on a link that signs_itself (sign_query, sign_datagram)
    signing: bool = False  # set by the signing layer: a key signs what goes out (a BLE link pairs for it)
    # set by a command that only reads (roar key show): nothing the car stores is written back to a
    # file the user named (sim://?eeprom=), and no such file is made
    read_only: bool = False

    @property
    def link(self) -> Transport:
        """The link itself: this transport, or the one under a layer's (signing, recording)."""
        return self

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

    def refusal(self) -> str | None:
        """The car's "ERR <reason> ..." line for the latest message it refused for signing, once,
        on a link that answers each message but carries no reply lines (HTTP, a phone's
        datagrams); else None."""
        return None

    def car_session(self) -> tuple[int, int] | None:
        """(the car's signing session, the last counter it took) where the link can ask without
        reply lines (BLE's session characteristic); (0, 0): the car has no key; None: cannot ask."""
        return None

    def model(self) -> Any:
        """What the car is, where the link knows it (the simulator's robots): a
        roar.autopilot.CarModel (wheelbase, steering lock, limits) or DiffDriveModel; else None."""
        return None

    def lidar_mount(self) -> tuple[float, float, float] | None:
        """(x ahead [m], y left [m], yaw [rad]) of the lidar on the car, where the link knows it (the
        simulator's robots); else None."""
        return None

    def camera_preset(self) -> Any:
        """The car's camera as a roar.vision.geometry.CameraPreset (field of view, mount) where the
        link knows it (the simulator's robots); else None."""
        return None

    def track(self) -> str | None:
        """The name of the track or map the car drives on, where the link knows it (roar.tracks.get
        takes it); else None."""
        return None

    @property
    def autopilots(self) -> tuple[str, ...]:
        """The drivers of the car's own that autopilot(name) offers (the simulator's; roar web's choice)."""
        return ()

    def autopilot(self, name: str) -> Any:
        """One of `autopilots`, to be stepped by the host on what it reads over this link."""
        raise TransportError(f"{self.scheme}:// offers no autopilot {name!r}")

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
