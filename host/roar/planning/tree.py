"""A planner's tree in growable arrays (no object per node): poses, parent, cost to come and the
edge into each node, doubled in capacity when full."""

from __future__ import annotations

import numpy as np

FIELDS = {"x": float, "y": float, "heading": float, "parent": np.int64, "cost": float, "direction": np.int8,
          "radius": float, "angle": float, "length": float, "reversed": float}


class Tree:
    """Node 0 is the root. The edge into node k leaves its parent's pose with (radius, angle,
    length, direction) -- an arc (roar.planning.arcs); planners with other edges keep their own
    description beside it."""

    def __init__(self, root, capacity: int = 1024, reversed_m: float = 0.0) -> None:
        self.n = 0
        self._a = {name: np.zeros(capacity, dtype) for name, dtype in FIELDS.items()}
        self.add(*root, parent=-1, cost=0.0, direction=1, radius=np.inf, angle=0.0, length=0.0, reversed_m=reversed_m)

    def __len__(self) -> int:
        return self.n

    def __getattr__(self, name: str) -> np.ndarray:
        if name in FIELDS:
            return self.__dict__["_a"][name][:self.__dict__["n"]]
        raise AttributeError(name)

    def add(self, x: float, y: float, heading: float, parent: int, cost: float, direction: int, radius: float,
            angle: float, length: float, reversed_m: float | None = None) -> int:
        """A node; reversed_m: metres driven backwards in a row up to it (default: from its parent's
        and its edge's)."""
        if self.n == len(self._a["x"]):
            self._a = {k: np.concatenate([v, np.zeros_like(v)]) for k, v in self._a.items()}
        k = self.n
        if reversed_m is None:
            reversed_m = float(self._a["reversed"][parent]) + length if direction < 0 else 0.0
        for name, value in (("x", x), ("y", y), ("heading", heading), ("parent", parent), ("cost", cost),
                            ("direction", direction), ("radius", radius), ("angle", angle), ("length", length),
                            ("reversed", reversed_m)):
            self._a[name][k] = value
        self.n += 1
        return k

    def pose(self, k: int) -> tuple[float, float, float]:
        a = self._a
        return float(a["x"][k]), float(a["y"][k]), float(a["heading"][k])

    def poses(self) -> np.ndarray:
        return np.stack([self.x, self.y, self.heading], axis=1)

    def branch(self, k: int) -> list[int]:
        """The nodes from the root to k."""
        out = []
        while k >= 0:
            out.append(k)
            k = int(self._a["parent"][k])
        return out[::-1]

    def keep(self, mask: np.ndarray, new_root: int, reversed_m: float | None = None) -> np.ndarray:
        """Keep the nodes of mask (new_root among them, every kept node's parent kept too), new_root
        becoming node 0; costs counted from it (and, given reversed_m, the metres reversed in a row
        from the new root's: a parent must then come before its children, as RRT's do).
        Returns old index -> new index (-1: dropped)."""
        order = np.concatenate([[new_root], np.flatnonzero(mask & (np.arange(self.n) != new_root))])
        remap = np.full(self.n, -1, np.int64)
        remap[order] = np.arange(len(order))
        old_cost = self.cost[new_root]
        a = {k: v[:self.n][order] for k, v in self._a.items()}
        a["parent"] = np.where(a["parent"] >= 0, remap[np.maximum(a["parent"], 0)], -1)
        a["parent"][0] = -1
        a["cost"] = a["cost"] - old_cost
        a["length"][0], a["radius"][0], a["angle"][0] = 0.0, np.inf, 0.0
        if reversed_m is not None:
            a["reversed"][0] = reversed_m
            for k in range(1, len(order)):
                a["reversed"][k] = a["reversed"][a["parent"][k]] + a["length"][k] if a["direction"][k] < 0 else 0.0
        capacity = max(1024, 2 * len(order))
        self._a = {k: np.concatenate([v, np.zeros(capacity - len(v), v.dtype)]) for k, v in a.items()}
        self.n = len(order)
        return remap

    def reparent(self, k: int, parent: int, cost: float, length: float, below: np.ndarray | None = None) -> None:
        """Hang node k (and everything below it: `below`, from descendants(k), if known) under
        parent by an edge of `length` that brings k's cost to `cost`; the costs below follow."""
        below = self.descendants(k) if below is None else below
        self._a["cost"][:self.n][below] -= float(self._a["cost"][k]) - cost
        self._a["parent"][k] = parent
        self._a["length"][k] = length

    def descendants(self, k: int) -> np.ndarray:
        """(n,) bool: k and every node below it."""
        mine = np.zeros(self.n, bool)
        mine[k] = True
        parent = self.parent
        has = parent >= 0
        while True:  # a level of the tree each round (RRT* rewires: a parent may come after its child)
            more = mine.copy()
            more[has] |= mine[parent[has]]
            if np.array_equal(more, mine):
                return mine
            mine = more
