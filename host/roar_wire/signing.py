"""Signed control (protocol/spec.toml [signed]), the twin of the core's roar/signing.h: the MAC
of a message, signing a message a host sends, and the car's verdict on one it receives.

    key = bytes.fromhex("000102030405060708090a0b0c0d0e0f")
    sign(b"(1600,1400)", key, session=7, counter=1)   b'(1600,1400,1,xxxxxxxxxxxx)'
    auth = Authenticator(); auth.set_key(key, 7)
    auth.check(control.OK, parser)                    OK, or UNSIGNED, FORGED, REPLAY, NOKEY

Runs unchanged on CPython and MicroPython.
"""

from roar_wire import control, siphash, spec

UNSIGNED = spec.PARSE_RESULT_UNSIGNED
FORGED = spec.PARSE_RESULT_FORGED
REPLAY = spec.PARSE_RESULT_REPLAY
NOKEY = spec.PARSE_RESULT_NOKEY

KEY_BYTES = spec.SIGNED_KEY_BYTES
MAC_MASK = (1 << spec.SIGNED_MAC_BITS) - 1
COUNTER_MAX = (1 << (4 * spec.SIGNED_COUNTER_DIGITS)) - 1
_START = ord(spec.CONTROL_START_CHAR)
_SET_START = ord(spec.SETPOINT_START_CHAR)


def _le(value, n):
    return bytes((value >> (8 * i)) & 0xFF for i in range(n))


def message_mac(key, session, start, first, steering, counter):
    """The MAC a signed message carries: start is '(' or '[' (a byte value), first the throttle
    [us] or the speed [mm/s]."""
    data = _le(session, 4) + bytes((start,)) + _le(first & 0xFFFF, 2) + _le(steering, 2) + _le(counter, 4)
    return siphash.mac(key, data) & MAC_MASK


def query_mac(key, session, text):
    """The MAC a signed HTTP query carries (the Junior): over the session and the query's text
    before "&mac=" (str or bytes)."""
    if isinstance(text, str):
        text = text.encode()
    return siphash.mac(key, _le(session, 4) + bytes(text)) & MAC_MASK


def sign_query(query, key, session, counter):
    """query (without '?') with its counter and MAC appended: "...&ctr=HEX&mac=HEX12"."""
    if not 1 <= counter <= COUNTER_MAX:
        raise ValueError("counter %d is outside 1..%d" % (counter, COUNTER_MAX))
    signed = (query + "&" if query else "") + "ctr=%x" % counter
    return signed + "&mac=%012x" % query_mac(key, session, signed)


def sign_datagram(text, key, session, counter):
    """A phone's control datagram ("throttle,steering") with its counter and MAC appended:
    "throttle,steering,HEX,HEX12", the MAC over the session and the text before the last ','."""
    if not 1 <= counter <= COUNTER_MAX:
        raise ValueError("counter %d is outside 1..%d" % (counter, COUNTER_MAX))
    signed = bytes(text) + (",%x" % counter).encode()
    return signed + (",%012x" % query_mac(key, session, signed)).encode()


_HEX = "0123456789abcdef"


def _hex(text, max_digits):
    """The value of 1..max_digits lowercase hex digits, else None."""
    if not 0 < len(text) <= max_digits or any(c not in _HEX for c in text):
        return None
    return int(text, 16)


def fingerprint(key):
    """The key's name (what a car answers to KEY ?): 8 hex digits that do not reveal it."""
    return "%08x" % (siphash.mac(key, b"ROAR") & 0xFFFFFFFF)


def check_key(key):
    """key as 16 bytes, from bytes or 32 hex digits; ValueError (one line) otherwise."""
    if isinstance(key, str):
        text = key.strip()
        try:
            key = bytes.fromhex(text)
        except ValueError:
            raise ValueError("a key is %d hex digits, got %r" % (2 * KEY_BYTES, text[:40]))
    if not isinstance(key, (bytes, bytearray)) or len(key) != KEY_BYTES:
        raise ValueError("a key is %d bytes (%d hex digits)" % (KEY_BYTES, 2 * KEY_BYTES))
    return bytes(key)


def sign(message, key, session, counter):
    """The signed form of one unsigned control or setpoint message (bytes, no line end)."""
    if not 1 <= counter <= COUNTER_MAX:
        raise ValueError("counter %d is outside 1..%d" % (counter, COUNTER_MAX))
    message = bytes(message).strip()
    parser = control.Parser()
    results = [parser.feed(b) for b in message]
    kind = results[-1] if results else control.NONE
    if kind not in (control.OK, control.SETPOINT) or any(r != control.NONE for r in results[:-1]) \
            or parser.signature is not None:
        raise ValueError("not one unsigned control or setpoint message: %r" % (message[:40],))
    if kind == control.OK:
        first, steering, start = parser.throttle_us, parser.steering_us, _START
    else:
        first, steering, start = parser.speed_mm_s, parser.setpoint_steering_us, _SET_START
    mac = message_mac(key, session, start, first, steering, counter)
    return message[:-1] + (",%x,%012x" % (counter, mac)).encode() + message[-1:]


def refusal(verdict, auth):
    """The words of a refusal after "ERR " (a parse_result code): the reason's token and, for
    unsigned / forged / replay, the session or the last counter in hex ("forged 0000002a")."""
    words = control.token(verdict)
    if verdict == UNSIGNED or verdict == FORGED:
        return words + " %08x" % auth.session
    if verdict == REPLAY:
        return words + " %x" % auth.last_counter
    return words


class Authenticator:
    """The car's verdict on each message its parser finished (the core's Authenticator)."""

    def __init__(self):
        self.key = None
        self.session = 0
        self.last_counter = 0

    def set_key(self, key, session):
        """Use this key (None: none) from a new session on; the counter starts again."""
        self.key = None if key is None else bytes(key)
        self.session = 0 if key is None else session
        self.last_counter = 0

    def check(self, kind, parser):
        """kind (control.OK or control.SETPOINT) when the message may act, else UNSIGNED,
        FORGED, REPLAY or NOKEY."""
        signature = parser.signature
        if self.key is None:
            return NOKEY if signature is not None else kind
        if signature is None:
            return UNSIGNED
        counter, mac = signature
        if kind == control.SETPOINT:
            first, steering, start = parser.speed_mm_s, parser.setpoint_steering_us, _SET_START
        else:
            first, steering, start = parser.throttle_us, parser.steering_us, _START
        return self._accept(kind, counter, mac, message_mac(self.key, self.session, start, first, steering, counter))

    def check_query(self, query):
        """(verdict, the part to apply) for an HTTP query (the Junior's): control.OK and the
        parameters before "&ctr=" when it may act; else UNSIGNED, FORGED, REPLAY, NOKEY or
        control.SYNTAX (a malformed ctr or mac), and the query."""
        mac_at = query.rfind("&") + 1
        if not query.startswith("mac=", mac_at):
            return (UNSIGNED if self.key is not None else control.OK), query
        if self.key is None:
            return NOKEY, query
        if mac_at == 0:
            return control.SYNTAX, query
        signed = query[:mac_at - 1]
        ctr_at = signed.rfind("&") + 1
        counter = _hex(signed[ctr_at + 4:], spec.SIGNED_COUNTER_DIGITS) if signed.startswith("ctr=", ctr_at) else None
        mac_text = query[mac_at + 4:]
        mac = _hex(mac_text, spec.SIGNED_MAC_DIGITS) if len(mac_text) == spec.SIGNED_MAC_DIGITS else None
        if counter is None or mac is None:
            return control.SYNTAX, query
        verdict = self._accept(control.OK, counter, mac, query_mac(self.key, self.session, signed))
        return verdict, query[:ctr_at - 1] if ctr_at else ""

    def check_datagram(self, data):
        """(verdict, the unsigned "throttle,steering" bytes) for a phone's control datagram:
        control.OK when it may act; else UNSIGNED, FORGED, REPLAY, NOKEY, or control.SYNTAX."""
        data = bytes(data).strip()
        fields = data.split(b",")
        if len(fields) != 4:
            return (UNSIGNED if self.key is not None else control.OK), data
        if self.key is None:
            return NOKEY, data
        try:
            counter = _hex(fields[2].decode(), spec.SIGNED_COUNTER_DIGITS)
            mac = _hex(fields[3].decode(), spec.SIGNED_MAC_DIGITS) if len(fields[3]) == spec.SIGNED_MAC_DIGITS else None
        except UnicodeError:
            counter = mac = None
        if counter is None or mac is None:
            return control.SYNTAX, data
        signed = data[:data.rfind(b",")]
        verdict = self._accept(control.OK, counter, mac, query_mac(self.key, self.session, signed))
        return verdict, b",".join(fields[:2])

    def _accept(self, kind, counter, mac, expected):
        if mac != expected:  # the MAC first: a forgery learns nothing of the counter
            return FORGED
        if counter <= self.last_counter:
            return REPLAY
        self.last_counter = counter
        return kind
