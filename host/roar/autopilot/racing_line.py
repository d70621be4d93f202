"""The minimum-curvature racing line of a track, and the lap limit it gives.

Each centre-line point (resampled every SPACING_M) may move along its normal by an offset a_i,
within the walls less the car's clearance (its half width and a margin):

    P_i = c_i + a_i n_i,      -(right_i - clearance) <= a_i <= left_i - clearance

and the line is the one whose summed squared second differences (P_{i-1} - 2 P_i + P_{i+1}),
which for evenly spaced points are its curvature times the spacing squared, are least: a convex
QP in the offsets (|A a + b|^2 with box bounds), solved sparse by OSQP. As the line moves its
points spread unevenly, so the line found is spaced evenly again and the QP solved about it
(along its own normals, within the walls as they lie from its points) until it settles: the
iterated QP TUM's own pipeline runs. Its speed profile is speed_profile()'s,
under the same limits as the centre line's, so the two lap limits compare like with like.

    line = racing_line(track, clearance_m=0.33)
    line.points, line.offsets_m, line.lap_time_s(limits)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from roar.autopilot.speed_profile import CarLimits, curvature, lap_time, speed_profile
from roar.tracks.track import evenly_spaced

SPACING_M = 0.25  # [m] between the line's points
ITERATIONS = 12  # solves at most, each about the line the one before found (evenly spaced again)
MIN_CORRIDOR_M = 0.02  # [m] the narrowest band a point may move in, where the walls leave less


@dataclass(frozen=True)
class RacingLine:
    points: np.ndarray  # (N, 2) [m] closed, no repeated last point
    offsets_m: np.ndarray  # (N,) [m] to the left of the centre line
    centre: np.ndarray  # (N, 2) [m] the resampled centre line the offsets are from

    def speeds(self, limits: CarLimits) -> np.ndarray:
        return speed_profile(self.points, limits)

    def lap_time_s(self, limits: CarLimits) -> float:
        return lap_time(self.points, self.speeds(limits))

    @property
    def max_curvature(self) -> float:
        return float(curvature(self.points).max())


def _resample(track, spacing_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(points, normals, (left, right) half widths) every ~spacing_m along the centre line."""
    n = max(16, int(round(track.length_m / spacing_m)))
    at = np.linspace(0.0, track.length_m, n, endpoint=False)
    seg = np.searchsorted(track.arc_start, at, side="right") - 1
    t = (at - track.arc_start[seg]) / track.segment_lengths[seg]
    nxt = (seg + 1) % len(track.centerline)
    points = track.centerline[seg] + t[:, None] * (track.centerline[nxt] - track.centerline[seg])
    halves = track.half_widths[seg] + t[:, None] * (track.half_widths[nxt] - track.half_widths[seg])
    tangent = np.roll(points, -1, axis=0) - np.roll(points, 1, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    return points, np.stack([-tangent[:, 1], tangent[:, 0]], axis=1), halves


def _second_difference(n: int):
    import scipy.sparse as sp

    i = np.arange(n)
    rows = np.concatenate([i, i, i])
    cols = np.concatenate([(i - 1) % n, i, (i + 1) % n])
    values = np.concatenate([np.ones(n), -2 * np.ones(n), np.ones(n)])
    return sp.csr_matrix((values, (rows, cols)), shape=(n, n))


def racing_line(track, clearance_m: float, spacing_m: float = SPACING_M) -> RacingLine:
    """The minimum-curvature line of a track (roar.tracks.Track) keeping clearance_m [m] (the car's
    half width and a margin) from both walls. Where the walls leave less, the line keeps to the
    middle."""
    import osqp
    import scipy.sparse as sp

    centre, _, _ = _resample(track, spacing_m)
    line, segments = centre, None
    d2 = _second_difference(len(centre))
    for _ in range(ITERATIONS):
        normals = _normals(line)
        segments, lower, upper = _bounds(track, line, clearance_m, segments)
        a = sp.vstack([d2 @ sp.diags(normals[:, 0]), d2 @ sp.diags(normals[:, 1])]).tocsr()
        b = np.concatenate([d2 @ line[:, 0], d2 @ line[:, 1]])
        moved = _solve(osqp, sp, (a.T @ a).tocsc(), a.T @ b, lower, upper)
        line = evenly_spaced(line + moved[:, None] * normals, len(centre))
        if np.max(np.abs(moved)) < 1e-3:
            break
    segments, lower, upper = _bounds(track, line, clearance_m, segments)
    offsets = np.array([track.project(p, seg, window=20)[2] for p, seg in zip(line, segments)])
    return RacingLine(line, offsets, centre)


def _normals(points: np.ndarray) -> np.ndarray:
    tangent = np.roll(points, -1, axis=0) - np.roll(points, 1, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    return np.stack([-tangent[:, 1], tangent[:, 0]], axis=1)


def _bounds(track, line: np.ndarray, clearance_m: float, segments) -> tuple[list, np.ndarray, np.ndarray]:
    """(centre-line segment of each point, how far each point of the line may move along its normal
    to the left (upper) and right (lower, negative)): its walls, less the clearance, less where it
    already is. Where the walls leave less than MIN_CORRIDOR_M, it keeps to the middle."""
    found, lower, upper = [], [], []
    n = len(track.centerline)
    for i, point in enumerate(line):
        hint = None if segments is None else segments[i]
        if hint is None:  # the first time: the resampled centre line's own segment
            hint = int(np.searchsorted(track.arc_start, i * track.length_m / len(line), side="right") - 1) % n
        seg, _, offset = track.project(point, hint, window=20)
        left, right = track.half_widths_at(seg)
        hi, lo = left - clearance_m, -(right - clearance_m)
        if hi - lo < MIN_CORRIDOR_M:
            hi, lo = (hi + lo) / 2 + MIN_CORRIDOR_M / 2, (hi + lo) / 2 - MIN_CORRIDOR_M / 2
        found.append(seg)
        upper.append(hi - offset)
        lower.append(lo - offset)
    return found, np.minimum(np.array(lower), 0.0), np.maximum(np.array(upper), 0.0)


def _solve(osqp, sp, p, q, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """argmin 1/2 x'Px + q'x with lower <= x <= upper."""
    problem = osqp.OSQP()
    problem.setup(sp.triu(p, format="csc"), q, sp.identity(len(q), format="csc"), lower, upper, verbose=False,
                  eps_abs=1e-6, eps_rel=1e-6, max_iter=200_000, polishing=False)
    result = problem.solve(raise_error=False)  # its status is checked here
    if result.info.status_val == osqp.SolverStatus.OSQP_SIGINT:
        # OSQP takes SIGINT for itself while it solves and returns "interrupted": the Ctrl-C is ours
        raise KeyboardInterrupt
    if result.x is None or not np.all(np.isfinite(result.x)):
        raise ValueError(f"the racing line's QP was not solved: {result.info.status}")
    return np.clip(result.x, lower, upper)


def centre_line_limit_s(track, limits: CarLimits) -> float:
    """[s] the lap limit of the centre line itself, resampled as the racing line is."""
    centre, _, _ = _resample(track, SPACING_M)
    return lap_time(centre, speed_profile(centre, limits))
