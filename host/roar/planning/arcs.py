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
    x, y, heading = (np.asarray(v, dtype=float) for v in (x, y, heading))
    th = heading + math.pi if reverse else heading
    c, s = np.cos(th), np.sin(th)
    dx, dy = px - x, py - y
    ahead = c * dx + s * dy  # along the direction of travel
    left = -s * dx + c * dy  # d . v_left
    d2 = dx * dx + dy * dy
    with np.errstate(divide="ignore", invalid="ignore"):
        straight = np.abs(left) <= 1e-12 * np.maximum(d2, 1e-300)
        radius = np.where(straight, np.inf, d2 / (2 * np.where(straight, 1.0, left)))
        angle = np.where(straight, np.where(ahead >= 0, 0.0, np.inf), 2 * np.arctan2(left, ahead))
        length = np.where(straight, np.where(ahead >= 0, np.sqrt(d2), np.inf), np.abs(angle * radius))
    length = np.where((np.abs(radius) < r_min_m) | (np.abs(angle) > max_turn_rad), np.inf, length)
    finite_r = np.where(np.isfinite(radius), radius, 0.0)
    return Arcs(radius, x - s * finite_r, y + c * finite_r, angle, length,
                np.where(np.isfinite(angle), heading + np.where(np.isfinite(angle), angle, 0.0), heading),
                np.full(x.shape, -1 if reverse else 1, np.int8))


def arc_poses(x: float, y: float, heading: float, radius_m: float, angle_rad: float, length_m: float,
              direction: int, step_m: float) -> np.ndarray:
    """(K, 3) poses along one arc from its start (excluded) to its end (included), at most step_m apart."""
    n = max(1, int(math.ceil(length_m / step_m)))
    f = np.arange(1, n + 1) / n
    th = heading + (math.pi if direction < 0 else 0.0)
    if math.isinf(radius_m):
        ahead, left, turn = f * length_m, np.zeros(n), np.zeros(n)
    else:
        turn = f * angle_rad
        ahead, left = radius_m * np.sin(turn), radius_m * (1 - np.cos(turn))
    c, s = math.cos(th), math.sin(th)
    return np.stack([x + c * ahead - s * left, y + s * ahead + c * left, heading + turn], axis=1)


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
