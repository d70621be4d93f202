"""Vehicle: drive a car with throttle and steering in [-1, 1], over any transport, and read back
what it does.

    from roar import Vehicle
    with Vehicle("sim://") as car:          # or "serial:///dev/ttyUSB0", "ble://"
        car.drive(throttle=0.3, steering=0.5)
        time.sleep(5)
        print(car.state().speed_m_s)        # None where the link cannot tell
    # leaving the block sends neutral, also on exceptions and Ctrl-C

A car with a speed controller (it says READY 2, or sends telemetry lines: the IARRC car,
"sim://?robot=iarrc") is driven by speed instead, and reports its battery, distance and mode:

    with Vehicle("sim://?robot=iarrc") as car:
        car.drive(speed=2.0, steering=0.1)  # [m/s], steering in [-1, 1]
        print(car.state().battery_v, car.state().distance_m, car.state().mode)

Threads: drive() may be called from any thread while the program's main thread runs. When the
main thread ends without close(), the vehicle stops sending (so the car's failsafe stops the
car) and from then on drive() raises TransportError and `connected` is False.
"""

from __future__ import annotations

import atexit
import dataclasses
import collections
import logging
import sys
import threading
import time
import weakref
from pathlib import Path
from typing import Any

from roar.calibration import Calibration, check_unit, load_default
from roar.checks import number, timeout
from roar.protocol import encode, encode_setpoint, spec
from roar.sender import CommandSender
from roar.telemetry import UNKNOWN, CarEvent, EventKind, VehicleState, parse_event, parse_telemetry
from roar.transports import TransportError, open_url

log = logging.getLogger("roar")

DEFAULT_PERIOD_S = spec.TIMING_HOST_SEND_PERIOD_US / 1e6  # [s]
STOP_FLUSH_TIMEOUT_S = 0.5  # [s]
VERSION_WAIT_S = 1.0  # [s] how long drive(speed=...) waits to hear which messages the car takes
MAX_SPEED_M_S = spec.SETPOINT_MAX_SPEED_MM_S / 1000  # [m/s]


class Vehicle:
    """A car at the end of a URL. Commands are held and re-sent at `rate_hz` by a background
    thread, so the car's failsafe stays fed while your program runs and trips when it stops.

    calibration: a Calibration, a path to a TOML file, or None for the user's default file
    (roar.calibration.default_path()) or, without one, 1000/1500/2000 us on both channels.
    reconnect: reopen a lost link with backoff (True) or give up (False; the next call raises).
    transport_options: options a URL cannot carry, passed to the transport (e.g. a bleak backend).
    record: an MCAP file to record the run into (roar.recorder: every message sent, every line
    received, the state, and the scans and frames asked for), finished when the vehicle closes;
    or a roar.recorder.Recorder (one that also serves the channels live, say).
    key: sign every message (roar.signing) with this key (bytes, 32 hex digits or a key file);
    None (default): with the user's key file (`roar key new` / `roar key set URL`) if there is
    one, else unsigned; False: never sign.
    """

    def __init__(self, url: str = "sim://", calibration: Calibration | str | Path | None = None,
                 rate_hz: float | None = None, reconnect: bool = True, record=None, key=None,
                 **transport_options) -> None:
        if isinstance(calibration, (str, Path)):
            calibration = Calibration.load(calibration)
        self.calibration = calibration if calibration is not None else load_default()
        period_s = DEFAULT_PERIOD_S if rate_hz is None else 1.0 / _check_rate(rate_hz)
        self.url = url
        from roar.signing import resolve_key
        from roar.transports.recording import RecordingTransport, RunClock, WireRecording
        from roar.transports.signing import SigningTransport

        signing_key = resolve_key(key)
        link = open_url(url, **transport_options)
        # the layers, in their one order (transports.recording): what the script asked is recorded
        # at the top, then signed, then what went on the wire is recorded just above the link
        clock = RunClock(link)
        self._wire = WireRecording(link, None, clock)
        self.signer: SigningTransport | None = None  # the signing layer, when the Vehicle signs
        if signing_key is not None:
            self.signer = SigningTransport(self._wire, signing_key)
        self.transport: RecordingTransport = RecordingTransport(self.signer or self._wire, None, clock)
        self.recorder = None
        if record is not None:
            self.recorder = self.transport.recorder = self._wire.recorder = self._new_recorder(record)
        try:
            self.transport.open()
        except BaseException:
            if self.recorder is not None:
                self.recorder.close()
            raise
        self.replies: collections.deque[str] = collections.deque(maxlen=200)  # the car's lines, newest last
        self.events: collections.deque[CarEvent] = collections.deque(maxlen=200)  # the same, typed
        self.errors = 0  # "ERR ..." replies seen
        self.refusals: collections.Counter[str] = collections.Counter()  # the same, by the reason after ERR
        self.rejected_telemetry = 0  # telemetry lines dropped: not the spec's fields (a number that is not one)
        self._events_cond = threading.Condition()
        self._throttle = self._steering = 0.0
        self._speed = 0.0  # [m/s] on a car that drives by speed
        self.protocol_version: int | None = None  # what the car said: READY n (2: it takes speed setpoints)
        self._telemetry: dict = {}  # the latest telemetry line's fields
        self._zero_speed_sent = False
        self._raw = False  # the message on the wire is raw pulses (send_pulses), not drive()'s
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

    def drive(self, throttle: float | None = None, steering: float | None = None, *,
              speed: float | None = None) -> None:
        """Set throttle and/or steering (each in [-1, 1]), or on a car with a speed controller
        speed [m/s] and/or steering; sent at once and kept fresh."""
        if throttle is not None and speed is not None:
            raise ValueError("give throttle or speed, not both")
        t = self._throttle if throttle is None else check_unit("throttle", throttle)
        s = self._steering if steering is None else check_unit("steering", steering)
        v = self._speed if speed is None else _check_speed(speed)
        self._check_usable()
        if speed is not None and self.told_version() != spec.META_SPEED_VERSION:
            heard = (f"says READY {self.protocol_version}: it drives by throttle" if self.protocol_version
                     else f"has not said which messages it takes (no READY or telemetry line in {VERSION_WAIT_S:g} s)")
            raise ValueError(f"drive(speed=...) needs a car with a speed controller (READY "
                             f"{spec.META_SPEED_VERSION}); this one {heard}: use drive(throttle=...)")
        if throttle is not None and self.protocol_version == spec.META_SPEED_VERSION:
            raise ValueError(f"this car drives by speed (it says READY {spec.META_SPEED_VERSION}): "
                             f"use drive(speed=..., steering=...)")
        if speed is not None and not self._zero_speed_sent:
            # A speed car boots (or fails safe) waiting for zero speed, as an ESC car waits for
            # neutral: put it on the wire once before the first speed.
            self._sender.set(self._message())
            self._zero_speed_sent = self.flush()
        self._throttle, self._steering, self._speed = t, s, v
        self._raw = False
        self._sender.set(self._message())
        time.sleep(0)  # yield the GIL so the sender can put it on the wire now, even in a busy loop

    def told_version(self) -> int | None:
        """The car's protocol version (READY n), waiting up to VERSION_WAIT_S for it to tell; None if
        it has not (a car that says nothing takes pulses)."""
        with self._events_cond:
            self._events_cond.wait_for(lambda: self.protocol_version is not None, VERSION_WAIT_S)
        return self.protocol_version

    def stop(self) -> None:
        """Neutral throttle (or zero speed), straight steering; returns once it is on the wire (so
        it also re-arms a car whose failsafe latched, even if a new command follows at once)."""
        self._check_usable()
        self._throttle = self._steering = self._speed = 0.0
        self._raw = False
        self._sender.set(self._message())
        self.flush()

    def flush(self, timeout_s: float = STOP_FLUSH_TIMEOUT_S) -> bool:
        """Wait until the latest command has been written to the link (False if it was not)."""
        return self._sender.flush(timeout("timeout_s", timeout_s))

    def send_pulses(self, throttle_us: int, steering_us: int) -> None:
        """Send raw pulse widths [us], bypassing the calibration (for calibration tools)."""
        message = encode(throttle_us, steering_us)  # ControlError (a ValueError) when out of range
        self._check_usable()
        self._raw = True  # the car's READY must not put the Vehicle's own command back over these
        self._sender.set(message)

    def pulses_us(self) -> tuple[int, int]:
        """(throttle, steering) [us] currently being sent."""
        return (self.calibration.throttle.to_us(self._throttle), self.calibration.steering.to_us(self._steering))

    def _message(self) -> bytes:
        if self.protocol_version == spec.META_SPEED_VERSION:
            return encode_setpoint(round(self._speed * 1000), self.calibration.steering.to_us(self._steering))
        return encode(*self.pulses_us())

    # --- link --------------------------------------------------------------------------------

    @property
    def connected(self) -> bool:
        """The link is up and commands are being sent."""
        return self._sender.connected and not self._closed and not self._sender.main_ended

    @property
    def messages_sent(self) -> int:
        """Control messages written to the link so far (each re-send counts)."""
        return self._sender.sent

    @property
    def link_error(self) -> TransportError | None:
        """Why the link is down, while it is (None when connected)."""
        return self._sender.error

    def _check_usable(self) -> None:
        if self._closed:
            raise TransportError(f"{self.url}: vehicle is closed")
        if self._sender.main_ended:
            raise TransportError(f"{self.url}: the program's main thread has ended, so the vehicle stopped sending "
                                 f"and the car's failsafe stops it; keep the main thread running while you drive")
        if not self._sender.reconnect and self._sender.error is not None:
            raise self._sender.error

    def _on_lines(self, lines: list[str]) -> None:
        now = time.monotonic()
        for line in lines:
            self.replies.append(line)
            telemetry = parse_telemetry(line)
            if telemetry is not None:
                self._telemetry = telemetry
                self._learn_version(spec.META_SPEED_VERSION)  # only a speed-controlled car sends these
            elif line.startswith(spec.TELEMETRY_REPLY + " "):
                self.rejected_telemetry += 1
            event = parse_event(line, now)
            if event is None:
                continue
            if event.kind is EventKind.READY and event.detail and event.detail.isdigit():
                self._learn_version(int(event.detail))
            if event.kind is EventKind.ERROR and event.detail == spec.SERIAL_ERROR_UNSUPPORTED \
                    and self.protocol_version in (None, spec.META_SPEED_VERSION):
                # Our first (THROTTLE,STEERING) reached a car that drives by speed before we
                # knew (a user's throttle is refused here once we know): that is how it says so.
                log.debug("the car drives by speed: %s", line)
                self._learn_version(spec.META_SPEED_VERSION)
            elif event.kind is EventKind.ERROR:
                self.errors += 1
                reason = event.detail.split()[0] if event.detail else ""
                self.refusals[reason] += 1
                if self.refusals[reason] == 1:  # once a reason: a refused message is refused again 50 times a second
                    log.warning("the car rejected a message: %s (more for the same reason are counted in "
                                "Vehicle.refusals, not shown)", line)
            elif event.kind is EventKind.FAILSAFE:
                rearm = "zero speed (stop())" if self.protocol_version == spec.META_SPEED_VERSION else "neutral"
                log.warning("the car's failsafe tripped (no valid command in time); send %s to re-arm", rearm)
            with self._events_cond:
                self.events.append(event)
                self._events_cond.notify_all()

    def _learn_version(self, version: int) -> None:
        """The car said which messages it takes: from now on send those (neutral becomes zero speed)."""
        if version == self.protocol_version:
            return
        with self._events_cond:
            self.protocol_version = version
            self._events_cond.notify_all()
        if not self._closed and not self._raw:
            self._sender.set(self._message())

    # --- what the car tells ---------------------------------------------------------------------

    def wait_for(self, *kinds: EventKind, timeout_s: float = 2.0, since: float | None = None) -> CarEvent | None:
        """The first event of these kinds (any kind when none given) received at or after `since`
        (time.monotonic(); default: now), waiting up to timeout_s; None if none came. Links
        without replies (ble://, loop://) never deliver events."""
        timeout_s = timeout("timeout_s", timeout_s)
        since = time.monotonic() if since is None else number("since", since, -1e12, 1e12, "s")

        def found() -> CarEvent | None:
            return next((e for e in self.events if e.at_s >= since and (not kinds or e.kind in kinds)), None)

        with self._events_cond:
            self._events_cond.wait_for(found, timeout_s)
            return found()

    def wait_armed(self, timeout_s: float = 2.0) -> bool:
        """True once the car is armed (at once if it already is), False after timeout_s. The car
        boots latched; the vehicle's first command is neutral, which arms it."""
        timeout_s = timeout("timeout_s", timeout_s)
        with self._events_cond:
            return self._events_cond.wait_for(lambda: self.latched is False, timeout_s)

    @property
    def latched(self) -> bool | None:
        """Whether the car's failsafe is latched, from its latest event (None before any)."""
        for event in reversed(self.events):
            if event.kind in (EventKind.READY, EventKind.FAILSAFE):
                return True
            if event.kind is EventKind.ARMED:
                return False
        return None

    def state(self) -> VehicleState:
        """The car's state as the link reports it now, completed by the car's latest telemetry
        line (battery, distance, mode, ...); fields nobody provides are None."""
        state = self.transport.state() or UNKNOWN
        known = {k: v for k, v in self._telemetry.items()
                 if k in VehicleState.__dataclass_fields__ and getattr(state, k) is None}
        return dataclasses.replace(state, **known) if known else state

    @property
    def pid_gains_pm(self) -> tuple[int, int, int, int] | None:
        """(kp, ki, kd, ff) per mille as the car's latest telemetry line reports them, or None."""
        return self._telemetry.get("pid_gains_pm")

    def lidar(self) -> Any:
        """A 2D scan, distances [m] from right to left over 270 degrees (numpy array), or None."""
        return self.transport.lidar()

    def camera(self, width: int = 160, height: int = 120) -> Any:
        """(RGB uint8 HxWx3, metric depth float32 HxW or None where the camera gives none), or
        None where the car has no camera on this link."""
        return self.transport.camera(width, height)

    def camera_stream(self) -> Any:
        """An iterator of RGB frames (a Junior's MJPEG stream), or None where there is none."""
        return self.transport.camera_stream()

    def _new_recorder(self, record):
        from roar.recorder import Recorder

        return record if isinstance(record, Recorder) else Recorder(
            record, {"car": self.url, "command": " ".join(sys.argv)},
            simulated=self.transport.scheme == "sim")

    def record(self, target=None):
        """Start recording the run from now into `target` (an MCAP path or a roar.recorder.Recorder),
        finishing any recording under way; None: stop recording (the file is finished). Returns
        the recorder (None when stopped)."""
        self._check_usable()
        recorder = None if target is None else self._new_recorder(target)
        previous, self.recorder = self.recorder, recorder
        self.transport.recorder = self._wire.recorder = recorder  # the next write and line are recorded
        if previous is not None:
            if self.protocol_version is not None:
                previous.note("car", {"protocol_version": str(self.protocol_version)})
            previous.close()
        return recorder

    def close(self) -> None:
        """Send neutral and release the link. Safe to call twice."""
        if self._closed:
            return
        self._closed = True
        self._throttle = self._steering = self._speed = 0.0
        self._sender.stop(final=self._message())
        if self.recorder is not None and self.protocol_version is not None:
            self.recorder.note("car", {"protocol_version": str(self.protocol_version)})
        self.transport.close()

    def __enter__(self) -> Vehicle:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"Vehicle({self.url!r}, throttle={self._throttle:+.2f}, steering={self._steering:+.2f})"


def _check_rate(rate_hz) -> float:
    """The failsafe needs a command every 250 ms: at least 5 Hz; a link takes at most 500 Hz."""
    return number("rate_hz", rate_hz, 5, 500, "Hz")


def _check_speed(speed) -> float:
    return number("speed", speed, -MAX_SPEED_M_S, MAX_SPEED_M_S, "m/s")


def _close_at_exit(ref: weakref.ref) -> None:
    vehicle = ref()
    if vehicle is not None:
        vehicle.close()
