"""Steer for the curvature asked, as the gyro says the car turns.

Pure pursuit asks for a curvature and turns it into a front-wheel angle by the kinematic bicycle,
atan(wheelbase * curvature): right for a car whose tyres do not slip. A real car turns less than
that angle says (understeer: its front tyres slip more as it corners harder, more so the faster
it goes), and a car whose steering trim is off turns when asked to go straight. Pure pursuit sees
either only once the car is off its line, and corrects it only in proportion to the miss over its
look-ahead squared: on a fast car's long look-ahead, a third of a metre out in a bend.

The tracker learns how the car turns for what it is sent, from the gyro, and sends what makes it
turn as asked. Each period it fits, by least squares over the last MEMORY_S (older periods
weighing less and less),

    driven = gain * sent + bias          driven = yaw rate / speed, sent: the last curvature sent

and sends (asked - bias) / gain, no further from what is asked than share * |asked| + floor (a
bad gyro or a sliding car never steers the car into a wall). The fit uses what was sent and what
the gyro says, both what the car really did: a jump of the pose the car drives on (a particle
filter's correction) changes what is asked but teaches the tracker nothing false. (Integrating
asked - driven instead followed every such jump: on a 343 m circuit driven on the filter's pose
the position RMS went from 0.11 to 0.29 m.) Without a gyro reading (yaw rate None or NaN) or
below min_speed it learns nothing, sees no slide and sends what it last knew to.

It also watches for slides: |asked - driven| over SLIP_S. From SLIPPING_PER_M the throttle is
eased, and from SLIDING_PER_M lifted (drive_share): a wheel spun up takes the grip a bend needs.

Measured on every built-in track and random:1..10: the ROAR car's best laps came 1-2 % nearer its
limit lap, the IARRC car's 1.14-1.18 x became 1.12-1.13, and the F1TENTH-like car, which turns a third
less than its steering says at 3.4 m/s, went from touching walls on 11 of 13 tracks to none
(issue 43, items 6 and 20)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

MEMORY_S = 1.0  # [s] the fit forgets older periods with this time constant
SPREAD_PER_M = 0.05  # [1/m] what was sent must vary this much (its spread) before a gain is fitted
GAIN_RANGE = (0.5, 1.5)  # the turn per curvature sent that the fit may find
SHARE = 0.5  # what is sent is at most this share of the curvature asked away from it...
FLOOR_PER_M = 0.1  # [1/m] ...plus this (a trim error turns the car on a straight: a 10 m circle at most)
# [m/s] slower than this it learns nothing and sees no slide: yaw rate / speed means little there (a
# launch's wheelspin turned a car at 0.8 rad/s at 0.5 m/s), and a lifted throttle must not keep it there
MIN_SPEED_M_S = 1.0
SLIPPING_PER_M = 0.1  # [1/m] turning this far from what is asked, the car starts to slide: less throttle...
SLIDING_PER_M = 0.25  # [1/m] ...and none from here
SLIP_S = 0.1  # [s] how long the turning is watched for a slide (a low-pass of |asked - driven|)


@dataclass
class CurvatureTracker:
    memory_s: float = MEMORY_S
    share: float = SHARE
    floor_per_m: float = FLOOR_PER_M
    min_speed_m_s: float = MIN_SPEED_M_S
    gain: float = field(default=1.0, init=False)  # the car turns gain * sent + bias
    bias_per_m: float = field(default=0.0, init=False)  # [1/m]
    slip_per_m: float = field(default=0.0, init=False)  # [1/m] |asked - driven| over the last SLIP_S
    _sums: list = field(default_factory=lambda: [0.0] * 5, init=False, repr=False)  # weight, s, s^2, d, s d
    _sent: float | None = field(default=None, init=False, repr=False)  # [1/m] last period's
    _asked: float = field(default=0.0, init=False, repr=False)  # [1/m] last period's

    def reset(self) -> None:
        self.gain, self.bias_per_m, self.slip_per_m = 1.0, 0.0, 0.0
        self._sums, self._sent, self._asked = [0.0] * 5, None, 0.0

    @property
    def drive_share(self) -> float:
        """The share of its throttle the car may use: all of it while it turns as asked, none once
        it turns SLIDING_PER_M away (its tyres slide: a spin, a push), in between from SLIPPING_PER_M."""
        excess = (self.slip_per_m - SLIPPING_PER_M) / (SLIDING_PER_M - SLIPPING_PER_M)
        return min(1.0, max(0.0, 1.0 - excess))

    def step(self, asked_per_m: float, speed_m_s: float, yaw_rate_rad_s: float | None, dt_s: float) -> float:
        """[1/m] the curvature to steer for, so that the car drives `asked_per_m` (left positive)
        at speed_m_s (a magnitude), turning at yaw_rate_rad_s (None or NaN: no gyro reading) now."""
        if yaw_rate_rad_s is not None and math.isfinite(yaw_rate_rad_s) and speed_m_s >= self.min_speed_m_s:
            driven = yaw_rate_rad_s / speed_m_s  # what it turns now answers last period's command
            # a slide lasts: one period's jump of what is asked (a pose corrected by a scan) is not one
            self.slip_per_m += (abs(self._asked - driven) - self.slip_per_m) * min(1.0, dt_s / SLIP_S)
            if self._sent is not None:
                # paired with the turn a period later (what was sent low-passed over 0.05-0.2 s, as
                # the servo follows it, fitted worse: the IARRC car's laps 1.13-1.20 x its limit
                # against 1.12-1.13)
                self._learn(self._sent, driven, dt_s)
        else:
            self.slip_per_m -= self.slip_per_m * min(1.0, dt_s / SLIP_S)
        sent = (asked_per_m - self.bias_per_m) / self.gain
        bound = self.share * abs(asked_per_m) + self.floor_per_m
        sent = max(asked_per_m - bound, min(asked_per_m + bound, sent))
        self._sent, self._asked = sent, asked_per_m
        return sent

    def _learn(self, sent: float, driven: float, dt_s: float) -> None:
        keep = math.exp(-dt_s / self.memory_s)
        w, s, ss, d, sd = (keep * v for v in self._sums)
        self._sums = [w + 1, s + sent, ss + sent * sent, d + driven, sd + sent * driven]
        w, s, ss, d, sd = self._sums
        spread = w * ss - s * s  # w^2 times the variance of what was sent
        if spread > (w * SPREAD_PER_M) ** 2:
            self.gain = min(GAIN_RANGE[1], max(GAIN_RANGE[0], (w * sd - s * d) / spread))
        self.bias_per_m = (d - self.gain * s) / w
