"""The wire protocol: constants generated from protocol/spec.toml, and the control-message codec."""

from roar.protocol.control import (
    ControlCommand,
    ControlError,
    ParseEvent,
    StreamDecoder,
    decode,
    encode,
)
from roar.protocol.spec import ParseResult

__all__ = ["ControlCommand", "ControlError", "ParseEvent", "ParseResult", "StreamDecoder", "decode", "encode"]
