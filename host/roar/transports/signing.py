"""The signing layer (protocol/spec.toml [signed]): signs every control and setpoint message the
Vehicle writes with the user's key (roar.signing: the key file), and learns the car's session
from what the car says.

The session the car signs in (a new one at each boot) comes from the car: its SESSION line after
READY, the session in its ERR unsigned / ERR forged replies, or, on links without reply lines,
the link's own answer (Transport.car_session(): a BLE read; Transport.refusal(): the Junior's or the
phone's refusal). A car without a key answers signed messages with ERR nokey; the layer then
sends unsigned to that car.
"""

from __future__ import annotations

import logging
import threading
import time

from roar.protocol import ParseResult, spec
from roar.transports.base import Transport
from roar.transports.layer import TransportLayer
from roar_wire import signing as wire

log = logging.getLogger("roar")

PROBE_WAIT_S = 1.0  # [s] for the car's session after the first (unsigned) message


def _neutral_like(data: bytes) -> bytes:
    """Neutral in the kind of message data is: "(1500,1500)" or zero speed, centred."""
    n = spec.CONTROL_NEUTRAL_US
    return b"[0,%d]" % n if data.lstrip()[:1] == spec.SETPOINT_START_CHAR.encode() else b"(%d,%d)" % (n, n)


def _hex_word(text: str) -> int | None:
    try:
        return int(text, 16)
    except ValueError:
        return None


class SigningTransport(TransportLayer):
    """Signs what the Vehicle writes; learns the car's session from what it says. Everything
    else is the wrapped transport's."""

    def __init__(self, inner: Transport, key: bytes) -> None:
        super().__init__(inner)
        self.key = key
        self.session: int | None = None  # the car's session, once known
        self.counter = 0  # the last counter sent in this session
        self.unkeyed = False  # the car said it has no key: send unsigned
        self.refused = 0  # messages the car refused as unsigned, forged or replayed
        self._lock = threading.Lock()
        self._probe_since: float | None = None  # when the first message went out without a session
        self._fresh = False  # a new session was learnt: its first signed message is neutral
        # A link whose car takes another form (the Junior's queries, a phone's datagrams) signs
        # that form itself through our sign_query / sign_datagram, and the Vehicle's messages
        # pass to it unsigned.
        self._link_signs = inner.signs_itself
        if self._link_signs:
            inner.signer = self
        inner.signing = True  # BLE: a keyed car may take only encrypted writes, so it pairs

    def open(self) -> None:
        self.inner.open()
        with self._lock:
            self.session, self._probe_since = None, None  # a reopened link may lead to a rebooted car
        line = self.inner.refusal()  # (the Junior's first request: a refused probe)
        if line:
            self._on_line(line)
        if not self.inner.replies:
            self._ask_session()

    def _ask_session(self) -> None:
        """A link without reply lines says (session, last counter) when asked (Transport.car_session)."""
        answer = self.inner.car_session()
        if answer is not None:
            self._learn(*answer)

    def _learn(self, session: int, last_counter: int = 0) -> None:
        """The car's session, and the last counter it took in it: we count on from there (another
        host may have driven it in this session)."""
        with self._lock:
            if session == 0:  # the link says: this car has no key
                self.unkeyed = True
                return
            self.unkeyed = False
            if session != self.session:
                self.session, self.counter, self._fresh = session, last_counter, True
            else:
                self.counter = max(self.counter, last_counter)

    def sign(self, data: bytes) -> bytes:
        """The signed form of a message (unchanged while the session is unknown or the car has no key)."""
        with self._lock:
            if self.unkeyed or self.session is None:
                return data
            self.counter += 1
            return wire.sign(data, self.key, self.session, self.counter)

    def sign_query(self, query: str) -> str:
        """The signed form of an HTTP query (unchanged while the session is unknown or the car has no key)."""
        return self._sign_with(wire.sign_query, query)

    def sign_datagram(self, line: bytes) -> bytes:
        """The signed form of a phone's control datagram (unchanged likewise)."""
        return self._sign_with(wire.sign_datagram, line)

    def _sign_with(self, sign, text):
        with self._lock:
            if self.unkeyed or self.session is None:
                return text
            self.counter += 1
            return sign(text, self.key, self.session, self.counter)

    def write(self, data: bytes) -> None:
        """Until the session is known, messages go unsigned: a car with a key refuses them and
        says its session (ERR unsigned S), one without takes them. Once it is known, the first
        signed message is neutral (or zero speed): it arms a car that has just booted."""
        if self.session is None and not self.unkeyed:
            if not self.inner.replies:
                self._ask_session()
            if self.session is None and not self.unkeyed:
                if self._probe_since is None:
                    self._probe_since = time.monotonic()
                elif time.monotonic() - self._probe_since > PROBE_WAIT_S:
                    self._learn(0)  # no word of a session: a car without a key
        with self._lock:
            fresh, self._fresh = self._fresh, False
        if fresh:
            self._write(_neutral_like(data))
        self._write(data)

    def _write(self, data: bytes) -> None:
        self.inner.write(data if self._link_signs else self.sign(data))
        line = self.inner.refusal()  # a link that answers each message (the Junior's HTTP)
        if line:
            self._on_line(line)

    def read_lines(self) -> list[str]:
        return [line for line in self.inner.read_lines() if not self._on_line(line)]

    def _on_line(self, line: str) -> bool:
        """Learn from one of the car's lines; True for a refusal that only taught the session
        (the handshake, not news for the Vehicle)."""
        words = line.split()
        if len(words) == 2 and words[0] == spec.SIGNED_REPLY_SESSION:
            value = _hex_word(words[1])
            if value is not None:
                self._learn(value)
            return False
        if len(words) < 2 or words[0] != spec.SERIAL_REPLY_ERROR:
            return False
        reason = words[1]
        value = _hex_word(words[2]) if len(words) == 3 else None
        if reason == str(ParseResult.NOKEY):
            if not self.unkeyed:
                log.info("%s has no key: sending unsigned (set one with: roar key set URL)", self.url)
            self._learn(0)
            return True
        elif reason == str(ParseResult.UNSIGNED) and value is not None:
            self._learn(value)  # the answer to a message sent before the session was known
            return True
        elif reason == str(ParseResult.FORGED) and value is not None:
            if value != self.session:  # a new session: the car rebooted
                self._learn(value)
                return True
            self.refused += 1
            if self.refused == 1:  # (once: every message after it is refused alike)
                log.warning("%s refused a signed message as forged: is this the car's key? (roar key show URL)",
                            self.url)
        elif reason == str(ParseResult.REPLAY) and value is not None:
            self.refused += 1
            if self.session is not None:  # another sender used the key in this session: go past its counter
                self._learn(self.session, value)
        return False
