"""The names of worlds drawn from a seed (`random:SEED,...`, `tunnel:SEED,...`), read the same way."""

from __future__ import annotations

from roar.checks import printable
from roar.tracks.track import TrackError

MAX_SEED = 10**18  # the largest seed a name may give


def seeded(name: str, prefix: str, usage: str, keys: tuple[str, ...], what: str = "seed") -> tuple[int, dict[str, str]]:
    """(seed, {key: its text}) of a name `PREFIX SEED[,key=value...]`; TrackError (one line, with
    the usage) for a seed (or the `what` in its place) that is not a whole number or a key not
    among `keys` or given twice."""
    seed_text, values = split_options(name, prefix, usage, keys)
    text = seed_text.strip()
    if not text.isdigit() or len(text) > len(str(MAX_SEED)) or int(text) > MAX_SEED:
        raise TrackError(f"{printable(name)!r}: the {what} must be a whole number 0..10^18 ({usage})")
    return int(text), values


def split_options(name: str, prefix: str, usage: str, keys: tuple[str, ...]) -> tuple[str, dict[str, str]]:
    """(the text after the prefix up to the first comma, {key: its text}) of `PREFIX X[,key=value...]`;
    TrackError (one line, with the usage) for a key not among `keys` or given twice."""
    first, *options = name[len(prefix):].split(",")
    values: dict[str, str] = {}
    for option in options:
        key, _, text = option.partition("=")
        key = key.strip()
        if key not in keys:
            raise TrackError(f"{printable(name)!r}: unknown parameter {printable(key)!r} ({usage})")
        if key in values:
            raise TrackError(f"{printable(name)!r}: parameter {key!r} given twice ({usage})")
        values[key] = text
    return first, values
