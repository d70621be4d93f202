"""A planned path: dense poses a follower tracks, each with its direction of travel."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Path:
    """poses (N, 3) [m, m, rad] from the start to the goal at most a step apart; direction (N,)
    +1 driving ahead, -1 reversing, into each pose; made_at_s [s] when the plan was made (the
    follower may get it late); nodes (M, 3) the planner's tree nodes on it."""

    poses: np.ndarray
    direction: np.ndarray
    made_at_s: float = 0.0
    nodes: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))

    @property
    def length_m(self) -> float:
        return float(np.linalg.norm(np.diff(self.poses[:, :2], axis=0), axis=1).sum())

    @property
    def reverses(self) -> int:
        """How many times the direction changes along the path."""
        return int(np.count_nonzero(np.diff(self.direction) != 0))

    def __len__(self) -> int:
        return len(self.poses)
