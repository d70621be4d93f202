"""What a real car measures of its own motion, for the localization: wheel encoders on the two
front wheels (undriven: they do not spin up under throttle nor lock under the brake, as the
driven rear wheels do) and a MEMS gyro's yaw rate -- each with the errors a real one has, drawn
from a seed:

- the encoders count whole counts, their mean is the distance; the radius the host assumes is
  off the tyre's true rolling radius by RADIUS_ERROR (a calibration's error); what the tyres
  slide in a bend, and the front wheels' longer arc in a turn, count as distance, as on a car;
- the gyro reads the rate over the period since its last reading (it low-passes), times a
  scale error, plus a bias that stays and white noise.

    sensors = WheelOdometry(robot.plant, seed=3)            # plant: a roar_sim.plants.racecar.Racecar
    travelled_m, yaw_rate = sensors.read(robot.time_s)      # [m] all told, signed; [rad/s]
"""

from __future__ import annotations

import math

import numpy as np

from roar.localization.odometry import Encoder

COUNTS_PER_REV = 1024  # [counts] a hobby car's encoder (the IARRC car's has 10,240)
ROLLING_RADIUS_M = 0.0505  # [m] the tyre's rolling radius at the URDF's size (measured: roar_sim.robots.iarrc)
RADIUS_ERROR = 0.01  # standard deviation of the assumed radius's relative error
GYRO_BIAS_RAD_S = 0.003  # [rad/s] standard deviation of the bias left after calibration at rest (0.17 deg/s)
GYRO_NOISE_RAD_S = 0.01  # [rad/s] standard deviation of each reading's white noise
GYRO_SCALE_ERROR = 0.01  # standard deviation of the gyro's relative scale error


class WheelOdometry:
    def __init__(self, plant, seed: int | None = None, counts_per_rev: int = COUNTS_PER_REV) -> None:
        self.plant = plant
        self.rng = np.random.default_rng(seed)
        self.encoder = Encoder(counts_per_rev, ROLLING_RADIUS_M * plant.profile.scale)
        self._true_radius = self.encoder.wheel_radius_m * (1 + self.rng.normal(0.0, RADIUS_ERROR))
        self._bias = self.rng.normal(0.0, GYRO_BIAS_RAD_S)
        self._scale = 1 + self.rng.normal(0.0, GYRO_SCALE_ERROR)
        self._last: tuple[float, float] | None = None  # (t [s], yaw [rad]) at the last reading
        self._rate = 0.0

    def counts(self) -> int:
        """The encoders' mean count: the front wheels' mean turn, scaled by the true radius over
        the assumed one (the host converts counts with the assumed radius)."""
        turned = self.plant.front_wheels_turned()
        return math.floor(turned * self._true_radius / self.encoder.wheel_radius_m / math.tau
                          * self.encoder.counts_per_rev)

    def yaw_rate(self, t_s: float) -> float:
        """[rad/s] the gyro's reading at t_s: the mean rate since its last reading, with its errors."""
        yaw = self.plant.state().yaw
        if self._last is not None and t_s > self._last[0]:
            self._rate = math.remainder(yaw - self._last[1], math.tau) / (t_s - self._last[0])
        self._last = (t_s, yaw)
        return self._rate * self._scale + self._bias + self.rng.normal(0.0, GYRO_NOISE_RAD_S)

    def read(self, t_s: float) -> tuple[float, float]:
        """(travelled [m] by the encoder, yaw rate [rad/s] by the gyro) at t_s [s]."""
        return self.encoder.metres(self.counts()), self.yaw_rate(t_s)
