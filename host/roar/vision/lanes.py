"""Lane lines from a camera frame, the IARRC car's way ("moving ROIs"): blur, bird's-eye view on
a metric grid, HLS, a threshold adapted per 20 x 20 block (saturation and hue for yellow,
lightness for white) and dilation; then each line is walked from near to far: a window a step
long ahead of the last point found, turned to the line's direction (so a line that bends across
the view in a tight bend is followed, not lost), starting where the line began in the frame
before, or for a line found anew at its nearest pixels; a quadratic through the window centres,
in metres in the car's frame, near ones weighed more. The road's centre is the yellow line, or
the white edges each moved a half width in square to themselves, or the one edge seen so moved;
the half width is measured, across from the yellow line, never assumed.

    detector = LaneDetector(BirdsEye(camera))
    lanes = detector.detect(rgb)          # Lanes: left, right, centre as y = a x^2 + b x + c
    lanes.offset_m, lanes.heading_rad     # the car from the road's centre, and against it
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from roar.compiled import compiled
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
MAX_TURN_RAD_PER_M = 2.0  # [rad/m] a painted line bends no tighter than 0.5 m radius: a walk turning more
# has run onto something else (a box's side, a wall's foot)
ELONGATED = 3.0  # a pixel cloud this many times longer than wide has a direction
MIN_AHEAD = 0.5  # a walk along a line stops where it turns more than 60 degrees from ahead (cos 60)


@dataclass(frozen=True)
class Line:
    """y = a x^2 + b x + c [m] in the car's frame, found in `confidence` of the bands."""

    coeffs: tuple[float, float, float]
    confidence: float
    points: np.ndarray = field(repr=False, default_factory=lambda: np.empty((0, 2)))  # (x, y) window centres

    def y(self, x):
        a, b, c = self.coeffs
        return a * np.asarray(x) ** 2 + b * np.asarray(x) + c

    def slope(self, x):
        a, b, _ = self.coeffs
        return 2 * a * np.asarray(x) + b

    def curvature(self) -> float:
        """[1/m] the line's sharpest bend where it was seen: a quadratic through its points in
        the frame of their chord (fitted in the car's frame, an arc that turns across the view
        reads up to 1.6 times too sharp)."""
        p = self.points
        chord = p[-1] - p[0]
        if len(p) < 3 or np.linalg.norm(chord) < 1e-6:
            return 0.0
        along = chord / np.linalg.norm(chord)
        u, v = (p - p[0]) @ along, (p - p[0]) @ np.array([-along[1], along[0]])
        a, b, _ = np.polyfit(u, v, 2)
        slope = 2 * a * np.linspace(u.min(), u.max(), 9) + b
        return float(np.max(np.abs(2 * a) / (1 + slope ** 2) ** 1.5))

    def offset(self, left_m: float) -> Line:
        """The parallel line left_m [m] to the left (right if negative): the points moved square
        to the fit, and fitted again."""
        slope = self.slope(self.points[:, 0])
        normal = np.column_stack([-slope, np.ones_like(slope)]) / np.sqrt(1 + slope ** 2)[:, None]
        return _fit(self.points + left_m * normal, self.confidence)


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
        starts = self._starts(white, yellow)
        found = {"yellow": self._follow(yellow, starts["yellow"])}
        found["left"] = self._follow(white, starts["left"])
        found["right"] = self._follow(white, starts["right"])
        self._measure(found)
        self._check(found)
        self._last = found
        self.debug = {"birds_eye": top, "white": white, "yellow": yellow, "lines": found}
        return self._lanes(found)

    def _measure(self, found: dict[str, Line | None]) -> None:
        """The road's half width from a frame that shows the yellow line and an edge clearly: the
        edge's distance across from the yellow line, square to it (a road of any width: the
        F1TENTH circuits' 2.2 m, where one edge at a time is in view, the simulator's 1.2 m);
        with both edges, only if they lie about as far either side. Kept as a running mean, so
        one odd frame moves it little."""
        yellow = found["yellow"]
        if yellow is None or yellow.confidence < MEASURE_CONFIDENCE:
            return
        halves = [sign * _across(found[name], yellow) for name, sign in (("left", 1), ("right", -1))
                  if found[name] is not None and found[name].confidence >= MEASURE_CONFIDENCE]
        if not halves or min(halves) <= 0 or max(halves) - min(halves) > SYMMETRY * max(halves):
            return
        half = sum(halves) / len(halves)
        if not HALF_WIDTH_RANGE_M[0] <= half <= HALF_WIDTH_RANGE_M[1]:
            return
        self.half_width_m = half if not self.measured else \
            (1 - MEASURE_WEIGHT) * self.half_width_m + MEASURE_WEIGHT * half
        self.measured = True

    def _check(self, found: dict[str, Line | None]) -> None:
        """The seed's consistency check: the edges lie either side of the yellow line about a
        half-width away, and a road's width apart; a line that breaks the layout is dropped."""
        tolerance = 0.6 * self.half_width_m
        if found["yellow"] is not None:
            for name, sign in (("left", 1), ("right", -1)):
                if found[name] is not None and \
                        abs(_across(found[name], found["yellow"]) - sign * self.half_width_m) > tolerance:
                    found[name] = None
        elif found["left"] is not None and found["right"] is not None and \
                abs(_across(found["left"], found["right"]) - 2 * self.half_width_m) > tolerance:
            weaker = "left" if found["left"].confidence < found["right"].confidence else "right"
            found[weaker] = None

    def _starts(self, white: np.ndarray, yellow: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray | None]]:
        """Where each line's walk starts and its direction there, in metres: for a line found in
        the last frame, where and how it began there; for a line without one, at the nearest
        pixels of a peak of its mask's column histogram over the near half (the yellow line's
        strongest, the white edges' outermost either side of it), its direction not known (None)."""
        out = {}
        for name, line in self._last.items():
            if line is not None:  # half a step before its first point, along its first two
                first, second = line.points[0], line.points[1]
                d = (second - first) / max(float(np.linalg.norm(second - first)), 1e-6)
                out[name] = (first - d * self._step_m / 2, d)
        mask = {"yellow": yellow, "left": white, "right": white}
        if "yellow" not in out:
            peaks = self._peaks(yellow)
            y = max(peaks, key=lambda p: p[1])[0] if peaks else 0.0
            out["yellow"] = (self._nearest(yellow, y), None)
        if "left" not in out or "right" not in out:
            # the whole view until the width is measured: on a wide road the edges come into
            # view only further ahead
            y_yellow = float(out["yellow"][0][1])
            peaks = [y for y, _ in self._peaks(white, near_half=self.measured)]
            for name, side, pick in (("left", 1, max), ("right", -1, min)):
                if name in out:
                    continue
                ys = [y for y in peaks if side * (y - y_yellow) > 0]
                y = pick(ys) if ys else y_yellow + side * self.half_width_m
                out[name] = (self._nearest(mask[name], y), None)
        return out

    def _nearest(self, mask: np.ndarray, y: float) -> np.ndarray:
        """(x, y) [m]: where the walk for a line seen at y starts -- half a step before its
        nearest pixel within a window of y (at the near edge if it has none)."""
        _, col = self.bev.to_pixel(0.0, y)
        half_px = WINDOW_M / 2 / self.bev.grid.m_per_px
        lo, hi = int(max(0, col - half_px)), int(max(0, col + half_px))
        hit = np.nonzero(mask[:, lo:hi].any(axis=1))[0]
        x_near = self.bev.grid.x_near
        x = float(self.bev.to_car(hit.max(), 0)[0]) - self._step_m / 2 if len(hit) else x_near
        return np.array([max(x_near, x), y])

    @property
    def _step_m(self) -> float:
        """[m] a walk's step: the view's depth in BANDS steps."""
        return (self.bev.grid.x_far - self.bev.grid.x_near) / BANDS

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

    def _follow(self, mask: np.ndarray, start: tuple[np.ndarray, np.ndarray | None]) -> Line | None:
        """Walk along the line: BANDS steps, each a window WINDOW_M across and a step long ahead
        of the last point found, in the line's direction (so a line that bends across the view
        is followed, not only one running away from the car); the centroid of the window's mask
        pixels is the next point, and the direction turns to run through the last two points
        (a line found anew turns at its first point to its pixels' long axis, when they have one).
        A step that finds nothing goes on in the same direction (a dash's gap, a shadow). A
        quadratic y(x) through the points. (The walk is compiled: roar.vision.walk_kernel.)"""
        d = np.array(start[1] if start[1] is not None else (1.0, 0.0), dtype=float)
        d /= np.linalg.norm(d)
        g = self.bev.grid
        points = np.empty((BANDS, 2))
        found = _walk_kernel()(np.ascontiguousarray(mask), float(start[0][0]), float(start[0][1]), float(d[0]),
                               float(d[1]), start[1] is not None, self._step_m, g.x_far, g.y_left, g.m_per_px,
                               WINDOW_M, MIN_PIXELS, MIN_AHEAD, MAX_TURN_RAD_PER_M, ELONGATED, points)
        points = points[:found]
        confidence = found / BANDS
        return _fit(points, confidence) if confidence >= MIN_CONFIDENCE else None

    def _lanes(self, found: dict[str, Line | None]) -> Lanes:
        left, right, yellow = found["left"], found["right"], found["yellow"]
        if yellow is not None and yellow.confidence >= 0.5:
            centre, source = yellow, "yellow"
        elif left is not None and right is not None:  # each edge moved a half width in, square to itself
            centre, source = _fit(np.vstack([left.offset(-self.half_width_m).points,
                                             right.offset(self.half_width_m).points]),
                                  min(left.confidence, right.confidence)), "edges"
        elif yellow is not None:  # seen in fewer bands (its dashes), but on the centre itself
            centre, source = yellow, "yellow"
        elif left is not None:
            centre, source = left.offset(-self.half_width_m), "left"
        elif right is not None:
            centre, source = right.offset(self.half_width_m), "right"
        else:
            centre, source = None, "none"
        near = None
        if centre is not None:
            x0 = self.bev.grid.x_near
            xs = np.linspace(x0, x0 + NEAR_M, 10)
            slope, intercept = np.polyfit(xs, centre.y(xs), 1)
            near = (float(slope), float(intercept))
        return Lanes(left, right, yellow, centre, source, near)


def _across(line: Line, of: Line) -> float:
    """[m] how far left of the line `of` the line `line` runs, square to `of`: by their fits,
    where `line` was seen nearest (further off, a pixel spans more floor, and an edge line's
    staircase of pixels merges with a wall's lit foot)."""
    x = float(line.points[:, 0].min())
    return float((line.y(x) - of.y(x)) / np.sqrt(1 + of.slope(x) ** 2))


def _fit(points: np.ndarray, confidence: float) -> Line:
    """A quadratic y(x) through points (a straight line through fewer than four), each weighed by
    how near it is: an image pixel spans more floor across the further off it is (and a slanted
    line's staircase of pixels with it)."""
    coeffs = np.polyfit(points[:, 0], points[:, 1], 2 if len(points) >= 4 else 1, w=1 / np.maximum(points[:, 0], 0.1))
    return Line(tuple(float(v) for v in np.concatenate([np.zeros(3 - len(coeffs)), coeffs])), confidence, points)


def _walk_kernel():
    return compiled("the lane detector's walk", _build_walk, "vision")


def _build_walk(nb):
    from roar.vision.walk_kernel import walk

    return walk


def debug_view(detector: LaneDetector, rgb: np.ndarray):
    """A figure: the camera frame, the bird's-eye view with the windows and fits, the masks."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    d = detector.debug
    # margins fixed, not constrained: solving the layout took half of each frame's 0.34 s in roar vision
    fig, axes = plt.subplots(1, 3, figsize=(12, 4))
    fig.subplots_adjust(left=0.04, right=0.99, bottom=0.12, top=0.92, wspace=0.25)
    axes[0].imshow(rgb)
    axes[0].set_title("camera")
    grid = detector.bev.grid  # the bird's-eye image in metres: across (left +) and ahead of the car
    axes[1].imshow(d["birds_eye"], extent=(grid.y_left, grid.y_right, grid.x_near, grid.x_far))
    axes[1].set_title("bird's-eye, windows and fits")
    axes[1].set(xlabel="to the left [m]", ylabel="ahead [m]")
    colours = {"left": "cyan", "right": "magenta", "yellow": "orange"}
    xs = np.linspace(grid.x_near, grid.x_far, 30)
    for name, line in d["lines"].items():
        if line is None:
            continue
        axes[1].plot(line.y(xs), xs, color=colours[name], lw=1.5,
                     label=f"{name} line, fit confidence {line.confidence:.2f}")
        axes[1].scatter(line.points[:, 1], line.points[:, 0], s=12, color=colours[name])
    if any(line is not None for line in d["lines"].values()):  # a legend of nothing is a warning
        axes[1].legend(fontsize=7, loc="lower right", title="dots: the windows' centres", title_fontsize=7)
    axes[2].imshow(np.dstack([d["white"], d["yellow"], np.zeros_like(d["white"])]))
    axes[2].set_title("masks: white (red), yellow (green)")
    for ax in (axes[0], axes[2]):
        ax.axis("off")
    return fig
