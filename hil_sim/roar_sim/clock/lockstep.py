"""What the simulators (the ESC car's SimCar, the JuniorSim) share: time moves only in run(),
one physics period at a time, optionally kept to the wall clock (times a speed-up)."""

from __future__ import annotations

import time

SLACK_S = 0.002  # [s] ahead by less than this, carry on without sleeping


class Pacer:
    def __init__(self, speedup: float = 1.0) -> None:
        self.speedup = speedup
        self._wall_start: float | None = None  # [s] perf_counter when simulated time was 0

    def keep_pace(self, sim_s: float) -> None:
        """Sleep until the wall clock reaches simulated time sim_s [s] (scaled by speedup)."""
        now = time.perf_counter()
        wall_s = sim_s / self.speedup
        if self._wall_start is None:
            self._wall_start = now - wall_s
        ahead = wall_s - (now - self._wall_start)
        if ahead > SLACK_S:
            time.sleep(ahead)


class Lockstep:
    """A plant (with state() and close()) and a firmware whose time moves only in run().
    Subclasses set plant, config (realtime, speedup) and t_us, and implement _advance(end_us):
    the firmware and physics up to the next physics step or end_us, moving t_us."""

    plant: object
    config: object
    t_us: int  # [us] simulated time
    _pacer: Pacer | None = None

    def _advance(self, end_us: int) -> None:
        raise NotImplementedError

    def run(self, seconds: float) -> None:
        end = self.t_us + int(round(seconds * 1e6))
        while self.t_us < end:
            self._advance(end)
            if self.config.realtime:
                self._pacer = self._pacer or Pacer(self.config.speedup)
                self._pacer.keep_pace(self.t_us / 1e6)

    @property
    def time_s(self) -> float:
        return self.t_us / 1e6

    def state(self):
        return self.plant.state()

    def close(self) -> None:
        self.plant.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()
