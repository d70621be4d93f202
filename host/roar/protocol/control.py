"""Encoders, strict decoder and streaming decoder for the control message "(THROTTLE,STEERING)"
and the setpoint message "[SPEED,STEERING]",
with host-side types (ControlCommand, ParseEvent, ParseResult) around the portable codec of
roar_wire.control, the one Python implementation of the parser, which also runs on the
MicroPython boards. It is the same state machine as the firmware's C++ parser (PROTOCOL.md
section 1.1); both run the golden vectors in protocol/vectors/ and a differential property test
feeds them the same random streams.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass

from roar.errors import ControlError
from roar.protocol import spec
from roar.protocol.spec import ParseResult
from roar_wire import control as wire


def _plain_ints(obj, names: tuple[str, ...]) -> None:
    """Make integer fields of a frozen dataclass plain ints (numpy integers too; not bools)."""
    for name in names:
        value = getattr(obj, name)
        if isinstance(value, numbers.Integral) and not isinstance(value, bool):
            object.__setattr__(obj, name, int(value))


@dataclass(frozen=True)
class ControlCommand:
    throttle_us: int  # [us] 1000..2000, 1500 neutral, above is forward
    steering_us: int  # [us] 1000..2000, 1500 centre, above turns right

    def __post_init__(self) -> None:
        _plain_ints(self, ("throttle_us", "steering_us"))
        try:
            wire.check_pulse("throttle_us", self.throttle_us)
            wire.check_pulse("steering_us", self.steering_us)
        except ValueError as e:
            raise ControlError(str(e)) from None

    def encode(self) -> bytes:
        return wire.encode(self.throttle_us, self.steering_us)


NEUTRAL = ControlCommand(spec.CONTROL_NEUTRAL_US, spec.CONTROL_NEUTRAL_US)


@dataclass(frozen=True)
class Setpoint:
    """A speed-and-steering setpoint "[SPEED,STEERING]", for boards with a speed controller."""

    speed_mm_s: int  # [mm/s] negative drives backwards
    steering_us: int  # [us] 1000..2000

    def __post_init__(self) -> None:
        _plain_ints(self, ("speed_mm_s", "steering_us"))
        try:
            wire.check_speed(self.speed_mm_s)
            wire.check_pulse("steering_us", self.steering_us)
        except ValueError as e:
            raise ControlError(str(e)) from None

    def encode(self) -> bytes:
        return wire.encode_setpoint(self.speed_mm_s, self.steering_us)


def encode_setpoint(speed_mm_s: int, steering_us: int) -> bytes:
    """The wire bytes of one setpoint; raises ControlError for values outside the protocol."""
    return Setpoint(speed_mm_s, steering_us).encode()


def encode(throttle_us: int, steering_us: int) -> bytes:
    """The wire bytes for one command; raises ControlError for values outside the protocol."""
    return ControlCommand(throttle_us, steering_us).encode()


def decode(message: bytes) -> ControlCommand:
    """Decode exactly one complete message (no surrounding bytes); raises ControlError."""
    if not isinstance(message, (bytes, bytearray, memoryview)):
        raise ControlError(f"expected bytes, got {type(message).__name__}")
    try:
        return ControlCommand(*wire.decode(bytes(message)))
    except ValueError as e:
        raise ControlError(str(e)) from None


@dataclass(frozen=True)
class ParseEvent:
    at: int  # index of the byte that produced the event, counted over everything fed so far
    result: ParseResult
    command: ControlCommand | None = None  # set when result is OK
    setpoint: Setpoint | None = None  # set when result is SETPOINT
    signature: tuple[int, int] | None = None  # (counter, mac) of a signed OK or SETPOINT message


_RESULTS = tuple(ParseResult)


class StreamDecoder:
    """Feed bytes as they arrive, in chunks of any size; get one event per finished message."""

    def __init__(self) -> None:
        self.offset = 0  # bytes consumed so far
        self._parser = wire.Parser()

    def feed(self, data: bytes) -> list[ParseEvent]:
        events = []
        feed = self._parser.feed
        for i, byte in enumerate(data):
            result = feed(byte)
            if result:
                command = setpoint = None
                p = self._parser
                if result == wire.OK:
                    command = ControlCommand(p.throttle_us, p.steering_us)
                elif result == wire.SETPOINT:
                    setpoint = Setpoint(p.speed_mm_s, p.setpoint_steering_us)
                signature = p.signature if command or setpoint else None
                events.append(ParseEvent(self.offset + i, _RESULTS[result], command, setpoint, signature))
        self.offset += len(data)
        return events

    def feed_byte(self, byte: int) -> ParseResult:
        return _RESULTS[self._parser.feed(byte)]
