"""A 2D scanning lidar, as the racecar carries a Hokuyo UST-10LX: beams over its field of view,
level from its link, each the distance to the first thing it meets (the walls, other cars,
boxes), or its range where it meets nothing."""

from __future__ import annotations

import math

import numpy as np

MIN_RANGE_M = 0.06  # [m] a UST-10LX's minimum range: the beams start this far out
FOV_RAD = math.radians(270)  # [rad]
RANGE_M = 10.0  # [m]
BEAMS = 1080


def scan(world, position, yaw: float, beams: int = BEAMS, fov_rad: float = FOV_RAD,
         range_m: float = RANGE_M, boxes=(), body: int | None = None) -> np.ndarray:
    """Distances [m] from right to left of a scan from `position` facing `yaw` [rad] by the lidar on
    `body`. boxes: other cars' footprints (box_ranges'), met by the beams at any height. Where the
    world can account for every body but those cars and `body` (World.lidar_caster), the beams are
    cast on its walls and solids without Bullet; otherwise Bullet's rays go through the whole world,
    starting at the housing's edge: from the link's centre, inside its own collision box, Bullet
    now and then reports a hit at distance 0 (the lidar seeing itself)."""
    angles = yaw + np.linspace(-fov_rad / 2, fov_rad / 2, beams)
    caster = world.lidar_caster(body, len(boxes), range_m)
    if caster is not None:
        return np.maximum(caster.cast(position, angles, boxes), MIN_RANGE_M)
    directions = np.stack([np.cos(angles), np.sin(angles), np.zeros(beams)], axis=1)
    start = np.asarray(position) + MIN_RANGE_M * directions
    end = np.asarray(position) + range_m * directions
    hits = world.ray_test(start.tolist(), end.tolist())
    reach = range_m - MIN_RANGE_M
    ranges = np.array([MIN_RANGE_M + h[2] * reach if h[0] >= 0 else range_m for h in hits])
    if len(boxes):
        ranges = np.minimum(ranges, box_ranges(position[:2], angles, boxes))
    return ranges


def box_ranges(origin, angles: np.ndarray, boxes) -> np.ndarray:
    """[m] along each beam from origin (x, y) at world angles [rad] to the first box it meets
    (inf where none): boxes (centre x [m], centre y [m], yaw [rad], half length [m], half width [m])
    (the slab method in each box's frame)."""
    out = np.full(len(angles), np.inf)
    dx, dy = np.cos(angles), np.sin(angles)
    for cx, cy, yaw, hl, hw in boxes:
        c, s = math.cos(yaw), math.sin(yaw)
        ox, oy = origin[0] - cx, origin[1] - cy
        px, py = c * ox + s * oy, -s * ox + c * oy  # the origin in the box's frame
        ux, uy = c * dx + s * dy, -s * dx + c * dy  # the beams' directions there
        with np.errstate(divide="ignore", invalid="ignore"):
            t1x, t2x = (-hl - px) / ux, (hl - px) / ux
            t1y, t2y = (-hw - py) / uy, (hw - py) / uy
        near = np.maximum(np.minimum(t1x, t2x), np.minimum(t1y, t2y))
        far = np.minimum(np.maximum(t1x, t2x), np.maximum(t1y, t2y))
        near = np.where(np.isnan(near), -np.inf, near)
        hit = (near <= far) & (near > 0)
        out = np.where(hit, np.minimum(out, near), out)
    return out


NOISE_M = 0.015  # [m] standard deviation of a reading's noise (a UST-10LX: +-40 mm accuracy)


class Lidar:
    """The car's lidar as a real driver gives it: roar.localization.LaserScans of `beams` beams
    over FOV_RAD, each reading with seeded noise (a reading that meets nothing is the range)."""

    def __init__(self, plant, seed: int | None = None, beams: int = BEAMS, noise_m: float = NOISE_M) -> None:
        self.plant, self.beams, self.noise_m = plant, beams, noise_m
        self.rng = np.random.default_rng(seed)

    def ranges(self, others=()) -> np.ndarray:
        """[m] right to left, before the noise: the world and the other cars' footprints."""
        return self.plant.lidar(self.beams, boxes=[o.footprint() for o in others])

    def scan(self, t_s: float, others=()):
        """others: the plants of other cars in its world (met by their footprints)."""
        from roar.localization.scan import LaserScan

        ranges = self.ranges(others)
        hit = ranges < RANGE_M
        ranges[hit] = np.clip(ranges[hit] + self.rng.normal(0.0, self.noise_m, int(hit.sum())), MIN_RANGE_M, RANGE_M)
        return LaserScan.fan(ranges, FOV_RAD, t_s, MIN_RANGE_M, RANGE_M)
