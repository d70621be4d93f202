"""Signed control on the host (protocol/spec.toml [signed]): the user's key file, and the transport
wrapper that signs every control and setpoint message the Vehicle writes.

    roar key set serial:///dev/ttyACM0     # once: a new key in your key file and in the car
    Vehicle("ble://")                       # from then on every Vehicle signs with it

    Vehicle(url, key="00112233...")         # or a key given here (bytes, hex or a key file)
    Vehicle(url, key=False)                 # never sign

The session the car signs in (a new one at each boot) comes from the car: its SESSION line after
READY, the session in its ERR unsigned / ERR forged replies, or, on links without reply lines,
the link's own question (Transport.session(): a BLE read, the Junior's refusal). A car without a
key answers signed messages with ERR nokey; the wrapper then sends unsigned to that car.
"""

from __future__ import annotations

import logging
import os
import secrets
import threading
import time
from pathlib import Path

from roar.errors import RoarError
from roar.protocol import ParseResult, spec
from roar.transports.base import Transport
from roar_wire import signing as wire

log = logging.getLogger("roar")

KEY_HEX_DIGITS = 2 * spec.SIGNED_KEY_BYTES
PROBE_WAIT_S = 1.0  # [s] for the car's session after the first (unsigned) message


class SigningError(RoarError):
    """A key or key file that cannot be used; str() is one line."""


def default_path() -> Path:
    """The user's key file: ~/.config/roar/key (or under $XDG_CONFIG_HOME)."""
    base = os.environ.get("XDG_CONFIG_HOME") or Path.home() / ".config"
    return Path(base) / "roar" / "key"


def new_key() -> bytes:
    return secrets.token_bytes(spec.SIGNED_KEY_BYTES)


def read_key_file(path: str | Path) -> bytes:
    """The key in a key file (32 hex digits; # comments allowed); SigningError (one line) otherwise."""
    path = Path(path)
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise SigningError(f"{path}: no such key file (make one with: roar key new)") from None
    except (OSError, UnicodeDecodeError) as e:
        raise SigningError(f"{path}: cannot read the key file ({e.__class__.__name__})") from None
    lines = [ln.split("#", 1)[0].strip() for ln in text.splitlines()]
    words = [ln for ln in lines if ln]
    try:
        if len(words) != 1:
            raise ValueError
        return wire.check_key(words[0])
    except ValueError:
        raise SigningError(f"{path}: a key file holds one key of {KEY_HEX_DIGITS} hex digits") from None


def write_key_file(path: str | Path, key: bytes) -> Path:
    """Write a key file readable by its owner only."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w") as f:
        f.write(f"# roar signing key (fingerprint {wire.fingerprint(key)}): keep it secret\n{key.hex()}\n")
    os.replace(tmp, path)
    return path


def resolve_key(key) -> bytes | None:
    """What Vehicle(key=...) means: None -> the user's key file if there is one, False -> no
    signing, bytes / 32 hex digits -> that key, a path -> the key file there."""
    if key is None:
        path = default_path()
        return read_key_file(path) if path.exists() else None
    if key is False:
        return None
    if isinstance(key, (bytes, bytearray)) or (isinstance(key, str) and len(key.strip()) == KEY_HEX_DIGITS
                                               and not Path(key).exists()):
        try:
            return wire.check_key(key)
        except ValueError as e:
            raise SigningError(str(e)) from None
    if isinstance(key, (str, Path)):
        return read_key_file(key)
    raise SigningError(f"key must be bytes, {KEY_HEX_DIGITS} hex digits, a key file or False, got {type(key).__name__}")


def _neutral_like(data: bytes) -> bytes:
    """Neutral in the kind of message data is: "(1500,1500)" or zero speed, centred."""
    n = spec.CONTROL_NEUTRAL_US
    return b"[0,%d]" % n if data.lstrip()[:1] == spec.SETPOINT_START_CHAR.encode() else b"(%d,%d)" % (n, n)


def _hex_word(text: str) -> int | None:
    try:
        return int(text, 16)
    except ValueError:
        return None


class SigningTransport(Transport):
    """Signs what the Vehicle writes; learns the car's session from what it says. Everything
    else is the wrapped transport's."""

    def __init__(self, inner: Transport, key: bytes) -> None:
        self.inner = inner
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
        self._link_signs = hasattr(inner, "signer")
        if self._link_signs:
            inner.signer = self
        if hasattr(inner, "signing"):  # BLE: a keyed car may take only encrypted writes, so pair
            inner.signing = True

    # the wrapped transport's identity
    @property
    def scheme(self):  # type: ignore[override]
        return self.inner.scheme

    @property
    def url(self):  # type: ignore[override]
        return self.inner.url

    @property
    def min_period_s(self):  # type: ignore[override]
        return self.inner.min_period_s

    @property
    def replies(self):  # type: ignore[override]
        return self.inner.replies

    @classmethod
    def from_url(cls, target, options):  # pragma: no cover - built by Vehicle, never from a URL
        raise NotImplementedError

    def open(self) -> None:
        self.inner.open()
        with self._lock:
            self.session, self._probe_since = None, None  # a reopened link may lead to a rebooted car
        refusal = getattr(self.inner, "refusal", None)
        line = refusal() if callable(refusal) else None  # (the Junior's first request: a refused probe)
        if line:
            self._on_line(line)
        if not self.inner.replies:
            self._ask_session()

    def close(self) -> None:
        self.inner.close()

    def _ask_session(self) -> None:
        """A link without reply lines says (session, last counter) when asked (Transport.session)."""
        ask = getattr(self.inner, "session", None)
        answer = ask() if callable(ask) else None
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
        refusal = getattr(self.inner, "refusal", None)
        if callable(refusal):  # a link that answers each message (the Junior's HTTP)
            line = refusal()
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

    # everything else passes through
    def state(self):
        return self.inner.state()

    def lidar(self):
        return self.inner.lidar()

    def camera(self, width, height):
        return self.inner.camera(width, height)

    def camera_stream(self):
        return self.inner.camera_stream()

    def __getattr__(self, name):
        return getattr(self.inner, name)
