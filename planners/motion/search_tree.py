"""``SearchTree``: the nodes of one RRT tree in joint space, with their clearances, parents and roots.

Nodes ``(n, nq)`` are stored in an array that doubles when full, beside each
node's :class:`~.clearance.Clearance` (refined in place by every edge that starts
or ends there), its parent (-1 for a root), its root (for the goal tree: which
goal the node leads to) and whether the edge from its parent is certified yet
(a lazy search certifies the edges of a candidate path only). A node whose edge
fails its certificate is pruned with everything grown from it: pruned nodes keep
their index but are never a nearest neighbour again. Nearest neighbour: a
compiled squared Euclidean scan over the nodes that are not pruned
(:func:`~.extend_kernel.nearest_node`); :attr:`SearchTree.points` and
:attr:`SearchTree.pruned` hand the arrays to the compiled extension step
(:func:`~.extend_kernel.extend_probe`).
"""

from __future__ import annotations

import numpy as np

from .clearance import Clearance
from .extend_kernel import nearest_node


class SearchTree:
    """A tree of configurations ``(nq,)`` with their clearances (see the module docstring)."""

    def __init__(self, nq: int, capacity: int = 256) -> None:
        self.size = 0
        self._nodes = np.empty((capacity, nq))
        self._pruned = np.zeros(capacity, dtype=bool)
        self._clearances: list[Clearance] = []
        self._parents: list[int] = []
        self._roots: list[int] = []
        self._certified: list[bool] = []

    def add(self, c: Clearance, parent: int, certified: bool = True) -> int:
        """Append node ``c.q`` with its clearance and ``parent`` (-1: a new root); ``certified``: whether the
        edge from ``parent`` is certified already. Its index."""
        if self.size == len(self._nodes):
            grown = np.empty((2 * len(self._nodes), self._nodes.shape[1]))
            grown[:self.size] = self._nodes[:self.size]
            self._nodes = grown
            self._pruned = np.concatenate([self._pruned, np.zeros(len(self._pruned), dtype=bool)])
        k = self.size
        self._nodes[k] = c.q
        self._clearances.append(c)
        self._parents.append(parent)
        self._roots.append(k if parent < 0 else self._roots[parent])
        self._certified.append(certified or parent < 0)
        self.size += 1
        return k

    @property
    def points(self) -> np.ndarray:
        """The node array ``(capacity, nq)``: rows ``[:size]`` are the nodes (read only by callers)."""
        return self._nodes

    @property
    def pruned(self) -> np.ndarray:
        """The pruned mask ``(capacity,)`` of :attr:`points`' rows (read only by callers)."""
        return self._pruned

    def node(self, k: int) -> np.ndarray:
        """Configuration of node ``k`` (a view)."""
        return self._nodes[k]

    def clearance(self, k: int) -> Clearance:
        """The clearance of node ``k``."""
        return self._clearances[k]

    def root(self, k: int) -> int:
        """Index of the root node ``k`` grows from."""
        return self._roots[k]

    def parent(self, k: int) -> int:
        """Index of node ``k``'s parent, -1 for a root."""
        return self._parents[k]

    def certified(self, k: int) -> bool:
        """Whether the edge from node ``k``'s parent to it is certified (True for a root)."""
        return self._certified[k]

    def mark_certified(self, k: int) -> None:
        """Record that the edge from node ``k``'s parent to it is certified."""
        self._certified[k] = True

    def prune(self, k: int) -> None:
        """Prune node ``k`` and every node grown from it (a child's index is above its parent's)."""
        pruned, parents = self._pruned, self._parents
        pruned[k] = True
        for j in range(k + 1, self.size):
            if pruned[parents[j]]:
                pruned[j] = True

    def nearest(self, q: np.ndarray) -> int:
        """Index of the node closest to ``q`` (Euclidean; the first one on ties) among those not pruned (a
        root is never pruned)."""
        return int(nearest_node(self._nodes, self._pruned, self.size, np.asarray(q, dtype=float)))

    def branch(self, k: int) -> list[int]:
        """Node indices from node ``k`` up to its root (``k`` first)."""
        out = [k]
        while self._parents[out[-1]] >= 0:
            out.append(self._parents[out[-1]])
        return out


__all__ = ["SearchTree"]
