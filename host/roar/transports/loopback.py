"""loop:// -- a link with no car: records every write, hands back lines a test injects.

    loop://             accepts writes
    loop://?fail_after=N  the N+1st write raises LinkLost (a pulled cable, for tests)
"""

from __future__ import annotations

import threading
import time

from roar.transports.base import LinkLost, Transport, TransportError, pop_option


class LoopbackTransport(Transport):
    scheme = "loop"
    min_period_s = 0.002  # [s] like a serial link, so tests see the same coalescing

    def __init__(self, fail_after: int = -1) -> None:
        self.fail_after = fail_after
        self.writes: list[tuple[float, bytes]] = []  # (time.monotonic(), data)
        self.opened = 0
        self.is_open = False
        self._replies: list[str] = []
        self._lock = threading.Lock()

    @classmethod
    def from_url(cls, target: str, options: dict[str, str]) -> LoopbackTransport:
        if target:
            raise TransportError(f"loop:// takes no target, got {target!r}")
        return cls(fail_after=pop_option(options, "fail_after", int, -1))

    def open(self) -> None:
        self.opened += 1
        self.is_open = True

    def write(self, data: bytes) -> None:
        with self._lock:
            if not self.is_open:
                raise LinkLost("loop:// is closed")
            if 0 <= self.fail_after <= len(self.writes):
                self.is_open = False
                raise LinkLost("loop:// link cut (fail_after)")
            self.writes.append((time.monotonic(), bytes(data)))

    def inject(self, *lines: str) -> None:
        """Lines the 'car' printed (read back by read_lines)."""
        with self._lock:
            self._replies.extend(lines)

    def read_lines(self) -> list[str]:
        with self._lock:
            lines, self._replies = self._replies, []
        return lines

    def messages(self) -> list[bytes]:
        with self._lock:
            return [data for _, data in self.writes]

    def close(self) -> None:
        self.is_open = False
