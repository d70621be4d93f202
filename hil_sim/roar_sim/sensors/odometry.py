"""What a real car measures of its own motion, for the localization: wheel encoders on the two
front wheels (undriven: they do not spin up under throttle nor lock under the brake, as the
driven rear wheels do) and a MEMS gyro's yaw rate -- each with the errors a real one has, drawn
from a seed:

- the encoders count whole counts, their mean is the distance; the radius the host assumes is
  off the tyre's true rolling radius by RADIUS_ERROR (a calibration's error); the front wheels'
  longer arc in a turn counts as distance, as on a car, and of what they slide sideways in a bend
  only what lies along the way they roll. The distance is the front axle's motion along the way
  its wheels point, not the simulated wheels' turn: PyBullet's rigid wheels leave the floor in
  most physics steps and turn less than they roll, 1 % short at 0.6 m/s, 3.5 % at 2.9 m/s, where a
  rubber tyre on the floor does not;
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
        self._axle = plant.front_axle()  # (x [m], y [m], heading [rad]) at the last count
        self._rolled_m = 0.0  # [m] the front axle's motion along its wheels, signed

    def counts(self) -> int:
        """The encoders' mean count: the front axle's motion since the start along the way its
        wheels point, in turns of the tyre's true radius (the host converts them with the assumed
        one)."""
        x, y, heading = self.plant.front_axle()
        x0, y0, heading0 = self._axle
        way = heading0 + math.remainder(heading - heading0, math.tau) / 2  # the mean over the step
        self._rolled_m += (x - x0) * math.cos(way) + (y - y0) * math.sin(way)
        self._axle = (x, y, heading)
        return math.floor(self._rolled_m / (math.tau * self._true_radius) * self.encoder.counts_per_rev)

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
