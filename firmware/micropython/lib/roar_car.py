"""The ESC car's logic on MicroPython: the twin of the C++ core's Car (firmware/core: control
parser, command watchdog, brake/reverse sequence, output mapping, reply lines), decision for
decision; a differential test in the suite runs both on the same bytes, clock and frames and
compares every pulse and every reply.

    car = Car()
    car.boot(nvm)                           # queues "READY 1" (and "SESSION ..." with a key)
    car.feed(byte, now_ms, serial=True)     # each received byte (serial=False: a BLE write)
    throttle_us, steering_us = car.step(now_ms, frames_started)
    line = car.take_reply()                 # "ERR syntax\\n", ... or None

Times are whole milliseconds from roar_clock.Clock.
"""

from roar_clock import BRAKE_STEP_MS, FAILSAFE_MS
from roar_wire import control, signing, spec

NEUTRAL = spec.CONTROL_NEUTRAL_US
REPLY_QUEUE = 8  # pending reply lines; more are dropped (the host is not reading)

# Watchdog events, as the C++ WatchdogEvent
TRIPPED, ARMED = 1, 2

# Brake phases, as the C++ BrakePhase
NEEDS_SEQUENCE, NEUTRAL1, TAP, NEUTRAL2, REVERSE_READY = 0, 1, 2, 3, 4


class Channel:
    """One output's calibration: trim, end-points, then the protocol's hard clamp."""

    def __init__(self, trim_us=0, min_us=spec.CONTROL_MIN_US, max_us=spec.CONTROL_MAX_US):
        half = (spec.CONTROL_MAX_US - spec.CONTROL_MIN_US) // 2
        if not (min_us <= max_us and -half < trim_us < half):
            raise ValueError("calibration: need min_us <= max_us and |trim_us| < %d" % half)
        self.trim_us, self.min_us, self.max_us = trim_us, min_us, max_us

    def pulse(self, command_us):
        v = min(max(command_us + self.trim_us, self.min_us), self.max_us)
        return min(max(v, spec.CONTROL_MIN_US), spec.CONTROL_MAX_US)


class CommandWatchdog:
    """No valid command for longer than the timeout: latched at neutral until a neutral command
    re-arms it. Boots latched."""

    def __init__(self, timeout_ms=FAILSAFE_MS):
        self.timeout_ms = timeout_ms
        self.latched = True
        self._last_ms = 0

    def poll(self, now_ms):
        """TRIPPED once, when the silence has just exceeded the timeout (it latches); else None."""
        if not self.latched and now_ms - self._last_ms > self.timeout_ms:
            self.latched = True
            return TRIPPED
        return None

    def accept(self, throttle_us, now_ms):
        """(may drive, event) for a valid command: the event is ARMED when it released the
        latch, else TRIPPED when a silence that just ended tripped the watchdog, else None."""
        event = self.poll(now_ms)
        drive = True
        if self.latched:
            drive = abs(throttle_us - NEUTRAL) <= spec.TIMING_ARM_WINDOW_US
            if drive:
                self.latched = False
                event = ARMED
        if drive:
            self._last_ms = now_ms
        return drive, event


class BrakeFsm:
    """After forward, a reverse command goes neutral -> slight reverse (the tap an ESC takes as
    brake) -> neutral -> reverse, each step at least BRAKE_STEP_MS and one output frame."""

    def __init__(self, step_ms=BRAKE_STEP_MS, tap_us=spec.TIMING_BRAKE_TAP_US):
        self.step_ms, self.tap_us = step_ms, tap_us
        self.phase = NEEDS_SEQUENCE
        self._start = 0
        self._frame_mark = None

    def _enter(self, phase, now_ms):
        self.phase = phase
        self._start = now_ms
        self._frame_mark = None  # marked on the next call, after this phase's value is out

    def _step_done(self, now_ms, frames):
        if self._frame_mark is None:
            self._frame_mark = frames
            return False
        return now_ms - self._start >= self.step_ms and frames != self._frame_mark

    def step(self, command_us, now_ms, frames):
        if command_us > NEUTRAL:  # forward: always allowed, and the ESC leaves reverse mode
            self.phase = NEEDS_SEQUENCE
            return command_us
        if command_us == NEUTRAL:  # keeps reverse mode, but cancels a half-done sequence
            if self.phase != REVERSE_READY:
                self.phase = NEEDS_SEQUENCE
            return NEUTRAL
        phase = self.phase
        if phase == REVERSE_READY:
            return command_us
        if phase == NEEDS_SEQUENCE:
            self._enter(NEUTRAL1, now_ms)
            return NEUTRAL
        if phase == NEUTRAL1:
            if not self._step_done(now_ms, frames):
                return NEUTRAL
            self._enter(TAP, now_ms)
            return self.tap_us
        if phase == TAP:
            if not self._step_done(now_ms, frames):
                return self.tap_us
            self._enter(NEUTRAL2, now_ms)
            return NEUTRAL
        if not self._step_done(now_ms, frames):  # NEUTRAL2
            return NEUTRAL
        self.phase = REVERSE_READY
        return command_us


class Car:
    """bytes -> parser -> command watchdog -> brake sequence -> calibration -> pulses."""

    def __init__(self, throttle=None, steering=None):
        self.throttle = throttle or Channel()
        self.steering = steering or Channel()
        self.parser = control.Parser()
        self.keys = signing.KeyStore()  # the key: set from the serial console only
        self.key_line = signing.KeyLine()
        self.watchdog = CommandWatchdog()
        self.brake = BrakeFsm()
        self.command = (NEUTRAL, NEUTRAL)
        self.replies = []
        self.dropped = 0
        self._latch_told = False  # FAILSAFE already said for this latched period

    def _queue(self, line):
        if len(self.replies) == REPLY_QUEUE:
            self.dropped += 1
        else:
            self.replies.append(line)

    def _watchdog_event(self, event):
        if event == TRIPPED and not self._latch_told:
            self._queue(spec.SERIAL_REPLY_FAILSAFE)
            self._latch_told = True
        elif event == ARMED:
            self._queue(spec.SERIAL_REPLY_ARMED)
            self._latch_told = False

    @property
    def auth(self):
        return self.keys.auth

    def boot(self, nvm=None):
        """Queue the boot banner. nvm: where the key and the session live (signing.FileNvm;
        None: nowhere, so this car can never have a key)."""
        self.keys.boot(nvm)
        self._queue("%s %d" % (spec.SERIAL_REPLY_READY, spec.META_PROTOCOL_VERSION))
        if self.auth.key:
            self._queue(signing.session_reply(self.auth))

    def feed(self, byte, now_ms, serial=False):
        """One received byte; serial: it came over the serial console, the only link whose
        key lines are read (a BLE write's are not)."""
        if serial:
            event = self.key_line.feed(byte)
            if event != signing.KEY_NOT_MINE:
                for line in self.keys.on_key_line(event, self.key_line.key):
                    self._queue(line)
                if event != signing.KEY_BAD:
                    return
        result = self.parser.feed(byte)
        if result == control.NONE:
            return
        if result == control.OK or result == control.SETPOINT:
            verdict = self.auth.check(result, self.parser)
            if verdict != result:  # refused: nothing changes, the failsafe is not fed
                self._queue("%s %s" % (spec.SERIAL_REPLY_ERROR, signing.refusal(verdict, self.auth)))
                return
        if result == control.SETPOINT:  # a valid message, but this car drives by throttle, not speed
            self._queue("%s %s" % (spec.SERIAL_REPLY_ERROR, spec.SERIAL_ERROR_UNSUPPORTED))
            return
        if result != control.OK:
            self._queue("%s %s" % (spec.SERIAL_REPLY_ERROR, control.token(result)))
            return
        p = self.parser
        drive, event = self.watchdog.accept(p.throttle_us, now_ms)
        if drive:
            self.command = (p.throttle_us, p.steering_us)
        elif not self._latch_told:  # ignored while latched: say why, once
            self._queue(spec.SERIAL_REPLY_FAILSAFE)
            self._latch_told = True
        self._watchdog_event(event)

    def step(self, now_ms, frames):
        """(throttle_us, steering_us) to output now; frames: output frames started so far."""
        self._watchdog_event(self.watchdog.poll(now_ms))
        throttle, steering = (NEUTRAL, NEUTRAL) if self.watchdog.latched else self.command
        throttle = self.brake.step(throttle, now_ms, frames)
        return self.throttle.pulse(throttle), self.steering.pulse(steering)

    def take_reply(self):
        """The next reply line with its line end, or None."""
        if not self.replies:
            return None
        return self.replies.pop(0) + spec.SERIAL_REPLY_LINE_END
