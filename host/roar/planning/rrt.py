"""RRT with circular-arc edges (the MIT racecar's planner): a tree of poses grown towards sampled
points, each edge the arc tangent to its parent's heading (roar.planning.arcs), ahead or
reversing, no tighter than the car's minimum turning radius, checked by the car's rectangle on
the planning grid.

    rrt = ArcRRT(grid, Footprint(), r_min_m=0.77, seed=1)
    path = rrt.plan((x, y, heading), (gx, gy), budget_s=0.2)     # NoPath (one line) if none
    path = rrt.replan(pose_now, goal, grid=new_grid)              # keeps the tree's still-valid part

replan() keeps the subtree under the node of the last path nearest the car (where a follower
put it), drops every edge the new grid blocks with all below it, and grows from there.

room_m: each metre driven with less room than room_m between the car's sides and the nearest
obstacle costs up to ROOM_COST metres more, so of two gaps the wider is taken when it is not much
longer (the pose's error and the follower's cut then have room).

max_reverse_m: a path reverses at most this far in a row, counting what the car has just reversed
(plan's reversed_m): there is no camera behind, and a long way backwards is a long way blind.

stop_room_m: a path ends only where the car would still fit that much further on (a car that
overshoots its stop does not meet the wall). improve=N draws N more samples after the first path
and keeps the cheapest path to the goal then (no rewiring: another branch that happens to be
cheaper). smooth=True shortcuts a path found: from its start, the one arc to the farthest of its
nodes that fits, then on from there (the new arcs join the tree as a branch of their own, so a replan keeps
them); the random detours of a first RRT path go, and it stays a chain of drivable arcs.
"""

from __future__ import annotations

import math
import time

import numpy as np

from roar.localization.odometry import checked_pose as pose_of
from roar.compiled import compiled
from roar.planning.arcs import MAX_TURN_RAD, arc_poses, arcs
from roar.planning.footprint import Footprint
from roar.planning.grid import NoPath, PlanningError, PlanningGrid
from roar.planning.path import Path
from roar.planning.tree import Tree

R_MIN_M = 0.77  # [m] the ROAR 1/10 car at full lock: wheelbase 0.325 m / tan(0.4 rad)
GOAL_BIAS = 0.1  # share of samples that are the goal
GOAL_TOLERANCE_M = 0.3  # [m] a node this near the goal reaches it
STEP_M = 1.5  # [m] the longest edge
REVERSE_COST = 2.0  # a reversing metre costs this many metres ahead
CANDIDATES = 3  # nearest nodes tried per sample before it is given up
PARENTS = 10  # with room_m: the nearest nodes weighed as a new node's parent, the cheapest way to it first
REGION_MARGIN_M = 3.0  # [m] samples are drawn from the free cells of the box round start and goal grown by this
REROOT_M = 0.6  # [m] the car within this of a node of its last path: the tree is kept from there
REROOT_RAD = 0.6  # [rad] ... and its heading within this
MAX_NODES = 200_000
MAX_KEPT = 2000  # a replan keeping more nodes than this starts afresh (each sample weighs every node)
ROOM_COST = 3.0  # extra metres per metre driven with no room beside the car's rectangle, falling to none at room_m


_NO_ROOM = np.zeros((0, 0))  # rrt_kernel.extend's "no crowding cost"


def _kernel():
    return compiled("the planner's growth step", _build, "planning")


def _build(nb):
    from roar.planning import rrt_kernel

    return rrt_kernel


def checked_pose(what: str, value, size: int = 3) -> tuple[float, ...]:
    """A pose (x, y, heading) of finite numbers, or with size 2 a point (x, y) or a pose (its
    heading kept); ValueError naming it in one line."""
    if size == 3:
        return pose_of(what, value)
    try:
        parts = tuple(value)
    except TypeError:
        raise PlanningError(f"{what} must be (x [m], y [m]) or (x, y, heading [rad]), got {value!r}") from None
    if len(parts) not in (2, 3):
        raise PlanningError(f"{what} must be (x [m], y [m]) or (x, y, heading [rad]), got {value!r}")
    return pose_of(what, parts if len(parts) == 3 else (*parts, 0.0))[:len(parts)]


class ArcRRT:
    def __init__(self, grid: PlanningGrid, footprint: Footprint = Footprint(), r_min_m: float = R_MIN_M,
                 reverse: bool = True, reverse_cost: float = REVERSE_COST, goal_bias: float = GOAL_BIAS,
                 goal_tolerance_m: float = GOAL_TOLERANCE_M, step_m: float = STEP_M, seed: int | None = None,
                 region_margin_m: float | None = REGION_MARGIN_M, smooth: bool = False, improve: int = 0,
                 stop_room_m: float = 0.0, max_reverse_m: float | None = None, room_m: float = 0.0) -> None:
        if not isinstance(grid, PlanningGrid):
            raise PlanningError(f"grid must be a PlanningGrid, got {type(grid).__name__}")
        if not (math.isfinite(r_min_m) and 0 < r_min_m < 50):
            raise PlanningError(f"r_min_m must be 0..50 m, got {r_min_m!r}")
        if not 0 <= goal_bias < 1:
            raise PlanningError(f"goal_bias must be 0..1, got {goal_bias!r}")
        self.footprint, self.r_min_m, self.reverse = footprint, float(r_min_m), reverse
        self.reverse_cost, self.goal_bias = float(reverse_cost), float(goal_bias)
        self.goal_tolerance_m, self.step_m = float(goal_tolerance_m), float(step_m)
        self.rng = np.random.default_rng(seed)
        self.region_margin_m = region_margin_m  # None: sample the whole grid
        self.smooth = smooth
        self.improve = improve  # samples drawn after the first path, the cheapest path to the goal then kept
        self.stop_room_m = stop_room_m  # [m] a path ends where the car fits this much further on (it may overshoot)
        self.max_reverse_m = max_reverse_m  # [m] reversing in a row at most (None: no limit)
        self.room_m = room_m  # [m] less room than this beside the car costs extra (0: length alone)
        self._room = None  # (distance to the nearest blocked cell [m] over the sampling region, i0, j0)
        self.tree: Tree | None = None
        self.path: Path | None = None
        self._branch: list[int] = []  # the last path's nodes
        self.iterations = 0
        self.kept_nodes = 0  # nodes the last replan kept from the tree before
        self._set_grid(grid)

    def _set_grid(self, grid: PlanningGrid) -> None:
        self.grid = grid
        self._all_free = self._free = grid.free_cells()
        self._labels = None

    def _region(self, start, goal) -> None:
        """Sample from the free cells of the box round start and goal (grown by region_margin_m)."""
        free = self._all_free
        if self.region_margin_m is None or not len(free):
            self._free = free
            return
        lo = np.minimum(start[:2], goal[:2]) - self.region_margin_m
        hi = np.maximum(start[:2], goal[:2]) + self.region_margin_m
        (i0, j0), (i1, j1) = self.grid.cells([lo, hi])
        inside = (free[:, 0] >= i0) & (free[:, 0] <= i1) & (free[:, 1] >= j0) & (free[:, 1] <= j1)
        self._free = free[inside] if inside.any() else free
        if self.room_m > 0:  # the distance to the nearest blocked cell over the region (a metre more round it)
            from scipy import ndimage

            pad = int(math.ceil(1.0 / self.grid.resolution_m))
            nx, ny = self.grid.shape
            i0, j0 = max(0, i0 - pad), max(0, j0 - pad)
            sub = self.grid.blocked[i0:min(nx, i1 + pad + 1), j0:min(ny, j1 + pad + 1)]
            self._room = (ndimage.distance_transform_edt(~sub) * self.grid.resolution_m, i0, j0)

    # -- the public calls -------------------------------------------------------------------------

    def plan(self, start, goal, budget_s: float = 0.2, max_iterations: int | None = None, t_s: float = 0.0,
             reversed_m: float = 0.0) -> Path:
        """A path from start (x, y, heading) to within goal_tolerance_m of goal (x, y[, heading:
        ignored]), searched for budget_s of wall time (or max_iterations); NoPath if none.
        reversed_m: metres the car has just driven backwards (they count towards max_reverse_m)."""
        start = checked_pose("start", start)
        goal = checked_pose("goal", goal, 2)[:2]
        self._check_ends(start, goal)
        self.tree, self.path, self._branch = Tree(start, reversed_m=reversed_m), None, []
        self.kept_nodes = 0
        return self._grow(goal, budget_s, max_iterations, t_s)

    def replan(self, pose, goal, grid: PlanningGrid | None = None, budget_s: float = 0.2,
               max_iterations: int | None = None, t_s: float = 0.0, reversed_m: float = 0.0) -> Path:
        """Plan again from pose, keeping the tree's part that is still valid (see the module's text)."""
        if grid is not None:
            self._set_grid(grid)
        pose = checked_pose("pose", pose)
        goal = checked_pose("goal", goal, 2)[:2]
        root = self._reroot_node(pose)
        if root is None:
            return self.plan(pose, goal, budget_s, max_iterations, t_s, reversed_m)
        self._check_ends(self.tree.pose(root), goal)
        tree = self.tree
        keep = tree.descendants(root)
        if np.count_nonzero(keep) > MAX_KEPT:
            return self.plan(pose, goal, budget_s, max_iterations, t_s, reversed_m)
        tree.keep(keep, root, reversed_m)
        self._drop_blocked()
        self.kept_nodes = len(self.tree)
        self.path, self._branch = None, []
        return self._grow(goal, budget_s, max_iterations, t_s)

    # -- inside ------------------------------------------------------------------------------------

    def _check_ends(self, start, goal) -> None:
        from scipy import ndimage

        if not len(self._all_free):
            raise NoPath("the map has no free space")
        fp, g = self.footprint, self.grid
        if not fp.fits(g, [start]):
            raise NoPath(f"the start ({start[0]:.2f}, {start[1]:.2f}) is in collision (the car's rectangle "
                         f"touches a wall or an obstacle)")
        if g.blocked_at([goal])[0]:
            raise NoPath(f"the goal ({goal[0]:.2f}, {goal[1]:.2f}) is inside a wall or an obstacle, or off the map")
        if self._labels is None:
            self._labels = ndimage.label(~g.blocked)[0]
        (si, sj), (gi, gj) = g.cells([start[:2], goal])
        if self._labels[si, sj] != self._labels[gi, gj]:
            raise NoPath(f"the goal ({goal[0]:.2f}, {goal[1]:.2f}) is not connected to the start by free space")
        self._region(start, goal)

    def _reroot_node(self, pose) -> int | None:
        if self.tree is None or not self._branch:
            return None
        nodes = np.array(self._branch)
        t = self.tree
        d = np.hypot(t.x[nodes] - pose[0], t.y[nodes] - pose[1])
        turn = np.abs(np.remainder(t.heading[nodes] - pose[2] + math.pi, math.tau) - math.pi)
        ok = (d <= REROOT_M) & (turn <= REROOT_RAD)
        if not ok.any():
            return None
        return int(nodes[np.flatnonzero(ok)[np.argmin(d[ok])]])

    def edge_poses(self, k: int) -> np.ndarray:
        """(K, 3) poses along the edge into node k (from its parent)."""
        t = self.tree
        p = int(t.parent[k])
        return arc_poses(*t.pose(p), float(t.radius[k]), float(t.angle[k]), float(t.length[k]), int(t.direction[k]),
                         self.grid.resolution_m)

    def _drop_blocked(self) -> None:
        """Drop every node whose edge the grid now blocks (or that reverses too far in a row), with
        everything below it."""
        t = self.tree
        bad = np.zeros(len(t), bool)
        if self.max_reverse_m is not None:
            bad[1:] = t.reversed[1:] > self.max_reverse_m + 1e-6
        g = self.grid
        bx, by = self.footprint.body_points(g.resolution_m)
        _kernel().blocked_edges(t.x, t.y, t.heading, t.parent, t.radius, t.angle, t.length, t.direction, bad,
                                g.blocked, float(g.x0), float(g.y0), float(g.resolution_m), bx, by)
        if bad.any():
            drop = np.zeros(len(t), bool)
            for k in np.flatnonzero(bad):
                drop |= t.descendants(int(k))
            t.keep(~drop, 0)

    def _sample(self, goal) -> tuple[float, float]:
        if self.rng.uniform() < self.goal_bias:
            return goal
        return self._free_point()

    def _free_point(self) -> tuple[float, float]:
        """A point drawn uniformly from the sampling region's free cells."""
        i, j = self._free[self.rng.integers(len(self._free))]
        r = self.grid.resolution_m
        return (self.grid.x0 + (i + self.rng.uniform()) * r, self.grid.y0 + (j + self.rng.uniform()) * r)

    def _extend(self, px: float, py: float) -> int | None:
        """Grow the tree towards (px, py): the cheapest arcs from its nodes (ahead, and reversing
        at reverse_cost, while a node has reversing left under max_reverse_m), cut at step_m (a
        reversing one also at what is left), the first that fits; its new node or None. The CANDIDATES
        nearest by arc length are tried shortest first, or with room_m the PARENTS nearest, cheapest
        way to the new node first (cost to come + arc). Compiled: roar.planning.rrt_kernel."""
        t, g, fp = self.tree, self.grid, self.footprint
        bx, by = fp.body_points(g.resolution_m)
        if self._room is None or self.room_m <= 0:
            room, i0, j0 = _NO_ROOM, 0, 0
        else:
            room, i0, j0 = self._room
        node, x, y, th, cost, direction, radius, angle, length = _kernel().extend(
            t.x, t.y, t.heading, t.cost, t.reversed, float(px), float(py), self.r_min_m, self.reverse,
            self.reverse_cost, math.inf if self.max_reverse_m is None else float(self.max_reverse_m), MAX_TURN_RAD,
            CANDIDATES if self.room_m <= 0 else PARENTS, self.room_m > 0, self.step_m, g.blocked, float(g.x0),
            float(g.y0), float(g.resolution_m), bx, by, room, int(i0), int(j0), (fp.front_m - fp.rear_m) / 2,
            fp.half_width_m + fp.margin_m, float(self.room_m), ROOM_COST)
        if node < 0:
            return None
        return t.add(x, y, math.remainder(th, math.tau), node, cost, direction, radius, angle, length)

    def _grow(self, goal, budget_s: float, max_iterations: int | None, t_s: float) -> Path:
        t = self.tree
        start = time.perf_counter()
        reached = self._reached(goal, np.arange(len(t)))
        it = 0
        while reached is None:
            if (max_iterations is not None and it >= max_iterations) or \
                    (max_iterations is None and time.perf_counter() - start > budget_s) or len(t) >= MAX_NODES:
                self.iterations = it
                raise NoPath(f"none found in {it} samples ({budget_s:g} s; {len(t)} nodes): the goal "
                             f"({goal[0]:.2f}, {goal[1]:.2f}) may be out of reach of a car turning no tighter than "
                             f"{self.r_min_m:g} m")
            it += 1
            k = self._extend(*self._sample(goal))
            if k is not None:
                reached = self._reached(goal, np.array([k]))
        for _ in range(self.improve):  # a first RRT path is a random one: more samples may offer a cheaper one
            it += 1
            k = self._extend(*self._sample(goal))
            if k is not None and self._reached(goal, np.array([k])) is not None and t.cost[k] < t.cost[reached]:
                reached = k
        self.iterations = it
        self._branch = t.branch(reached)
        if self.smooth:
            self._branch = self._shortcut(self._branch)
        self.path = self._path(self._branch, t_s)
        return self.path

    def _shortcut(self, branch: list[int]) -> list[int]:
        """The branch shortcut (see the module's text); itself when it reverses or nothing is shorter."""
        t = self.tree
        if len(branch) < 3 or (t.direction[branch[1:]] < 0).any():
            return branch
        out = [branch[0]]
        at, i = branch[0], 0
        while i < len(branch) - 1:
            for j in range(len(branch) - 1, i, -1):
                target = branch[j]
                if j == i + 1 and at == branch[i]:  # the original edge
                    out.append(target)
                    at, i = target, j
                    break
                a = arcs(t.x[at], t.y[at], t.heading[at], float(t.x[target]), float(t.y[target]), self.r_min_m)
                length = float(a.length_m)
                if not math.isfinite(length):
                    continue
                poses = arc_poses(*t.pose(at), float(a.radius_m), float(a.angle_rad), length, 1,
                                  self.grid.resolution_m)
                if not self.footprint.fits(self.grid, poses):
                    continue
                x, y, th = poses[-1]
                at = t.add(x, y, math.remainder(th, math.tau), at,
                           float(t.cost[at]) + length + self._crowding(poses, length), 1, float(a.radius_m),
                           float(a.angle_rad), length)
                out.append(at)
                i = j
                break
            else:
                return branch  # from a shortcut's end the rest cannot be reached: keep the path as found
        return out if t.cost[out[-1]] < t.cost[branch[-1]] else branch

    def _crowding(self, poses: np.ndarray, length: float) -> float:
        """[m] the extra cost of an edge for the room it leaves beside the car: ROOM_COST per metre
        with none, nothing with room_m or more (0 without room_m)."""
        if self._room is None or self.room_m <= 0:
            return 0.0
        dist, i0, j0 = self._room
        fp, g = self.footprint, self.grid
        return _kernel().crowding(np.ascontiguousarray(poses, dtype=float), float(length), dist, int(i0), int(j0),
                                  float(g.x0), float(g.y0), float(g.resolution_m), (fp.front_m - fp.rear_m) / 2,
                                  fp.half_width_m + fp.margin_m, float(self.room_m), ROOM_COST)

    def _reached(self, goal, nodes: np.ndarray) -> int | None:
        t = self.tree
        d = np.hypot(t.x[nodes] - goal[0], t.y[nodes] - goal[1])
        ok = d <= self.goal_tolerance_m
        if not ok.any():
            return None
        cands = nodes[ok]
        if self.stop_room_m > 0:  # room to stop: the car fits stop_room_m on along its last edge's direction
            room = []
            for k in cands:
                x, y, th = t.pose(int(k))
                ahead = self.stop_room_m * (1 if t.direction[k] > 0 else -1)
                ends = [(x + f * ahead * math.cos(th), y + f * ahead * math.sin(th), th) for f in (0.5, 1.0)]
                if self.footprint.fits(self.grid, ends):
                    room.append(k)
            if not room:
                return None
            cands = np.array(room)
        return int(cands[np.argmin(t.cost[cands])])

    def _path(self, branch: list[int], t_s: float) -> Path:
        t = self.tree
        poses = [np.array([t.pose(branch[0])])]
        direction = [np.array([t.direction[branch[1]] if len(branch) > 1 else 1])]
        for k in branch[1:]:
            p = self.edge_poses(k)
            poses.append(p)
            direction.append(np.full(len(p), t.direction[k]))
        return Path(np.concatenate(poses), np.concatenate(direction).astype(np.int8), t_s,
                    np.array([t.pose(k) for k in branch]))
