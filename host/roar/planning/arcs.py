"""Circular arcs from a pose to a point: the edges of the MIT racecar's RRT. From a pose
(p_s, theta_s) the one arc tangent to theta_s that passes through p_d has, with
v_left = (-sin theta_s, cos theta_s) and d = p_d - p_s,

    signed radius  r = |d|^2 / (2 d . v_left)          (r > 0: the centre to the left; d . v_left = 0: straight)
    centre         c = p_s + r v_left
    angle          phi: the signed turn along the arc, atan2((p_s - c) x (p_d - c), (p_s - c) . (p_d - c))
                   for a point ahead (|phi| < pi); beyond that the turn continues past a half circle
    length         |phi r| (|d| straight), infinite when |r| < r_min or |phi| > max_turn
    end heading    theta_s + phi

Reversing, the car drives the same arc backwards: the formulas above with theta_s + pi, the
heading at the end theta_s + phi. Everything is vectorised over many start poses (a whole tree).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from roar.compiled import compiled

MAX_TURN_RAD = math.pi  # [rad] no edge turns further than a half circle


@dataclass(frozen=True)
class Arcs:
    """Arcs from N poses, each field (N,): signed radius [m] (inf: straight), centre [m], signed
    turn [rad], length [m] (inf: not drivable), heading at the end [rad], direction (+1 ahead,
    -1 reversing)."""

    radius_m: np.ndarray
    centre_x: np.ndarray
    centre_y: np.ndarray
    angle_rad: np.ndarray
    length_m: np.ndarray
    end_heading: np.ndarray
    direction: np.ndarray


def arcs(x, y, heading, px: float, py: float, r_min_m: float, reverse: bool = False,
         max_turn_rad: float = MAX_TURN_RAD) -> Arcs:
    """The arcs from poses (x, y, heading) (arrays or numbers) to the point (px, py)."""
    x, y, heading = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (x, y, heading)))
    shape = x.shape
    out = np.empty((6, x.size))
    _kernels().arcs_into(np.ascontiguousarray(x.ravel()), np.ascontiguousarray(y.ravel()),
                         np.ascontiguousarray(heading.ravel()), float(px), float(py), float(r_min_m), bool(reverse),
                         float(max_turn_rad), out)
    radius, cx, cy, angle, length, end = (row.reshape(shape) for row in out)
    return Arcs(radius, cx, cy, angle, length, end, np.full(shape, -1 if reverse else 1, np.int8))


def arc_poses(x: float, y: float, heading: float, radius_m: float, angle_rad: float, length_m: float,
              direction: int, step_m: float) -> np.ndarray:
    """(K, 3) poses along one arc from its start (excluded) to its end (included), at most step_m apart."""
    return _kernels().arc_poses(float(x), float(y), float(heading), float(radius_m), float(angle_rad),
                                float(length_m), int(direction), float(step_m))


def _kernels():
    return compiled("the planner's arcs", _build, "planning")


def _build(nb):
    from roar.planning import arc_kernel

    return arc_kernel


def truncated(angle_rad: float, length_m: float, max_m: float) -> tuple[float, float]:
    """(angle, length) of the first max_m of an arc (itself if shorter)."""
    if length_m <= max_m:
        return angle_rad, length_m
    return angle_rad * max_m / length_m, max_m


def end_of(x: float, y: float, heading: float, radius_m: float, angle_rad: float, length_m: float,
           direction: int) -> tuple[float, float, float]:
    """The pose at the end of an arc."""
    p = arc_poses(x, y, heading, radius_m, angle_rad, length_m, direction, max(length_m, 1e-9))[-1]
    return float(p[0]), float(p[1]), float(p[2])
