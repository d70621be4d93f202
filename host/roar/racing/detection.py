"""Other cars in a lidar scan: the points the known map does not explain, clustered, each cluster
of a car's size one detection at the car's estimated centre. A scan's beams go round in order,
so a cluster is a run of neighbouring unexplained points (a gap wider than CLUSTER_GAP_M starts the
next); a lidar sees a car's near faces only, so its centre lies beyond them, half a car's depth
further along the ray.

    detector = CarDetector(known)                        # known: roar.tracks.OccupancyMap (walls)
    cars = detector.detect(scan, sensor_pose)            # [Detection(x, y, size_m)] in the world frame
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from roar.localization.scan import LaserScan
from roar.tracks.occupancy_map import OccupancyMap

WALL_M = 0.15  # [m] a point this near a wall of the map is that wall (its cells, the lidar's noise)
CLUSTER_GAP_M = 0.25  # [m] neighbouring points further apart than this belong to different objects
MIN_POINTS = 3  # a cluster of fewer points is noise
MIN_SIZE_M, MAX_SIZE_M = 0.05, 0.9  # [m] a car seen from any side: its width (0.2-0.3 m) to its diagonal
CENTRE_BEHIND_M = 0.1  # [m] from the faces a lidar sees to the car's centre, along the ray (half a car's width)


@dataclass(frozen=True)
class Detection:
    x: float  # [m] world frame, the car's estimated centre
    y: float  # [m]
    size_m: float  # [m] the cluster's extent
    kind: str = "car"


class CarDetector:
    def __init__(self, known: OccupancyMap, wall_m: float = WALL_M) -> None:
        from scipy import ndimage

        self.known, self.wall_m = known, wall_m
        # [m] from each cell to the nearest wall cell (unknown space counts as a wall: nothing drives there)
        solid = known.occupied | ~known.free
        self._to_wall = ndimage.distance_transform_edt(~solid) * known.resolution_m

    def unexplained(self, points: np.ndarray) -> np.ndarray:
        """Which world points (N, 2) lie further than wall_m from every wall of the map (inside it)."""
        cells = np.round(self.known.to_cells(points)).astype(int)
        rows, cols = self._to_wall.shape
        inside = (cells[:, 0] >= 0) & (cells[:, 0] < cols) & (cells[:, 1] >= 0) & (cells[:, 1] < rows)
        far = np.zeros(len(points), dtype=bool)
        far[inside] = self._to_wall[cells[inside, 1], cells[inside, 0]] > self.wall_m
        return far

    def detect(self, scan: LaserScan, sensor_pose: tuple[float, float, float]) -> list[Detection]:
        """The cars in one scan taken from sensor_pose (x [m], y [m], yaw [rad] of the lidar in the world)."""
        local = scan.points()
        if not len(local):
            return []
        sx, sy, yaw = sensor_pose
        c, s = math.cos(yaw), math.sin(yaw)
        world = np.column_stack([sx + c * local[:, 0] - s * local[:, 1], sy + s * local[:, 0] + c * local[:, 1]])
        far = self.unexplained(world)
        found = []
        for run in _runs(world, far):
            if len(run) < MIN_POINTS:
                continue
            size = float(np.linalg.norm(run.max(axis=0) - run.min(axis=0)))
            if not MIN_SIZE_M <= size <= MAX_SIZE_M:
                continue
            centre = run.mean(axis=0)
            away = centre - (sx, sy)
            centre = centre + away / max(float(np.linalg.norm(away)), 1e-6) * CENTRE_BEHIND_M
            found.append(Detection(float(centre[0]), float(centre[1]), size))
        return found


def _runs(points: np.ndarray, keep: np.ndarray) -> list[np.ndarray]:
    """Runs of consecutive kept points no further than CLUSTER_GAP_M apart."""
    kept = np.flatnonzero(keep)
    if not len(kept):
        return []
    steps = np.linalg.norm(np.diff(points[kept], axis=0), axis=1)
    breaks = np.flatnonzero((np.diff(kept) > 1) | (steps > CLUSTER_GAP_M)) + 1
    return [points[part] for part in np.split(kept, breaks)]
