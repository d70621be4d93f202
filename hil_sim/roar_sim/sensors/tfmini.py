"""The TFmini: Benewake's 1-D laser rangefinder, as the IARRC car carried it on its nose. It
measures along the car's heading in a narrow cone, 100 times a second, 0.3 to 12 m, to within
4 cm up to 6 m and 1 % beyond; nothing in range reads as None.

    laser = Tfmini(plant, seed=1)
    laser.read()                            # [m] or None: the latest sample
"""

from __future__ import annotations

import math

import numpy as np


MIN_RANGE_M, MAX_RANGE_M = 0.3, 12.0  # [m]
RATE_HZ = 100  # [Hz] samples
CONE_RAD = math.radians(2.3)  # [rad] the beam's full angle
NEAR_ACCURACY_M = 0.04  # [m] within NEAR_M
NEAR_M = 6.0  # [m]
FAR_ACCURACY = 0.01  # of the distance, beyond NEAR_M
MOUNT_X_M, MOUNT_Z_M = 0.5, 0.1  # [m] ahead of the car's reference point, above the floor


class Tfmini:
    """Rays across the beam's cone (level) from the car's nose; the nearest hit, with the sensor's noise
    (its accuracy as two standard deviations), sampled at RATE_HZ in simulated time."""

    def __init__(self, plant, seed: int = 0) -> None:
        self.plant = plant
        self.rng = np.random.default_rng(seed)
        self._sample: tuple[int, float | None] | None = None  # (sample index, reading)

    def _measure(self) -> float | None:
        s = self.plant.state()
        half = CONE_RAD / 2
        starts, ends = [], []
        for dyaw in (-half, 0.0, half):  # across the cone, level: the floor is not a target
            yaw = s.yaw + dyaw
            start = [s.x + MOUNT_X_M * math.cos(s.yaw), s.y + MOUNT_X_M * math.sin(s.yaw), MOUNT_Z_M]
            direction = [math.cos(yaw), math.sin(yaw), 0.0]
            starts.append(start)
            ends.append([a + MAX_RANGE_M * d for a, d in zip(start, direction)])
        hits = self.plant.world.ray_test(starts, ends)
        distances = [h[2] * MAX_RANGE_M for h in hits if h[0] >= 0 and h[0] != self.plant.car]
        if not distances:
            return None
        true_m = min(distances)
        sigma = (NEAR_ACCURACY_M if true_m <= NEAR_M else FAR_ACCURACY * true_m) / 2
        reading = round(true_m + float(self.rng.normal(0.0, sigma)), 2)  # the sensor reports centimetres
        return reading if MIN_RANGE_M <= reading <= MAX_RANGE_M else None

    def read(self) -> float | None:
        """[m] the latest sample (one per 1/RATE_HZ of simulated time), or None."""
        index = int(self.plant.time_s * RATE_HZ + 1e-9)
        if self._sample is None or self._sample[0] != index:
            self._sample = (index, self._measure())
        return self._sample[1]
