"""The names of worlds drawn from a seed (`random:SEED,...`, `tunnel:SEED,...`), read the same way."""

from __future__ import annotations

from roar.checks import printable
from roar.tracks.track import TrackError


def seeded(name: str, prefix: str, usage: str, keys: tuple[str, ...], what: str = "seed") -> tuple[int, dict[str, str]]:
    """(seed, {key: its text}) of a name `PREFIX SEED[,key=value...]`; TrackError (one line, with
    the usage) for a seed (or the `what` in its place) that is not a whole number or a key not
    among `keys`."""
    seed_text, *options = name[len(prefix):].split(",")
    if not seed_text.strip().isdigit() or len(seed_text.strip()) > 18:
        raise TrackError(f"{printable(name)!r}: the {what} must be a whole number 0..10^18 ({usage})")
    values = {}
    for option in options:
        key, _, text = option.partition("=")
        if key.strip() not in keys:
            raise TrackError(f"{printable(name)!r}: unknown parameter {printable(key.strip())!r} ({usage})")
        values[key.strip()] = text
    return int(seed_text), values
