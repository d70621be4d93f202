"""Each object counted once over many frames: SORT in the world frame. Every track predicts its
position with a constant-velocity Kalman filter (cones and markers stand still; the filter also
takes what moves), detections are assigned to tracks by the Hungarian method (scipy's
linear_sum_assignment) on their distance, gated; a new track is on probation until it has been
seen `confirm_hits` times (a detection within the gate of a track that another detection took
starts none: a second piece of the same object), and is dropped when missed `max_misses` times while in view
(a confirmed one after `max_misses_confirmed`: a false object fades, a real one out of view stays).

    tracker = Tracker()
    tracker.update(detections, t_s, in_view=lambda x, y: ...)   # in_view: would the camera see (x, y) now
    tracker.objects("cone")                                      # confirmed tracks; .position: where it stands
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

GATE_M = 0.6  # [m] a detection further than this from a track's prediction is not it
CONFIRM_HITS = 2
MAX_MISSES = 2
MAX_MISSES_CONFIRMED = 6
MEASUREMENT_M = 0.08  # [m] standard deviation of a detection's position
ACCEL_M_S2 = 0.2  # [m/s^2] standard deviation of the objects' acceleration (process noise)
POSITION_FROM = 30  # detections an object's position is the median of
COAST_S = 0.5  # [s] unseen longer than this, a track stops moving (its velocity is forgotten): a cone out of view
# stays where it was seen instead of drifting on a velocity made of the last detections' noise


@dataclass
class TrackedObject:
    id: int
    kind: str
    state: np.ndarray  # (x, y, vx, vy)
    cov: np.ndarray  # (4, 4)
    t_s: float
    last_seen_s: float = 0.0
    hits: int = 1
    misses: int = 0
    confirmed: bool = False
    detections: list = field(default_factory=list, repr=False)

    @property
    def x(self) -> float:
        return float(self.state[0])

    @property
    def y(self) -> float:
        return float(self.state[1])

    @property
    def position(self) -> tuple[float, float]:
        """[m] where the object stands: the median of its last POSITION_FROM detections. The
        filter's state leads a standing object by the velocity it read into a run of biased
        detections (a marker seen ever closer); the median does not."""
        recent = self.detections[-POSITION_FROM:]
        return (float(np.median([d.x for d in recent])), float(np.median([d.y for d in recent])))


class Tracker:
    def __init__(self, gate_m: float = GATE_M, confirm_hits: int = CONFIRM_HITS, max_misses: int = MAX_MISSES,
                 max_misses_confirmed: int = MAX_MISSES_CONFIRMED, accel_m_s2: float = ACCEL_M_S2,
                 coast_s: float = COAST_S) -> None:
        """accel_m_s2: [m/s^2] how hard the objects may change speed (cars racing: several m/s^2);
        coast_s: [s] unseen longer than this, a track's velocity is forgotten."""
        self.gate_m, self.confirm_hits = gate_m, confirm_hits
        self.accel_m_s2, self.coast_s = accel_m_s2, coast_s
        self.max_misses, self.max_misses_confirmed = max_misses, max_misses_confirmed
        self.tracks: list[TrackedObject] = []
        self._ids = itertools.count(1)

    def _predict(self, track: TrackedObject, t_s: float) -> None:
        dt = max(0.0, t_s - track.t_s)
        if dt == 0:
            return
        f = np.eye(4)
        f[0, 2] = f[1, 3] = dt
        g = np.array([[dt * dt / 2, 0], [0, dt * dt / 2], [dt, 0], [0, dt]])
        if t_s - track.last_seen_s > self.coast_s:
            track.state[2:] = 0.0
            f[0, 2] = f[1, 3] = 0.0
        track.state = f @ track.state
        track.cov = f @ track.cov @ f.T + g @ g.T * self.accel_m_s2 ** 2
        track.t_s = t_s

    def update(self, detections, t_s: float, in_view=None) -> list[TrackedObject]:
        """Take one frame's detections (all captured at t_s); returns the tracks."""
        from scipy.optimize import linear_sum_assignment

        for track in self.tracks:
            self._predict(track, t_s)
        h = np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0]])
        r = np.eye(2) * MEASUREMENT_M ** 2
        matched_tracks: set[int] = set()
        new = []
        for kind in {d.kind for d in detections} | {t.kind for t in self.tracks}:
            dets = [d for d in detections if d.kind == kind]
            tracks = [t for t in self.tracks if t.kind == kind]
            pairs = []
            if dets and tracks:
                cost = np.hypot(np.array([[t.x - d.x for d in dets] for t in tracks]),
                                np.array([[t.y - d.y for d in dets] for t in tracks]))
                rows, cols = linear_sum_assignment(np.where(cost <= self.gate_m, cost, 1e6))
                pairs = [(i, j) for i, j in zip(rows, cols) if cost[i, j] <= self.gate_m]
            for i, j in pairs:
                t, d = tracks[i], dets[j]
                s = h @ t.cov @ h.T + r
                k = t.cov @ h.T @ np.linalg.inv(s)
                t.state = t.state + k @ (np.array([d.x, d.y]) - h @ t.state)
                t.cov = (np.eye(4) - k @ h) @ t.cov
                t.hits += 1
                t.misses = 0
                t.last_seen_s = t_s
                t.confirmed = t.confirmed or t.hits >= self.confirm_hits
                t.detections.append(d)
                matched_tracks.add(t.id)
            used = {j for _, j in pairs}
            for j, d in enumerate(dets):
                # a second piece of an object already tracked (a marker seen in two parts) starts no track
                if j not in used and not any(math.hypot(t.x - d.x, t.y - d.y) <= self.gate_m for t in tracks):
                    cov = np.diag([MEASUREMENT_M ** 2, MEASUREMENT_M ** 2, 0.05, 0.05])
                    new.append(TrackedObject(next(self._ids), kind, np.array([d.x, d.y, 0.0, 0.0]), cov, t_s,
                                             last_seen_s=t_s, detections=[d]))
        kept = []
        for t in self.tracks:
            if t.id not in matched_tracks and (in_view is None or in_view(t.x, t.y)):
                t.misses += 1
            if t.misses > (self.max_misses_confirmed if t.confirmed else self.max_misses):
                continue
            kept.append(t)
        self.tracks = kept + new
        return self.tracks

    def objects(self, kind: str | None = None) -> list[TrackedObject]:
        """The confirmed tracks (of one kind)."""
        return [t for t in self.tracks if t.confirmed and (kind is None or t.kind == kind)]
