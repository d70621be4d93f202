"""serial:// -- a car on a serial port (USB CDC, FTDI, CH340, or the simulator's pty).

    serial:///dev/ttyUSB0?baud=115200     Linux (baud defaults to the protocol's 115200)
    serial://COM3                         Windows
"""

from __future__ import annotations

import serial  # pyserial

from roar.protocol import spec
from roar.transports.base import LinkLost, Transport, TransportError, pop_option

_LINE_END = spec.SERIAL_REPLY_LINE_END.encode("ascii")
_MAX_PENDING = 4 * spec.SERIAL_MAX_REPLY_BYTES  # [bytes] a longer unterminated line is noise


class SerialTransport(Transport):
    scheme = "serial"
    # [s] one 11-byte message takes ~1 ms at 115200 baud (10 bits per byte); keep the wire half idle
    min_period_s = 0.002
    replies = True

    def __init__(self, port: str, baud: int = spec.SERIAL_BAUD, write_timeout_s: float = 0.5) -> None:
        self.port = port
        self.baud = baud
        self.write_timeout_s = write_timeout_s
        self._serial: serial.Serial | None = None
        self._pending = b""

    @classmethod
    def from_url(cls, target: str, options: dict[str, str]) -> SerialTransport:
        if not target:
            raise TransportError("serial:// needs a port, e.g. serial:///dev/ttyUSB0 (see `roar ports`)")
        baud = pop_option(options, "baud", int, spec.SERIAL_BAUD)
        if baud <= 0:
            raise TransportError(f"baud must be positive, got {baud}")
        return cls(target, baud)

    def open(self) -> None:
        try:
            self._serial = serial.Serial(self.port, self.baud, timeout=0, write_timeout=self.write_timeout_s)
        except (serial.SerialException, OSError, ValueError) as e:
            raise TransportError(f"cannot open serial port {self.port}: {_reason(e)}") from None
        self._pending = b""

    def write(self, data: bytes) -> None:
        if self._serial is None:
            raise LinkLost(f"serial port {self.port} is not open")
        try:
            self._serial.write(data)
        except (serial.SerialException, OSError) as e:
            self.close()
            raise LinkLost(f"serial port {self.port} disconnected: {_reason(e)}") from None

    def read_lines(self) -> list[str]:
        if self._serial is None:
            return []
        try:
            waiting = self._serial.in_waiting
            data = self._serial.read(waiting) if waiting else b""
        except (serial.SerialException, OSError) as e:
            self.close()
            raise LinkLost(f"serial port {self.port} disconnected: {_reason(e)}") from None
        self._pending += data
        *lines, self._pending = self._pending.split(_LINE_END)
        if len(self._pending) > _MAX_PENDING:
            self._pending = b""
        return [line.decode("ascii", "replace").rstrip("\r") for line in lines if line.strip()]

    def close(self) -> None:
        port, self._serial = self._serial, None
        if port is not None:
            try:
                port.close()
            except (serial.SerialException, OSError):
                pass


def _reason(e: BaseException) -> str:
    """pyserial's messages repeat errno tuples; keep the human part on one line."""
    text = getattr(e, "strerror", None) or str(e) or type(e).__name__
    return " ".join(str(text).split())
