"""The ROAR Junior's logic, from the core: the L298N driver with its reversal dead time, the
HTTP control (JuniorControl), the bounded HTTP request reader, and JuniorBoard, its loop, on the
host board's memory HAL."""

from __future__ import annotations

from dataclasses import dataclass

from roar.protocol import spec
from roar_sim.core.memory_hal import MemorySerialPort
from roar_sim.core.library import U32_MASK, HttpRead, JuniorQueryError, as_bytes, ffi, lib, new_object


@dataclass(frozen=True)
class SidePins:
    in1: bool
    in2: bool
    duty: int  # [permille]


class L298nDriver:
    """The firmware's per-side L298N direction/duty driver with reversal dead time."""

    def __init__(self, dead_time_us: int = spec.L298N_DEAD_TIME_US) -> None:
        self._lib = lib()
        self._mem = new_object("roar_l298n_size")
        self._lib.roar_l298n_init(self._mem, dead_time_us)
        self._out = ffi.new("roar_side_pins_t[2]")

    def step(self, left_permille: int, right_permille: int, now_us: int) -> tuple[SidePins, SidePins]:
        lo, ro = self._out + 0, self._out + 1
        self._lib.roar_l298n_step(self._mem, left_permille, right_permille, now_us, lo, ro)
        return (SidePins(bool(lo.in1), bool(lo.in2), lo.duty), SidePins(bool(ro.in1), bool(ro.in2), ro.duty))


class JuniorControl:
    """The ROAR Junior's HTTP control: query strings applied in order, and its 500 ms failsafe."""

    def __init__(self) -> None:
        self._lib = lib()
        self._mem = new_object("roar_junior_size")
        self._lib.roar_junior_init(self._mem)

    ERRORS = {JuniorQueryError.UNKNOWN_NAME: "unknown parameter", JuniorQueryError.BAD_FLAG: "bad flag",
              JuniorQueryError.BAD_SPEED: "bad speed"}

    def apply_query(self, query: str, now_us: int) -> tuple[int, str | None]:
        """(parameters applied, None), or (0, why) when the query was refused and nothing changed."""
        raw = query.encode()
        r = self._lib.roar_junior_apply_query(self._mem, raw, len(raw), now_us)
        return (r, None) if r >= 0 else (0, self.ERRORS[JuniorQueryError(-r)])

    def duties(self, now_us: int) -> tuple[int, int]:
        left, right = ffi.new("int16_t *"), ffi.new("int16_t *")
        self._lib.roar_junior_duties(self._mem, now_us, left, right)
        return left[0], right[0]


class HttpRequestReader:
    """The firmware's bounded HTTP request reader, one per connection."""

    def __init__(self) -> None:
        self._lib = lib()
        self._mem = new_object("roar_http_reader_size")
        self._state = ffi.new("uint8_t *")
        self.reset()

    def reset(self) -> None:
        """Ready for the next request on the connection."""
        self._lib.roar_http_reader_init(self._mem)

    def feed(self, data: bytes) -> tuple[int, HttpRead]:
        """(bytes taken, state): it stops taking bytes once the request is decided."""
        used = self._lib.roar_http_reader_feed(self._mem, as_bytes(data), len(data), self._state)
        return used, HttpRead(self._state[0])

    @property
    def path(self) -> str:
        """After a complete read: the request's path, without its query."""
        length = ffi.new("size_t *")
        path = self._lib.roar_http_reader_path(self._mem, length)
        return ffi.unpack(path, length[0]).decode("ascii")

    def refusal(self) -> bytes:
        """The response with which every port of the Junior refuses this decided request
        (malformed, too long, not GET, a GET with a body); b"" for one its routes answer."""
        out = ffi.new("char[]", self._lib.roar_junior_reply_max())
        return ffi.unpack(out, self._lib.roar_http_refuse(self._mem, out, len(out)))


class JuniorBoard(MemorySerialPort):
    """The Junior's loop (JuniorBoard::poll) on a HAL of plain memory: the board's wrapping 32-bit
    microsecond counter, the L298N pins it writes, the distance its replies report, its USB
    serial port (key lines) and its non-volatile memory (nvm: as a previous board left it, so
    this one is that board rebooted; None: blank)."""

    def __init__(self, loop_us: int = 1_000, start_us: int = 0, nvm: bytes | None = None) -> None:
        self._lib = lib()
        self.hal = ffi.new("roar_junior_hal_t *")
        self.hal.now_us, self.hal.loop_us = start_us & U32_MASK, loop_us
        self._init_nvm(nvm)
        self._mem = new_object("roar_junior_board_size")
        self._lib.roar_junior_board_init(self._mem, self.hal)
        self._lib.roar_junior_board_begin(self._mem)
        self._reply = ffi.new("char[]", self._lib.roar_junior_reply_max())
        self._keep = ffi.new("uint8_t *")
        self.loops = 0
        self._raw_pins: tuple | None = None
        self._pins: tuple[SidePins, SidePins] | None = None

    def run(self, loops: int = 1) -> None:
        self._lib.roar_junior_board_run(self._mem, loops)
        self.loops += loops
        if self._rx_backlog:
            self._refill()

    @property
    def session(self) -> int:
        """The signing session the board booted into (0: it has no key)."""
        return self._lib.roar_junior_board_session(self._mem)

    def respond(self, reader: HttpRequestReader) -> tuple[bytes, bool]:
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
