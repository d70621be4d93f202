"""What a car's camera can see from a pose: a floor point inside its field of view, within its
range, and (given the known map) with no wall between. The tracker counts an object missed only
where the camera should have seen it; an object round a bend, behind a corner, is not missed.

    view = CameraView(SIMULATED_CAR_CAMERA.model(320, 240), known_map)
    view.sees((x, y, yaw), px, py)        # True: the camera at that pose would see (px, py)
"""

from __future__ import annotations

import math

import numpy as np

from roar.tracks.occupancy_map import OccupancyMap
from roar.vision.geometry import CameraModel

NEAR_M = 0.8  # [m] from the camera: nearer, an object fills or leaves the frame's bottom and edges
FAR_M = 3.5  # [m] farther, an object is a few pixels: seen in some frames, not in others
FOV_SHARE = 0.8  # of the half field of view: nearer its edges, an object is cut by the frame
SIGHT_SLACK_M = 0.15  # [m] the line of sight may end this short of the point (an object's radius, a cell)


class CameraView:
    def __init__(self, camera: CameraModel, known: OccupancyMap | None = None, near_m: float = NEAR_M,
                 far_m: float = FAR_M, fov_share: float = FOV_SHARE) -> None:
        self.camera, self.near_m, self.far_m = camera, near_m, far_m
        self.half_fov_rad = math.atan(camera.width / 2 / camera.fx) * fov_share  # [rad]
        self._rays = None
        if known is not None:
            from roar.localization.raycast import RayMarcher

            self._rays = RayMarcher(known, far_m + 1.0)

    def camera_xy(self, pose) -> tuple[float, float]:
        """[m] where the camera is when the car is at pose (x, y, yaw)."""
        px, py, yaw = pose
        return (px + self.camera.x_m * math.cos(yaw) - self.camera.y_m * math.sin(yaw),
                py + self.camera.x_m * math.sin(yaw) + self.camera.y_m * math.cos(yaw))

    def sees(self, pose, x: float, y: float) -> bool:
        """Whether the camera at pose (x, y, yaw) [m, m, rad] sees the floor point (x, y) [m]."""
        yaw = pose[2]
        cx, cy = self.camera_xy(pose)
        distance = math.hypot(x - cx, y - cy)
        heading = math.atan2(y - cy, x - cx)
        if not (self.near_m < distance < self.far_m and abs(math.remainder(heading - yaw, math.tau)) < self.half_fov_rad):
            return False
        if self._rays is None:
            return True
        free = float(self._rays.cast(np.array([[cx, cy, heading]]), np.zeros(1))[0, 0])  # [m] to the first wall
        return free >= distance - SIGHT_SLACK_M
