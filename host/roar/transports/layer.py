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


class TransportLayer(Transport):
    def __init__(self, inner: Transport) -> None:
        self.inner = inner

    # the wrapped link's identity
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

    @property
    def link(self) -> Transport:
        return self.inner.link

    # what the signing layer and the commands set and ask reaches the link itself
    @property
    def signs_itself(self):  # type: ignore[override]
        return self.inner.signs_itself

    @property
    def signer(self):  # type: ignore[override]
        return self.inner.signer

    @signer.setter
    def signer(self, value) -> None:
        self.inner.signer = value

    @property
    def signing(self):  # type: ignore[override]
        return self.inner.signing

    @signing.setter
    def signing(self, value: bool) -> None:
        self.inner.signing = value

    @property
    def read_only(self):  # type: ignore[override]
        return self.inner.read_only

    @read_only.setter
    def read_only(self, value: bool) -> None:
        self.inner.read_only = value

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
