"""Lane lines from a camera frame, the IARRC car's way ("moving ROIs"): blur, bird's-eye view on
a metric grid, HLS, a threshold adapted per 20 x 20 block (saturation and hue for yellow,
lightness for white) and dilation; then, for each line, windows scanned row band by row band
from near to far, each centred by the histogram of the band around where the line was in the
band before (or in the frame before); a quadratic through the window centres, in metres in the
car's frame. The road's centre is the yellow line, or midway between the white edges, or a
half-width from the one edge seen.

    detector = LaneDetector(BirdsEye(camera))
    lanes = detector.detect(rgb)          # Lanes: left, right, centre as y = a x^2 + b x + c
    lanes.offset_m, lanes.heading_rad     # the car from the road's centre, and against it
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from roar.vision.geometry import BirdsEye, cv2

BLOCK_PX = 21  # [px] the adaptive threshold's block (about 20 x 20 as in the seed)
BANDS = 8  # row bands, near to far
WINDOW_M = 0.24  # [m] a window's width
MIN_PIXELS = 6  # mask pixels a window needs to count
HALF_WIDTH_M = 0.5  # [m] from the road's centre to an edge line, until a frame measures it
MEASURE_CONFIDENCE = 0.45  # all three lines found in this share of the bands: a frame that measures the width
# (on a wide road the edges come into view only in the farther half of the bands)
SYMMETRY = 0.2  # the edges' distances from the yellow line may differ by this share, in such a frame
MEASURE_WEIGHT = 0.2  # of a new measurement in the half width kept
HALF_WIDTH_RANGE_M = (0.2, 2.4)  # [m] half widths a measurement may give
MIN_CONFIDENCE = 0.35  # share of bands a line must be found in to be used
NEAR_M = 1.0  # [m] of road beyond the nearest visible row that offset and heading are read from
PEAK_FRACTION = 0.3  # a histogram peak must reach this share of the strongest to be a line


@dataclass(frozen=True)
class Line:
    """y = a x^2 + b x + c [m] in the car's frame, found in `confidence` of the bands."""

    coeffs: tuple[float, float, float]
    confidence: float
    points: np.ndarray = field(repr=False, default_factory=lambda: np.empty((0, 2)))  # (x, y) window centres

    def y(self, x):
        a, b, c = self.coeffs
        return a * np.asarray(x) ** 2 + b * np.asarray(x) + c

    def slope(self, x: float) -> float:
        a, b, _ = self.coeffs
        return 2 * a * x + b

    def shifted(self, dy: float, confidence: float | None = None) -> Line:
        a, b, c = self.coeffs
        return Line((a, b, c + dy), self.confidence if confidence is None else confidence, self.points + [0, dy])


@dataclass(frozen=True)
class Lanes:
    left: Line | None  # the left white edge
    right: Line | None
    yellow: Line | None  # the dashed centre line
    centre: Line | None  # the road's centre, from whichever lines were seen
    source: str  # how the centre was found: yellow, edges, left, right, none
    near: tuple[float, float] | None = None  # the centre's straight fit over the nearest metre: (slope, y at 0)

    @property
    def offset_m(self) -> float | None:
        """[m] the car's reference point left (+) of the road's centre (its nearest metre
        extended to the car), or None."""
        return None if self.near is None else -self.near[1]

    @property
    def heading_rad(self) -> float | None:
        """[rad] the car's heading against the road's centre line near the car, anticlockwise +."""
        return None if self.near is None else -math.atan(self.near[0])


def masks(bev_rgb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(white, yellow) uint8 masks of a bird's-eye RGB image."""
    cv = cv2()
    hls = cv.cvtColor(cv.GaussianBlur(bev_rgb, (3, 3), 0), cv.COLOR_RGB2HLS)
    h, light, sat = hls[:, :, 0], hls[:, :, 1], hls[:, :, 2]
    brighter = cv.adaptiveThreshold(light, 255, cv.ADAPTIVE_THRESH_MEAN_C, cv.THRESH_BINARY, BLOCK_PX, -25)
    white = brighter & ((light > 170) & (sat < 80)).astype(np.uint8) * 255
    saturated = cv.adaptiveThreshold(sat, 255, cv.ADAPTIVE_THRESH_MEAN_C, cv.THRESH_BINARY, BLOCK_PX, -20)
    yellow = saturated & ((h >= 15) & (h <= 40) & (sat > 90) & (light > 50)).astype(np.uint8) * 255
    kernel = np.ones((3, 3), np.uint8)
    return cv.dilate(white, kernel), cv.dilate(yellow, kernel)


class LaneDetector:
    """Keeps each line's fit from frame to frame (the moving ROIs); detect() one frame at a time."""

    def __init__(self, birds_eye: BirdsEye, half_width_m: float = HALF_WIDTH_M) -> None:
        self.bev, self.initial_half_width_m = birds_eye, half_width_m
        self._last: dict[str, Line | None] = {"left": None, "right": None, "yellow": None}
        self.debug: dict = {}  # the last frame's bird's-eye image, masks and windows
        self.reset()

    def reset(self) -> None:
        self._last = dict.fromkeys(self._last)
        self.half_width_m = self.initial_half_width_m  # [m] the road's centre to an edge, as measured
        self.measured = False  # whether a frame has measured it yet

    def detect(self, rgb: np.ndarray) -> Lanes:
        top = self.bev.warp(rgb)
        white, yellow = masks(top)
        guesses = self._guesses(white, yellow)
        found = {"yellow": self._follow(yellow, guesses["yellow"])}
        found["left"] = self._follow(white, guesses["left"])
        found["right"] = self._follow(white, guesses["right"])
        self._measure(found)
        self._check(found)
        self._last = found
        self.debug = {"birds_eye": top, "white": white, "yellow": yellow, "lines": found}
        return self._lanes(found)

    def _measure(self, found: dict[str, Line | None]) -> None:
        """The road's half width from a frame that shows all three lines clearly, the two edges
        as far either side of the yellow line (a road of any width: the F1TENTH circuits' 2.2 m,
        the simulator's 1.2 m); kept as a running mean, so one odd frame moves it little."""
        if any(line is None or line.confidence < MEASURE_CONFIDENCE for line in found.values()):
            return
        x = self.bev.grid.x_near + 0.5
        left, right = float(found["left"].y(x) - found["yellow"].y(x)), float(found["yellow"].y(x) - found["right"].y(x))
        if min(left, right) <= 0 or abs(left - right) > SYMMETRY * max(left, right):
            return
        half = (left + right) / 2
        if not HALF_WIDTH_RANGE_M[0] <= half <= HALF_WIDTH_RANGE_M[1]:
            return
        self.half_width_m = half if not self.measured else \
            (1 - MEASURE_WEIGHT) * self.half_width_m + MEASURE_WEIGHT * half
        self.measured = True

    def _check(self, found: dict[str, Line | None]) -> None:
        """The seed's consistency check: the edges lie either side of the yellow line about a
        half-width away, and a road's width apart; a line that breaks the layout is dropped."""
        x = self.bev.grid.x_near + 0.5
        y = {name: None if line is None else float(line.y(x)) for name, line in found.items()}
        tolerance = 0.6 * self.half_width_m
        if y["yellow"] is not None:
            for name, sign in (("left", 1), ("right", -1)):
                if y[name] is not None and abs(y[name] - y["yellow"] - sign * self.half_width_m) > tolerance:
                    found[name] = None
        elif y["left"] is not None and y["right"] is not None and \
                abs(y["left"] - y["right"] - 2 * self.half_width_m) > tolerance:
            weaker = "left" if found["left"].confidence < found["right"].confidence else "right"
            found[weaker] = None

    def _guesses(self, white: np.ndarray, yellow: np.ndarray) -> dict[str, float]:
        """Where each line starts at the near edge [m]: last frame's fit; for a line without one,
        a peak of its mask's column histogram over the near half (the yellow line's strongest,
        the white edges' outermost either side of it)."""
        out = {}
        for name, line in self._last.items():
            if line is not None:
                out[name] = float(line.y(self.bev.grid.x_near))
        if "yellow" not in out:
            peaks = self._peaks(yellow)
            out["yellow"] = max(peaks, key=lambda p: p[1])[0] if peaks else 0.0
        if "left" not in out or "right" not in out:
            # the whole view until the width is measured: on a wide road the edges come into
            # view only further ahead
            peaks = [y for y, _ in self._peaks(white, near_half=self.measured)]
            left = [y for y in peaks if y > out["yellow"]]
            right = [y for y in peaks if y < out["yellow"]]
            out.setdefault("left", max(left) if left else out["yellow"] + self.half_width_m)
            out.setdefault("right", min(right) if right else out["yellow"] - self.half_width_m)
        return out

    def _peaks(self, mask: np.ndarray, near_half: bool = True) -> list[tuple[float, float]]:
        """[(y [m], strength)] of the column histogram's peaks over the near half (or the whole
        view)."""
        rows = mask.shape[0]
        histogram = mask[rows // 2 if near_half else 0:].sum(axis=0).astype(float)
        if histogram.max() <= 0:
            return []
        smooth = np.convolve(histogram, np.ones(9) / 9, mode="same")
        floor = PEAK_FRACTION * smooth.max()
        peaks = [c for c in range(1, len(smooth) - 1)
                 if smooth[c] >= floor and smooth[c] >= smooth[c - 1] and smooth[c] > smooth[c + 1]]
        return [(float(self.bev.to_car(0, c)[1]), float(smooth[c])) for c in peaks]

    def _follow(self, mask: np.ndarray, y_start: float) -> Line | None:
        """Windows from the near band to the far one, each centred on the band's histogram peak
        near where the line was in the band before; a quadratic through their centres."""
        rows, cols = mask.shape
        band_rows = rows // BANDS
        half_px = WINDOW_M / 2 / self.bev.grid.m_per_px
        _, col = self.bev.to_pixel(0.0, y_start)
        points, drift = [], 0.0
        for band in range(BANDS):
            r1 = rows - band * band_rows
            r0 = r1 - band_rows
            lo, hi = int(max(0, col - half_px)), int(min(cols, col + half_px))
            if hi - lo < 2:
                break
            histogram = mask[r0:r1, lo:hi].sum(axis=0) / 255
            if histogram.sum() >= MIN_PIXELS:
                peak = lo + float(np.average(np.arange(hi - lo), weights=histogram))
                drift = peak - col
                col = peak
                points.append(self.bev.to_car((r0 + r1) / 2, col))
            else:
                col += drift  # keep the line's direction through a gap (a dash, a shadow)
        confidence = len(points) / BANDS
        if confidence < MIN_CONFIDENCE:
            return None
        p = np.array(points, dtype=float)
        degree = 2 if len(p) >= 4 else 1
        coeffs = np.polyfit(p[:, 0], p[:, 1], degree)
        coeffs = tuple(float(v) for v in np.concatenate([np.zeros(3 - len(coeffs)), coeffs]))
        return Line(coeffs, confidence, p)

    def _lanes(self, found: dict[str, Line | None]) -> Lanes:
        left, right, yellow = found["left"], found["right"], found["yellow"]
        if yellow is not None and yellow.confidence >= 0.5:
            centre, source = yellow, "yellow"
        elif left is not None and right is not None:
            a = [(l + r) / 2 for l, r in zip(left.coeffs, right.coeffs)]
            centre, source = Line(tuple(a), min(left.confidence, right.confidence)), "edges"
        elif yellow is not None:  # seen in fewer bands (its dashes), but on the centre itself
            centre, source = yellow, "yellow"
        elif left is not None:
            centre, source = left.shifted(-self.half_width_m), "left"
        elif right is not None:
            centre, source = right.shifted(self.half_width_m), "right"
        else:
            centre, source = None, "none"
        near = None
        if centre is not None:
            x0 = self.bev.grid.x_near
            xs = np.linspace(x0, x0 + NEAR_M, 10)
            slope, intercept = np.polyfit(xs, centre.y(xs), 1)
            near = (float(slope), float(intercept))
        return Lanes(left, right, yellow, centre, source, near)


def debug_view(detector: LaneDetector, rgb: np.ndarray):
    """A figure: the camera frame, the bird's-eye view with the windows and fits, the masks."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    d = detector.debug
    fig, axes = plt.subplots(1, 3, figsize=(12, 4), constrained_layout=True)
    axes[0].imshow(rgb)
    axes[0].set_title("camera")
    axes[1].imshow(d["birds_eye"])
    axes[1].set_title("bird's-eye, windows and fits")
    colours = {"left": "cyan", "right": "magenta", "yellow": "orange"}
    xs = np.linspace(detector.bev.grid.x_near, detector.bev.grid.x_far, 30)
    for name, line in d["lines"].items():
        if line is None:
            continue
        r, c = detector.bev.to_pixel(xs, line.y(xs))
        axes[1].plot(c, r, color=colours[name], lw=1.5, label=f"{name} {line.confidence:.2f}")
        pr, pc = detector.bev.to_pixel(line.points[:, 0], line.points[:, 1])
        axes[1].scatter(pc, pr, s=12, color=colours[name])
    if any(line is not None for line in d["lines"].values()):  # a legend of nothing is a warning
        axes[1].legend(fontsize=7, loc="lower right")
    axes[2].imshow(np.dstack([d["white"], d["yellow"], np.zeros_like(d["white"])]))
    axes[2].set_title("masks: white (red), yellow (green)")
    for ax in axes:
        ax.axis("off")
    return fig
