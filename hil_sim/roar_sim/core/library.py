"""Binding of the firmware core's C ABI (firmware/core/include/roar/c_api.h) through cffi, which
reads the declarations from that header itself: the ABI is written once, in C.

Every object here wraps the real C++ code that runs on the cars. The library is the host build
from roar_sim.toolchains.native; set ROAR_CORE_LIB to load another build (the sanitizer test does).
Times are the core's 64-bit microseconds, which never wrap; Board runs the board loop on the
wrapping 32-bit counter a board's hardware has.
"""

from __future__ import annotations

import bisect
import os
import re
from dataclasses import dataclass, field
from enum import IntEnum
from functools import lru_cache
from pathlib import Path

from cffi import FFI

from roar.errors import RoarError
from roar.protocol import spec
from roar.protocol.control import ControlCommand, ParseEvent, Setpoint
from roar.protocol.spec import ParseResult
from roar_sim.toolchains import native

HEADER = native.HOST_BOARD / "c_api.h"
_U32_MASK = 0xFFFFFFFF


class CoreLoadError(RoarError):
    """The core library could not be built or loaded; str() is one line."""


def declarations(header_text: str) -> str:
    """c_api.h as cffi's cdef() takes it: the declarations, without the include guard, the
    includes and the C++-only lines; integer #defines stay (cffi knows them)."""
    lines, skipping = [], False
    for line in header_text.splitlines():
        stripped = line.strip()
        if stripped.startswith("#ifdef __cplusplus"):
            skipping = True
        elif skipping:
            skipping = not stripped.startswith("#endif")
        elif not stripped.startswith("#") or re.fullmatch(r"#define\s+ROAR_\w+\s+\d+", stripped):
            lines.append(line)
    return "\n".join(lines)


ffi = FFI()
ffi.cdef(declarations(HEADER.read_text()))


def library_path() -> Path:
    """The library to load: $ROAR_CORE_LIB, or the release host build (built if stale)."""
    override = os.environ.get("ROAR_CORE_LIB")
    if override:
        return Path(override)
    try:
        return native.build("library", "release")
    except native.CoreBuildError as e:
        raise CoreLoadError(str(e)) from None


@lru_cache(maxsize=None)
def _lib_at(path: str):
    try:
        lib = ffi.dlopen(path)
    except OSError as e:
        raise CoreLoadError(f"cannot load firmware core {path}: {e}") from None
    if lib.roar_core_abi_version() != lib.ROAR_CORE_ABI_VERSION:  # a library built from another header
        raise CoreLoadError(f"{path}: C ABI version {lib.roar_core_abi_version()}, "
                            f"{HEADER.name} says {lib.ROAR_CORE_ABI_VERSION}")
    return lib


def lib():
    return _lib_at(str(library_path()))


def _object(size_fn: str):
    """Zeroed memory for one core object, 8-byte aligned (uint64_t units)."""
    size = getattr(lib(), size_fn)()
    return ffi.new("uint64_t[]", (size + 7) // 8)


def _bytes(data: bytes):
    return ffi.from_buffer("uint8_t[]", bytes(data))


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
        buf = ffi.new("roar_parse_event_t[]", max(1, len(data)))
        n = self._lib.roar_parser_feed_buffer(self._mem, _bytes(data), len(data), buf, len(data))
        events = []
        for ev in buf[0:n]:
            result = ParseResult(ev.result)
            command = ControlCommand(ev.throttle, ev.steering) if result == ParseResult.OK else None
            setpoint = Setpoint(ev.speed_mm_s, ev.steering) if result == ParseResult.SETPOINT else None
            events.append(ParseEvent(self.offset + ev.at, result, command, setpoint))
        self.offset += len(data)
        return events

    def count(self, data: bytes) -> int:
        """Feed without collecting events; returns how many there were (for benchmarks)."""
        self.offset += len(data)
        return self._lib.roar_parser_feed_buffer(self._mem, _bytes(data), len(data), ffi.NULL, 0)


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
        ev = ffi.new("uint8_t *")
        ok = self._lib.roar_watchdog_accept(self._mem, throttle_us, steering_us, now_us, ev)
        return bool(ok), WatchdogEvent(ev[0])

    def poll(self, now_us: int) -> WatchdogEvent:
        return WatchdogEvent(self._lib.roar_watchdog_poll(self._mem, now_us))

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
        return self._lib.roar_brake_step(self._mem, command_us, now_us, frames_started & _U32_MASK)

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
        self._lib.roar_rc_pulse(self._mem, channel, width_us, now_us)

    def active(self, now_us: int) -> bool:
        return bool(self._lib.roar_rc_active(self._mem, now_us))

    def command(self) -> tuple[int, int]:
        t, s = ffi.new("uint16_t *"), ffi.new("uint16_t *")
        self._lib.roar_rc_command(self._mem, t, s)
        return t[0], s[0]


@dataclass(frozen=True)
class SidePins:
    in1: bool
    in2: bool
    duty: int  # [permille]


class L298nDriver:
    """The firmware's per-side L298N direction/duty driver with reversal dead time."""

    def __init__(self, dead_time_us: int = spec.L298N_DEAD_TIME_US) -> None:
        self._lib = lib()
        self._mem = _object("roar_l298n_size")
        self._lib.roar_l298n_init(self._mem, dead_time_us)
        self._out = ffi.new("roar_side_pins_t[2]")

    def step(self, left_permille: int, right_permille: int, now_us: int) -> tuple[SidePins, SidePins]:
        lo, ro = self._out + 0, self._out + 1
        self._lib.roar_l298n_step(self._mem, left_permille, right_permille, now_us, lo, ro)
        return (SidePins(bool(lo.in1), bool(lo.in2), lo.duty), SidePins(bool(ro.in1), bool(ro.in2), ro.duty))


class SbusDecoder:
    """The core's SBUS frame decoder: feed(byte, now_us) -> 0 none, 1 frame, 2 failsafe frame,
    3 dropped (roar_wire.sbus has the same codes)."""

    def __init__(self) -> None:
        self._lib = lib()
        self._mem = _object("roar_sbus_decoder_size")
        self._lib.roar_sbus_decoder_init(self._mem)
        self._frame = ffi.new("roar_sbus_frame_t *")
        self._status = ffi.new("roar_sbus_status_t *")

    def feed(self, byte: int, now_us: int) -> int:
        return self._lib.roar_sbus_feed(self._mem, byte, now_us)

    def frame(self) -> tuple[list[int], int, int]:
        """(channels, flags, end) of the last good frame."""
        self._lib.roar_sbus_last_frame(self._mem, self._frame)
        return _sbus_frame(self._frame)

    def status(self) -> dict:
        self._lib.roar_sbus_status(self._mem, self._status)
        st = self._status
        return {"locked": bool(st.locked), "good_frames": st.good_frames, "lost_frames": st.lost_frames,
                "failsafe_frames": st.failsafe_frames, "dropped": st.dropped, "last_good_us": st.last_good_us}


def _sbus_frame(f) -> tuple[list[int], int, int]:
    flags = f.ch17 * spec.SBUS_FLAG_CH17 | f.ch18 * spec.SBUS_FLAG_CH18 | \
        f.frame_lost * spec.SBUS_FLAG_FRAME_LOST | f.failsafe * spec.SBUS_FLAG_FAILSAFE
    return list(f.raw), flags, f.end


def sbus_encode(channels: list[int], flags: int = 0, end: int = 0) -> bytes:
    f = ffi.new("roar_sbus_frame_t *")
    f.raw = channels
    f.ch17, f.ch18 = bool(flags & spec.SBUS_FLAG_CH17), bool(flags & spec.SBUS_FLAG_CH18)
    f.frame_lost, f.failsafe = bool(flags & spec.SBUS_FLAG_FRAME_LOST), bool(flags & spec.SBUS_FLAG_FAILSAFE)
    f.end = end
    out = ffi.new("uint8_t[]", spec.SBUS_FRAME_BYTES)
    lib().roar_sbus_encode(f, out)
    return bytes(ffi.buffer(out))


def sbus_decode(data: bytes) -> tuple[list[int], int, int] | None:
    f = ffi.new("roar_sbus_frame_t *")
    return _sbus_frame(f) if lib().roar_sbus_decode(_bytes(bytes(data)), f) else None


class Iarrc:
    """The IARRC car's controller (IarrcController, default configuration): SBUS bytes, host
    bytes, encoder counts and battery readings in; control(now_us) -> a status dict with the
    pulses, the mode and what the controller knows."""

    MODES = ("boot", "disarmed", "manual", "autonomous", "failsafe", "emergency")
    FAILSAFES = ("none", "rc_lost", "host_silent", "battery")

    def __init__(self) -> None:
        self._lib = lib()
        self._mem = _object("roar_iarrc_size")
        self._lib.roar_iarrc_init(self._mem)
        self._status = ffi.new("roar_iarrc_status_t *")

    def set_pid(self, kp_pm: int, ki_pm: int, kd_pm: int, ff_pm: int) -> None:
        """Gains in per mille: us per m/s, us per m, us per m/s^2, us per m/s of setpoint."""
        self._lib.roar_iarrc_set_pid(self._mem, kp_pm, ki_pm, kd_pm, ff_pm)

    def sbus(self, data: bytes, now_us: int, byte_us: int = 120) -> None:
        """Bytes from the receiver, byte_us apart from now_us on."""
        for i, byte in enumerate(data):
            self._lib.roar_iarrc_sbus_byte(self._mem, byte, now_us + i * byte_us)

    def host(self, data: bytes, now_us: int) -> list[int]:
        """Bytes from the host; the parse result of each."""
        return [self._lib.roar_iarrc_host_byte(self._mem, b, now_us) for b in data]

    def encoder(self, count: int, now_us: int) -> None:
        self._lib.roar_iarrc_encoder(self._mem, count, now_us)

    def battery(self, adc_counts: int) -> None:
        self._lib.roar_iarrc_battery(self._mem, adc_counts)

    def control(self, now_us: int, frames_started: int | None = None) -> dict:
        """One control step; frames_started defaults to one frame per 20 ms of now_us."""
        frames = now_us // spec.TIMING_SERVO_FRAME_US + 1 if frames_started is None else frames_started
        self._lib.roar_iarrc_control(self._mem, now_us, frames & _U32_MASK, self._status)
        return iarrc_status(self._status)


def iarrc_status(st) -> dict:
    """A roar_iarrc_status_t as a dict of Python values (modes and failsafes as words)."""
    return {"throttle_us": st.throttle_us, "steering_us": st.steering_us, "mode": Iarrc.MODES[st.mode],
            "failsafe": Iarrc.FAILSAFES[st.failsafe], "rc_present": bool(st.rc_present),
            "mode_switch": ("off", "manual", "autonomous")[st.mode_switch], "speed_mm_s": st.speed_mm_s,
            "setpoint_mm_s": st.setpoint_mm_s, "distance_mm": st.distance_mm, "battery_mv": st.battery_mv,
            "battery_low": bool(st.battery_low), "battery_cutoff": bool(st.battery_cutoff),
            "pid_integral_mm": st.pid_integral_mm}


@dataclass(frozen=True)
class TaskSpec:
    """One row of a board's task table."""

    name: str
    period_us: int  # [us]
    priority: int  # higher pre-empts lower
    stack_words: int  # [32-bit words]
    cost_us: int  # [us] declared worst case on the board


def iarrc_tasks() -> tuple[TaskSpec, ...]:
    """The IARRC car's task table, as the core declares it."""
    out = ffi.new("roar_task_spec_t *")
    rows = []
    for i in range(lib().roar_iarrc_task_count()):
        lib().roar_iarrc_task(i, out)
        rows.append(TaskSpec(ffi.string(out.name).decode(), out.period_us, out.priority, out.stack_words,
                             out.cost_us))
    return tuple(rows)


class _Rx:
    """Bytes waiting for a HAL receive buffer of `cap` bytes (with their arrival times)."""

    def __init__(self, data, length: str, pos: str, times=None) -> None:
        self.pending = bytearray()
        self.times: list[int] = []
        self._data, self._len, self._pos, self._times = data, length, pos, times

    def load(self, hal, now_us: int) -> None:
        """Into the HAL: the bytes that have arrived by now_us, as many as fit."""
        n = min(len(self.pending), len(self._data))
        if self._times is not None:
            n = bisect.bisect_right(self.times, now_us, 0, n)
            self._times[0:n] = [t & _U32_MASK for t in self.times[:n]]
        self._data[0:n] = bytes(self.pending[:n])
        setattr(hal, self._len, n)
        setattr(hal, self._pos, 0)

    def consume(self, hal) -> None:
        used = getattr(hal, self._pos)
        del self.pending[:used]
        del self.times[:used]


class IarrcBoard:
    """The IARRC car's tasks (IarrcBoard) on a HAL of plain memory. The caller is the scheduler:
    it sets the inputs (encoder_count, battery_adc, gyro_z_raw), queues received bytes with
    sbus()/host()/link(), and calls run(task, now_us) for each release of a task."""

    def __init__(self, counts_per_m: int = 0) -> None:
        self._lib = lib()
        self.hal = ffi.new("roar_iarrc_hal_t *")
        self._mem = _object("roar_iarrc_board_size")
        self._lib.roar_iarrc_board_init(self._mem, self.hal, counts_per_m)
        self._status = ffi.new("roar_iarrc_status_t *")
        h = self.hal
        self._sbus = _Rx(h.sbus, "sbus_len", "sbus_pos", h.sbus_at_us)
        self._host = _Rx(h.host_rx, "host_len", "host_pos")
        self._link = _Rx(h.link_rx, "link_len", "link_pos")
        self.host_out = bytearray()  # lines the board wrote to the vision computer
        self.link_out = bytearray()  # lines the board wrote to the Bluetooth module
        self.now_us = 0
        self.hal.throttle_us = self.hal.steering_us = spec.CONTROL_NEUTRAL_US
        names = [t.name for t in iarrc_tasks()]
        self._rx_of_task = {names.index("rc"): self._sbus, names.index("host"): self._host,
                            names.index("telemetry"): self._link}  # the task that reads each port

    def begin(self) -> None:
        self._lib.roar_iarrc_board_begin(self._mem)
        self._take_tx()

    def sbus(self, data: bytes, at_us: int, byte_us: int = 120) -> None:
        """SBUS bytes that arrive from at_us on, byte_us apart (100 kbaud, 12 bits a byte)."""
        self._sbus.pending += data
        self._sbus.times += [at_us + i * byte_us for i in range(len(data))]

    def host(self, data: bytes) -> None:
        self._host.pending += data

    def link(self, data: bytes) -> None:
        self._link.pending += data

    @property
    def encoder_count(self) -> int:
        return self.hal.encoder_count

    @encoder_count.setter
    def encoder_count(self, value: int) -> None:
        self.hal.encoder_count = (value + 2**31) % 2**32 - 2**31  # the timer's count wraps

    def set_inputs(self, battery_adc: int | None = None, gyro_z_raw: int | None = None) -> None:
        if battery_adc is not None:
            self.hal.battery_adc = max(0, min(0xFFFF, battery_adc))
        if gyro_z_raw is not None:
            self.hal.gyro_z_raw = max(-32768, min(32767, gyro_z_raw))

    def run(self, task: int, now_us: int) -> None:
        """One release of task (an index into iarrc_tasks()) at now_us."""
        self.now_us = now_us
        h = self.hal
        h.now_us = now_us & _U32_MASK
        h.frames_started = (now_us // spec.TIMING_SERVO_FRAME_US + 1) & _U32_MASK
        rx = self._rx_of_task.get(task)
        if rx is not None:
            rx.load(h, now_us)
        self._lib.roar_iarrc_board_run(self._mem, task)
        if rx is not None:
            rx.consume(h)
        self._take_tx()

    def overran(self, task: int, missed: int) -> None:
        self._lib.roar_iarrc_board_overran(self._mem, task, missed)
        self._take_tx()

    def set_pid(self, kp_pm: int, ki_pm: int, kd_pm: int, ff_pm: int) -> None:
        self._lib.roar_iarrc_board_set_pid(self._mem, kp_pm, ki_pm, kd_pm, ff_pm)

    def _take_tx(self) -> None:
        h = self.hal
        if h.host_tx_len:
            self.host_out += ffi.buffer(h.host_tx, h.host_tx_len)
            h.host_tx_len = 0
        if h.link_tx_len:
            self.link_out += ffi.buffer(h.link_tx, h.link_tx_len)
            h.link_tx_len = 0

    @property
    def pulses(self) -> tuple[int, int]:
        """(throttle, steering) [us] as the control task last wrote them."""
        return self.hal.throttle_us, self.hal.steering_us

    @property
    def watchdog_feeds(self) -> int:
        return self.hal.watchdog_feeds

    @property
    def overruns(self) -> int:
        return self._lib.roar_iarrc_board_overruns(self._mem)

    def status(self) -> dict:
        self._lib.roar_iarrc_board_status(self._mem, self._status)
        return iarrc_status(self._status)


class Junior:
    """The ROAR Junior's HTTP control: query strings applied in order, and its 500 ms failsafe."""

    def __init__(self) -> None:
        self._lib = lib()
        self._mem = _object("roar_junior_size")
        self._lib.roar_junior_init(self._mem)

    ERRORS = {1: "unknown parameter", 2: "bad flag", 3: "bad speed"}

    def apply_query(self, query: str, now_us: int) -> tuple[int, str | None]:
        """(parameters applied, None), or (0, why) when the query was refused and nothing changed."""
        raw = query.encode()
        r = self._lib.roar_junior_apply_query(self._mem, raw, len(raw), now_us)
        return (r, None) if r >= 0 else (0, self.ERRORS[-r])

    def duties(self, now_us: int) -> tuple[int, int]:
        left, right = ffi.new("int16_t *"), ffi.new("int16_t *")
        self._lib.roar_junior_duties(self._mem, now_us, left, right)
        return left[0], right[0]


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

    @staticmethod
    def from_c(out) -> CarOutputs:
        return CarOutputs(out.throttle_us, out.steering_us, ControlSource(out.source), BrakePhase(out.brake_phase),
                          bool(out.latched))


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

    def to_c(self):
        t, s = self.throttle, self.steering
        return ffi.new("roar_car_config_t *", {
            "failsafe_timeout_us": self.failsafe_timeout_us, "brake_step_us": self.brake_step_us,
            "brake_tap_us": self.brake_tap_us,
            "throttle_trim_us": t.trim_us, "throttle_min_us": t.min_us, "throttle_max_us": t.max_us,
            "steering_trim_us": s.trim_us, "steering_min_us": s.min_us, "steering_max_us": s.max_us,
            "failsafe_enabled": self.failsafe_enabled, "brake_fsm_enabled": self.brake_fsm_enabled,
            "rc_override_enabled": self.rc_override_enabled,
        })


INVALID_CALIBRATION = "invalid channel calibration: need min_us <= max_us and |trim_us| < 500"


def default_config_from_core():
    cfg = ffi.new("roar_car_config_t *")
    lib().roar_car_default_config(cfg)
    return cfg


class Car:
    """The whole board logic of a servo/ESC car: parser, failsafe, RC override, brake FSM, outputs."""

    def __init__(self, config: CarConfig | None = None) -> None:
        self._lib = lib()
        self.config = config or CarConfig()
        self._mem = _object("roar_car_size")
        if self._lib.roar_car_init(self._mem, self.config.to_c()) != 0:
            raise ValueError(INVALID_CALIBRATION)
        self._reply = ffi.new("char[]", spec.SERIAL_MAX_REPLY_BYTES + 1)
        self._out = ffi.new("roar_car_outputs_t *")

    def boot(self) -> None:
        self._lib.roar_car_boot(self._mem)

    def feed(self, data: bytes, now_us: int) -> None:
        self._lib.roar_car_feed(self._mem, _bytes(data), len(data), now_us)

    def rc_pulse(self, channel: int, width_us: int, now_us: int) -> None:
        self._lib.roar_car_rc_pulse(self._mem, channel, width_us, now_us)

    def step(self, now_us: int, frames_started: int) -> CarOutputs:
        self._lib.roar_car_step(self._mem, now_us, frames_started & _U32_MASK, self._out)
        return CarOutputs.from_c(self._out)

    def replies(self) -> list[str]:
        """Drain all pending reply lines (each ends with a newline)."""
        lines = []
        while n := self._lib.roar_car_take_reply(self._mem, self._reply, len(self._reply)):
            lines.append(ffi.string(self._reply, n).decode("ascii"))
        return lines


class Board:
    """The board loop every car runs (CarBoard::poll), on a HAL of plain memory: a 1 kHz loop
    on the board's wrapping 32-bit microsecond counter, output frames every 20 ms that carry
    the pulses written before they start, a serial port, BLE writes and an RC receiver.

        board = Board(); board.begin()
        board.serial_in(b"(1500,1500)")     # bytes arriving on the serial port
        board.run(loops=20)                 # 20 loop iterations, 1 ms apart
        board.wire                          # (throttle, steering) on the wire in this frame
        board.serial_out()                  # b"READY 1\nARMED\n"
    """

    def __init__(self, config: CarConfig | None = None, loop_us: int = 1_000,
                 frame_us: int = spec.TIMING_SERVO_FRAME_US, start_us: int = 0) -> None:
        self._lib = lib()
        self.config = config or CarConfig()
        self.hal = ffi.new("roar_host_hal_t *")
        self.hal.now_us = self.hal.next_frame_us = start_us & _U32_MASK
        self.hal.loop_us, self.hal.frame_us = loop_us, frame_us
        self._mem = _object("roar_board_size")
        if self._lib.roar_board_init(self._mem, self.hal, self.config.to_c()) != 0:
            raise ValueError(INVALID_CALIBRATION)
        self._rx_backlog = b""
        self.loops = 0  # loop iterations run so far

    def begin(self) -> None:
        self._lib.roar_board_begin(self._mem)

    def ble_write(self, data: bytes) -> None:
        """One BLE write to the control characteristic, fed to the loop at once."""
        self._lib.roar_board_feed(self._mem, _bytes(data), len(data))

    def serial_in(self, data: bytes) -> None:
        """Bytes arriving on the serial port; the loop reads at most 64 per iteration."""
        self._rx_backlog += bytes(data)
        self._refill()

    def _refill(self) -> None:
        hal = self.hal
        if hal.rx_pos < hal.rx_len or not self._rx_backlog:
            return
        chunk, self._rx_backlog = self._rx_backlog[:len(hal.rx)], self._rx_backlog[len(hal.rx):]
        ffi.memmove(hal.rx, chunk, len(chunk))
        hal.rx_pos, hal.rx_len = 0, len(chunk)

    def rc(self, pulses: tuple[int, int] | None) -> None:
        """RC receiver pulses (throttle, steering) at every frame start from now on; None = off."""
        self.hal.rc_us[0], self.hal.rc_us[1] = pulses or (0, 0)

    def run(self, loops: int = 1) -> None:
        self._lib.roar_board_run(self._mem, loops)
        self.loops += loops
        if self._rx_backlog:
            self._refill()

    def serial_out(self) -> bytes:
        """Reply bytes the loop wrote since the last call."""
        hal = self.hal
        out = ffi.unpack(hal.tx, hal.tx_len)
        hal.tx_len = 0
        return out

    def set_clock(self, now_us: int) -> None:
        """Set the board's 32-bit counter (a wall-clock loop does this before each run(1))."""
        self.hal.now_us = now_us & _U32_MASK

    @property
    def outputs(self) -> CarOutputs:
        """What the car decided in the last loop iteration (pulses pending for the next frame)."""
        return CarOutputs.from_c(self.hal.outputs)

    @property
    def wire(self) -> tuple[int, int]:
        """(throttle, steering) [us] on the wire in the current output frame."""
        return self.hal.wire_us[0], self.hal.wire_us[1]

    @property
    def frames(self) -> int:
        return self.hal.frames_started


class HttpReader:
    """The firmware's bounded HTTP request reader, one per connection."""

    INCOMPLETE, COMPLETE, MALFORMED, TOO_LONG = 0, 1, 2, 3

    def __init__(self) -> None:
        self._lib = lib()
        self._mem = _object("roar_http_reader_size")
        self._state = ffi.new("uint8_t *")
        self.reset()

    def reset(self) -> None:
        """Ready for the next request on the connection."""
        self._lib.roar_http_reader_init(self._mem)

    def feed(self, data: bytes) -> tuple[int, int]:
        """(bytes taken, state): it stops taking bytes once the request is decided."""
        used = self._lib.roar_http_reader_feed(self._mem, _bytes(data), len(data), self._state)
        return used, self._state[0]


class JuniorBoard:
    """The Junior's loop (JuniorBoard::poll) on a HAL of plain memory: the board's wrapping 32-bit
    microsecond counter, the L298N pins it writes, the distance its replies report."""

    def __init__(self, loop_us: int = 1_000, start_us: int = 0) -> None:
        self._lib = lib()
        self.hal = ffi.new("roar_junior_hal_t *")
        self.hal.now_us, self.hal.loop_us = start_us & _U32_MASK, loop_us
        self._mem = _object("roar_junior_board_size")
        self._lib.roar_junior_board_init(self._mem, self.hal)
        self._reply = ffi.new("char[]", self._lib.roar_junior_reply_max())
        self._keep = ffi.new("uint8_t *")
        self.loops = 0
        self._raw_pins: tuple | None = None
        self._pins: tuple[SidePins, SidePins] | None = None

    def run(self, loops: int = 1) -> None:
        self._lib.roar_junior_board_run(self._mem, loops)
        self.loops += loops

    def respond(self, reader: HttpReader) -> tuple[bytes, bool]:
        """(the response bytes, keep the connection open) to a decided request."""
        n = self._lib.roar_junior_board_respond(self._mem, reader._mem, self._reply, len(self._reply), self._keep)
        return ffi.unpack(self._reply, n), bool(self._keep[0])

    @property
    def pins(self) -> tuple[SidePins, SidePins]:
        """(left, right) L298N inputs after the last loop iteration."""
        left, right = self.hal.left, self.hal.right
        raw = (left.in1, left.in2, left.duty, right.in1, right.in2, right.duty)
        if raw != self._raw_pins:  # read every physics step: build new objects only on a change
            self._raw_pins = raw
            self._pins = (SidePins(bool(raw[0]), bool(raw[1]), raw[2]), SidePins(bool(raw[3]), bool(raw[4]), raw[5]))
        return self._pins

    @property
    def distance_cm(self) -> int:
        return self.hal.distance_cm

    @distance_cm.setter
    def distance_cm(self, value: int) -> None:
        self.hal.distance_cm = value
