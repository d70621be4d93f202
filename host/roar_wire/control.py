"""The control message "(THROTTLE,STEERING)" and the setpoint message "[SPEED,STEERING]":
encoders, and the streaming parser with the same states and results as the firmware's C++
parser (protocol/PROTOCOL.md section 1.1); both run the golden vectors in protocol/vectors/.

    encode(1600, 1400)                 b'(1600,1400)'
    encode_setpoint(-750, 1500)        b'[-750,1500]'
    p = Parser()
    for byte in data:
        r = p.feed(byte)               # a spec.PARSE_RESULT_* code
        if r == OK: p.throttle_us, p.steering_us
        if r == SETPOINT: p.speed_mm_s, p.setpoint_steering_us
        p.signature                    # (counter, mac) a signed message carried, else None

Signed messages "(T,S,COUNTER,MAC)" parse to OK / SETPOINT too; whether the MAC is right is
roar_wire.signing's question.

Runs unchanged on CPython and MicroPython.
"""

from roar_wire import spec

NONE = spec.PARSE_RESULT_NONE
OK = spec.PARSE_RESULT_OK
SYNTAX = spec.PARSE_RESULT_SYNTAX
RANGE = spec.PARSE_RESULT_RANGE
TOO_LONG = spec.PARSE_RESULT_TOO_LONG
UNTERMINATED = spec.PARSE_RESULT_UNTERMINATED
GARBAGE = spec.PARSE_RESULT_GARBAGE
SETPOINT = spec.PARSE_RESULT_SETPOINT

# Parser states
IDLE = 0  # between messages
GARBAGE_RUN = 1  # inside bytes that are not a message
THROTTLE = 2  # inside the first field
STEERING = 3  # inside the second field
SKIP = 4  # after an error inside a message, until its end
SPEED = 5  # inside a setpoint's first field
SET_STEERING = 6  # inside a setpoint's second field
COUNTER = 7  # inside a signed message's COUNTER (hex)
MAC = 8  # inside a signed message's MAC (hex)

_START = ord(spec.CONTROL_START_CHAR)
_SEPARATOR = ord(spec.CONTROL_SEPARATOR_CHAR)
_END = ord(spec.CONTROL_END_CHAR)
_SET_START = ord(spec.SETPOINT_START_CHAR)
_SET_END = ord(spec.SETPOINT_END_CHAR)
_MINUS = 45
_CR, _LF = 13, 10
_ZERO, _NINE = 48, 57
_BETWEEN = b"\r\n \t\x00"  # bytes that separate messages without being garbage


def token(result):
    """The wire token of a result code: 'ok', 'syntax', ... (printed after "ERR ")."""
    return spec.PARSE_RESULT_TOKENS[result]


def check_pulse(name, value):
    """value, when it is a pulse width the protocol allows; ValueError (one line) otherwise."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise ValueError("%s must be an integer number of microseconds, got %r" % (name, value))
    if not spec.CONTROL_MIN_US <= value <= spec.CONTROL_MAX_US:
        raise ValueError("%s %d us is outside %d..%d us" % (name, value, spec.CONTROL_MIN_US, spec.CONTROL_MAX_US))
    return value


def encode(throttle_us, steering_us):
    """The wire bytes of one command; ValueError for values outside the protocol."""
    check_pulse("throttle_us", throttle_us)
    check_pulse("steering_us", steering_us)
    return b"(%d,%d)" % (throttle_us, steering_us)


def check_speed(speed_mm_s):
    """speed_mm_s, when a setpoint may ask it; ValueError (one line) otherwise."""
    if isinstance(speed_mm_s, bool) or not isinstance(speed_mm_s, int):
        raise ValueError("speed_mm_s must be an integer number of mm/s, got %r" % (speed_mm_s,))
    if not -spec.SETPOINT_MAX_SPEED_MM_S <= speed_mm_s <= spec.SETPOINT_MAX_SPEED_MM_S:
        raise ValueError("speed %d mm/s is beyond the protocol's %d mm/s" % (speed_mm_s, spec.SETPOINT_MAX_SPEED_MM_S))
    return speed_mm_s


def encode_setpoint(speed_mm_s, steering_us):
    """The wire bytes of one setpoint (for a board with a speed controller)."""
    check_speed(speed_mm_s)
    check_pulse("steering_us", steering_us)
    return b"[%d,%d]" % (speed_mm_s, steering_us)


class Parser:
    """Feed bytes one at a time; after OK, throttle_us and steering_us hold the control message,
    after SETPOINT, speed_mm_s and setpoint_steering_us the setpoint."""

    def __init__(self):
        self.state = IDLE
        self.digits = 0  # digits in the current field
        self.value = 0  # the current field so far
        self.throttle_us = spec.CONTROL_NEUTRAL_US  # the last valid control message
        self.steering_us = spec.CONTROL_NEUTRAL_US
        self.speed_mm_s = 0  # the last valid setpoint
        self.setpoint_steering_us = spec.CONTROL_NEUTRAL_US
        self._first = 0  # the first field of the message being read
        self._second = 0  # a signed message's steering
        self._negative = False  # a setpoint's speed with a leading '-'
        self._setpoint_kind = False  # in COUNTER or MAC: the message began with '['
        self._counter = 0
        self.signature = None  # (counter, mac) of the last valid message when it was signed

    def feed(self, byte):
        state = self.state
        if state >= COUNTER:
            return self._hex(byte, state)
        if state >= THROTTLE and state != SKIP:
            if _ZERO <= byte <= _NINE:
                if self.digits == spec.CONTROL_MAX_DIGITS:
                    self.state = SKIP
                    return TOO_LONG
                self.digits += 1
                self.value = self.value * 10 + byte - _ZERO
                return NONE
            return self._field_end(byte, state)
        if byte == _START or byte == _SET_START:
            self._start(byte)
            return GARBAGE if state == GARBAGE_RUN else NONE
        if state == IDLE:
            if byte not in _BETWEEN:
                self.state = GARBAGE_RUN
        elif state == GARBAGE_RUN:
            if byte in _BETWEEN:
                self.state = IDLE
                return GARBAGE
        elif byte == _END or byte == _SET_END or byte == _CR or byte == _LF:  # SKIP
            self.state = IDLE
        return NONE

    def _start(self, byte):
        self.state = THROTTLE if byte == _START else SPEED
        self.digits = 0
        self.value = 0
        self._negative = False

    def _field_end(self, byte, state):
        first = state == THROTTLE or state == SPEED
        setpoint = state == SPEED or state == SET_STEERING
        if byte == _MINUS and state == SPEED and not self.digits and not self._negative:
            self._negative = True
            return NONE
        if byte == _SEPARATOR and self.digits:
            if first:
                self._first = self.value
                self.state = SET_STEERING if setpoint else STEERING
            else:  # after the steering: a signed message's COUNTER follows
                self._setpoint_kind, self._second = setpoint, self.value
                self.state, self._counter = COUNTER, 0
            self.digits = 0
            self.value = 0
            return NONE
        if byte == _END or byte == _SET_END:
            self.state = IDLE
            if first or not self.digits or (byte == _SET_END) != setpoint:
                return SYNTAX
            return self._finish(setpoint, self.value, None)
        return self._cut(byte)

    def _cut(self, byte):
        """Any other byte inside a message: a new message or a line end cuts it short, anything
        else is a syntax error (the rest of the message is skipped)."""
        if byte == _START or byte == _SET_START:
            self._start(byte)
            return UNTERMINATED
        if byte == _CR or byte == _LF:
            self.state = IDLE
            return UNTERMINATED
        self.state = SKIP
        return SYNTAX

    def _hex(self, byte, state):
        nibble = byte - _ZERO if _ZERO <= byte <= _NINE else byte - 87 if 97 <= byte <= 102 else -1
        if nibble >= 0:
            if self.digits == (spec.SIGNED_COUNTER_DIGITS if state == COUNTER else spec.SIGNED_MAC_DIGITS):
                self.state = SKIP
                return TOO_LONG
            self.digits += 1
            self.value = (self.value << 4) | nibble
            return NONE
        if byte == _SEPARATOR and state == COUNTER and self.digits:
            self._counter = self.value
            self.state, self.digits, self.value = MAC, 0, 0
            return NONE
        if byte == _END or byte == _SET_END:
            self.state = IDLE
            if state == COUNTER or self.digits != spec.SIGNED_MAC_DIGITS or (byte == _SET_END) != self._setpoint_kind:
                return SYNTAX  # no MAC, a truncated one, or the other kind's end
            return self._finish(self._setpoint_kind, self._second, (self._counter, self.value))
        return self._cut(byte)

    def _finish(self, setpoint, second, signature):
        lo, hi = spec.CONTROL_MIN_US, spec.CONTROL_MAX_US
        if setpoint:
            if self._first > spec.SETPOINT_MAX_SPEED_MM_S or not lo <= second <= hi:
                return RANGE
            self.speed_mm_s = -self._first if self._negative else self._first
            self.setpoint_steering_us = second
        else:
            if not (lo <= self._first <= hi and lo <= second <= hi):
                return RANGE
            self.throttle_us, self.steering_us = self._first, second
        self.signature = signature
        return SETPOINT if setpoint else OK


def decode(message):
    """(throttle_us, steering_us) of exactly one complete message, no bytes around it; ValueError
    with the reason otherwise."""
    parser = Parser()
    last = len(message) - 1
    events, ok_at_end, error = 0, False, None
    for i in range(len(message)):
        result = parser.feed(message[i])
        if result == NONE:
            continue
        events += 1
        if result == OK:
            ok_at_end = i == last
        elif error is None:
            error = token(result)
    if events == 1 and ok_at_end:
        return parser.throttle_us, parser.steering_us
    reason = error or ("extra bytes" if events else "incomplete")
    raise ValueError("not a control message (%s): %r" % (reason, bytes(message[:32])))
