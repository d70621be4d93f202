"""Orange cones and green floor markers by colour, placed in the world by depth and the pose at
the frame's capture time (the MIT challenge's vision).

Colour is judged by hue and saturation in HSV, with wide ranges, after the frame is smoothed (a
5x5 Gaussian: the sensor's noise) and balanced the way a camera's auto white balance and exposure
would: each channel scaled so the frame's median
is grey (the floor and walls are), then all so that grey sits mid-range. So a dim, dark, warm
or cold light (the simulator's Light; a real room's lamps) leaves the hues in range: orange
OpenCV hue 0-22 (of 180), green 38-90. Each region of enough pixels (after an opening takes out specks) is one object; its
pixels' depths put it in the car's frame (the pinhole camera of roar.vision.geometry), the pose
then in the world. A cone is placed at its centre (its seen surface pushed back by its radius); an
orange region that does not stand on the floor and up from it is not a cone (another car's red parts).

    detector = ObjectDetector(SIMULATED_CAR_CAMERA.model(320, 240))
    for d in detector.detect(rgb, depth, pose_at_capture, t_capture):
        d.kind, d.x, d.y                    # 'cone' | 'marker', world [m]
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from roar.tracks.tunnel import CONE_RADIUS_M
from roar.vision.geometry import CameraModel, cv2

KINDS = ("cone", "marker")
HUE = {"cone": (0, 22), "marker": (38, 90)}  # OpenCV hue (0..180) ranges
MIN_SATURATION = {"cone": 110, "marker": 110}  # of 255 (both paints are 200+ in any light, balanced)
MIN_VALUE = 15  # of 255, as the camera gave it (smoothed): darker pixels' hue is their noise's
MIN_PIXELS = 8  # a region smaller than this is noise
GREY = 110.0  # [0..255] where balancing puts the frame's median
MAX_GAIN = 8.0  # the most balancing brightens a channel (a darker frame stays dark)
MERGE_M = 0.6  # [m] regions of one colour placed nearer than this are one object (a marker, 0.5 m long, seen in
# pieces: dim, or half hidden); two cones or two markers stand at least 1.2 m apart (roar.tracks.tunnel)
MAX_RANGE_M = 4.5  # [m] farther objects are too few pixels to place well
# A cone stands on the floor and stands up: an orange region (not cut by the frame's top or bottom) whose lowest
# point is higher, or which spans less height, is something else -- another car's red parts: the simulated car's
# camera box (0.125-0.155 m up), its wheels' rims (up to 0.1 m, a few centimetres tall)
CONE_BASE_WITHIN_M = 0.08  # [m] of the floor
CONE_SEEN_M = 0.12  # [m] of its CONE_HEIGHT_M (0.3 m) seen at least


@dataclass(frozen=True)
class Detection:
    kind: str  # 'cone' or 'marker'
    x: float  # [m] world
    y: float  # [m]
    t_s: float  # [s] the frame's capture time
    range_m: float  # [m] from the camera
    pixels: int


class ObjectDetector:
    def __init__(self, camera: CameraModel, max_range_m: float = MAX_RANGE_M, min_pixels: int = MIN_PIXELS) -> None:
        self.camera, self.max_range_m, self.min_pixels = camera, max_range_m, min_pixels
        self._v, self._u = np.mgrid[0:camera.height, 0:camera.width]

    @staticmethod
    def balanced(rgb: np.ndarray) -> np.ndarray:
        """The frame with each channel scaled so its median is GREY (grey-world white balance and
        exposure at once)."""
        median = np.median(rgb[::4, ::4].reshape(-1, 3), axis=0).astype(np.float32)
        gain = np.clip(GREY / np.maximum(median, 1.0), 1 / MAX_GAIN, MAX_GAIN)
        return np.clip(rgb * gain, 0, 255).astype(np.uint8)

    def masks(self, rgb: np.ndarray) -> dict[str, np.ndarray]:
        """kind -> (H, W) bool: the pixels of that colour (in the balanced frame)."""
        smooth = cv2().GaussianBlur(np.ascontiguousarray(rgb), (5, 5), 0)  # the sensor's noise, amplified by balancing
        hsv = cv2().cvtColor(self.balanced(smooth), cv2().COLOR_RGB2HSV)
        h, s = hsv[..., 0], hsv[..., 1]
        v = smooth.max(axis=2)  # brightness before balancing: a darker pixel's hue is the noise's
        out = {}
        for kind in KINDS:
            lo, hi = HUE[kind]
            mask = ((h >= lo) & (h <= hi) & (s >= MIN_SATURATION[kind]) & (v >= MIN_VALUE)).astype(np.uint8)
            out[kind] = cv2().morphologyEx(mask, cv2().MORPH_OPEN, np.ones((3, 3), np.uint8)).astype(bool)
        return out

    def detect(self, rgb: np.ndarray, depth: np.ndarray, pose, t_s: float) -> list[Detection]:
        """The cones and markers in a frame (RGB HxWx3, depth HxW [m] along the optical axis) taken
        at t_s from the car's pose (x, y, yaw) then."""
        c = self.camera
        if rgb.shape[:2] != (c.height, c.width) or depth.shape != (c.height, c.width):
            raise ValueError(f"frame {rgb.shape[1]}x{rgb.shape[0]} and depth {depth.shape[::-1]} do not match the "
                             f"camera's {c.width}x{c.height}")
        x0, y0, yaw = pose
        cos_y, sin_y = math.cos(yaw), math.sin(yaw)
        out = []
        for kind, mask in self.masks(rgb).items():
            n, labels, stats, _ = cv2().connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
            for k in range(1, n):
                if stats[k, 4] < self.min_pixels:
                    continue
                sel = labels == k
                z = depth[sel]
                ok = np.isfinite(z) & (z > 0)
                if not ok.any():
                    continue
                ahead, left, up = c.unproject(self._u[sel][ok], self._v[sel][ok], z[ok])
                cut = stats[k, 1] == 0 or stats[k, 1] + stats[k, 3] >= c.height  # the frame cuts it
                if kind == "cone" and not cut and (float(np.min(up)) > CONE_BASE_WITHIN_M
                                                   or float(np.ptp(up)) < CONE_SEEN_M):
                    continue
                fx, fy = float(np.median(ahead)), float(np.median(left))
                rng = math.hypot(fx - c.x_m, fy - c.y_m)
                if rng > self.max_range_m:
                    continue
                if kind == "cone":  # the surface seen -> the cone's axis
                    fx += CONE_RADIUS_M * (fx - c.x_m) / max(rng, 1e-6)
                    fy += CONE_RADIUS_M * (fy - c.y_m) / max(rng, 1e-6)
                out.append(Detection(kind, x0 + cos_y * fx - sin_y * fy, y0 + sin_y * fx + cos_y * fy, float(t_s),
                                     rng, int(stats[k, 4])))
        return _merged(out)


def _merged(found: list[Detection]) -> list[Detection]:
    """Detections of one kind nearer than MERGE_M joined into one, weighted by their pixels."""
    out: list[Detection] = []
    for d in sorted(found, key=lambda d: -d.pixels):
        near = next((i for i, o in enumerate(out) if o.kind == d.kind and math.hypot(o.x - d.x, o.y - d.y) < MERGE_M),
                    None)
        if near is None:
            out.append(d)
            continue
        o = out[near]
        w = o.pixels + d.pixels
        out[near] = Detection(o.kind, (o.x * o.pixels + d.x * d.pixels) / w, (o.y * o.pixels + d.y * d.pixels) / w,
                              o.t_s, min(o.range_m, d.range_m), w)
    return out
