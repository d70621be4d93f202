"""What the simulator builds from a track's shape alone (wall meshes, floor textures, ray
clients), made once per shape in a process: every fresh world of a track (each Gym reset) reuses
them."""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import TypeVar

from roar.tracks import Track

T = TypeVar("T")

_SHAPES: dict[tuple[str, bytes], object] = {}
_SHAPES_LOCK = threading.RLock()


def per_shape(what: str, track: Track, make: Callable[[], T]) -> T:
    """make()'s result for `what` of this track's shape, made once per shape in this process."""
    key = (what, track.fingerprint)
    with _SHAPES_LOCK:
        if key not in _SHAPES:
            _SHAPES[key] = make()
        return _SHAPES[key]  # type: ignore[return-value]
