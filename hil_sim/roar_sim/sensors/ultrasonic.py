"""The HC-SR04 ultrasonic ranger, as the Junior carries it: a cone of rays, 2..400 cm; only
obstacles echo (the floor, met at a grazing angle, reflects the sound away rather than back)."""

from __future__ import annotations

import math

import numpy as np

MIN_RANGE_M, MAX_RANGE_M = 0.02, 4.0  # [m]
CONE_DEG = 15.0  # [deg] full angle
RAYS = 5  # per side of the cone, horizontally and vertically (3.75 degrees apart)


def _cone_rays() -> list[tuple[float, float, float]]:
    """The rays [m] to the maximum range, in the sensor's frame (facing +x)."""
    half = math.radians(CONE_DEG / 2)
    angles = np.linspace(-half, half, RAYS)
    az, el = (a.ravel() for a in np.meshgrid(angles, angles))
    rays = np.stack([np.cos(az) * np.cos(el), np.sin(az) * np.cos(el), np.sin(el)], axis=1) * MAX_RANGE_M
    return [tuple(ray) for ray in rays.tolist()]


CONE = _cone_rays()


def reading_cm(world, origin, yaw: float, ignored: set[int]) -> int:
    """What the sensor at `origin` facing `yaw` [rad] reports: the nearest echo in its cone in
    whole cm, 2..400, or 0 when nothing is within range (no echo); bodies in `ignored` (its own
    robot, the floor) never echo."""
    c, s = math.cos(yaw), math.sin(yaw)
    ox, oy, oz = origin
    ends = [(ox + x * c - y * s, oy + x * s + y * c, oz + z) for x, y, z in CONE]
    hits = world.ray_test([list(origin)] * len(ends), ends)
    ranges = [h[2] * MAX_RANGE_M for h in hits if h[0] not in ignored | {-1}]
    if not ranges:
        return 0
    return int(round(max(MIN_RANGE_M, min(ranges)) * 100))
