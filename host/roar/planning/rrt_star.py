"""RRT* with Dubins edges: the asymptotically optimal variant. Arc edges join a pose to a point
and cannot rewire; Dubins curves (roar.planning.dubins) join pose to pose, so each new node takes
the cheapest collision-free parent among its neighbours and then offers itself as a cheaper
parent to them (rewiring), and the path shortens as the search goes on. Drives ahead only.

    star = DubinsRRTStar(grid, Footprint(), r_min_m=0.77, seed=1)
    path = star.plan(start, goal, budget_s=1.0)     # the best path found in the budget
"""

from __future__ import annotations

import math
import time

import numpy as np

from roar.planning.dubins import dubins, dubins_poses
from roar.planning.footprint import Footprint
from roar.planning.grid import NoPath, PlanningGrid
from roar.planning.path import Path
from roar.planning.rrt import GOAL_BIAS, GOAL_TOLERANCE_M, R_MIN_M, REGION_MARGIN_M, STEP_M, ArcRRT, checked_pose
from roar.planning.tree import Tree

GOAL_HEADING_RAD = math.radians(30)  # [rad] a pose goal is reached within this of its heading
NEAR_GAMMA_M = 4.0  # [m] the neighbours' radius is NEAR_GAMMA_M sqrt(log n / n), at most 2 STEP_M
MAX_NEAR = 40  # neighbours weighed at most


class DubinsRRTStar(ArcRRT):
    def __init__(self, grid: PlanningGrid, footprint: Footprint = Footprint(), r_min_m: float = R_MIN_M,
                 goal_bias: float = GOAL_BIAS, goal_tolerance_m: float = GOAL_TOLERANCE_M, step_m: float = STEP_M,
                 seed: int | None = None, stop_at_first: bool = False, region_margin_m: float | None = REGION_MARGIN_M
                 ) -> None:
        super().__init__(grid, footprint, r_min_m, False, 1.0, goal_bias, goal_tolerance_m, step_m, seed,
                         region_margin_m)
        self.stop_at_first = stop_at_first
        self.first_found_s: float | None = None  # [s] after the start of the last plan()
        self.rewires = 0

    def plan(self, start, goal, budget_s: float = 1.0, max_iterations: int | None = None, t_s: float = 0.0) -> Path:
        """The cheapest path found in budget_s (or max_iterations) from start to within
        goal_tolerance_m of goal (x, y[, heading]: then within GOAL_HEADING_RAD of it too)."""
        start = checked_pose("start", start)
        goal = checked_pose("goal", goal, 2)
        self._check_ends(start, goal[:2])
        self.tree, self.path, self._branch, self.rewires = Tree(start), None, [], 0
        self.first_found_s = None
        began = time.perf_counter()
        best: int | None = None
        it = 0
        while True:
            elapsed = time.perf_counter() - began
            if (max_iterations is not None and it >= max_iterations) or (max_iterations is None and elapsed > budget_s):
                break
            if best is not None and self.stop_at_first:
                break
            it += 1
            k = self._step(goal)
            if k is not None and self._at_goal(goal, k):
                if self.first_found_s is None:
                    self.first_found_s = time.perf_counter() - began
                if best is None or self.tree.cost[k] < self.tree.cost[best]:
                    best = k
            if best is not None:  # rewiring may have lowered another goal node below the best
                goals = self._goal_nodes(goal)
                best = int(goals[np.argmin(self.tree.cost[goals])])
        self.iterations = it
        if best is None:
            raise NoPath(f"none found in {it} samples ({budget_s:g} s; {len(self.tree)} nodes): the goal "
                         f"({goal[0]:.2f}, {goal[1]:.2f}) may be out of reach of a car turning no tighter than "
                         f"{self.r_min_m:g} m")
        self._branch = self.tree.branch(best)
        self.path = self._path(self._branch, t_s)
        return self.path

    def replan(self, pose, goal, grid=None, budget_s: float = 1.0, max_iterations=None, t_s: float = 0.0) -> Path:
        if grid is not None:
            self._set_grid(grid)
        return self.plan(pose, goal, budget_s, max_iterations, t_s)

    def _at_goal(self, goal, k: int) -> bool:
        return len(self._goal_nodes(goal, np.array([k]))) > 0

    def _goal_nodes(self, goal, nodes: np.ndarray | None = None) -> np.ndarray:
        t = self.tree
        nodes = np.arange(len(t)) if nodes is None else nodes
        ok = np.hypot(t.x[nodes] - goal[0], t.y[nodes] - goal[1]) <= self.goal_tolerance_m
        if len(goal) == 3:
            ok &= np.abs(np.remainder(t.heading[nodes] - goal[2] + math.pi, math.tau) - math.pi) <= GOAL_HEADING_RAD
        return nodes[ok]

    def _sample_pose(self, goal) -> np.ndarray:
        if self.rng.uniform() < self.goal_bias:
            heading = goal[2] if len(goal) == 3 else self.rng.uniform(-math.pi, math.pi)
            return np.array([goal[0], goal[1], heading])
        x, y = self._free_point()
        return np.array([x, y, self.rng.uniform(-math.pi, math.pi)])

    def _edge(self, a, b) -> tuple[float, np.ndarray]:
        """(length, poses) of the Dubins curve from pose a to pose b."""
        d = dubins(a, b, self.r_min_m)
        if not math.isfinite(d.length_m[0]):
            return math.inf, np.zeros((0, 3))
        return float(d.length_m[0]), dubins_poses(a, d, 0, self.grid.resolution_m)

    def edge_poses(self, k: int) -> np.ndarray:
        t = self.tree
        return self._edge(t.pose(int(t.parent[k])), t.pose(k))[1]

    def _step(self, goal) -> int | None:
        t = self.tree
        sample = self._sample_pose(goal)
        nearest = int(np.argmin(np.hypot(t.x - sample[0], t.y - sample[1])))
        q_near = np.array(t.pose(nearest))
        d = dubins(q_near, sample, self.r_min_m)
        if not math.isfinite(d.length_m[0]):
            return None
        poses = dubins_poses(q_near, d, 0, self.grid.resolution_m, upto_m=self.step_m)
        if not self.footprint.fits(self.grid, poses):
            return None
        q_new = poses[-1]
        n = len(t)
        radius = min(2 * self.step_m, NEAR_GAMMA_M * math.sqrt(math.log(n + 1) / (n + 1)) + self.step_m * 0.5)
        dist = np.hypot(t.x - q_new[0], t.y - q_new[1])
        near = np.flatnonzero(dist <= radius)
        if len(near) > MAX_NEAR:
            near = near[np.argsort(dist[near])[:MAX_NEAR]]
        # the cheapest parent among the neighbours whose curve fits
        parent, cost_new = nearest, float(t.cost[nearest]) + min(float(d.length_m[0]), self.step_m)
        if len(near):
            into = dubins(t.poses()[near], q_new, self.r_min_m)
            total = t.cost[near] + into.length_m
            for i in np.argsort(total):
                if not total[i] < cost_new - 1e-9:
                    break
                j = int(near[i])
                if j == nearest:
                    continue
                if self.footprint.fits(self.grid, dubins_poses(t.pose(j), into, int(i), self.grid.resolution_m)):
                    parent, cost_new = j, float(total[i])
                    break
        k = t.add(float(q_new[0]), float(q_new[1]), float(q_new[2]), parent, cost_new, 1, np.inf, 0.0,
                  cost_new - float(t.cost[parent]))
        # rewire: the new node as a cheaper parent of its neighbours
        if len(near):
            out = dubins(q_new, t.poses()[near], self.r_min_m)
            via = cost_new + out.length_m
            better = np.flatnonzero(via < t.cost[near] - 1e-9)
            for i in better[np.argsort(via[better] - t.cost[near][better])]:
                j = int(near[i])
                if j == parent or via[i] >= t.cost[j] - 1e-9:
                    continue
                if not self.footprint.fits(self.grid, dubins_poses(q_new, out, int(i), self.grid.resolution_m)):
                    continue
                below = t.descendants(j)
                if below[k]:  # never under itself
                    continue
                t.reparent(j, k, float(via[i]), float(out.length_m[i]), below)
                self.rewires += 1
        return k
