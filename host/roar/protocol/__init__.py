"""The wire protocol: constants generated from protocol/spec.toml, and the codec of the control
and setpoint messages."""

from roar.protocol.control import (
    ControlCommand,
    ControlError,
    ParseEvent,
    Setpoint,
    StreamDecoder,
    decode,
    encode,
    encode_setpoint,
)
from roar.protocol.spec import ParseResult

__all__ = ["ControlCommand", "ControlError", "ParseEvent", "ParseResult", "Setpoint", "StreamDecoder", "decode", "encode",
           "encode_setpoint"]
