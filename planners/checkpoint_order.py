"""Shortest visiting order of checkpoints (a travelling-salesman path).

Given ``N`` points and a cost ``c(i, j)`` of going from point ``i`` to point
``j`` (Euclidean distance between positions by default, or any user matrix or
function, possibly asymmetric), find the order that starts at a fixed point,
visits every point once and

* ends anywhere (``end=None``, an open path), or
* ends at a fixed point (``end=k``), or
* returns to the start (``return_to_start=True``, a tour).

Up to ``exact_limit`` points (default 12) the answer is exact: Held-Karp
dynamic programming over subsets, ``O(2^N N^2)`` time and ``O(2^N N)`` memory
(``D[S, j] = min_k D[S - {j}, k] + c(k, j)``), vectorised over ``k``. It is
refused above :data:`HELD_KARP_LIMIT` points (16 points take a few seconds, each
further point doubles that), and ``exact_limit`` may not exceed it.

At most :data:`MAX_POINTS` points are ordered (the cost matrix is ``N x N``).

Above that: nearest-neighbour construction followed by 2-opt (segment
reversals, Or-style, until no improving move remains). The result carries a
certified lower bound: the weight of a minimum spanning tree of the
symmetrised costs ``min(c_ij, c_ji)`` (every Hamiltonian path is a spanning
tree, and a tour contains one), so ``cost / lower_bound`` bounds how far the
heuristic is from the optimum on that instance. For metric costs the
nearest-neighbour tour is also known to be within ``(ceil(log2 N) + 1) / 2``
of the optimal tour (Rosenkrantz, Stearns & Lewis 1977) and 2-opt never
increases the cost.

The seed document sums *squared* distances times 0.5; that ranks orders
differently from travelled distance and is not used here.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from kinserve.kinematics.errors import InputError, ShapeError
from kinserve.kinematics.validation import as_count, as_flag, as_numbers

from .checks import as_index
from .two_opt_kernel import reverse_while_improving

#: Most points :func:`held_karp` accepts (and the largest ``exact_limit`` of :func:`shortest_order`).
HELD_KARP_LIMIT = 16
#: Most points :func:`shortest_order` orders.
MAX_POINTS = 1000


@dataclass(frozen=True)
class OrderResult:
    """A visiting order (indices into the input points) and its cost.

    ``method`` is ``"held-karp"`` (exact; ``lower_bound == cost``) or
    ``"nn+2opt"`` (heuristic; ``lower_bound`` from the spanning tree).
    """

    order: list[int]
    cost: float
    method: str
    lower_bound: float

    @property
    def optimal(self) -> bool:
        """True when the order is exact (Held-Karp), False for a heuristic order."""
        return self.method == "held-karp"

    @property
    def gap_bound(self) -> float:
        """``cost / lower_bound`` (>= 1; 1 for exact answers)."""
        if self.lower_bound <= 0:
            return 1.0 if self.cost <= 0 else math.inf
        return self.cost / self.lower_bound


def positions_of(points: ArrayLike) -> np.ndarray:
    """Positions ``(N, d)`` of points given as positions ``(N, d)`` or poses ``(N, 4, 4)``; finite numbers
    only, at most :data:`MAX_POINTS` points (:class:`InputError` / :class:`ShapeError` otherwise)."""
    P = as_numbers(points, "points")
    if P.ndim == 3 and P.shape[1:] == (4, 4):
        P = P[:, :3, 3].copy()
    elif P.ndim != 2:
        raise ShapeError(f"points must be positions (N, d) or poses (N, 4, 4), got shape {P.shape}")
    _check_size(len(P))
    return P


def _check_size(n: int) -> None:
    if n > MAX_POINTS:
        raise InputError(f"at most {MAX_POINTS} points can be ordered, got {n}")


def euclidean_cost_matrix(points: ArrayLike) -> np.ndarray:
    """``C[i, j] = ||p_i - p_j||`` for positions or poses (their translations)."""
    P = positions_of(points)
    return np.linalg.norm(P[:, None, :] - P[None, :, :], axis=-1)


def as_cost_matrix(C: ArrayLike, name: str = "cost matrix") -> np.ndarray:
    """``C`` as a square float ``(N, N)`` array of costs ``>= 0`` (``inf`` allowed: a forbidden move);
    :class:`ShapeError` / :class:`InputError` for another shape, non-numbers, NaN or negative costs."""
    if C is None or isinstance(C, (str, bytes, dict)):
        raise ShapeError(f"{name} must be a square (N, N) array of numbers, got {C!r:.60}")
    try:
        C = np.asarray(C, dtype=float)
    except (TypeError, ValueError):
        raise ShapeError(f"{name} must be a square (N, N) array of numbers") from None
    if C.ndim != 2 or C.shape[0] != C.shape[1]:
        raise ShapeError(f"{name} must be square (N, N), got shape {C.shape}")
    if np.any(np.isnan(C)) or np.any(C < 0):
        raise InputError(f"{name}: costs must be >= 0 and not NaN (use inf for a forbidden move)")
    return C


def _call_cost(cost: Callable[[Any, Any], float], points: Any, i: int, j: int) -> float:
    """``cost(points[i], points[j])`` as a float; :class:`InputError` naming the pair when the cost function
    fails or does not return a number."""
    try:
        return float(cost(points[i], points[j]))
    except Exception as exc:  # the user's function: its failure is reported as bad input, with the pair
        raise InputError(f"the cost function failed on points {i} and {j}: "
                         f"{type(exc).__name__}: {exc}") from exc


def _cost_matrix(points, cost) -> np.ndarray:
    if cost is None:
        if points is None:
            raise InputError("give points, or a cost matrix / function with n")
        return as_cost_matrix(euclidean_cost_matrix(points))
    if callable(cost):
        if points is None or isinstance(points, (str, bytes, dict)) or not hasattr(points, "__len__"):
            raise InputError("a cost function needs the sequence of points it is evaluated on")
        n = len(points)
        _check_size(n)
        return as_cost_matrix([[0.0 if i == j else _call_cost(cost, points, i, j) for j in range(n)]
                               for i in range(n)], "costs of the cost function")
    C = as_cost_matrix(cost)
    _check_size(C.shape[0])
    if points is not None and len(points) != C.shape[0]:
        raise ShapeError(f"cost matrix is {C.shape} but {len(points)} points were given")
    return C


def path_cost(C: np.ndarray, order: Sequence[int], return_to_start: bool = False) -> float:
    """Sum of ``C[order[k], order[k+1]]`` (plus the closing edge for a tour).

    Refused (:class:`InputError` / :class:`ShapeError`): ``C`` not a square matrix of costs >= 0 (NaN,
    negative), ``order`` holding an index outside ``[0, N - 1]`` (negative ones included) or an index
    twice, ``return_to_start`` not True or False.
    """
    C = as_cost_matrix(C)
    return_to_start = as_flag(return_to_start, "return_to_start")
    if order is None or isinstance(order, (str, bytes, dict)) or not hasattr(order, "__iter__"):
        raise InputError(f"order must be a sequence of indices into the cost matrix, got {order!r:.60}")
    o = [as_index(v, C.shape[0], f"order[{k}]") for k, v in enumerate(order)]
    if len(set(o)) != len(o):
        raise InputError(f"order must visit each point at most once, got {o!r:.200} (close a tour with "
                         "return_to_start=True)")
    total = float(sum(C[a, b] for a, b in zip(o[:-1], o[1:])))
    if return_to_start and len(o) > 1:
        total += float(C[o[-1], o[0]])
    return total


def held_karp(C: np.ndarray, start: int = 0, end: int | None = None,
              return_to_start: bool = False) -> tuple[list[int], float]:
    """Exact optimal order by dynamic programming over subsets; returns ``(order, cost)``.

    Refused (:class:`InputError` / :class:`ShapeError`): ``C`` not a square matrix of costs >= 0 (NaN,
    negative), more than :data:`HELD_KARP_LIMIT` points (the work doubles with each point), ``start`` /
    ``end`` not an index of ``C``, ``return_to_start`` not True or False.
    """
    C = as_cost_matrix(C)
    return_to_start = as_flag(return_to_start, "return_to_start")
    n = C.shape[0]
    if n == 0:
        raise InputError("no points to order: the cost matrix is empty")
    if n > HELD_KARP_LIMIT:
        raise InputError(f"held_karp takes at most {HELD_KARP_LIMIT} points (O(2^N N^2) time, O(2^N N) "
                         f"memory), got {n}; use shortest_order for more")
    start = as_index(start, n, "start")
    end = None if end is None else as_index(end, n, "end")
    if n == 1:
        return [start], 0.0
    others = [i for i in range(n) if i != start and (end is None or i != end or return_to_start)]
    if end is not None and not return_to_start and end == start:
        raise InputError("end must differ from start (use return_to_start=True for a tour)")
    m = len(others)
    idx = np.array(others)
    full = (1 << m) - 1
    D = np.full((1 << m, m), np.inf)
    P = np.full((1 << m, m), -1, dtype=np.int64)
    D[1 << np.arange(m), np.arange(m)] = C[start, idx]
    Csub = C[np.ix_(idx, idx)]
    bits = [(1 << j) for j in range(m)]
    for S in range(1, full + 1):
        if S & (S - 1) == 0:
            continue
        members = [j for j in range(m) if S & bits[j]]
        for j in members:
            prev = S ^ bits[j]
            cand = D[prev, members] + Csub[members, j]
            k = int(np.argmin(cand))
            D[S, j] = cand[k]
            P[S, j] = members[k]
    if return_to_start:
        closing = C[idx, start]
    elif end is not None:
        closing = C[idx, end]
    else:
        closing = np.zeros(m)
    total = D[full] + closing
    j = int(np.argmin(total))
    best = float(total[j])
    seq, S = [], full
    while j >= 0:
        seq.append(others[j])
        j, S = int(P[S, j]), S ^ bits[j]
    order = [start] + seq[::-1]
    if end is not None and not return_to_start:
        order.append(end)
    return order, best


def _nearest_neighbour(C: np.ndarray, start: int, end: int | None, return_to_start: bool) -> list[int]:
    """The greedy order from ``start``: each step goes to the cheapest point not yet visited, the lowest index
    among equal costs; ``end``, when fixed on an open path, comes last. One row's minimum per step over the
    points left (O(N) in NumPy; O(N^2) in all)."""
    open_end = end is not None and not return_to_start
    left = np.ones(C.shape[0], dtype=bool)
    left[start] = False
    if open_end:
        left[end] = False
    order = [start]
    for _ in range(int(np.count_nonzero(left))):
        candidates = np.flatnonzero(left)
        nxt = int(candidates[np.argmin(C[order[-1], candidates])])  # (argmin: the first of equal costs)
        order.append(nxt)
        left[nxt] = False
    if open_end:
        order.append(end)
    return order


def two_opt(C: np.ndarray, order: Sequence[int], fixed_end: bool, return_to_start: bool = False,
            max_rounds: int = 1000) -> tuple[list[int], float]:
    """Improve ``order`` by reversing segments while that lowers the cost (first improvement, at most
    ``max_rounds`` reversals; compiled: :func:`~.two_opt_kernel.reverse_while_improving`).

    The first point always stays first; the last stays last when ``fixed_end``.
    Works for asymmetric costs: the change of reversing ``o[i..k]`` is
    ``C[o[i-1], o[k]] + C[o[i], o[k+1]] - C[o[i-1], o[i]] - C[o[k], o[k+1]]``
    plus (backward - forward) cost of the segment's inner edges, O(1) from
    prefix sums.
    """
    o = np.array(order, dtype=np.int64)
    closed = return_to_start
    last = len(o) - 1 if (fixed_end and not closed) else len(o)  # segment ends k < last
    reverse_while_improving(np.ascontiguousarray(C, dtype=float), o, last, closed, int(max_rounds))
    o = o.tolist()
    return o, path_cost(C, o, closed)


def spanning_tree_bound(C: np.ndarray) -> float:
    """Weight of a minimum spanning tree of ``min(C, C^T)``: a lower bound on any path through all points
    (0 when a cost between two points is infinite). Prim's algorithm on the dense matrix: each step adds the
    point nearest the tree and lowers the others' distances to the tree by its row (O(N^2))."""
    S = np.minimum(C, C.T)
    n = len(S)
    if n < 2 or np.any(~np.isfinite(S[~np.eye(n, dtype=bool)])):
        return 0.0
    inside = np.zeros(n, dtype=bool)
    inside[0] = True
    to_tree = S[0].copy()  # the cheapest edge from each point to the tree
    to_tree[0] = np.inf
    total = 0.0
    for _ in range(n - 1):
        j = int(np.argmin(to_tree))
        total += float(to_tree[j])
        inside[j] = True
        np.minimum(to_tree, S[j], out=to_tree)
        to_tree[inside] = np.inf
    return total


def shortest_order(
    points: ArrayLike | None = None,
    *,
    cost: ArrayLike | Callable[[Any, Any], float] | None = None,
    start: int = 0,
    end: int | None = None,
    return_to_start: bool = False,
    exact_limit: int = 12,
) -> OrderResult:
    """Best order to visit every point, starting at ``start``.

    ``points``: positions ``(N, d)`` or poses ``(N, 4, 4)`` (Euclidean distance
    between positions); ``cost``: an ``(N, N)`` matrix or a function
    ``cost(point_i, point_j)`` overriding the metric. ``end`` fixes the last
    point; ``return_to_start`` closes the tour. Exact (Held-Karp) for
    ``N <= exact_limit``, nearest neighbour + 2-opt above (see the module
    docstring for the bound reported).

    Refused (:class:`InputError` / :class:`ShapeError` naming the argument): points that are not finite
    positions or poses, more than :data:`MAX_POINTS` of them, NaN or negative costs, ``start`` / ``end``
    not an index of the points (None, NaN, out of range), ``exact_limit`` not an integer in
    ``[0, HELD_KARP_LIMIT]``, ``return_to_start`` not True or False (no truthiness: it was passed to the
    compiled 2-opt, which refused it with Numba's own TypeError).
    """
    exact_limit = as_count(exact_limit, "exact_limit", 0, HELD_KARP_LIMIT)
    return_to_start = as_flag(return_to_start, "return_to_start")
    C = _cost_matrix(points, cost)
    n = C.shape[0]
    if n == 0:
        raise InputError("no points to order")
    start = as_index(start, n, "start")
    end = None if end is None else as_index(end, n, "end")
    if end is not None and return_to_start:
        raise InputError("give either end (an open path ending there) or return_to_start (a tour), not both")
    if end is not None and end == start and not return_to_start:
        raise InputError("end must differ from start (use return_to_start=True for a tour)")
    if n <= exact_limit:
        order, c = held_karp(C, start, end, return_to_start)
        return OrderResult(order, c, "held-karp", c)
    order = _nearest_neighbour(C, start, end, return_to_start)
    order, c = two_opt(C, order, fixed_end=end is not None, return_to_start=return_to_start)
    return OrderResult(order, c, "nn+2opt", min(spanning_tree_bound(C), c))
