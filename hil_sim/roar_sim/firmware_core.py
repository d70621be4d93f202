"""ctypes binding of the firmware core's C ABI (firmware/core/include/roar/c_api.h).

Every object here wraps the real C++ code that runs on the cars. The library is the host build
from roar_sim.core_build; set ROAR_CORE_LIB to load another build (the sanitizer test does).
"""

from __future__ import annotations

import ctypes
import os
from dataclasses import dataclass, field
from enum import IntEnum
from functools import lru_cache
from pathlib import Path

from roar.protocol import spec
from roar.protocol.control import ControlCommand, ParseEvent
from roar.protocol.spec import ParseResult
from roar_sim import core_build

ABI_VERSION = 1
_u8, _u16, _i16, _u32, _sz, _vp = (ctypes.c_uint8, ctypes.c_uint16, ctypes.c_int16, ctypes.c_uint32,
                                   ctypes.c_size_t, ctypes.c_void_p)
_U32_MASK = 0xFFFFFFFF


class CoreLoadError(RuntimeError):
    """The core library could not be built or loaded; str() is one line."""


class _ParseEvent(ctypes.Structure):
    _fields_ = [("at", _u32), ("result", _u8), ("reserved", _u8), ("throttle", _u16), ("steering", _u16)]


class _SidePins(ctypes.Structure):
    _fields_ = [("in1", _u8), ("in2", _u8), ("duty", _u16)]


class _CarConfig(ctypes.Structure):
    _fields_ = [
        ("failsafe_timeout_us", _u32), ("brake_step_us", _u32), ("brake_tap_us", _u16),
        ("throttle_trim_us", _i16), ("throttle_min_us", _u16), ("throttle_max_us", _u16),
        ("steering_trim_us", _i16), ("steering_min_us", _u16), ("steering_max_us", _u16),
        ("failsafe_enabled", _u8), ("brake_fsm_enabled", _u8), ("rc_override_enabled", _u8),
        ("reserved", _u8 * 3),
    ]


class _CarOutputs(ctypes.Structure):
    _fields_ = [("throttle_us", _u16), ("steering_us", _u16), ("source", _u8), ("brake_phase", _u8),
                ("latched", _u8), ("reserved", _u8)]


_P = ctypes.POINTER
_SIGNATURES = {
    "roar_core_abi_version": (_u32, []),
    "roar_protocol_version": (_u32, []),
    "roar_parser_size": (_sz, []),
    "roar_parser_init": (None, [_vp]),
    "roar_parser_feed": (_u8, [_vp, _u8, _P(_u16), _P(_u16)]),
    "roar_parser_feed_buffer": (_sz, [_vp, ctypes.c_char_p, _sz, _P(_ParseEvent), _sz]),
    "roar_watchdog_size": (_sz, []),
    "roar_watchdog_init": (None, [_vp, _u32]),
    "roar_watchdog_accept": (ctypes.c_int, [_vp, _u16, _u16, _u32, _P(_u8)]),
    "roar_watchdog_poll": (_u8, [_vp, _u32]),
    "roar_watchdog_latched": (ctypes.c_int, [_vp]),
    "roar_brake_size": (_sz, []),
    "roar_brake_init": (None, [_vp, _u16, _u16, _u32]),
    "roar_brake_step": (_u16, [_vp, _u16, _u32, _u32]),
    "roar_brake_phase": (_u8, [_vp]),
    "roar_map_pulse": (_u16, [_u16, _i16, _u16, _u16]),
    "roar_calibration_valid": (ctypes.c_int, [_i16, _u16, _u16]),
    "roar_rc_size": (_sz, []),
    "roar_rc_init": (None, [_vp]),
    "roar_rc_pulse": (None, [_vp, _u8, _u16, _u32]),
    "roar_rc_active": (ctypes.c_int, [_vp, _u32]),
    "roar_rc_command": (None, [_vp, _P(_u16), _P(_u16)]),
    "roar_mix_ackermann": (None, [_u16, _u16, _P(_i16), _P(_i16)]),
    "roar_l298n_size": (_sz, []),
    "roar_l298n_init": (None, [_vp, _u32]),
    "roar_l298n_step": (None, [_vp, _i16, _i16, _u32, _P(_SidePins), _P(_SidePins)]),
    "roar_car_config_size": (_sz, []),
    "roar_car_default_config": (None, [_P(_CarConfig)]),
    "roar_car_size": (_sz, []),
    "roar_car_init": (ctypes.c_int, [_vp, _P(_CarConfig)]),
    "roar_car_boot": (None, [_vp]),
    "roar_car_feed": (None, [_vp, ctypes.c_char_p, _sz, _u32]),
    "roar_car_rc_pulse": (None, [_vp, _u8, _u16, _u32]),
    "roar_car_step": (None, [_vp, _u32, _u32, _P(_CarOutputs)]),
    "roar_car_take_reply": (_sz, [_vp, ctypes.c_char_p, _sz]),
}


def library_path() -> Path:
    """The library to load: $ROAR_CORE_LIB, or the release host build (built if stale)."""
    override = os.environ.get("ROAR_CORE_LIB")
    if override:
        return Path(override)
    try:
        return core_build.build("library", "release")
    except core_build.CoreBuildError as e:
        raise CoreLoadError(str(e)) from None


@lru_cache(maxsize=None)
def _lib_at(path: str) -> ctypes.CDLL:
    try:
        lib = ctypes.CDLL(path)
    except OSError as e:
        raise CoreLoadError(f"cannot load firmware core {path}: {e}") from None
    for name, (restype, argtypes) in _SIGNATURES.items():
        fn = getattr(lib, name)
        fn.restype, fn.argtypes = restype, argtypes
    if lib.roar_core_abi_version() != ABI_VERSION:
        raise CoreLoadError(f"{path}: C ABI version {lib.roar_core_abi_version()}, this binding needs {ABI_VERSION}")
    if lib.roar_car_config_size() != ctypes.sizeof(_CarConfig):
        raise CoreLoadError(f"{path}: roar_car_config_t layout differs from this binding")
    return lib


def lib() -> ctypes.CDLL:
    return _lib_at(str(library_path()))


def _object(size_fn: str) -> ctypes.Array:
    # c_uint64 array: 8-byte alignment for the C++ object placed in it.
    size = getattr(lib(), size_fn)()
    return (ctypes.c_uint64 * ((size + 7) // 8))()


def _time(now_us: int) -> int:
    return now_us & _U32_MASK  # the car's clock is a wrapping 32-bit counter


class Parser:
    """The firmware's streaming control-message parser."""

    def __init__(self) -> None:
        self._lib = lib()
        self._mem = _object("roar_parser_size")
        self._lib.roar_parser_init(self._mem)
        self.offset = 0

    def feed(self, data: bytes) -> list[ParseEvent]:
        """Same contract as roar.protocol.StreamDecoder.feed: events with absolute offsets."""
        data = bytes(data)
        buf = (_ParseEvent * max(1, len(data)))()
        n = self._lib.roar_parser_feed_buffer(self._mem, data, len(data), buf, len(data))
        events = []
        for ev in buf[:n]:
            result = ParseResult(ev.result)
            command = ControlCommand(ev.throttle, ev.steering) if result == ParseResult.OK else None
            events.append(ParseEvent(self.offset + ev.at, result, command))
        self.offset += len(data)
        return events

    def count(self, data: bytes) -> int:
        """Feed without collecting events; returns how many there were (for benchmarks)."""
        self.offset += len(data)
        return self._lib.roar_parser_feed_buffer(self._mem, data, len(data), None, 0)


class WatchdogEvent(IntEnum):
    NONE = 0
    TRIPPED = 1
    ARMED = 2


class Watchdog:
    """The firmware's command watchdog (failsafe)."""

    def __init__(self, timeout_us: int = spec.TIMING_FAILSAFE_TIMEOUT_US) -> None:
        self._lib = lib()
        self._mem = _object("roar_watchdog_size")
        self._lib.roar_watchdog_init(self._mem, timeout_us)

    def accept(self, throttle_us: int, steering_us: int, now_us: int) -> tuple[bool, WatchdogEvent]:
        ev = _u8()
        ok = self._lib.roar_watchdog_accept(self._mem, throttle_us, steering_us, _time(now_us), ctypes.byref(ev))
        return bool(ok), WatchdogEvent(ev.value)

    def poll(self, now_us: int) -> WatchdogEvent:
        return WatchdogEvent(self._lib.roar_watchdog_poll(self._mem, _time(now_us)))

    @property
    def latched(self) -> bool:
        return bool(self._lib.roar_watchdog_latched(self._mem))


class BrakePhase(IntEnum):
    NEEDS_SEQUENCE = 0
    NEUTRAL1 = 1
    TAP = 2
    NEUTRAL2 = 3
    REVERSE_READY = 4


class BrakeFsm:
    """The firmware's non-blocking forward-to-reverse sequence."""

    def __init__(self, neutral_us: int = spec.CONTROL_NEUTRAL_US, tap_us: int = spec.TIMING_BRAKE_TAP_US,
                 step_us: int = spec.TIMING_BRAKE_STEP_US) -> None:
        self._lib = lib()
        self._mem = _object("roar_brake_size")
        self._lib.roar_brake_init(self._mem, neutral_us, tap_us, step_us)

    def step(self, command_us: int, now_us: int, frames_started: int) -> int:
        return self._lib.roar_brake_step(self._mem, command_us, _time(now_us), frames_started & _U32_MASK)

    @property
    def phase(self) -> BrakePhase:
        return BrakePhase(self._lib.roar_brake_phase(self._mem))


def map_pulse(command_us: int, trim_us: int = 0, min_us: int = spec.CONTROL_MIN_US,
              max_us: int = spec.CONTROL_MAX_US) -> int:
    return lib().roar_map_pulse(command_us, trim_us, min_us, max_us)


def calibration_valid(trim_us: int, min_us: int, max_us: int) -> bool:
    return bool(lib().roar_calibration_valid(trim_us, min_us, max_us))


class RcOverride:
    """The firmware's RC receiver arbitration."""

    THROTTLE, STEERING = 0, 1

    def __init__(self) -> None:
        self._lib = lib()
        self._mem = _object("roar_rc_size")
        self._lib.roar_rc_init(self._mem)

    def pulse(self, channel: int, width_us: int, now_us: int) -> None:
        self._lib.roar_rc_pulse(self._mem, channel, width_us, _time(now_us))

    def active(self, now_us: int) -> bool:
        return bool(self._lib.roar_rc_active(self._mem, _time(now_us)))

    def command(self) -> tuple[int, int]:
        t, s = _u16(), _u16()
        self._lib.roar_rc_command(self._mem, ctypes.byref(t), ctypes.byref(s))
        return t.value, s.value


@dataclass(frozen=True)
class SidePins:
    in1: bool
    in2: bool
    duty: int  # [permille]


def mix_ackermann(throttle_us: int, steering_us: int) -> tuple[int, int]:
    left, right = _i16(), _i16()
    lib().roar_mix_ackermann(throttle_us, steering_us, ctypes.byref(left), ctypes.byref(right))
    return left.value, right.value


class L298nDriver:
    """The firmware's per-side L298N direction/duty driver with reversal dead time."""

    def __init__(self, dead_time_us: int = spec.L298N_DEAD_TIME_US) -> None:
        self._lib = lib()
        self._mem = _object("roar_l298n_size")
        self._lib.roar_l298n_init(self._mem, dead_time_us)

    def step(self, left_permille: int, right_permille: int, now_us: int) -> tuple[SidePins, SidePins]:
        lo, ro = _SidePins(), _SidePins()
        self._lib.roar_l298n_step(self._mem, left_permille, right_permille, _time(now_us), ctypes.byref(lo),
                                  ctypes.byref(ro))
        return (SidePins(bool(lo.in1), bool(lo.in2), lo.duty), SidePins(bool(ro.in1), bool(ro.in2), ro.duty))


class ControlSource(IntEnum):
    FAILSAFE = 0
    HOST = 1
    RC = 2


@dataclass(frozen=True)
class CarOutputs:
    throttle_us: int
    steering_us: int
    source: ControlSource
    brake_phase: BrakePhase
    latched: bool


@dataclass(frozen=True)
class ChannelCalibration:
    trim_us: int = 0
    min_us: int = spec.CONTROL_MIN_US
    max_us: int = spec.CONTROL_MAX_US


@dataclass(frozen=True)
class CarConfig:
    failsafe_timeout_us: int = spec.TIMING_FAILSAFE_TIMEOUT_US
    brake_step_us: int = spec.TIMING_BRAKE_STEP_US
    brake_tap_us: int = spec.TIMING_BRAKE_TAP_US
    throttle: ChannelCalibration = field(default_factory=ChannelCalibration)
    steering: ChannelCalibration = field(default_factory=ChannelCalibration)
    failsafe_enabled: bool = True
    brake_fsm_enabled: bool = True
    rc_override_enabled: bool = True

    def to_c(self) -> _CarConfig:
        t, s = self.throttle, self.steering
        return _CarConfig(self.failsafe_timeout_us, self.brake_step_us, self.brake_tap_us,
                          t.trim_us, t.min_us, t.max_us, s.trim_us, s.min_us, s.max_us,
                          self.failsafe_enabled, self.brake_fsm_enabled, self.rc_override_enabled)


def default_config_from_core() -> _CarConfig:
    cfg = _CarConfig()
    lib().roar_car_default_config(ctypes.byref(cfg))
    return cfg


class Car:
    """The whole board logic of a servo/ESC car: parser, failsafe, RC override, brake FSM, outputs."""

    def __init__(self, config: CarConfig | None = None) -> None:
        self._lib = lib()
        self.config = config or CarConfig()
        self._mem = _object("roar_car_size")
        if self._lib.roar_car_init(self._mem, ctypes.byref(self.config.to_c())) != 0:
            raise ValueError("invalid channel calibration: need min_us <= max_us and |trim_us| < 500")
        self._reply = ctypes.create_string_buffer(spec.SERIAL_MAX_REPLY_BYTES + 1)

    def boot(self) -> None:
        self._lib.roar_car_boot(self._mem)

    def feed(self, data: bytes, now_us: int) -> None:
        data = bytes(data)
        self._lib.roar_car_feed(self._mem, data, len(data), _time(now_us))

    def rc_pulse(self, channel: int, width_us: int, now_us: int) -> None:
        self._lib.roar_car_rc_pulse(self._mem, channel, width_us, _time(now_us))

    def step(self, now_us: int, frames_started: int) -> CarOutputs:
        out = _CarOutputs()
        self._lib.roar_car_step(self._mem, _time(now_us), frames_started & _U32_MASK, ctypes.byref(out))
        return CarOutputs(out.throttle_us, out.steering_us, ControlSource(out.source), BrakePhase(out.brake_phase),
                          bool(out.latched))

    def replies(self) -> list[str]:
        """Drain all pending reply lines (each ends with a newline)."""
        lines = []
        while n := self._lib.roar_car_take_reply(self._mem, self._reply, len(self._reply)):
            lines.append(self._reply.raw[:n].decode("ascii"))
        return lines
