"""The command sender: one thread that keeps the car fed with the latest command.

- A new command goes out at once (no faster than the link's min_period_s), so the API call to
  bytes-on-the-wire latency is short.
- The latest command is re-sent every period (default 50 Hz, protocol timing
  host_send_period_us), well inside the car's failsafe timeout. Older commands are never queued.
- The thread stops sending when the program's main thread ends, so a host that dies or forgets
  to close leaves the car to its own failsafe.
- When the link is lost it reconnects with backoff (if allowed) and reports each change.
"""

from __future__ import annotations

import logging
import threading
import time
from typing import Callable

from roar.transports.base import LinkLost, Transport, TransportError

log = logging.getLogger("roar")

BACKOFF_FIRST_S = 0.1  # [s] first wait before reopening a lost link
BACKOFF_MAX_S = 2.0  # [s]


class CommandSender:
    def __init__(self, transport: Transport, period_s: float, on_lines: Callable[[list[str]], None],
                 reconnect: bool = True) -> None:
        self.transport = transport
        self.period_s = period_s
        self.reconnect = reconnect
        self._on_lines = on_lines
        self._cond = threading.Condition()
        self._message: bytes | None = None
        self._fresh = False
        self._seq = self._sent_seq = 0  # numbers of the latest set() and of the latest written
        self._stop = False
        self.connected = True
        self.error: TransportError | None = None  # why the link is down, while it is
        self.sent = 0  # messages written
        self.main_ended = False  # stopped because the program's main thread ended
        self._last_send = -1e9
        self._thread = threading.Thread(target=self._run, name="roar-sender", daemon=True)

    def start(self, message: bytes) -> None:
        self._message = message
        self._fresh = True
        self._thread.start()

    def set(self, message: bytes) -> None:
        """Make `message` the command to send; wakes the thread."""
        with self._cond:
            self._message = message
            self._fresh = True
            self._seq += 1
            self._cond.notify_all()

    def flush(self, timeout_s: float) -> bool:
        """Wait until the latest command has been written (False on timeout or a dead link)."""
        with self._cond:
            return self._cond.wait_for(lambda: self._sent_seq >= self._seq or not self.connected or self._stop,
                                       timeout_s) and self._sent_seq >= self._seq

    def stop(self, final: bytes | None = None, timeout_s: float = 1.0) -> None:
        """Stop the thread; then write `final` once if the link is up (e.g. neutral)."""
        with self._cond:
            self._stop = True
            self._cond.notify_all()  # the thread and any flush() waiting
        if self._thread.is_alive() and threading.current_thread() is not self._thread:
            self._thread.join(timeout_s)
        if final is not None and self.connected:
            try:
                self.transport.write(final)
                self.sent += 1
            except TransportError:
                pass

    # --- the thread ------------------------------------------------------------------------

    def _run(self) -> None:
        main = threading.main_thread()
        while True:
            with self._cond:
                while True:
                    if not main.is_alive():
                        self.main_ended = True
                        self._cond.notify_all()
                        return  # the program ended without closing: the car fails safe
                    if self._stop:
                        return
                    now = time.monotonic()
                    due = self._last_send + (self.transport.min_period_s if self._fresh else self.period_s)
                    if now >= due:
                        break
                    self._cond.wait(min(due - now, 0.05))
                message, seq, self._fresh = self._message, self._seq, False
            self._send(message, seq)

    def _send(self, message: bytes, seq: int) -> None:
        self._last_send = time.monotonic()
        try:
            self.transport.write(message)
            self.sent += 1
            with self._cond:
                self._sent_seq = seq
                self._cond.notify_all()
            lines = self.transport.read_lines()
        except LinkLost as e:
            self._link_lost(e)
            return
        if lines:
            self._on_lines(lines)

    def _link_lost(self, error: LinkLost) -> None:
        with self._cond:
            self.connected, self.error = False, error
            self._cond.notify_all()
        log.warning("%s", error)
        self.transport.close()
        if not self.reconnect:
            with self._cond:
                self._stop = True
            return
        wait = BACKOFF_FIRST_S
        while True:
            with self._cond:
                if self._cond.wait_for(lambda: self._stop, wait):
                    return
            try:
                self.transport.open()
            except TransportError as e:
                self.error = e
                wait = min(2 * wait, BACKOFF_MAX_S)
                continue
            self.connected, self.error = True, None
            log.warning("link to %s restored; if the car's failsafe latched, send neutral "
                        "(stop()) to re-arm it", self.transport.url)
            with self._cond:
                self._fresh = True
            return
