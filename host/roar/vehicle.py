"""Vehicle: drive a car with throttle and steering in [-1, 1], over any transport.

    from roar import Vehicle
    with Vehicle("sim://") as car:          # or "serial:///dev/ttyUSB0", "ble://"
        car.drive(throttle=0.3, steering=0.5)
        time.sleep(5)
    # leaving the block sends neutral, also on exceptions and Ctrl-C
"""

from __future__ import annotations

import atexit
import collections
import logging
import time
import weakref
from pathlib import Path

from roar.calibration import Calibration, check_unit, load_default
from roar.protocol import encode, spec
from roar.sender import CommandSender
from roar.transports import Transport, TransportError, open_url

log = logging.getLogger("roar")

DEFAULT_PERIOD_S = spec.TIMING_HOST_SEND_PERIOD_US / 1e6  # [s]
STOP_FLUSH_TIMEOUT_S = 0.5  # [s]


class Vehicle:
    """A car at the end of a URL. Commands are held and re-sent at `rate_hz` by a background
    thread, so the car's failsafe stays fed while your program runs and trips when it stops.

    calibration: a Calibration, a path to a TOML file, or None for the user's default file
    (roar.calibration.default_path()) or, without one, 1000/1500/2000 us on both channels.
    reconnect: reopen a lost link with backoff (True) or give up (False; the next call raises).
    transport_options: options a URL cannot carry, passed to the transport (e.g. a bleak backend).
    """

    def __init__(self, url: str = "sim://", calibration: Calibration | str | Path | None = None,
                 rate_hz: float | None = None, reconnect: bool = True, **transport_options) -> None:
        if isinstance(calibration, (str, Path)):
            calibration = Calibration.load(calibration)
        self.calibration = calibration if calibration is not None else load_default()
        period_s = DEFAULT_PERIOD_S if rate_hz is None else 1.0 / _check_rate(rate_hz)
        self.url = url
        self.transport: Transport = open_url(url, **transport_options)
        self.transport.open()
        self.replies: collections.deque[str] = collections.deque(maxlen=200)  # the car's lines, newest last
        self.errors = 0  # "ERR ..." replies seen
        self._throttle = self._steering = 0.0
        self._closed = False
        self._sender = CommandSender(self.transport, period_s, self._on_lines, reconnect)
        self._sender.start(self._message())
        # A program that ends without close() still leaves the car at neutral.
        atexit.register(_close_at_exit, weakref.ref(self))

    # --- commands --------------------------------------------------------------------------

    @property
    def throttle(self) -> float:
        """[-1, 1]: +1 full forward, -1 full reverse (the firmware brakes first), 0 neutral."""
        return self._throttle

    @throttle.setter
    def throttle(self, value: float) -> None:
        self.drive(throttle=value)

    @property
    def steering(self) -> float:
        """[-1, 1]: +1 full right, -1 full left, 0 straight."""
        return self._steering

    @steering.setter
    def steering(self, value: float) -> None:
        self.drive(steering=value)

    def drive(self, throttle: float | None = None, steering: float | None = None) -> None:
        """Set throttle and/or steering (each in [-1, 1]); sent at once and kept fresh."""
        t = self._throttle if throttle is None else check_unit("throttle", throttle)
        s = self._steering if steering is None else check_unit("steering", steering)
        self._check_usable()
        self._throttle, self._steering = t, s
        self._sender.set(self._message())
        time.sleep(0)  # yield the GIL so the sender can put it on the wire now, even in a busy loop

    def stop(self) -> None:
        """Neutral throttle, straight steering; returns once neutral is on the wire (so it also
        re-arms a car whose failsafe latched, even if a new command follows at once)."""
        self.drive(0.0, 0.0)
        self.flush()

    def flush(self, timeout_s: float = STOP_FLUSH_TIMEOUT_S) -> bool:
        """Wait until the latest command has been written to the link (False if it was not)."""
        return self._sender.flush(timeout_s)

    def send_pulses(self, throttle_us: int, steering_us: int) -> None:
        """Send raw pulse widths [us], bypassing the calibration (for calibration tools)."""
        message = encode(throttle_us, steering_us)  # ControlError (a ValueError) when out of range
        self._check_usable()
        self._sender.set(message)

    def pulses_us(self) -> tuple[int, int]:
        """(throttle, steering) [us] currently being sent."""
        return (self.calibration.throttle.to_us(self._throttle), self.calibration.steering.to_us(self._steering))

    def _message(self) -> bytes:
        return encode(*self.pulses_us())

    # --- link --------------------------------------------------------------------------------

    @property
    def connected(self) -> bool:
        return self._sender.connected and not self._closed

    @property
    def link_error(self) -> TransportError | None:
        """Why the link is down, while it is (None when connected)."""
        return self._sender.error

    def _check_usable(self) -> None:
        if self._closed:
            raise TransportError(f"{self.url}: vehicle is closed")
        if not self._sender.reconnect and self._sender.error is not None:
            raise self._sender.error

    def _on_lines(self, lines: list[str]) -> None:
        for line in lines:
            self.replies.append(line)
            word = line.split(" ", 1)[0]
            if word == spec.SERIAL_REPLY_ERROR:
                self.errors += 1
                log.warning("the car rejected a message: %s", line)
            elif word == spec.SERIAL_REPLY_FAILSAFE:
                log.warning("the car's failsafe tripped (no valid command in time); send neutral to re-arm")

    def close(self) -> None:
        """Send neutral and release the link. Safe to call twice."""
        if self._closed:
            return
        self._closed = True
        self._throttle = self._steering = 0.0
        self._sender.stop(final=self._message())
        self.transport.close()

    def __enter__(self) -> Vehicle:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"Vehicle({self.url!r}, throttle={self._throttle:+.2f}, steering={self._steering:+.2f})"


def _check_rate(rate_hz) -> float:
    if isinstance(rate_hz, bool) or not isinstance(rate_hz, (int, float)) or not 5 <= rate_hz <= 500:
        raise ValueError(f"rate_hz must be 5..500 (the car's failsafe needs a command every "
                         f"{spec.TIMING_FAILSAFE_TIMEOUT_US / 1000:g} ms), got {rate_hz!r}")
    return float(rate_hz)


def _close_at_exit(ref: weakref.ref) -> None:
    vehicle = ref()
    if vehicle is not None:
        vehicle.close()
