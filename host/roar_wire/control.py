"""The control message "(THROTTLE,STEERING)": encoder, and the streaming parser with the same
states and results as the firmware's C++ parser (protocol/PROTOCOL.md section 1.1); both run
the golden vectors in protocol/vectors/.

    encode(1600, 1400)                 b'(1600,1400)'
    p = Parser()
    for byte in data:
        r = p.feed(byte)               # a spec.PARSE_RESULT_* code
        if r == OK: p.throttle_us, p.steering_us

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

# Parser states
IDLE = 0  # between messages
GARBAGE_RUN = 1  # inside bytes that are not a message
THROTTLE = 2  # inside the first field
STEERING = 3  # inside the second field
SKIP = 4  # after an error inside a message, until its end

_START = ord(spec.CONTROL_START_CHAR)
_SEPARATOR = ord(spec.CONTROL_SEPARATOR_CHAR)
_END = ord(spec.CONTROL_END_CHAR)
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


class Parser:
    """Feed bytes one at a time; after OK, throttle_us and steering_us hold the message."""

    def __init__(self):
        self.state = IDLE
        self.digits = 0  # digits in the current field
        self.value = 0  # the current field so far
        self.throttle_us = spec.CONTROL_NEUTRAL_US  # the last valid message
        self.steering_us = spec.CONTROL_NEUTRAL_US
        self._throttle = 0  # the first field of the message being read

    def feed(self, byte):
        state = self.state
        if state >= THROTTLE and state != SKIP:
            if _ZERO <= byte <= _NINE:
                if self.digits == spec.CONTROL_MAX_DIGITS:
                    self.state = SKIP
                    return TOO_LONG
                self.digits += 1
                self.value = self.value * 10 + byte - _ZERO
                return NONE
            return self._field_end(byte, state)
        if byte == _START:
            self._start()
            return GARBAGE if state == GARBAGE_RUN else NONE
        if state == IDLE:
            if byte not in _BETWEEN:
                self.state = GARBAGE_RUN
        elif state == GARBAGE_RUN:
            if byte in _BETWEEN:
                self.state = IDLE
                return GARBAGE
        elif byte == _END or byte == _CR or byte == _LF:  # SKIP
            self.state = IDLE
        return NONE

    def _start(self):
        self.state = THROTTLE
        self.digits = 0
        self.value = 0

    def _field_end(self, byte, state):
        if byte == _SEPARATOR and state == THROTTLE and self.digits:
            self._throttle = self.value
            self.state = STEERING
            self.digits = 0
            self.value = 0
            return NONE
        if byte == _END:
            self.state = IDLE
            if state == THROTTLE or not self.digits:
                return SYNTAX
            lo, hi = spec.CONTROL_MIN_US, spec.CONTROL_MAX_US
            if not (lo <= self._throttle <= hi and lo <= self.value <= hi):
                return RANGE
            self.throttle_us, self.steering_us = self._throttle, self.value
            return OK
        if byte == _START:
            self._start()
            return UNTERMINATED
        if byte == _CR or byte == _LF:
            self.state = IDLE
            return UNTERMINATED
        self.state = SKIP
        return SYNTAX


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
