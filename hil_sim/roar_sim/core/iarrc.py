"""The IARRC car's logic, from the core: the SBUS receiver's frames, the controller
(IarrcController: modes, speed PID, battery) and IarrcBoard, its six tasks, on the host board's
memory HAL; the task table as the core declares it."""

from __future__ import annotations

import bisect
from dataclasses import dataclass

from roar.protocol import spec
from roar.protocol.spec import IarrcFailsafe, IarrcMode, SbusResult
from roar_sim.core.memory_hal import MemoryNvm
from roar_sim.core.library import U32_MASK, IarrcTask, ModeSwitch, as_bytes, ffi, lib, new_object


class SbusDecoder:
    """The core's SBUS frame decoder: feed(byte, now_us) -> an SbusResult (roar_wire.sbus, the
    portable decoder, reports the same codes: both come from the spec)."""

    def __init__(self) -> None:
        self._lib = lib()
        self._mem = new_object("roar_sbus_decoder_size")
        self._lib.roar_sbus_decoder_init(self._mem)
        self._frame = ffi.new("roar_sbus_frame_t *")
        self._status = ffi.new("roar_sbus_status_t *")

    def feed(self, byte: int, now_us: int) -> SbusResult:
        return SbusResult(self._lib.roar_sbus_feed(self._mem, byte, now_us))

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
    return _sbus_frame(f) if lib().roar_sbus_decode(as_bytes(bytes(data)), f) else None


class IarrcController:
    """The IARRC car's controller (IarrcController, default configuration): SBUS bytes, host
    bytes, encoder counts and battery readings in; control(now_us) -> a status dict with the
    pulses, the mode and what the controller knows."""

    def __init__(self) -> None:
        self._lib = lib()
        self._mem = new_object("roar_iarrc_size")
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
        self._lib.roar_iarrc_control(self._mem, now_us, frames & U32_MASK, self._status)
        return iarrc_status(self._status)


def iarrc_status(st) -> dict:
    """A roar_iarrc_status_t as a dict of Python values (the mode, failsafe and mode switch as
    words: the mode and failsafe as a TEL line spells them)."""
    return {"throttle_us": st.throttle_us, "steering_us": st.steering_us, "mode": str(IarrcMode(st.mode)),
            "failsafe": str(IarrcFailsafe(st.failsafe)), "rc_present": bool(st.rc_present),
            "mode_switch": ModeSwitch(st.mode_switch).name.lower(), "speed_mm_s": st.speed_mm_s,
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
            self._times[0:n] = [t & U32_MASK for t in self.times[:n]]
        self._data[0:n] = bytes(self.pending[:n])
        setattr(hal, self._len, n)
        setattr(hal, self._pos, 0)

    def consume(self, hal) -> None:
        used = getattr(hal, self._pos)
        del self.pending[:used]
        del self.times[:used]


class IarrcBoard(MemoryNvm):
    """The IARRC car's tasks (IarrcBoard) on a HAL of plain memory. The caller is the scheduler:
    it sets the inputs (encoder_count, battery_adc, gyro_z_raw), queues received bytes with
    sbus()/host()/link(), and calls run(task, now_us) for each release of a task."""

    def __init__(self, counts_per_m: int = 0, nvm: bytes | None = None) -> None:
        """nvm: the board's flash as a previous board left it (`.nvm`: key and session); None: blank."""
        self._lib = lib()
        self.hal = ffi.new("roar_iarrc_hal_t *")
        self._init_nvm(nvm)
        self._mem = new_object("roar_iarrc_board_size")
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
        # the task that reads each port
        self._rx_of_task = {IarrcTask.RC: self._sbus, IarrcTask.HOST: self._host, IarrcTask.TELEMETRY: self._link}

    def begin(self) -> None:
        self._lib.roar_iarrc_board_begin(self._mem)
        self._take_tx()

    @property
    def session(self) -> int:
        """The signing session the board booted into (0: it has no key)."""
        return self._lib.roar_iarrc_board_session(self._mem)

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

    def run(self, task: IarrcTask, now_us: int) -> None:
        """One release of a task (an IarrcTask: its row of iarrc_tasks()) at now_us."""
        self.now_us = now_us
        h = self.hal
        h.now_us = now_us & U32_MASK
        h.frames_started = (now_us // spec.TIMING_SERVO_FRAME_US + 1) & U32_MASK
        rx = self._rx_of_task.get(task)
        if rx is not None:
            rx.load(h, now_us)
        self._lib.roar_iarrc_board_run(self._mem, task)
        if rx is not None:
            rx.consume(h)
        self._take_tx()

    def overran(self, task: IarrcTask, missed: int) -> None:
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
