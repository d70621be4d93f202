"""Signed control on the host (protocol/spec.toml [signed]): the user's key file; the layer that
signs every control and setpoint message the Vehicle writes is roar.transports.signing.

    roar key set serial:///dev/ttyACM0     # once: a new key in your key file and in the car
    Vehicle("ble://")                       # from then on every Vehicle signs with it

    Vehicle(url, key="00112233...")         # or a key given here (bytes, hex or a key file)
    Vehicle(url, key=False)                 # never sign
"""

from __future__ import annotations

import os
import secrets
from pathlib import Path

from roar.errors import SigningError
from roar.protocol import spec
from roar.transports.signing import PROBE_WAIT_S, SigningTransport  # noqa: F401 (importable from here too)
from roar_wire import signing as wire

KEY_HEX_DIGITS = 2 * spec.SIGNED_KEY_BYTES


def default_path() -> Path:
    """The user's key file: ~/.config/roar/key (or under $XDG_CONFIG_HOME)."""
    from roar.user_files import config_folder

    return config_folder() / "key"


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
