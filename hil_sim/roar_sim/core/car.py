"""The ESC car's logic, from the core: the streaming control-message parser, the command
watchdog (failsafe), the brake/reverse FSM, the output mapping, the RC override, the whole Car,
and CarBoard, the board loop every ESC car runs, on the host board's memory HAL."""

from __future__ import annotations

from dataclasses import dataclass, field

from roar.protocol import spec
from roar.protocol.control import ControlCommand, ParseEvent, Setpoint
from roar.protocol.spec import ParseResult
from roar_sim.core.memory_hal import MemorySerialPort
from roar_sim.core.library import (U32_MASK, BrakePhase, ControlSource, RcChannel, WatchdogEvent, as_bytes, ffi, lib,
                                   new_object)


class ControlParser:
    """The firmware's streaming control-message parser."""

    def __init__(self) -> None:
        self._lib = lib()
        self._mem = new_object("roar_parser_size")
        self._lib.roar_parser_init(self._mem)
        self.offset = 0

    def feed(self, data: bytes) -> list[ParseEvent]:
        """Same contract as roar.protocol.StreamDecoder.feed: events with absolute offsets."""
        data = bytes(data)
        buf = ffi.new("roar_parse_event_t[]", max(1, len(data)))
        n = self._lib.roar_parser_feed_buffer(self._mem, as_bytes(data), len(data), buf, len(data))
        events = []
        for ev in buf[0:n]:
            result = ParseResult(ev.result)
            command = ControlCommand(ev.throttle, ev.steering) if result == ParseResult.OK else None
            setpoint = Setpoint(ev.speed_mm_s, ev.steering) if result == ParseResult.SETPOINT else None
            signature = (ev.counter, ev.mac) if ev.is_signed else None
            events.append(ParseEvent(self.offset + ev.at, result, command, setpoint, signature))
        self.offset += len(data)
        return events

    def count(self, data: bytes) -> int:
        """Feed without collecting events; returns how many there were (for benchmarks)."""
        self.offset += len(data)
        return self._lib.roar_parser_feed_buffer(self._mem, as_bytes(data), len(data), ffi.NULL, 0)


class Authenticator:
    """The firmware's verdict on signed messages (roar/signing.h), beside a ControlParser."""

    def __init__(self) -> None:
        self._lib = lib()
        self._mem = new_object("roar_auth_size")
        self._lib.roar_auth_init(self._mem)

    def set_key(self, key: bytes | None, session: int) -> None:
        self._lib.roar_auth_set_key(self._mem, ffi.NULL if key is None else as_bytes(key), session)

    def check(self, kind: ParseResult, parser: ControlParser) -> ParseResult:
        return ParseResult(self._lib.roar_auth_check(self._mem, kind, parser._mem))

    @property
    def last_counter(self) -> int:
        return self._lib.roar_auth_last_counter(self._mem)


def message_mac(key: bytes, session: int, start: int, first: int, steering: int, counter: int) -> int:
    return lib().roar_message_mac(as_bytes(key), session, start, first, steering, counter)


def key_fingerprint(key: bytes) -> str:
    return "%08x" % lib().roar_key_fingerprint(as_bytes(key))


class CommandWatchdog:
    """The firmware's command watchdog (failsafe)."""

    def __init__(self, timeout_us: int = spec.TIMING_FAILSAFE_TIMEOUT_US) -> None:
        self._lib = lib()
        self._mem = new_object("roar_watchdog_size")
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


class BrakeFsm:
    """The firmware's non-blocking forward-to-reverse sequence."""

    def __init__(self, neutral_us: int = spec.CONTROL_NEUTRAL_US, tap_us: int = spec.TIMING_BRAKE_TAP_US,
                 step_us: int = spec.TIMING_BRAKE_STEP_US) -> None:
        self._lib = lib()
        self._mem = new_object("roar_brake_size")
        self._lib.roar_brake_init(self._mem, neutral_us, tap_us, step_us)

    def step(self, command_us: int, now_us: int, frames_started: int) -> int:
        return self._lib.roar_brake_step(self._mem, command_us, now_us, frames_started & U32_MASK)

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

    def __init__(self) -> None:
        self._lib = lib()
        self._mem = new_object("roar_rc_size")
        self._lib.roar_rc_init(self._mem)

    def pulse(self, channel: RcChannel, width_us: int, now_us: int) -> None:
        self._lib.roar_rc_pulse(self._mem, channel, width_us, now_us)

    def active(self, now_us: int) -> bool:
        return bool(self._lib.roar_rc_active(self._mem, now_us))

    def command(self) -> tuple[int, int]:
        t, s = ffi.new("uint16_t *"), ffi.new("uint16_t *")
        self._lib.roar_rc_command(self._mem, t, s)
        return t[0], s[0]


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
        self._mem = new_object("roar_car_size")
        if self._lib.roar_car_init(self._mem, self.config.to_c()) != 0:
            raise ValueError(INVALID_CALIBRATION)
        self._reply = ffi.new("char[]", spec.SERIAL_MAX_REPLY_BYTES + 1)
        self._out = ffi.new("roar_car_outputs_t *")

    def boot(self) -> None:
        self._lib.roar_car_boot(self._mem)

    def feed(self, data: bytes, now_us: int) -> None:
        self._lib.roar_car_feed(self._mem, as_bytes(data), len(data), now_us)

    def rc_pulse(self, channel: RcChannel, width_us: int, now_us: int) -> None:
        self._lib.roar_car_rc_pulse(self._mem, channel, width_us, now_us)

    def step(self, now_us: int, frames_started: int) -> CarOutputs:
        self._lib.roar_car_step(self._mem, now_us, frames_started & U32_MASK, self._out)
        return CarOutputs.from_c(self._out)

    def replies(self) -> list[str]:
        """Drain all pending reply lines (each ends with a newline)."""
        lines = []
        while n := self._lib.roar_car_take_reply(self._mem, self._reply, len(self._reply)):
            lines.append(ffi.string(self._reply, n).decode("ascii"))
        return lines


class CarBoard(MemorySerialPort):
    """The board loop every car runs (CarBoard::poll), on a HAL of plain memory: a 1 kHz loop
    on the board's wrapping 32-bit microsecond counter, output frames every 20 ms that carry
    the pulses written before they start, a serial port, BLE writes and an RC receiver.

        board = CarBoard(); board.begin()
        board.serial_in(b"(1500,1500)")     # bytes arriving on the serial port
        board.run(loops=20)                 # 20 loop iterations, 1 ms apart
        board.wire                          # (throttle, steering) on the wire in this frame
        board.serial_out()                  # b"READY 1\nARMED\n"
    """

    def __init__(self, config: CarConfig | None = None, loop_us: int = 1_000,
                 frame_us: int = spec.TIMING_SERVO_FRAME_US, start_us: int = 0, nvm: bytes | None = None) -> None:
        """nvm: the board's non-volatile memory as a previous board left it (`.nvm`), so a new
        board is that board rebooted; None: blank, as from the factory."""
        self._lib = lib()
        self.config = config or CarConfig()
        self.hal = ffi.new("roar_host_hal_t *")
        self._init_nvm(nvm)
        self.hal.now_us = self.hal.next_frame_us = start_us & U32_MASK
        self.hal.loop_us, self.hal.frame_us = loop_us, frame_us
        self._mem = new_object("roar_board_size")
        if self._lib.roar_board_init(self._mem, self.hal, self.config.to_c()) != 0:
            raise ValueError(INVALID_CALIBRATION)
        self._rx_backlog = b""
        self.loops = 0  # loop iterations run so far

    def begin(self) -> None:
        self._lib.roar_board_begin(self._mem)

    @property
    def session(self) -> int:
        """The signing session the car booted into (0: it has no key)."""
        return self._lib.roar_board_session(self._mem)

    @property
    def last_counter(self) -> int:
        """The last counter the car accepted in its session."""
        return self._lib.roar_board_last_counter(self._mem)

    def ble_write(self, data: bytes) -> None:
        """One BLE write to the control characteristic, fed to the loop at once."""
        self._lib.roar_board_feed(self._mem, as_bytes(data), len(data))

    def rc(self, pulses: tuple[int, int] | None) -> None:
        """RC receiver pulses (throttle, steering) at every frame start from now on; None = off."""
        self.hal.rc_us[0], self.hal.rc_us[1] = pulses or (0, 0)

    def run(self, loops: int = 1) -> None:
        self._lib.roar_board_run(self._mem, loops)
        self.loops += loops
        if self._rx_backlog:
            self._refill()

    def set_clock(self, now_us: int) -> None:
        """Set the board's 32-bit counter (a wall-clock loop does this before each run(1))."""
        self.hal.now_us = now_us & U32_MASK

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
