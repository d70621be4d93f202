"""Lines round a track as offsets from its centre line, one offset per centre-line point, so every
line shares the centre line's indexing: the car's place on the track (its segment) is its place
on each line. A racing line, a defensive line and the lanes a passing car may take are each such
an offset, kept where a car of `half_width_m` stays `clearance_m` from the walls, with its own
speed profile (its bends, the car's limits).

    lanes = Lanes(track, half_width_m=0.15)
    racing = lanes.line(lanes.offsets_of(optimal_points))      # a Line: points, offsets, speeds
    beside = lanes.line(np.full(n, 0.5))                       # 0.5 m left of the centre where there is room
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from roar.autopilot.speed_profile import CarLimits, signed_curvature, speed_profile
from roar.tracks.track import Track

CLEARANCE_M = 0.3  # [m] from a car's side to a wall, on any line: pure pursuit cuts inside a bend by up to 0.25 m
DEFEND_AHEAD_M = 3.0  # [m] a defending car covers the inside this far before a bend
DEFEND_SHARE = 0.6  # of the room to the inside a defending car takes
BEND_CURVATURE = 0.15  # [1/m] a bend (radius under 6.7 m) for the defensive line
PROFILE_CHORD_M = 0.3  # [m] between the points a line's speed profile is planned on (as a racing line's)
SMOOTH_M = 1.5  # [m] a defensive line's changes of side are spread over this much track


@dataclass(frozen=True)
class Line:
    points: np.ndarray  # (N, 2) [m] one per centre-line point
    offsets: np.ndarray  # (N,) [m] left of the centre line
    speeds: np.ndarray  # (N,) [m/s] the fastest the car may go at each point
    stretch: np.ndarray  # (N,) the line's length over the centre line's, segment by segment (> 1 outside a bend)


class Lanes:
    def __init__(self, track: Track, half_width_m: float, limits: CarLimits, clearance_m: float = CLEARANCE_M) -> None:
        self.track, self.limits = track, limits
        room = track.half_widths - half_width_m - clearance_m  # (N, 2) left, right
        self.left_room, self.right_room = np.maximum(room[:, 0], 0.0), np.maximum(room[:, 1], 0.0)

    @property
    def n(self) -> int:
        return len(self.track.centerline)

    def clip(self, offsets: np.ndarray) -> np.ndarray:
        """Offsets [m] kept within the room beside the centre line at each point."""
        return np.clip(offsets, -self.right_room, self.left_room)

    def line(self, offsets) -> Line:
        d = self.clip(np.broadcast_to(np.asarray(offsets, dtype=float), (self.n,)).copy())
        points = self.track.centerline + d[:, None] * self.track.normals
        # the profile's curvature over PROFILE_CHORD_M: over the centre line's own spacing, an
        # offset interpolated from another line's points reads kinks no car drives
        step = max(1, int(round(PROFILE_CHORD_M / float(np.mean(self.track.segment_lengths)))))
        picked = np.arange(0, self.n, step)
        speeds = speed_profile(points[picked], self.limits)
        at = np.concatenate([picked, [self.n]])
        stretch = np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1) / self.track.segment_lengths
        return Line(points, d, np.interp(np.arange(self.n), at, np.concatenate([speeds, speeds[:1]])), stretch)

    def offsets_of(self, points: np.ndarray) -> np.ndarray:
        """A closed line (M, 2) as offsets at each centre-line point (interpolated along the lap)."""
        _, s, d = self.track.follow(np.asarray(points, dtype=float)[:, :2])
        order = np.argsort(s)
        s, d = s[order], d[order]
        length = self.track.length_m
        s_wrap = np.concatenate([s - length, s, s + length])
        return np.interp(self.track.arc_start, s_wrap, np.tile(d, 3))

    def defensive_offsets(self) -> np.ndarray:
        """A line that covers the inside of each bend from DEFEND_AHEAD_M before it (a car behind
        cannot dive down the inside), DEFEND_SHARE of the room there, the centre elsewhere."""
        k = signed_curvature(self.track.centerline)
        spacing = float(np.mean(self.track.segment_lengths))
        ahead = max(1, int(round(DEFEND_AHEAD_M / spacing)))
        side = np.zeros(self.n)
        for shift in range(ahead + 1):  # the sharpest bend within reach ahead decides the side
            bend = np.roll(k, -shift)
            stronger = np.abs(bend) > np.abs(side)
            side = np.where(stronger & (np.abs(bend) >= BEND_CURVATURE), bend, side)
        d = np.where(side > 0, DEFEND_SHARE * self.left_room, np.where(side < 0, -DEFEND_SHARE * self.right_room, 0.0))
        window = max(1, int(round(SMOOTH_M / spacing)))
        kernel = np.ones(window) / window
        return np.convolve(np.concatenate([d[-window:], d, d[:window]]), kernel, mode="same")[window:-window]


def segment_at(track: Track, s_m: float) -> int:
    """The centre-line segment at arc length s_m [m] (wrapping round the lap)."""
    return int(np.searchsorted(track.arc_start, s_m % track.length_m, side="right") - 1)

