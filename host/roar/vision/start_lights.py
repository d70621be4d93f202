"""Start lights, the IARRC car's way: consecutive frames are compared in a region of the image
(the top half by default), in HSV, and a start is red and green areas changing together: in one
frame, bright saturated red pixels of the frame before went dark (no red left near them) while
bright saturated green pixels lit (no green near them before), each at least `min_pixels`. The
next frame must still show the green (and the red still gone), so one glitch cannot start the
car: it goes on the second frame that shows green.

A shaking camera moves the red lamp -- red leaves one side and covers the other, and nothing
green lights -- and sensor noise does not make dark pixels bright and saturated, so neither
starts the car.

    lights = StartLightDetector()
    for frame in frames:
        if lights.update(frame):          # True from the frame the start is confirmed on
            go()
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from roar.vision.geometry import cv2

MIN_SATURATION = 120  # [0..255] a lamp's colour, not a grey wall's tint
MIN_VALUE = 120  # [0..255] a lit lamp
SHAKE_PX = 4  # [px] a lamp that moved this far between frames only moved
RED_HUES = (8, 172)  # OpenCV hue (0..179): red is <= the first or >= the second
GREEN_HUES = (45, 85)
MIN_PIXELS = 20  # [px] of a 320 x 240 frame: the simulator's lamp at 3 m is ~150


@dataclass(frozen=True)
class LightCounts:
    red: int  # [px] bright red now
    green: int  # [px] bright green now
    red_dark: int  # [px] red the frame before with no red near it now
    green_lit: int  # [px] green now with no green near it the frame before


class StartLightDetector:
    """update(rgb) -> True once green has replaced red (latched until reset()). roi = (top,
    bottom) rows as fractions of the height; the default is the top half, where lights stand."""

    def __init__(self, roi: tuple[float, float] = (0.0, 0.5), min_pixels: int = MIN_PIXELS) -> None:
        self.roi, self.min_pixels = roi, min_pixels
        self.reset()

    def reset(self) -> None:
        self.started = False
        self.frames_seen = 0
        self._previous: tuple[np.ndarray, np.ndarray] | None = None  # (red, green) masks of the frame before
        self._pending: tuple[int, int] | None = None  # (red before, red gone dark) at a switch to confirm
        self.last: LightCounts | None = None

    def _masks(self, rgb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        h = rgb.shape[0]
        top, bottom = (round(f * h) for f in self.roi)
        hsv = cv2().cvtColor(np.ascontiguousarray(rgb[top:bottom]), cv2().COLOR_RGB2HSV)
        hue, sat, value = hsv[..., 0], hsv[..., 1], hsv[..., 2]
        bright = (sat >= MIN_SATURATION) & (value >= MIN_VALUE)
        red = bright & ((hue <= RED_HUES[0]) | (hue >= RED_HUES[1]))
        green = bright & (hue >= GREEN_HUES[0]) & (hue <= GREEN_HUES[1])
        return red, green

    def _near(self, mask: np.ndarray) -> np.ndarray:
        """Where a pixel of `mask` lies within SHAKE_PX: a lamp that only moved is still there."""
        size = 2 * SHAKE_PX + 1
        return cv2().dilate(mask.view(np.uint8), np.ones((size, size), np.uint8)).view(bool)

    def update(self, rgb: np.ndarray) -> bool:
        if self.started:
            return True
        self.frames_seen += 1
        red, green = self._masks(rgb)
        red_dark = green_lit = 0
        if self._previous is not None:
            red_before, green_before = self._previous
            red_dark = int(np.count_nonzero(red_before & ~self._near(red)))
            green_lit = int(np.count_nonzero(green & ~self._near(green_before)))
        self.last = LightCounts(int(red.sum()), int(green.sum()), red_dark, green_lit)
        if self._pending is not None:  # the frame after the switch: is it still green, and red still dark?
            (red_then, went_dark), self._pending = self._pending, None
            if self.last.green >= self.min_pixels and self.last.red <= red_then - went_dark // 2:
                self.started = True
                return True
        if red_dark >= self.min_pixels and green_lit >= self.min_pixels:
            self._pending = (int(self._previous[0].sum()), red_dark)
        self._previous = (red, green)
        return False
