"""Signed control (protocol/spec.toml [signed]), the twin of the core's roar/signing.h: the MAC
of a message, signing a message a host sends, and the car's verdict on one it receives.

    key = bytes.fromhex("000102030405060708090a0b0c0d0e0f")
    sign(b"(1600,1400)", key, session=7, counter=1)   b'(1600,1400,1,xxxxxxxxxxxx)'
    auth = Authenticator(); auth.set_key(key, 7)
    auth.check(control.OK, parser)                    OK, or UNSIGNED, FORGED, REPLAY, NOKEY

A board's side (the core's KeyRecord, KeyLine and KeyStore): the key and the last session in
its non-volatile memory (MemoryNvm, FileNvm), key lines read from its serial console only.

    keys = KeyStore(); keys.boot(FileNvm("/roar_key.bin"))   a new session, stored before use
    line = KeyLine(); ev = line.feed(byte)                     KEY_NOT_MINE: to the control parser
    keys.on_key_line(ev, line.key)                             ["KEY 1a2b3c4d", "SESSION 00000003"]

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


# --- a board's key: the core's KeyRecord, KeyLine and KeyStore ----------------------------------

# The record the key lives in, as the core lays it out in a board's non-volatile memory: magic
# "RK", flags (bit 0: a key is set), the key, the last session drawn (uint32 LE), and a check
# (the low 16 bits of SipHash-2-4 under a zero key over the bytes before it).
RECORD_MAGIC = b"RK"
RECORD_BYTES = 2 + 1 + KEY_BYTES + 4 + 2  # [bytes]
_FLAG_KEYED = 1
_ZERO_KEY = bytes(KEY_BYTES)


def _check(body):
    return _le(siphash.mac(_ZERO_KEY, body) & 0xFFFF, 2)


def record(key, session):
    """The stored bytes of a key (None: no key) and the last session drawn."""
    body = RECORD_MAGIC + bytes((_FLAG_KEYED if key else 0,)) + (bytes(key) if key else _ZERO_KEY) + _le(session, 4)
    return body + _check(body)


def load_record(data):
    """(key or None, last session) from stored bytes; (None, 0) when blank or damaged."""
    data = bytes(data or b"")[:RECORD_BYTES]
    if len(data) != RECORD_BYTES or data[:2] != RECORD_MAGIC or data[-2:] != _check(data[:-2]):
        return None, 0
    at = 3 + KEY_BYTES
    session = data[at] | data[at + 1] << 8 | data[at + 2] << 16 | data[at + 3] << 24
    return (data[3:at] if data[2] & _FLAG_KEYED else None), session


class MemoryNvm:
    """Non-volatile memory that lasts as long as the object (tests, simulators)."""

    def __init__(self, data=b""):
        self.data = bytes(data)
        self.writes = 0

    def read(self):
        return self.data

    def write(self, data):
        self.data = bytes(data)
        self.writes += 1


class FileNvm:
    """The record in a file of the board's filesystem, replaced whole (written beside it, then
    renamed over it): a reset while writing leaves the old record or the new one, never half."""

    def __init__(self, path):
        self.path = path

    def read(self):
        try:
            with open(self.path, "rb") as f:
                return f.read(RECORD_BYTES)
        except OSError:
            return b""  # none yet: blank

    def write(self, data):
        import os

        tmp = self.path + ".new"
        with open(tmp, "wb") as f:
            f.write(data)
        try:
            os.rename(tmp, self.path)
        except OSError:  # a filesystem that will not rename over a file
            os.remove(self.path)
            os.rename(tmp, self.path)


def _next_session(session):
    session = (session + 1) & 0xFFFFFFFF
    return session or 1  # after 2^32 draws; 0 means "no key" on the wire


def start_session(nvm, auth):
    """Boot: the key in nvm (if any) with a fresh session, stored before it is used."""
    if nvm is None:
        return
    key, session = load_record(nvm.read())
    if key is None:
        auth.set_key(None, 0)
        return
    session = _next_session(session)
    nvm.write(record(key, session))
    auth.set_key(key, session)


# What KeyLine.feed says became of a byte (the core's KeyLine::Event)
KEY_NOT_MINE = 0  # not a key line: the byte goes to the control parser
KEY_TAKEN = 1  # part of a key line
KEY_SET = 2  # "KEY <32 hex>" ended: .key holds the new key
KEY_CLEAR = 3  # "KEY -" ended
KEY_ASK = 4  # "KEY ?" ended
KEY_BAD = 5  # a line that began "K" but is not a key command: answered ERR syntax, and the byte
#              goes to the control parser too, so stray bytes never hold control back
_LINE_START, _OTHER, _WORD, _DIGITS, _CLEARING, _ASKING = range(6)
_KEY_WORD = (spec.SIGNED_KEY_COMMAND + " ").encode()
_MESSAGE_ENDS = (ord(spec.CONTROL_END_CHAR), ord(spec.SETPOINT_END_CHAR))


def _digit(byte):
    """A hex digit's value (a key line also takes uppercase), else -1."""
    return "0123456789abcdef".find(chr(byte).lower()) if byte < 128 else -1


class KeyLine:
    """"KEY <32 hex>" / "KEY -" / "KEY ?" on the serial link, at the start of a line or right
    after a message, read as it arrives."""

    def __init__(self):
        self.state = _LINE_START
        self.at = 0  # characters of "KEY " matched, then hex digits taken
        self.key = bytearray(KEY_BYTES)

    def feed(self, byte):
        end = byte == 10 or byte == 13
        state = self.state
        if state == _OTHER:
            if end or byte in _MESSAGE_ENDS:
                self.state = _LINE_START
            return KEY_NOT_MINE
        if state == _LINE_START:
            if byte == _KEY_WORD[0]:
                self.state, self.at = _WORD, 1
                return KEY_TAKEN
            if not end and byte not in _MESSAGE_ENDS:
                self.state = _OTHER
            return KEY_NOT_MINE
        if state == _WORD:
            if byte == _KEY_WORD[self.at]:
                self.at += 1
                if self.at == len(_KEY_WORD):
                    self.state, self.at = _DIGITS, 0
                return KEY_TAKEN
        elif state == _DIGITS:
            if self.at == 0 and byte in (45, 63):  # "-", "?"
                self.state = _CLEARING if byte == 45 else _ASKING
                return KEY_TAKEN
            value = _digit(byte)
            if value >= 0 and self.at < 2 * KEY_BYTES:
                i = self.at // 2
                self.key[i] = value << 4 if self.at % 2 == 0 else self.key[i] | value
                self.at += 1
                return KEY_TAKEN
            if end and self.at == 2 * KEY_BYTES:
                self.state = _LINE_START
                return KEY_SET
        elif end:  # _CLEARING, _ASKING
            self.state = _LINE_START
            return KEY_CLEAR if state == _CLEARING else KEY_ASK
        self.state = _LINE_START if end else _OTHER
        return KEY_BAD


def key_reply(auth):
    """ "KEY <fingerprint>" or "KEY none" (no line end)."""
    return "%s %s" % (spec.SIGNED_KEY_COMMAND, fingerprint(auth.key) if auth.key else spec.SIGNED_KEY_NONE)


def session_reply(auth):
    """ "SESSION <8 hex>" (no line end)."""
    return "%s %08x" % (spec.SIGNED_REPLY_SESSION, auth.session)


class KeyStore:
    """A board's key: kept in its non-volatile memory (an object with read() and write(bytes);
    None: the board has none and refuses a key), changed only by key lines from its serial link."""

    def __init__(self):
        self.nvm = None
        self.auth = Authenticator()

    def boot(self, nvm):
        self.nvm = nvm
        start_session(nvm, self.auth)

    def on_key_line(self, event, key):
        """The reply lines (without line ends) to what KeyLine.feed returned; [] for none."""
        if event == KEY_SET or event == KEY_CLEAR:
            if self.nvm is None:  # nowhere to keep a key: refuse rather than forget it
                return ["%s %s" % (spec.SERIAL_REPLY_ERROR, control.token(NOKEY))]
            key = bytes(key) if event == KEY_SET else None
            session = _next_session(load_record(self.nvm.read())[1])  # a new key starts a new session
            self.nvm.write(record(key, session))
            if load_record(self.nvm.read()) != (key, session):  # read back: full or failing storage refuses
                return ["%s %s" % (spec.SERIAL_REPLY_ERROR, control.token(NOKEY))]
            self.auth.set_key(key, session)
            return [key_reply(self.auth), session_reply(self.auth)] if key else [key_reply(self.auth)]
        if event == KEY_ASK:
            return [key_reply(self.auth)]
        if event == KEY_BAD:
            return ["%s %s" % (spec.SERIAL_REPLY_ERROR, control.token(control.SYNTAX))]
        return []
