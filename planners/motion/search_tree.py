"""``SearchTree``: the nodes of one RRT tree in joint space, with their clearances, parents and roots.

Nodes ``(n, nq)`` are stored in an array that doubles when full, beside each
node's parent (-1 for a root; an array too), whether the edge from its parent is
certified yet (a lazy search certifies the edges of a candidate path only) and
its :class:`~.clearance.Clearance` (refined in place by every edge that starts or
ends there): given with the node, or made from the node on its first read by the
tree's ``clearance`` function (the nodes the compiled search adds,
:mod:`~.search_kernel`). A node's root (for the goal tree: which goal the node
leads to) is found up its parents. A node whose edge fails its certificate is
pruned with everything grown from it: pruned nodes keep their index but are
never a nearest neighbour again. Nearest neighbour: a compiled squared Euclidean
scan over the nodes that are not pruned (:func:`~.extend_kernel.nearest_node`);
:attr:`SearchTree.points`, :attr:`SearchTree.pruned` and
:attr:`SearchTree.parents` hand the arrays to the compiled search, which writes
nodes and parents and the new :attr:`SearchTree.size`.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .clearance import Clearance
from .extend_kernel import nearest_node


class SearchTree:
    """A tree of configurations ``(nq,)`` with their clearances (see the module docstring). ``clearance``:
    makes the clearance of a node added without one (None: every node comes with its own)."""

    def __init__(self, nq: int, capacity: int = 256,
                 clearance: Callable[[np.ndarray], Clearance] | None = None) -> None:
        self.size = 0
        self._nodes = np.empty((capacity, nq))
        self._pruned = np.zeros(capacity, dtype=bool)
        self._parents = np.full(capacity, -1, dtype=np.int64)
        self._certified = np.zeros(capacity, dtype=bool)
        self._clearances: dict[int, Clearance] = {}
        self._make = clearance

    def reserve(self) -> None:
        """Double the arrays when every row is in use (the nodes and their records kept)."""
        if self.size < len(self._nodes):
            return
        grow = len(self._nodes)
        self._nodes = np.concatenate([self._nodes, np.empty((grow, self._nodes.shape[1]))])
        self._pruned = np.concatenate([self._pruned, np.zeros(grow, dtype=bool)])
        self._parents = np.concatenate([self._parents, np.full(grow, -1, dtype=np.int64)])
        self._certified = np.concatenate([self._certified, np.zeros(grow, dtype=bool)])

    def add(self, c: Clearance, parent: int, certified: bool = True) -> int:
        """Append node ``c.q`` with its clearance and ``parent`` (-1: a new root); ``certified``: whether the
        edge from ``parent`` is certified already. Its index."""
        self.reserve()
        k = self.size
        self._nodes[k] = c.q
        self._clearances[k] = c
        self._parents[k] = parent
        self._certified[k] = certified or parent < 0
        self.size += 1
        return k

    @property
    def points(self) -> np.ndarray:
        """The node array ``(capacity, nq)``: rows ``[:size]`` are the nodes (written by the compiled search
        only)."""
        return self._nodes

    @property
    def pruned(self) -> np.ndarray:
        """The pruned mask ``(capacity,)`` of :attr:`points`' rows (read only by callers)."""
        return self._pruned

    @property
    def parents(self) -> np.ndarray:
        """The parent of each row of :attr:`points` ``(capacity,)``, -1 for a root (written by the compiled
        search only)."""
        return self._parents

    def node(self, k: int) -> np.ndarray:
        """Configuration of node ``k`` (a view)."""
        return self._nodes[k]

    def clearance(self, k: int) -> Clearance:
        """The clearance of node ``k`` (made on first read for a node added without one)."""
        c = self._clearances.get(k)
        if c is None:
            if self._make is None:
                raise ValueError(f"SearchTree: node {k} has no clearance and the tree no function to make it")
            c = self._clearances[k] = self._make(self._nodes[k].copy())
        return c

    def root(self, k: int) -> int:
        """Index of the root node ``k`` grows from."""
        return self.branch(k)[-1]

    def parent(self, k: int) -> int:
        """Index of node ``k``'s parent, -1 for a root."""
        return int(self._parents[k])

    def certified(self, k: int) -> bool:
        """Whether the edge from node ``k``'s parent to it is certified (True for a root)."""
        return bool(self._certified[k])

    def mark_certified(self, k: int) -> None:
        """Record that the edge from node ``k``'s parent to it is certified."""
        self._certified[k] = True

    def prune(self, k: int) -> None:
        """Prune node ``k`` and every node grown from it (a child's index is above its parent's)."""
        pruned, parents = self._pruned, self._parents[:self.size].tolist()
        pruned[k] = True
        for j in range(k + 1, self.size):
            if parents[j] >= 0 and pruned[parents[j]]:
                pruned[j] = True

    def nearest(self, q: np.ndarray) -> int:
        """Index of the node closest to ``q`` (Euclidean; the first one on ties) among those not pruned (a
        root is never pruned)."""
        return int(nearest_node(self._nodes, self._pruned, self.size, np.asarray(q, dtype=float)))

    def branch(self, k: int) -> list[int]:
        """Node indices from node ``k`` up to its root (``k`` first)."""
        parents = self._parents
        out = [int(k)]
        while parents[out[-1]] >= 0:
            out.append(int(parents[out[-1]]))
        return out


__all__ = ["SearchTree"]
