"""A lead car's distance by camera, ROAR's first platoon: an ArUco marker on the leader's rear,
found by OpenCV's detector in the follower's frame, its pose from the four corners (solvePnP,
IPPE for a square), and the distance and bearing of its centre from the follower's camera.

    ranger = MarkerRanger(SIMULATED_CAR_CAMERA.model(320, 240))
    seen = ranger.find(rgb)          # MarkerSighting (distance_m, bearing_rad, ahead_m) or None
    ranger.gap_m(rgb)                # [m] follower's reference point to the leader's, or None
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from roar.vision.geometry import CameraModel, cv2

DICTIONARY = "DICT_4X4_50"  # OpenCV's predefined dictionary the marker is drawn from
MARKER_ID = 7
SIDE_M = 0.15  # [m] the marker's black square, border included (0.1 m is lost beyond 1.2 m at 320x240)
CELLS = 6  # across the black square: 4 bits and a border cell each side
MOUNT_BEHIND_M = 0.065  # [m] the marker's face behind the lead car's reference point (the rear axle)


@dataclass(frozen=True)
class MarkerSighting:
    distance_m: float  # [m] from the camera to the marker's centre, over the floor
    bearing_rad: float  # [rad] of the marker's centre from the camera's heading, left +
    ahead_m: float  # [m] of it along the car's heading from the camera


def marker_cells(marker_id: int = MARKER_ID) -> np.ndarray:
    """(CELLS, CELLS) bool, True where the marker is black, row 0 at its top."""
    aruco = cv2().aruco
    image = aruco.generateImageMarker(aruco.getPredefinedDictionary(getattr(aruco, DICTIONARY)), marker_id, CELLS)
    return image < 128


class MarkerRanger:
    """Finds marker `marker_id` of side side_m in a frame of `camera` (the pinhole model of the
    car's camera, tilted down by its pitch)."""

    def __init__(self, camera: CameraModel, marker_id: int = MARKER_ID, side_m: float = SIDE_M) -> None:
        aruco = cv2().aruco
        self.camera, self.marker_id, self.side_m = camera, marker_id, side_m
        parameters = aruco.DetectorParameters()
        parameters.cornerRefinementMethod = aruco.CORNER_REFINE_SUBPIX  # to the edge, not the contour's pixels
        self.detector = aruco.ArucoDetector(aruco.getPredefinedDictionary(getattr(aruco, DICTIONARY)), parameters)
        h = side_m / 2  # its corners as OpenCV's IPPE_SQUARE wants them: top-left, top-right, bottom-right, bottom-left
        self.corners = np.array([[-h, h, 0], [h, h, 0], [h, -h, 0], [-h, -h, 0]], dtype=np.float64)
        self.matrix = np.array([[camera.fx, 0, camera.cx], [0, camera.fy, camera.cy], [0, 0, 1]], dtype=np.float64)

    def find(self, rgb: np.ndarray) -> MarkerSighting | None:
        cv = cv2()
        gray = cv.cvtColor(rgb, cv.COLOR_RGB2GRAY)
        corners, ids, _ = self.detector.detectMarkers(gray)
        if ids is None:
            return None
        for found, marker in zip(corners, ids.ravel()):
            if int(marker) != self.marker_id:
                continue
            ok, _, tvec = cv.solvePnP(self.corners, found.reshape(4, 2).astype(np.float64), self.matrix, None,
                                      flags=cv.SOLVEPNP_IPPE_SQUARE)
            right, down, forward = (float(v) for v in tvec.ravel())
            if not ok or not all(map(math.isfinite, (right, down, forward))) or forward <= 0:
                return None
            c, s = math.cos(self.camera.pitch_rad), math.sin(self.camera.pitch_rad)
            ahead = forward * c - down * s  # the optical axis tilted down by the pitch, in the car's frame
            left = -right
            return MarkerSighting(math.hypot(ahead, left), math.atan2(left, ahead), ahead)
        return None

    def gap_m(self, rgb: np.ndarray) -> float | None:
        """[m] from the follower's reference point to the leader's, as a platoon's gap is kept, or
        None: the marker's distance plus the camera's mount ahead and the marker's behind."""
        seen = self.find(rgb)
        return None if seen is None else seen.distance_m + self.camera.x_m + MOUNT_BEHIND_M
