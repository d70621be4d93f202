"""Steer for the curvature asked, as the gyro says the car turns.

Pure pursuit asks for a curvature and turns it into a front-wheel angle by the kinematic bicycle,
atan(wheelbase * curvature): right for a car whose tyres do not slip. A real car turns less than
that angle says (understeer: its front tyres slip more as it corners harder, more so the faster
it goes), and a car whose steering trim is off turns when asked to go straight. Pure pursuit sees
either only once the car is off its line, and corrects it only in proportion to the miss over its
look-ahead squared: on a fast car's long look-ahead, a third of a metre out in a bend.

The tracker closes that loop on the yaw rate: it integrates the difference between the curvature
asked and the one driven (yaw rate / speed) into a correction added to the next ask:

    correction += (gain * (asked - yaw_rate / speed) - leak * correction) * dt
    |correction| <= share * |asked| + floor

The leak lets the correction fade where it is no longer needed; the bound keeps a bad gyro or a
sliding car from steering the car into a wall. Without a gyro reading (yaw rate None) or below
min_speed (the curvature driven is meaningless at a standstill) the correction holds still.

Measured on every built-in track and random:1..10 (gain 8/s): the ROAR car's best laps came 1-2 %
nearer its limit lap, and the F1TENTH-like car, which understeers by up to a third at 3.4 m/s,
went from touching walls on 11 of 13 tracks to lapping them (issue 43, item 6)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

GAIN_PER_S = 8.0  # [1/s] correction per unit of curvature error, per second (2-30 tried: 3 too slow, 30 rings)
LEAK_PER_S = 1.0  # [1/s] the correction fades by this fraction per second where the error is gone
SHARE = 0.5  # the correction is at most this share of the curvature asked...
FLOOR_PER_M = 0.1  # [1/m] ...plus this (a trim error turns the car on a straight: a 10 m circle at most)
MIN_SPEED_M_S = 0.5  # [m/s] slower than this the correction holds still
SLIDING_PER_M = 0.25  # [1/m] turning this far from what is asked, the car slides: it holds its speed


@dataclass
class CurvatureTracker:
    gain_per_s: float = GAIN_PER_S
    leak_per_s: float = LEAK_PER_S
    share: float = SHARE
    floor_per_m: float = FLOOR_PER_M
    min_speed_m_s: float = MIN_SPEED_M_S
    correction_per_m: float = field(default=0.0, init=False)  # [1/m] added to what is asked
    error_per_m: float = field(default=0.0, init=False)  # [1/m] asked - driven, at the last step (0: unknown)

    def reset(self) -> None:
        self.correction_per_m = self.error_per_m = 0.0

    @property
    def sliding(self) -> bool:
        """Whether the car turns far from what it was asked: its tyres slide (a spin, a push)."""
        return abs(self.error_per_m) > SLIDING_PER_M

    def step(self, asked_per_m: float, speed_m_s: float, yaw_rate_rad_s: float | None, dt_s: float) -> float:
        """[1/m] the curvature to steer for, so that the car drives `asked_per_m` (left positive)
        at speed_m_s (a magnitude), turning at yaw_rate_rad_s (None or NaN: no gyro reading) now."""
        self.error_per_m = 0.0
        if yaw_rate_rad_s is not None and math.isfinite(yaw_rate_rad_s) and speed_m_s >= self.min_speed_m_s:
            driven = yaw_rate_rad_s / speed_m_s
            self.error_per_m = asked_per_m - driven
            c = self.correction_per_m
            c += (self.gain_per_s * self.error_per_m - self.leak_per_s * c) * dt_s
            bound = self.share * abs(asked_per_m) + self.floor_per_m
            self.correction_per_m = max(-bound, min(bound, c))
        return asked_per_m + self.correction_per_m
