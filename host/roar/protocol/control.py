"""Encoder, strict decoder and streaming decoder for the control message "(THROTTLE,STEERING)".

The streaming decoder is the same state machine as the firmware's C++ parser
(protocol/PROTOCOL.md section 1.1); both run the golden vectors in protocol/vectors/ and a
differential property test feeds them the same random streams.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass
from enum import Enum

from roar.protocol import spec
from roar.protocol.spec import ParseResult

_START = ord(spec.CONTROL_START_CHAR)
_SEP = ord(spec.CONTROL_SEPARATOR_CHAR)
_END = ord(spec.CONTROL_END_CHAR)
_LINE_END = frozenset(b"\r\n")
_SEPARATORS = frozenset(b"\r\n \t\0")
_ZERO = ord("0")


class ControlError(ValueError):
    """A control value or message that the protocol does not allow. str() is one line."""


@dataclass(frozen=True)
class ControlCommand:
    throttle_us: int  # [us] 1000..2000, 1500 neutral, above is forward
    steering_us: int  # [us] 1000..2000, 1500 centre, above turns right

    def __post_init__(self) -> None:
        for name in ("throttle_us", "steering_us"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, numbers.Integral):  # numpy integers too
                raise ControlError(f"{name} must be an integer number of microseconds, got {value!r}")
            value = int(value)
            object.__setattr__(self, name, value)
            if not spec.CONTROL_MIN_US <= value <= spec.CONTROL_MAX_US:
                raise ControlError(
                    f"{name} {value} us is outside {spec.CONTROL_MIN_US}..{spec.CONTROL_MAX_US} us"
                )

    def encode(self) -> bytes:
        return f"({self.throttle_us},{self.steering_us})".encode("ascii")


NEUTRAL = ControlCommand(spec.CONTROL_NEUTRAL_US, spec.CONTROL_NEUTRAL_US)


def encode(throttle_us: int, steering_us: int) -> bytes:
    """The wire bytes for one command; raises ControlError for values outside the protocol."""
    return ControlCommand(throttle_us, steering_us).encode()


def decode(message: bytes) -> ControlCommand:
    """Decode exactly one complete message (no surrounding bytes); raises ControlError."""
    if not isinstance(message, (bytes, bytearray, memoryview)):
        raise ControlError(f"expected bytes, got {type(message).__name__}")
    data = bytes(message)
    decoder = StreamDecoder()
    events = decoder.feed(data)
    if len(events) == 1 and events[0].command is not None and events[0].at == len(data) - 1:
        return events[0].command
    reason = next((str(e.result) for e in events if e.result != ParseResult.OK), "incomplete")
    if events and reason == "incomplete":
        reason = "extra bytes"
    raise ControlError(f"not a control message ({reason}): {data[:32]!r}")


@dataclass(frozen=True)
class ParseEvent:
    at: int  # index of the byte that produced the event, counted over everything fed so far
    result: ParseResult
    command: ControlCommand | None = None  # set when result is OK


class _State(Enum):
    IDLE = 0
    GARBAGE = 1
    THROTTLE = 2
    STEERING = 3
    SKIP = 4


class StreamDecoder:
    """Feed bytes as they arrive, in chunks of any size; get one event per finished message."""

    def __init__(self) -> None:
        self.offset = 0  # bytes consumed so far
        self._state = _State.IDLE
        self._digits = 0
        self._fields = [0, 0]

    def feed(self, data: bytes) -> list[ParseEvent]:
        events = []
        for i, byte in enumerate(data):
            result = self.feed_byte(byte)
            if result != ParseResult.NONE:
                command = ControlCommand(*self._fields) if result == ParseResult.OK else None
                events.append(ParseEvent(self.offset + i, result, command))
        self.offset += len(data)
        return events

    def feed_byte(self, byte: int) -> ParseResult:
        state = self._state
        if state is _State.THROTTLE or state is _State.STEERING:
            return self._field_byte(byte, 0 if state is _State.THROTTLE else 1)
        if byte == _START:
            return self._start(ParseResult.GARBAGE if state is _State.GARBAGE else ParseResult.NONE)
        if state is _State.IDLE:
            if byte not in _SEPARATORS:
                self._state = _State.GARBAGE
        elif state is _State.GARBAGE:
            if byte in _SEPARATORS:
                self._state = _State.IDLE
                return ParseResult.GARBAGE
        elif byte == _END or byte in _LINE_END:  # SKIP
            self._state = _State.IDLE
        return ParseResult.NONE

    def _start(self, result: ParseResult) -> ParseResult:
        self._state = _State.THROTTLE
        self._digits = 0
        self._fields = [0, 0]
        return result

    def _field_byte(self, byte: int, field: int) -> ParseResult:
        if _ZERO <= byte <= _ZERO + 9:
            if self._digits == spec.CONTROL_MAX_DIGITS:
                self._state = _State.SKIP
                return ParseResult.TOO_LONG
            self._digits += 1
            self._fields[field] = self._fields[field] * 10 + byte - _ZERO
            return ParseResult.NONE
        if byte == _SEP and field == 0 and self._digits > 0:
            self._state = _State.STEERING
            self._digits = 0
            return ParseResult.NONE
        if byte == _END:
            self._state = _State.IDLE
            if field == 0 or self._digits == 0:
                return ParseResult.SYNTAX
            lo, hi = spec.CONTROL_MIN_US, spec.CONTROL_MAX_US
            if not all(lo <= v <= hi for v in self._fields):
                return ParseResult.RANGE
            return ParseResult.OK
        if byte == _START:
            return self._start(ParseResult.UNTERMINATED)
        if byte in _LINE_END:
            self._state = _State.IDLE
            return ParseResult.UNTERMINATED
        self._state = _State.SKIP
        return ParseResult.SYNTAX
