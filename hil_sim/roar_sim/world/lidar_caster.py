"""The world as a level lidar meets it, without Bullet: the track's walls as 2D boxes, and the
static solids (cubes, and the circles cones and people make at the lidar's height), each beam
cast on them in compiled loops (beam_kernels). World.lidar_caster hands one to a lidar
(roar_sim.sensors.lidar) while the world can account for every body its beams may meet."""

from __future__ import annotations

import numpy as np


def wall_boxes(track, wall_thickness_m: float) -> np.ndarray:
    """(K, 5) a track's walls as the simulator builds them (roar_sim.world.scene: each wall segment
    a box wall_thickness_m [m] thick, half a thickness longer at each end), as 2D boxes: centre x
    [m], centre y [m], yaw [rad], half length [m], half width [m]."""
    boxes = []
    for wall in track.walls:
        a, b = wall, np.roll(wall, -1, axis=0)
        d = b - a
        half_length = np.linalg.norm(d, axis=1) / 2 + wall_thickness_m / 2
        boxes.append(np.column_stack([(a + b) / 2, np.arctan2(d[:, 1], d[:, 0]), half_length,
                                      np.full(len(a), wall_thickness_m / 2)]))
    return np.ascontiguousarray(np.concatenate(boxes)) if boxes else np.zeros((0, 5))


class Caster:
    """A world's walls and static solids as a level lidar meets them, and the beams cast on them in
    compiled loops: boxes (the walls, cubes) by the slab method, the cross-sections of cylinders
    and cones at the lidar's height as circles. The ranges Bullet's rays find there, ~20-100 x
    faster (1,080 beams every period cost Bullet 3-8 ms among walls, ~22 ms among a tunnel's cones
    and people).

    solids: (M, 7) rows of centre x [m], centre y [m], yaw [rad], half length [m], half width [m]
    (a box; 0, 0 for a round solid), radius at the floor [m] (0 for a box), height [m]; a round
    solid with a negative radius is a cone (its radius -r at the floor, 0 at its top)."""

    def __init__(self, walls: np.ndarray, solids: np.ndarray, range_m: float) -> None:
        self.boxes, self.solids, self.range_m = walls, np.asarray(solids, dtype=float).reshape(-1, 7), range_m
        self._reach = np.hypot(self.boxes[:, 3], self.boxes[:, 4]) + range_m  # [m] a box this near may be met
        from roar.compiled import compiled  # (not at start-up: every simulated car imports this module)

        self._slabs, self._circles = compiled("the simulated lidar's ray casting", _kernels, "sim")

    def sections(self, z_m: float) -> tuple[np.ndarray, np.ndarray]:
        """(boxes (K, 5), circles (M, 3): centre x, centre y, radius [m]) of the solids at height z_m."""
        s = self.solids[self.solids[:, 6] > z_m]
        round_ = s[:, 5] != 0
        radius = np.where(s[:, 5] > 0, s[:, 5], -s[:, 5] * (1 - z_m / s[:, 6]))
        return s[~round_, :5], np.column_stack([s[round_, :2], radius[round_]])

    def cast(self, origin, angles: np.ndarray, others=()) -> np.ndarray:
        """[m] along each beam from origin (x, y, z) at world angles [rad] to the first wall, solid or
        box of `others` ((centre x, centre y, yaw, half length, half width)) it meets; range_m if none."""
        near = np.hypot(self.boxes[:, 0] - origin[0], self.boxes[:, 1] - origin[1]) < self._reach
        boxes, circles = self.sections(float(origin[2]))
        boxes = np.concatenate([self.boxes[near], boxes, np.asarray(others, dtype=float).reshape(-1, 5)])
        out = np.full(len(angles), self.range_m)
        angles = np.ascontiguousarray(angles, dtype=float)
        self._slabs(float(origin[0]), float(origin[1]), angles, np.ascontiguousarray(boxes), out)
        if len(circles):
            self._circles(float(origin[0]), float(origin[1]), angles, np.ascontiguousarray(circles), out)
        return out


def _kernels(nb):
    from roar_sim.world.beam_kernels import circles, slabs

    return slabs, circles
