"""A forward camera over a flat floor: where a floor point appears in the image, and the
bird's-eye view -- the image warped onto a metric grid of the floor in the car's frame (x ahead,
y to the left, metres from the car's reference point).

    cam = CameraModel.from_fov(320, 240, fov_deg=70, x_m=0.39, z_m=0.0935, pitch_rad=0.245)
    cam = SIMULATED_CAR_CAMERA.model(320, 240)       # the same: the simulated ESC car's camera
    bev = BirdsEye(cam)                      # 0.45..2.5 m ahead, +-1.6 m, 1 cm a pixel
    top = bev.warp(rgb)                      # row 0 is the far edge, column 0 the left edge
    x, y = bev.to_car(row, col)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def cv2():
    try:
        import cv2 as module
    except ImportError:
        raise ImportError("roar.vision needs OpenCV: pip install 'roar-platform[vision]'", name="cv2") from None
    return module


@dataclass(frozen=True)
class CameraModel:
    width: int  # [px]
    height: int  # [px]
    fx: float  # [px]
    fy: float  # [px]
    cx: float  # [px]
    cy: float  # [px]
    x_m: float  # [m] ahead of the car's reference point
    y_m: float  # [m] to its left
    z_m: float  # [m] above the floor
    pitch_rad: float  # [rad] tilted down from level

    @classmethod
    def from_fov(cls, width: int, height: int, fov_deg: float, x_m: float, z_m: float, pitch_rad: float,
                 y_m: float = 0.0) -> CameraModel:
        """A pinhole camera with square pixels, the principal point at the image's centre, and a
        vertical field of view fov_deg. Pixel (0, 0)'s centre is at (0, 0), as OpenCV counts:
        the centre of a 320 x 240 image is at (159.5, 119.5)."""
        f = (height / 2) / math.tan(math.radians(fov_deg) / 2)
        return cls(width, height, f, f, (width - 1) / 2, (height - 1) / 2, x_m, y_m, z_m, pitch_rad)

    def unproject(self, u, v, depth) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(x ahead, y left, z up) [m] in the car's frame of pixels (u, v) seen at depth [m] along
        the optical axis (the inverse of project, off the floor too)."""
        z = np.asarray(depth, dtype=np.float64)
        right = (np.asarray(u) - self.cx) / self.fx * z
        down = (np.asarray(v) - self.cy) / self.fy * z
        c, s = math.cos(self.pitch_rad), math.sin(self.pitch_rad)
        return self.x_m + z * c - down * s, self.y_m - right, self.z_m - z * s - down * c

    def project(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(u, v) [px] of floor points (x, y) in the car's frame (points behind the camera give
        nonsense; keep x ahead of it)."""
        dx, dy, dz = np.asarray(x) - self.x_m, np.asarray(y) - self.y_m, -self.z_m
        c, s = math.cos(self.pitch_rad), math.sin(self.pitch_rad)
        forward = dx * c - dz * s  # along the optical axis
        down = -(dx * s + dz * c)  # image rows grow downwards
        right = -dy
        return self.cx + self.fx * right / forward, self.cy + self.fy * down / forward


@dataclass(frozen=True)
class CameraPreset:
    """A car's camera at any resolution: its vertical field of view and where it is mounted."""

    fov_deg: float  # [deg] vertical field of view
    x_m: float  # [m] ahead of the car's reference point (the rear axle)
    z_m: float  # [m] above the floor
    pitch_rad: float  # [rad] tilted down from level
    y_m: float = 0.0  # [m] to the left

    def model(self, width: int, height: int) -> CameraModel:
        return CameraModel.from_fov(width, height, self.fov_deg, self.x_m, self.z_m, self.pitch_rad, self.y_m)


# The simulated ESC car's camera: the ZED link of PyBullet's racecar.urdf (9.35 cm up with the car
# standing on its wheels), tilted down a quarter.
SIMULATED_CAR_CAMERA = CameraPreset(fov_deg=70.0, x_m=0.39, z_m=0.0935, pitch_rad=math.atan(0.25))


@dataclass(frozen=True)
class Grid:
    """The bird's-eye grid: x_near..x_far ahead, y_right..y_left across, m_per_px a pixel."""

    x_near: float = 0.45  # [m]
    x_far: float = 2.5  # [m]
    y_left: float = 1.6  # [m] wide enough to keep a bending line in view
    y_right: float = -1.6  # [m]
    m_per_px: float = 0.01  # [m]

    @property
    def shape(self) -> tuple[int, int]:
        return (round((self.x_far - self.x_near) / self.m_per_px), round((self.y_left - self.y_right) / self.m_per_px))


class BirdsEye:
    def __init__(self, camera: CameraModel, grid: Grid = Grid()) -> None:
        self.camera, self.grid = camera, grid
        rows, cols = grid.shape
        corners_px = np.float32([[0, 0], [cols - 1, 0], [cols - 1, rows - 1], [0, rows - 1]])
        corners_m = [self.to_car(r, c) for c, r in corners_px]
        u, v = camera.project(np.array([p[0] for p in corners_m]), np.array([p[1] for p in corners_m]))
        self._homography = cv2().getPerspectiveTransform(np.float32(np.column_stack([u, v])), corners_px)

    def warp(self, image: np.ndarray) -> np.ndarray:
        rows, cols = self.grid.shape
        return cv2().warpPerspective(image, self._homography, (cols, rows), flags=1)  # 1: INTER_LINEAR

    def to_car(self, row, col):
        """(x, y) [m] in the car's frame of a bird's-eye pixel (row, col)."""
        g = self.grid
        return g.x_far - np.asarray(row) * g.m_per_px, g.y_left - np.asarray(col) * g.m_per_px

    def to_pixel(self, x, y):
        """(row, col) of a car-frame floor point."""
        g = self.grid
        return (g.x_far - np.asarray(x)) / g.m_per_px, (g.y_left - np.asarray(y)) / g.m_per_px
