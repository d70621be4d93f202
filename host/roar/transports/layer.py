"""A layer over a link: a Transport that wraps another and is that link to everyone else, the
Vehicle's signing and recording layers (transports.signing, transports.recording) among them.
Every part of Transport's interface passes through to the link below unless the layer overrides
it; so does what a link offers beyond that interface (the simulator's robot, a loop link's log),
and `link` is the link itself under every layer.

The Vehicle stacks them in one order (transports.recording): what the script asked is recorded at
the top, then signed, then what went on the wire is recorded just above the link."""

from __future__ import annotations

from typing import Any

from roar.transports.base import Transport


def _from_inner(name: str, settable: bool = False) -> property:
    """The wrapped transport's attribute `name`, read (and, if settable, set) through the layer:
    Transport declares these on the class, so __getattr__ never sees them."""

    def get(self):
        return getattr(self.inner, name)

    def set_(self, value) -> None:
        setattr(self.inner, name, value)

    return property(get, set_ if settable else None, doc=f"the link's {name}")


class TransportLayer(Transport):
    def __init__(self, inner: Transport) -> None:
        self.inner = inner

    # the wrapped link's identity
    scheme = _from_inner("scheme")  # type: ignore[assignment]
    url = _from_inner("url")  # type: ignore[assignment]
    min_period_s = _from_inner("min_period_s")  # type: ignore[assignment]
    replies = _from_inner("replies")  # type: ignore[assignment]
    link = _from_inner("link")  # type: ignore[assignment]

    # what the signing layer and the commands set and ask reaches the link itself
    signs_itself = _from_inner("signs_itself")  # type: ignore[assignment]
    signer = _from_inner("signer", settable=True)  # type: ignore[assignment]
    signing = _from_inner("signing", settable=True)  # type: ignore[assignment]
    read_only = _from_inner("read_only", settable=True)  # type: ignore[assignment]

    @classmethod
    def from_url(cls, target, options):  # pragma: no cover - a layer is built over a link, never from a URL
        raise NotImplementedError

    # everything passes through unless the layer says otherwise
    def open(self) -> None:
        self.inner.open()

    def write(self, data: bytes) -> None:
        self.inner.write(data)

    def read_lines(self) -> list[str]:
        return self.inner.read_lines()

    def close(self) -> None:
        self.inner.close()

    def state(self):
        return self.inner.state()

    def lidar(self):
        return self.inner.lidar()

    def camera(self, width, height):
        return self.inner.camera(width, height)

    def camera_stream(self):
        return self.inner.camera_stream()

    def refusal(self):
        return self.inner.refusal()

    def car_session(self):
        return self.inner.car_session()

    @property
    def autopilots(self) -> tuple[str, ...]:
        return self.inner.autopilots

    def autopilot(self, name: str) -> Any:
        return self.inner.autopilot(name)

    def __getattr__(self, name: str):
        """What the link offers beyond Transport's interface (the simulator's robot, say)."""
        if name == "inner":  # not set yet (a half-built layer): no recursion
            raise AttributeError(name)
        return getattr(self.inner, name)

    def __repr__(self) -> str:
        return f"<{type(self).__name__} over {self.inner!r}>"
