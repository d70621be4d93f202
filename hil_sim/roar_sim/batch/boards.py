"""Many ESC cars' board loops stepped together: the firmware core's CarBoard::poll, the very loop
every ESC car runs (and roar_sim.core.car.CarBoard runs one of), for n cars through one call of
the C ABI's roar_boards_run per control period.

    boards = Boards(1024)
    wire = boards.run(throttle_us, steering_us, loops=20)   # uint16 [20, 1024, 2]: each car's pulses
    boards.reboot([3, 17])                                  # those two boards power-cycled

A car's control message arrives as a host writes it ("(1600,1450)"); a throttle of 0 sends
nothing (the host silent: the core's failsafe then does what it does on a car). Each board keeps
its own free-running 32-bit microsecond counter, which wraps as on the cars.
"""

from __future__ import annotations

import numpy as np

from roar.protocol import spec
from roar_sim.core.car import INVALID_CALIBRATION, CarConfig
from roar_sim.core.library import U32_MASK, ffi, lib
from roar_sim.core.lockstep import LOOP_US

FRAME_US = spec.TIMING_SERVO_FRAME_US  # [us]
MAX_BOARDS = 1 << 20  # the most a batch steps


class Boards:
    def __init__(self, n: int, config: CarConfig | None = None, start_us=0) -> None:
        """n boards (1..MAX_BOARDS), each with the core's configuration `config` (default: the
        cars'), blank non-volatile memory, its counter at start_us [us] (one for all, or one each)."""
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= n <= MAX_BOARDS:
            raise ValueError(f"a batch has 1..{MAX_BOARDS} cars, got {n!r}")
        self.n = int(n)
        self._lib = lib()
        self.config = config or CarConfig()
        self._config = self.config.to_c()
        self._size = self._lib.roar_board_size()
        if self._size % 8:
            raise RuntimeError(f"roar_board_size() is {self._size}: not a multiple of 8, boards cannot sit side "
                               f"by side")
        self._memory = np.zeros(self.n * self._size // 8, dtype=np.uint64)
        self._boards = ffi.cast("void *", ffi.from_buffer(self._memory))
        self.hals = ffi.new("roar_host_hal_t[]", self.n)
        self._wire: np.ndarray | None = None
        start = np.broadcast_to(np.asarray(start_us, dtype=np.int64) & U32_MASK, (self.n,))
        for i in range(self.n):
            self._boot(i, int(start[i]))

    @property
    def bytes_per_board(self) -> int:
        """[bytes] a board's state and its HAL's memory."""
        return self._size + ffi.sizeof("roar_host_hal_t")

    def _boot(self, i: int, now_us: int) -> None:
        hal = self.hals[i]
        ffi.memmove(ffi.addressof(self.hals, i), b"\x00" * ffi.sizeof("roar_host_hal_t"), ffi.sizeof("roar_host_hal_t"))
        ffi.memmove(hal.nvm, b"\xff" * len(hal.nvm), len(hal.nvm))
        hal.now_us = hal.next_frame_us = now_us & U32_MASK
        hal.loop_us, hal.frame_us = LOOP_US, FRAME_US
        board = self._board(i)
        if self._lib.roar_board_init(board, ffi.addressof(self.hals, i), self._config) != 0:
            raise ValueError(INVALID_CALIBRATION)
        self._lib.roar_board_begin(board)

    def _board(self, i: int):
        return ffi.cast("uint8_t *", self._boards) + i * self._size

    def reboot(self, cars) -> None:
        """Those boards power-cycled: booted afresh (blank memory), their counters running on."""
        for i in np.atleast_1d(cars).tolist():
            self._boot(i, self.hals[i].now_us)

    def now_us(self, i: int) -> int:
        """[us] board i's 32-bit counter."""
        return self.hals[i].now_us

    def run(self, throttle_us: np.ndarray, steering_us: np.ndarray, loops: int, cars: np.ndarray | None = None,
            ) -> np.ndarray:
        """Each car's control message (throttle 0: none), then `loops` loop iterations of its board;
        uint16 [loops, n, 2]: the (throttle, steering) pulses on each car's wire after each. cars:
        a bool mask of the boards to run (None: all); the others' rows are as they were."""
        throttle = np.ascontiguousarray(throttle_us, dtype=np.uint16)
        steering = np.ascontiguousarray(steering_us, dtype=np.uint16)
        if throttle.shape != (self.n,) or steering.shape != (self.n,):
            raise ValueError(f"one throttle and one steering pulse per car ({self.n}), got {throttle.shape} and "
                             f"{steering.shape}")
        if self._wire is None or self._wire.shape[0] != loops:
            self._wire = np.empty((loops, self.n, 2), dtype=np.uint16)
        wire = self._wire
        if cars is None:
            run = ffi.NULL
        else:
            run_mask = np.ascontiguousarray(cars, dtype=np.uint8)
            if run_mask.shape != (self.n,):
                raise ValueError(f"one flag per car ({self.n}), got {run_mask.shape}")
            run = ffi.from_buffer("uint8_t[]", run_mask)
        self._lib.roar_boards_run(self._boards, self.hals, self.n, run, ffi.from_buffer("uint16_t[]", throttle),
                                  ffi.from_buffer("uint16_t[]", steering), loops, ffi.from_buffer("uint16_t[]", wire))
        return wire
