"""The recording layer: every control message the Vehicle writes, every reply line, the state,
and the scans and frames a script asks for, also go into a recording (roar.recorder.Recorder,
an MCAP file) with the time they happened: the simulator's clock on sim://, else the host's."""

from __future__ import annotations

import time

from roar.transports.base import LIDAR_FOV_RAD, Transport
from roar.transports.layer import TransportLayer


class RecordingTransport(TransportLayer):
    """A transport whose every write, reply line, state, scan and camera frame is also recorded:
    what Vehicle(..., record=PATH) drives through. Everything else is the link's own. The
    recorder (a roar.recorder.Recorder) may be swapped or set to None (nothing recorded) at any
    time (Vehicle.record)."""

    def __init__(self, inner: Transport, recorder) -> None:
        super().__init__(inner)
        self.recorder = recorder
        self._t0 = time.monotonic_ns()
        self._simulated = inner.scheme == "sim"

    def now_ns(self, state=None) -> int:
        """[ns] the simulator's clock on sim:// (of `state` if given; 0 before its first step, so
        the two clocks are never mixed in one file), else the host's monotonic clock since the
        start."""
        if self._simulated:
            state = state if state is not None else self.inner.state()
            return 0 if state is None or state.time_s is None else int(round(state.time_s * 1e9))
        return time.monotonic_ns() - self._t0

    def write(self, data: bytes) -> None:
        self.inner.write(data)
        rec = self.recorder  # read once: Vehicle.record(None) may take it away meanwhile
        if rec is None:
            return
        state = self.inner.state()  # one snapshot: its time is the record's
        t = self.now_ns(state)
        rec.control(data, t)
        if state is not None:
            rec.state(state, t)

    def read_lines(self) -> list[str]:
        lines = self.inner.read_lines()
        rec = self.recorder
        if lines and rec is not None:
            t = self.now_ns()
            for line in lines:
                rec.line(line, t)
        return lines

    def lidar(self):
        ranges = self.inner.lidar()
        rec = self.recorder
        if ranges is not None and rec is not None:
            rec.scan(ranges, -LIDAR_FOV_RAD / 2, LIDAR_FOV_RAD / 2, self.now_ns())
        return ranges

    def camera(self, width: int, height: int):
        frame = self.inner.camera(width, height)
        rec = self.recorder
        if frame is not None and rec is not None:
            t = self.now_ns()
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
