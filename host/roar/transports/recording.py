"""The recording layers: what a Vehicle's run does goes into a recording (roar.recorder.Recorder, an
MCAP file) with the time it happened -- the simulator's clock on sim://, else the host's.

The Vehicle stacks its layers in one order, the link at the bottom:

    RecordingTransport    what the script asked for (/control), the state, the scans and frames it read
    SigningTransport      signs each message (when a key signs: transports.signing)
    WireRecording         the bytes as they went to the car (/wire/control: signed, the signer's own
    link                  neutral among them) and every line the car sent, the signing handshake's too

so a recording holds both, labelled: what went on the wire, and what the script asked for (what
`roar replay --to` plays again, re-signed by the Vehicle that plays it: the car's replay
protection would refuse the old signatures). Both taps share one clock and one recorder, which
Vehicle.record swaps (or sets to None: nothing recorded) at any time.
"""

from __future__ import annotations

import time

from roar.transports.base import LIDAR_FOV_RAD, Transport
from roar.transports.layer import TransportLayer


class RunClock:
    """[ns] the simulator's clock on sim:// (of a state, or the link's now; 0 before its first
    step, so the two clocks are never mixed in one file), else the host's monotonic clock since
    the start."""

    def __init__(self, link: Transport) -> None:
        self.link, self.t0 = link, time.monotonic_ns()
        self.simulated = link.scheme == "sim"

    def now_ns(self, state=None) -> int:
        if self.simulated:
            state = state if state is not None else self.link.state()
            return 0 if state is None or state.time_s is None else int(round(state.time_s * 1e9))
        return time.monotonic_ns() - self.t0


class WireRecording(TransportLayer):
    """Just above the link: every message as it went to the car, every line as it came."""

    def __init__(self, link: Transport, recorder, clock: RunClock | None = None) -> None:
        super().__init__(link)
        self.recorder = recorder
        self.clock = clock or RunClock(link)

    def write(self, data: bytes) -> None:
        self.inner.write(data)
        rec = self.recorder  # read once: Vehicle.record(None) may take it away meanwhile
        if rec is not None:
            rec.wire_control(data, self.clock.now_ns())

    def read_lines(self) -> list[str]:
        lines = self.inner.read_lines()
        rec = self.recorder
        if lines and rec is not None:
            t = self.clock.now_ns()
            for line in lines:
                rec.line(line, t)
        return lines


class RecordingTransport(TransportLayer):
    """At the top: every control message the script's Vehicle writes, as it asked for it, with the
    state then; the scans and frames it reads. Everything else is the link's own."""

    def __init__(self, inner: Transport, recorder, clock: RunClock | None = None) -> None:
        super().__init__(inner)
        self.recorder = recorder
        self.clock = clock or RunClock(inner.link)

    def write(self, data: bytes) -> None:
        self.inner.write(data)
        rec = self.recorder
        if rec is None:
            return
        state = self.inner.state()  # one snapshot: its time is the record's
        t = self.clock.now_ns(state)
        rec.control(data, t)
        if state is not None:
            rec.state(state, t)

    def lidar(self):
        ranges = self.inner.lidar()
        rec = self.recorder
        if ranges is not None and rec is not None:
            rec.scan(ranges, -LIDAR_FOV_RAD / 2, LIDAR_FOV_RAD / 2, self.clock.now_ns())
        return ranges

    def camera(self, width: int, height: int):
        frame = self.inner.camera(width, height)
        rec = self.recorder
        if frame is not None and rec is not None:
            t = self.clock.now_ns()
            rec.image(frame[0], t)
            if frame[1] is not None:
                rec.depth(frame[1], t)
        return frame

    def close(self) -> None:
        try:
            self.inner.close()
        finally:
            if self.recorder is not None:
                self.recorder.close()
