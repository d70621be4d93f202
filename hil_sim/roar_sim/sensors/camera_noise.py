"""A camera as a real car's is: its mount shakes (a small random turn each frame, in yaw and
pitch) and its sensor adds noise to every pixel. Seeded, so a run can be repeated exactly."""

from __future__ import annotations

import math

import numpy as np

SHAKE_RAD = math.radians(0.5)  # [rad] standard deviation of the mount's turn, yaw and pitch
NOISE = 6.0  # [0..255] standard deviation of the sensor's noise per pixel and channel


class ShakyCamera:
    """camera() -> (RGB, depth) of `plant`'s camera at width x height, shaken and noisy."""

    def __init__(self, plant, width: int, height: int, seed: int, shake_rad: float = SHAKE_RAD,
                 noise: float = NOISE) -> None:
        self.plant, self.size, self.shake_rad, self.noise = plant, (width, height), shake_rad, noise
        self.rng = np.random.default_rng(seed)

    def __call__(self) -> tuple[np.ndarray, np.ndarray]:
        yaw, pitch = self.rng.normal(0.0, self.shake_rad, 2)
        rgb, depth = self.plant.camera(*self.size, shake_rad=(float(yaw), float(pitch)))
        noisy = rgb + self.rng.normal(0.0, self.noise, rgb.shape)
        return np.clip(noisy, 0, 255).astype(np.uint8), depth
