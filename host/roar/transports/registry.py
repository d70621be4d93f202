"""URL scheme -> transport class, imported only when used."""

from __future__ import annotations

import importlib
from urllib.parse import parse_qsl, unquote, urlsplit

from roar.transports.base import Transport, TransportError

ENTRY_POINT_GROUP = "roar.transports"

# scheme -> "module:Class"; the module is imported on first use (bleak and pyserial are only
# loaded by programs that use them). The simulator's sim:// comes from its entry point.
_REGISTRY: dict[str, str | type[Transport]] = {
    "serial": "roar.transports.serial_link:SerialTransport",
    "ble": "roar.transports.ble:BleTransport",
    "loop": "roar.transports.loopback:LoopbackTransport",
    "http": "roar.transports.junior_http:HttpTransport",
    "udp": "roar.transports.phone_udp:UdpPhoneTransport",
}
# What to install for the schemes this project's extras provide.
EXTRAS = {"ble": "ble", "sim": "sim"}
# scheme -> (an example URL, what it reaches), for `roar --help`
EXAMPLES = {
    "sim": ("sim://  sim://oval?robot=iarrc", "a simulated robot, on an open floor or a track"),
    "serial": ("serial:///dev/ttyUSB0", "a car on USB serial (find the port with `roar ports`)"),
    "ble": ("ble://  ble://ROAR Car", "a car over Bluetooth LE (find it with `roar scan`)"),
    "http": ("http://192.168.4.1:81", "the ROAR Junior (control port; its camera on the port below)"),
    "udp": ("udp://192.168.1.20", "a car through the phone on it (ROAR's UDP streams and controls)"),
    "loop": ("loop://", "no car: records what is sent (for tests)"),
}
_entry_points_loaded = False


def install_hint(scheme: str) -> str:
    extra = EXTRAS.get(scheme)
    return f"pip install 'roar-platform[{extra}]'" if extra else "pip install roar-platform"


def register(scheme: str, transport: str | type[Transport]) -> None:
    """Make `scheme://` open `transport` (a Transport subclass or "module:Class")."""
    _REGISTRY[scheme.lower()] = transport


def schemes() -> list[str]:
    _load_entry_points()
    return sorted(_REGISTRY)


def url_help() -> str:
    """Every scheme this installation opens, one line each with an example: `roar --help`'s list."""
    installed = schemes()
    lines = []
    for scheme in [s for s in EXAMPLES if s in installed] + [s for s in installed if s not in EXAMPLES]:
        example, what = EXAMPLES.get(scheme, (f"{scheme}://", "(from an installed plug-in)"))
        lines.append(f"  {example:32}{what}")
    return "\n".join(lines)


def _load_entry_points() -> None:
    global _entry_points_loaded
    if not _entry_points_loaded:
        _entry_points_loaded = True
        from importlib.metadata import entry_points  # (~25 ms to import: only where a URL is opened)

        for ep in entry_points(group=ENTRY_POINT_GROUP):
            _REGISTRY.setdefault(ep.name.lower(), ep.value)


def _resolve(scheme: str) -> type[Transport]:
    _load_entry_points()
    entry = _REGISTRY.get(scheme)
    if entry is None and scheme in EXTRAS:
        raise TransportError(f"{scheme}:// is not installed: {install_hint(scheme)}")
    if entry is None:
        raise TransportError(f"unknown URL scheme {scheme + '://'!r}: use one of "
                             + ", ".join(s + "://" for s in sorted(_REGISTRY)))
    if isinstance(entry, str):
        module, _, name = entry.partition(":")
        try:
            entry = getattr(importlib.import_module(module), name)
        except ImportError as e:
            raise TransportError(f"{scheme}:// needs {e.name or module}, which is not installed: "
                                 f"{install_hint(scheme)}") from None
        _REGISTRY[scheme] = entry
    return entry


def parse_url(url: str) -> tuple[str, str, dict[str, str]]:
    """("scheme", "target", {options}) of a car URL; one-line TransportError if malformed."""
    if not isinstance(url, str) or "://" not in url:
        raise TransportError(f"not a car URL: {url!r} (expected e.g. serial:///dev/ttyUSB0, ble://, sim://)")
    parts = urlsplit(url)
    options: dict[str, str] = {}
    for key, value in parse_qsl(parts.query, keep_blank_values=True):
        if key in options:
            raise TransportError(f"{url}: option {key!r} given twice")
        options[key] = value
    return parts.scheme.lower(), unquote(parts.netloc + parts.path), options


def open_url(url: str, **overrides) -> Transport:
    """Build (not yet open) the transport for a URL. Keyword overrides are passed as options that
    URLs cannot carry (e.g. a bleak backend class in tests)."""
    scheme, target, options = parse_url(url)
    cls = _resolve(scheme)
    transport = cls.from_url(target, options, **overrides) if overrides else cls.from_url(target, options)
    if options:
        raise TransportError(f"{url}: unknown option(s) {', '.join(sorted(options))} for {scheme}://")
    transport.url = url
    return transport
