"""Dubins curves: the shortest way from pose to pose for a car that only drives ahead and turns no
tighter than a radius rho -- two turns joined by a straight or a third turn (LSL, RSR, LSR, RSL,
RLR, LRL), the closed forms of Shkel and Lumelsky (2001) in the normalised frame (the distance
over rho, the headings measured from the line joining the poses). Vectorised over many pairs.

    d = dubins(starts, ends, rho)            # starts, ends (N, 3) broadcast; d.length_m (N,)
    dubins_poses(start, d, k, step_m)        # poses along the k-th curve
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

WORDS = ("LSL", "RSR", "LSR", "RSL", "RLR", "LRL")


@dataclass(frozen=True)
class Dubins:
    length_m: np.ndarray  # (N,) [m] of the shortest word (inf: none, only where the inputs were)
    word: np.ndarray  # (N,) index into WORDS
    segments: np.ndarray  # (N, 3) each segment's length over rho (turns in radians)
    rho_m: float


EPS = 1e-9  # rounding allowed where a word is exactly feasible (a turn alone: its straight of length 0)


def _root(p2):
    """sqrt of a squared length, a hair below 0 being 0 (else the one-turn paths are lost)."""
    return np.sqrt(np.where(p2 >= -EPS, np.maximum(p2, 0.0), np.nan))


def _mod(a):
    """a in [0, 2 pi), a turn a hair short of a full circle being none (rounding: a turn that
    should be 0 computed as -1e-16 would otherwise add a whole circle)."""
    m = np.mod(a, 2 * math.pi)
    return np.where(m > 2 * math.pi - EPS, 0.0, m)


def dubins(starts, ends, rho_m: float) -> Dubins:
    q0, q1 = np.broadcast_arrays(np.asarray(starts, dtype=float).reshape(-1, 3),
                                 np.asarray(ends, dtype=float).reshape(-1, 3))
    dx, dy = q1[:, 0] - q0[:, 0], q1[:, 1] - q0[:, 1]
    d = np.hypot(dx, dy) / rho_m
    theta = np.where(d > 0, np.arctan2(dy, dx), 0.0)
    a, b = _mod(q0[:, 2] - theta), _mod(q1[:, 2] - theta)
    sa, sb, ca, cb = np.sin(a), np.sin(b), np.cos(a), np.cos(b)
    cab = np.cos(a - b)
    nan = np.full_like(d, np.nan)
    out = np.full((6, len(d), 3), np.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        # LSL
        p2 = 2 + d * d - 2 * cab + 2 * d * (sa - sb)
        t1 = np.arctan2(cb - ca, d + sa - sb)
        out[0] = np.stack([_mod(-a + t1), _root(p2), _mod(b - t1)], axis=1)
        # RSR
        p2 = 2 + d * d - 2 * cab + 2 * d * (sb - sa)
        t1 = np.arctan2(ca - cb, d - sa + sb)
        out[1] = np.stack([_mod(a - t1), _root(p2), _mod(-b + t1)], axis=1)
        # LSR
        p2 = -2 + d * d + 2 * cab + 2 * d * (sa + sb)
        p = _root(p2)
        t2 = np.arctan2(-ca - cb, d + sa + sb) - np.arctan2(-2.0, p)
        out[2] = np.stack([_mod(-a + t2), p, _mod(-b + t2)], axis=1)
        # RSL
        p2 = d * d - 2 + 2 * cab - 2 * d * (sa + sb)
        p = _root(p2)
        t2 = np.arctan2(ca + cb, d - sa - sb) - np.arctan2(2.0, p)
        out[3] = np.stack([_mod(a - t2), p, _mod(b - t2)], axis=1)
        # RLR
        c = (6 - d * d + 2 * cab + 2 * d * (sa - sb)) / 8
        p = _mod(2 * math.pi - np.arccos(np.where(np.abs(c) <= 1 + EPS, np.clip(c, -1, 1), nan)))
        t = _mod(a - np.arctan2(ca - cb, d - sa + sb) + p / 2)
        out[4] = np.stack([t, p, _mod(a - b - t + p)], axis=1)
        # LRL
        c = (6 - d * d + 2 * cab + 2 * d * (sb - sa)) / 8
        p = _mod(2 * math.pi - np.arccos(np.where(np.abs(c) <= 1 + EPS, np.clip(c, -1, 1), nan)))
        t = _mod(-a - np.arctan2(ca - cb, d + sa - sb) + p / 2)
        out[5] = np.stack([t, p, _mod(b - a - t + p)], axis=1)
    # LSL and RSR with no straight are one circle: where the straight's direction is undefined the
    # split between the two turns is arbitrary and may add a whole circle; one turn does it all
    for w in (0, 1):
        one = out[w, :, 1] < 1e-6
        out[w, one, 0] = _mod(out[w, one, 0] + out[w, one, 2])
        out[w, one, 2] = 0.0
    total = np.where(np.isnan(out).any(axis=2), np.inf, out.sum(axis=2))  # (6, N)
    word = np.argmin(total, axis=0)
    idx = np.arange(len(d))
    return Dubins(total[word, idx] * rho_m, word, out[word, idx], float(rho_m))


def dubins_poses(start, curves: Dubins, k: int, step_m: float, upto_m: float | None = None) -> np.ndarray:
    """(K, 3) poses along curve k from start (excluded) to its end (or upto_m along it), at most
    step_m apart."""
    rho = curves.rho_m
    total = float(curves.length_m[k])
    end = total if upto_m is None else min(total, upto_m)
    n = max(1, int(math.ceil(end / step_m)))
    s = np.arange(1, n + 1) * (end / n) / rho  # normalised arc length
    word = WORDS[int(curves.word[k])]
    seg = curves.segments[k]
    x, y, th = (np.full(n, float(v)) for v in start)
    done = np.zeros(n)
    for i, kind in enumerate(word):
        run = np.clip(s - done, 0.0, seg[i])
        if kind == "S":
            x, y = x + rho * run * np.cos(th), y + rho * run * np.sin(th)
        else:
            sign = 1.0 if kind == "L" else -1.0
            nth = th + sign * run
            x = x + sign * rho * (np.sin(nth) - np.sin(th))
            y = y - sign * rho * (np.cos(nth) - np.cos(th))
            th = nth
        done = done + seg[i]
    return np.stack([x, y, np.remainder(th + math.pi, 2 * math.pi) - math.pi], axis=1)
