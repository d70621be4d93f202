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
         range_m: float = RANGE_M, boxes=()) -> np.ndarray:
    """Distances [m] from right to left of a scan from `position` facing `yaw` [rad]. The beams
    start at the housing's edge: from the link's centre, inside its own collision box, Bullet now
    and then reports a hit at distance 0 (the lidar seeing itself). boxes: other cars' footprints
    (box_ranges'), met by the beams at any height; the world's rays then go to its walls alone."""
    angles = yaw + np.linspace(-fov_rad / 2, fov_rad / 2, beams)
    directions = np.stack([np.cos(angles), np.sin(angles), np.zeros(beams)], axis=1)
    start = np.asarray(position) + MIN_RANGE_M * directions
    end = np.asarray(position) + range_m * directions
    hits = world.ray_test(start.tolist(), end.tolist(), walls_only=bool(len(boxes)))
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


class WallCaster:
    """A world's walls as 2D boxes (each wall segment as the simulator builds it: WALL_THICKNESS_M
    thick, half a thickness longer at each end) and beams cast on them by the slab method in one
    compiled loop over the boxes in range: the ranges Bullet's rays find among the walls, ~20 x
    faster (a race's 1,080 beams every period cost Bullet 3-8 ms)."""

    def __init__(self, track, wall_thickness_m: float, range_m: float = RANGE_M) -> None:
        """track: its walls (Track.walls, the centre lines of the simulator's wall boxes);
        wall_thickness_m [m]: theirs (roar_sim.world.scene.WALL_THICKNESS_M)."""
        boxes = []
        for wall in track.walls:
            a, b = wall, np.roll(wall, -1, axis=0)
            d = b - a
            half_length = np.linalg.norm(d, axis=1) / 2 + wall_thickness_m / 2
            boxes.append(np.column_stack([(a + b) / 2, np.arctan2(d[:, 1], d[:, 0]), half_length,
                                          np.full(len(a), wall_thickness_m / 2)]))
        self.boxes = np.ascontiguousarray(np.concatenate(boxes))
        self.range_m = range_m
        self._reach = np.hypot(self.boxes[:, 3], self.boxes[:, 4]) + range_m  # [m] a box this near may be met
        from roar.compiled import compiled  # (not at start-up: every simulated car imports this module)

        self._slabs = compiled("the simulated lidar's wall slabs", _slab_kernel, "sim")

    def cast(self, origin, angles: np.ndarray, others=()) -> np.ndarray:
        """[m] along each beam from origin (x, y) at world angles [rad] to the first wall or box of
        `others` ((centre x, centre y, yaw, half length, half width)) it meets; range_m if none."""
        near = np.hypot(self.boxes[:, 0] - origin[0], self.boxes[:, 1] - origin[1]) < self._reach
        boxes = self.boxes[near]
        if len(others):
            boxes = np.concatenate([boxes, np.asarray(others, dtype=float).reshape(-1, 5)])
        out = np.full(len(angles), self.range_m)
        self._slabs(float(origin[0]), float(origin[1]), np.ascontiguousarray(angles, dtype=float),
                    np.ascontiguousarray(boxes), out)
        return out


def _slab_kernel(nb):
    from roar_sim.sensors.slab_kernel import slabs

    return slabs


class Lidar:
    """The car's lidar as a real driver gives it: roar.localization.LaserScans of `beams` beams
    over FOV_RAD, each reading with seeded noise (a reading that meets nothing is the range).
    walls: a WallCaster of its world, which holds those walls alone (as a race's does): the beams
    are cast on them here rather than by Bullet's rays, the same ranges ~20 x faster."""

    def __init__(self, plant, seed: int | None = None, beams: int = BEAMS, noise_m: float = NOISE_M,
                 walls: WallCaster | None = None) -> None:
        self.plant, self.beams, self.noise_m = plant, beams, noise_m
        self.rng = np.random.default_rng(seed)
        self.caster = walls
        self._angles = np.linspace(-FOV_RAD / 2, FOV_RAD / 2, beams)

    def ranges(self, others=()) -> np.ndarray:
        """[m] right to left, before the noise: the walls and the other cars' footprints."""
        boxes = [o.footprint() for o in others]
        if self.caster is None:
            return self.plant.lidar(self.beams, boxes=boxes)
        x, y, yaw = self.plant.lidar_pose()
        return np.maximum(self.caster.cast((x, y), yaw + self._angles, boxes), MIN_RANGE_M)

    def scan(self, t_s: float, others=()):
        """others: the plants of other cars in its world (met by their footprints)."""
        from roar.localization.scan import LaserScan

        ranges = self.ranges(others)
        hit = ranges < RANGE_M
        ranges[hit] = np.clip(ranges[hit] + self.rng.normal(0.0, self.noise_m, int(hit.sum())), MIN_RANGE_M, RANGE_M)
        return LaserScan.fan(ranges, FOV_RAD, t_s, MIN_RANGE_M, RANGE_M)
