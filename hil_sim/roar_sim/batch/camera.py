"""A camera for the batched world's flat worlds: roar_sim.world.ray_camera's, every car's frame at
once. The PyBullet car's camera as roar/Race-v0 has it: the ZED link's place, the same pinhole
(roar.vision's SIMULATED_CAR_CAMERA: vertical field of view, pitch, principal point between the
middle pixels), PyBullet's default light on the same colours, white beyond the far plane, depth
along the optical axis; the floor's paint, the walls, a tunnel's cones and people and any solids
added (boxes, start lights' lamps: FloorPool.add); on request a mount turned per car (shake=, as
roar_sim.sensors.camera_noise shakes it) and the sensor's noise (noise=, its sigma; drawn from each
car's key, the same every run).

    floors = FloorPool(pool)                          # every track's paint, walls and solids
    rgb, depth = render(world, floors, 320, 240)      # uint8 [n, 240, 320, 3], float32 [n, 240, 320]

What it leaves out: other cars, markers standing up, shadows, and the renderers' anti-aliasing.
"""

from __future__ import annotations

import numpy as np

from roar.vision.geometry import SIMULATED_CAR_CAMERA
from roar_sim.batch import kernels as k
from roar_sim.batch.model import URDF_LIDAR_AHEAD_M
from roar_sim.world import ray_camera
from roar_sim.world.appearance import Light

CAMERA_AHEAD_M = 0.39  # [m] the ZED link ahead of the base's origin (racecar.urdf; measured on a settled car)
CAMERA_HEIGHT_M = 0.0908  # [m] ...and above the floor
FAR_M = 10.0  # [m] the renderers' far plane (roar_sim.world.scene.World.render's)


class FloorPool(ray_camera.Scenes):
    """The pool's tracks as the camera sees them: floors, walls (the pool's own distance fields),
    solids."""

    def __init__(self, pool, light: Light | None = None) -> None:
        super().__init__(pool.tracks, light, fields=(pool.field, pool.meta))


def camera_poses(world, shake: np.ndarray | None = None) -> np.ndarray:
    """[n, 5]: each car's camera (x, y, height [m], yaw, pitch [rad]); shake [n, 2]: its mount turned
    by (yaw, pitch) more."""
    states = world.states()
    scale = world.params[:, k.P_LIDAR] / URDF_LIDAR_AHEAD_M  # each car's size over the URDF's
    yaw = states[:, 2]
    ahead = CAMERA_AHEAD_M * scale
    cams = np.column_stack([states[:, 0] + ahead * np.cos(yaw), states[:, 1] + ahead * np.sin(yaw),
                            CAMERA_HEIGHT_M * scale, yaw, np.full(world.n, SIMULATED_CAR_CAMERA.pitch_rad)])
    if shake is not None:
        cams[:, 3] += shake[:, 0]
        cams[:, 4] += shake[:, 1]
    return cams


def render(world, floors: FloorPool, width: int, height: int, shake: np.ndarray | None = None,
           noise: float = 0.0, keys: np.ndarray | None = None, out=None) -> tuple[np.ndarray, np.ndarray]:
    """(RGB uint8 [n, height, width, 3], depth float32 [n, height, width] [m]) of every car's camera."""
    return ray_camera.render(floors, camera_poses(world, shake), world.track_of, width, height,
                             SIMULATED_CAR_CAMERA.fov_deg, FAR_M, noise, keys, out)
