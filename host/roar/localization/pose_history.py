"""The car's recent poses, to place what a late sensor saw with the pose of its capture time (a
camera's frame arrives 0.2-0.5 s after it was taken; by then the car has moved half a metre).

    history = PoseHistory(seconds=2.0)
    history.add(t_s, (x, y, yaw))          # every control period
    history.at(frame_time_s)               # interpolated; None if older than the history
"""

from __future__ import annotations

import math
from collections import deque

SECONDS = 2.0  # [s] kept


class PoseHistory:
    def __init__(self, seconds: float = SECONDS) -> None:
        self.seconds = seconds
        self._poses: deque[tuple[float, float, float, float]] = deque()

    def add(self, t_s: float, pose) -> None:
        x, y, yaw = (float(v) for v in pose)
        if self._poses and t_s <= self._poses[-1][0]:
            if t_s == self._poses[-1][0]:
                self._poses[-1] = (t_s, x, y, yaw)
            return
        self._poses.append((t_s, x, y, yaw))
        while self._poses and self._poses[0][0] < t_s - self.seconds:
            self._poses.popleft()

    def at(self, t_s: float) -> tuple[float, float, float] | None:
        """The pose at t_s, interpolated between the two around it (the newest if later than it;
        None if earlier than the oldest kept)."""
        p = self._poses
        if not p or t_s < p[0][0] - 1e-9:
            return None
        if t_s >= p[-1][0]:
            return p[-1][1:]
        lo, hi = 0, len(p) - 1
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if p[mid][0] <= t_s:
                lo = mid
            else:
                hi = mid
        (t0, x0, y0, a0), (t1, x1, y1, a1) = p[lo], p[hi]
        f = 0.0 if t1 <= t0 else (t_s - t0) / (t1 - t0)
        return (x0 + f * (x1 - x0), y0 + f * (y1 - y0), a0 + f * math.remainder(a1 - a0, math.tau))
