"""``SearchTree``: the nodes of one RRT tree in joint space, with their clearances, parents and roots.

Nodes ``(n, nq)`` are stored in an array that doubles when full, beside each
node's :class:`~.clearance.Clearance` (refined in place by every edge that starts
or ends there), its parent (-1 for a root) and its root (for the goal tree:
which goal the node leads to). Nearest neighbour: a vectorised squared Euclidean
search over the nodes.
"""

from __future__ import annotations

import numpy as np

from .clearance import Clearance


class SearchTree:
    """A tree of configurations ``(nq,)`` with their clearances (see the module docstring)."""

    def __init__(self, nq: int, capacity: int = 256) -> None:
        self.size = 0
        self._nodes = np.empty((capacity, nq))
        self._clearances: list[Clearance] = []
        self._parents: list[int] = []
        self._roots: list[int] = []

    def add(self, c: Clearance, parent: int) -> int:
        """Append node ``c.q`` with its clearance and ``parent`` (-1: a new root); its index."""
        if self.size == len(self._nodes):
            grown = np.empty((2 * len(self._nodes), self._nodes.shape[1]))
            grown[:self.size] = self._nodes[:self.size]
            self._nodes = grown
        k = self.size
        self._nodes[k] = c.q
        self._clearances.append(c)
        self._parents.append(parent)
        self._roots.append(k if parent < 0 else self._roots[parent])
        self.size += 1
        return k

    def node(self, k: int) -> np.ndarray:
        """Configuration of node ``k`` (a view)."""
        return self._nodes[k]

    def clearance(self, k: int) -> Clearance:
        """The clearance of node ``k``."""
        return self._clearances[k]

    def root(self, k: int) -> int:
        """Index of the root node ``k`` grows from."""
        return self._roots[k]

    def nearest(self, q: np.ndarray) -> int:
        """Index of the node closest to ``q`` (Euclidean; the first one on ties)."""
        diff = self._nodes[:self.size] - q
        return int(np.argmin(np.einsum("ij,ij->i", diff, diff)))

    def branch(self, k: int) -> list[int]:
        """Node indices from node ``k`` up to its root (``k`` first)."""
        out = [k]
        while self._parents[out[-1]] >= 0:
            out.append(self._parents[out[-1]])
        return out


__all__ = ["SearchTree"]
