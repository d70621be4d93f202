"""Simulated time as every robot keeps it: the firmware loop at 1 kHz on the board's clock, physics
at 200 Hz, a host's command every 20 ms; time moves only in run(), one physics period at a time,
or kept to the wall clock (realtime, times a speed-up)."""

from __future__ import annotations

import time

from roar.protocol import spec

LOOP_US = 1_000  # [us] the firmware's main-loop period
PHYSICS_US = 5_000  # [us] one PyBullet step
CONTROL_PERIOD_S = spec.TIMING_HOST_SEND_PERIOD_US / 1e6  # [s] a host's command period (50 Hz)
SLACK_S = 0.002  # [s] ahead by less than this, carry on without sleeping
# [s] behind the wall clock by more than this (the process was busy: a camera frame rendered, a
# browser starting), simulated time slips rather than catching up in a burst: a real car's time
# never jumps, and a burst would run the firmware through the host's commands still to come,
# tripping its failsafe for a gap the host never left
MAX_BEHIND_S = 0.05


def loops_until(t_us: int, end_us: int) -> int:
    """Firmware-loop iterations from t_us to the next physics step or end_us, whichever is first."""
    period_end = (t_us // PHYSICS_US + 1) * PHYSICS_US
    return max(1, (min(period_end, end_us) - t_us) // LOOP_US)


class Pacer:
    def __init__(self, speedup: float = 1.0) -> None:
        self.speedup = speedup
        self._wall_start: float | None = None  # [s] perf_counter when simulated time was 0
        self.slips = 0  # times simulated time fell behind by more than MAX_BEHIND_S and slipped

    def keep_pace(self, sim_s: float) -> None:
        """Sleep until the wall clock reaches simulated time sim_s [s] (scaled by speedup)."""
        now = time.perf_counter()
        wall_s = sim_s / self.speedup
        if self._wall_start is None:
            self._wall_start = now - wall_s
        ahead = wall_s - (now - self._wall_start)
        if ahead > SLACK_S:
            time.sleep(ahead)
        elif ahead < -MAX_BEHIND_S:
            self._wall_start += -ahead - MAX_BEHIND_S
            self.slips += 1


class Lockstep:
    """A plant (with state() and close()) and a firmware whose time moves only in run().
    Subclasses set plant, realtime, speedup and t_us, and implement _advance(end_us): the
    firmware and physics up to the next physics step or end_us, moving t_us."""

    plant: object
    realtime: bool = False  # run() keeps pace with the wall clock
    speedup: float = 1.0  # simulated seconds per wall second when realtime
    t_us: int  # [us] simulated time
    _pacer: Pacer | None = None

    def _advance(self, end_us: int) -> None:
        raise NotImplementedError

    def run(self, seconds: float) -> None:
        end = self.t_us + int(round(seconds * 1e6))
        while self.t_us < end:
            self._advance(end)
            if self.realtime:
                self._pacer = self._pacer or Pacer(self.speedup)
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
