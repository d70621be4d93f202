"""What the host boards' HALs of plain memory share (firmware/host/c_api.h): a serial port (rx
filled from a backlog as the loop reads it, tx drained by the caller) and a few bytes of
non-volatile memory (or a flash sector) that a new board can take from an old one (a reboot)."""

from __future__ import annotations

from roar_sim.core.library import ffi


class MemoryNvm:
    """Mixed into a board wrapper whose `hal` struct has nvm (bytes), or flash (a roar_flash_t:
    the sector a FlashLog keeps the key in)."""

    hal: object

    def _memory(self):
        return self.hal.flash.bytes if hasattr(self.hal, "flash") else self.hal.nvm

    def _init_nvm(self, nvm: bytes | None) -> None:
        """nvm: the memory a previous board left (`.nvm`); None: blank (0xFF), as from the factory."""
        if hasattr(self.hal, "flash"):
            self.hal.flash.power_words = -1  # the power never fails unless a test cuts it
        memory = self._memory()
        size = len(memory)
        data = (bytes([0xFF]) * size if nvm is None else bytes(nvm)).ljust(size, b"\xff")[:size]
        ffi.memmove(memory, data, size)

    @property
    def nvm(self) -> bytes:
        """The board's non-volatile memory now (its signing key and session: roar/signing.h)."""
        memory = self._memory()
        return ffi.unpack(ffi.cast("char *", memory), len(memory))


class MemorySerialPort(MemoryNvm):
    """Mixed into a board wrapper whose `hal` struct also has rx, rx_pos, rx_len, tx, tx_len."""

    _rx_backlog: bytes = b""

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

    def serial_out(self) -> bytes:
        """Bytes the loop wrote to the serial port since the last call."""
        hal = self.hal
        out = ffi.unpack(hal.tx, hal.tx_len)
        hal.tx_len = 0
        return out
