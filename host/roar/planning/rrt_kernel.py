"""The RRT's growth step (roar.planning.rrt.ArcRRT._extend) compiled by Numba: per sample it
weighs an arc from every node of the tree, ahead and reversing, and checks the cheapest few with
the car's rectangle; in Python that was ~0.5 ms a sample, most of a challenge run's time. The
rules are rrt.py's (see _extend there); the arcs are arc_kernel's and the check footprint_kernel's,
so a plan is the one the numpy steps made."""

import math

import numba as nb
import numpy as np

from roar.planning.arc_kernel import arc, arc_poses
from roar.planning.footprint_kernel import first_collision

NONE = (-1, 0.0, 0.0, 0.0, 0.0, 1, 0.0, 0.0, 0.0)


@nb.njit(cache=True, nogil=True)
def crowding(poses, length, room, i0, j0, x0, y0, res, mid_m, clearance_m, room_m, room_cost):
    """[m] the extra cost of an edge (poses along it, length [m]) for the room it leaves beside the
    car: room (distance to the nearest blocked cell [m] over cells from (i0, j0)); mid_m [m] the
    rectangle's centre ahead of a pose, clearance_m [m] its half width with margin."""
    total = 0.0
    for k in range(poses.shape[0]):
        th = poses[k, 2]
        i = int(math.floor((poses[k, 0] + mid_m * math.cos(th) - x0) / res)) - i0
        j = int(math.floor((poses[k, 1] + mid_m * math.sin(th) - y0) / res)) - j0
        if 0 <= i < room.shape[0] and 0 <= j < room.shape[1]:
            share = 1.0 - (room[i, j] - clearance_m) / room_m
            total += min(max(share, 0.0), 1.0)
    return room_cost * length * (total / poses.shape[0])


@nb.njit(cache=True, nogil=True)
def _insert(best, best_metric, filled, b, value):
    """Put candidate b with metric value into the sorted list of the smallest (best, best_metric:
    ties go to the lower index); the number filled after."""
    count = best.shape[0]
    if filled == count and not (value < best_metric[count - 1] or
                                (value == best_metric[count - 1] and b < best[count - 1])):
        return filled
    at = filled if filled < count else count - 1
    while at > 0 and (value < best_metric[at - 1] or (value == best_metric[at - 1] and b < best[at - 1])):
        best[at], best_metric[at] = best[at - 1], best_metric[at - 1]
        at -= 1
    best[at], best_metric[at] = b, value
    return min(filled + 1, count)


@nb.njit(cache=True, nogil=True)
def extend(x, y, heading, cost, reversed_m, px, py, r_min_m, reverse, reverse_cost, max_reverse_m, max_turn_rad,
           nearest, weigh_cost, step_m, blocked, x0, y0, res, bx, by, room, i0, j0, mid_m, clearance_m, room_m,
           room_cost):
    """The new node grown towards (px, py): (parent, x, y, heading (not wrapped), cost, direction,
    radius, angle, length), parent -1 when no arc of the `nearest` fits. Candidates are numbered as
    rrt.py's were: node k ahead is k, reversing n + k. max_reverse_m inf: no limit; weigh_cost: try
    the nearest in order of cost to come + arc (else by arc alone); room of shape (0, 0): no crowding
    cost."""
    n = x.shape[0]
    count = min(nearest, 2 * n if reverse else n)
    best = np.empty(count, np.int64)
    best_metric = np.empty(count)
    filled = 0
    for k in range(n):
        # an arc is no shorter than its chord: a node whose chord is already longer than the
        # count-th shortest arc so far is passed by without its arcs (the margin keeps rounding out)
        chord = math.hypot(px - x[k], py - y[k]) * (1.0 - 1e-9)
        if filled < count or chord <= best_metric[count - 1]:
            length = arc(x[k], y[k], heading[k], px, py, r_min_m, False, max_turn_rad)[4]
            filled = _insert(best, best_metric, filled, k, length)
        if reverse:
            value = math.inf
            if max_reverse_m - reversed_m[k] > 0.05:
                if filled == count and chord * reverse_cost > best_metric[count - 1]:
                    continue
                value = arc(x[k], y[k], heading[k], px, py, r_min_m, True, max_turn_rad)[4] * reverse_cost
            filled = _insert(best, best_metric, filled, n + k, value)
    order = np.empty(count)
    for i in range(count):
        order[i] = best_metric[i] + (cost[best[i] % n] if weigh_cost else 0.0)
    for i in np.argsort(order, kind="mergesort"):
        b = best[i]
        if not math.isfinite(best_metric[i]):
            break
        node, backwards = b % n, b >= n
        radius, _, _, angle, length, _ = arc(x[node], y[node], heading[node], px, py, r_min_m, backwards,
                                             max_turn_rad)
        reach = min(step_m, max_reverse_m - reversed_m[node]) if backwards else step_m
        if length > reach:
            angle, length = angle * reach / length, reach
        if length < 1e-3:
            continue
        direction = -1 if backwards else 1
        poses = arc_poses(x[node], y[node], heading[node], radius, angle, length, direction, res)
        if first_collision(blocked, x0, y0, 1.0 / res, poses, bx, by) >= 0:
            continue
        extra = 0.0
        if room.shape[0] > 0:
            extra = crowding(poses, length, room, i0, j0, x0, y0, res, mid_m, clearance_m, room_m, room_cost)
        last = poses.shape[0] - 1
        return (node, poses[last, 0], poses[last, 1], poses[last, 2],
                cost[node] + length * (reverse_cost if direction < 0 else 1.0) + extra, direction, radius, angle,
                length)
    return NONE


@nb.njit(cache=True, nogil=True)
def blocked_edges(x, y, heading, parent, radius, angle, length, direction, bad, blocked, x0, y0, res, bx, by):
    """Mark in bad every node k >= 1 whose edge from its parent the grid blocks; nodes already bad,
    or whose parent is, are not checked (they go with it)."""
    for k in range(1, x.shape[0]):
        p = parent[k]
        if bad[k] or bad[p]:
            continue
        poses = arc_poses(x[p], y[p], heading[p], radius[k], angle[k], length[k], direction[k], res)
        bad[k] = first_collision(blocked, x0, y0, 1.0 / res, poses, bx, by) >= 0
