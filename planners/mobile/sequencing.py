"""Visiting waypoints on a grid map: in the given order, or in the best order.

With ``order="given"`` consecutive waypoints are joined by A* paths. With
``order="optimal"`` the first and last waypoints stay fixed and the
intermediate ones are reordered to minimise the total A* path cost: the
pairwise costs ``C[i, j]`` (A* between every pair, ``inf`` when no path) feed
:func:`planners.checkpoint_order.shortest_order` (exact Held-Karp up to 12
waypoints). That is the travelling-salesman formulation of SCENARIOS.md S7,
with obstacle-aware distances instead of straight lines.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from kinserve.kinematics.errors import InputError, suggest

from ..checkpoint_order import shortest_order
from ..errors import NoPathError
from ._checks import as_points
from .astar import GridPath, astar
from .maps import OccupancyGrid, check_grid

#: Keyword arguments passed on to :func:`astar`.
ASTAR_OPTIONS = ("heuristic", "turn_penalty", "proximity_weight", "proximity_range", "method")
#: Most waypoints of :func:`pairwise_costs` (one A* search per pair).
MAX_PAIRWISE = 200
#: Most waypoints of :func:`plan_waypoints` in the given order (one A* search per leg).
MAX_WAYPOINTS = 10_000


def _check_astar_options(options: dict[str, Any]) -> None:
    """:class:`InputError` naming an unknown :func:`astar` option (with close matches)."""
    for key in options:
        if key not in ASTAR_OPTIONS:
            raise InputError(f"unknown A* option {key!r}; accepted: {', '.join(ASTAR_OPTIONS)}."
                             + suggest(key, ASTAR_OPTIONS))


def _waypoints(waypoints: ArrayLike, maximum: int) -> np.ndarray:
    """``waypoints`` as finite ``(K, 2)`` points with ``2 <= K <= maximum``."""
    P = as_points(waypoints, "waypoints", min_rows=2)
    if len(P) > maximum:
        raise InputError(f"waypoints: at most {maximum:,} points, got {len(P):,}")
    return P


@dataclass(frozen=True)
class WaypointPlan:
    """Waypoints visited in ``order`` (indices into the input), joined by A* ``segments``.

    ``points`` is the whole path (lattice points, each waypoint once);
    ``waypoint_index[k]`` is the index in ``points`` of the ``k``-th visited waypoint.
    """

    order: list[int]
    segments: list[GridPath]
    cost: float
    length: float
    points: np.ndarray
    waypoint_index: list[int]
    names: list[str]
    ordering_method: str

    @property
    def visited_names(self) -> list[str]:
        """The waypoint names in visiting order."""
        return [self.names[i] for i in self.order]


def pairwise_costs(grid: OccupancyGrid, waypoints: ArrayLike,
                   **astar_kwargs: Any) -> tuple[np.ndarray, dict[tuple[int, int], GridPath]]:
    """``(C, paths)``: A* cost between every ordered pair (``inf`` if unreachable) and the paths.

    Costs are symmetric for the distance and proximity costs (one search per
    unordered pair); with a turn penalty both directions are searched.

    Refused: ``grid`` not an :class:`OccupancyGrid`; ``waypoints`` not finite
    ``(K, 2)`` points with ``2 <= K <= 200``; unknown A* options; what
    :func:`astar` refuses.
    """
    check_grid(grid)
    _check_astar_options(astar_kwargs)
    P = _waypoints(waypoints, MAX_PAIRWISE)
    n = len(P)
    C = np.zeros((n, n))
    paths: dict[tuple[int, int], GridPath] = {}
    symmetric = not astar_kwargs.get("turn_penalty", 0.0)
    for i in range(n):
        for j in range(n):
            if i == j or (symmetric and j < i):
                continue
            try:
                p = astar(grid, P[i], P[j], **astar_kwargs)
                C[i, j] = p.cost
                paths[(i, j)] = p
            except NoPathError:
                C[i, j] = math.inf
            if symmetric:
                C[j, i] = C[i, j]
    return C, paths


def _reverse(p: GridPath) -> GridPath:
    return GridPath(p.points[::-1].copy(), p.cells[::-1].copy(), p.cost, p.length, p.expanded, p.method)


def plan_waypoints(grid: OccupancyGrid, waypoints: ArrayLike, *, order: str = "given",
                   names: Sequence[str] | None = None, **astar_kwargs: Any) -> WaypointPlan:
    """Join ``waypoints`` (``(K, 2)``, world units) by A* paths, in the given or the best order.

    ``order="optimal"`` keeps the first and the last waypoint and reorders the
    rest (see the module docstring). ``astar_kwargs`` go to :func:`astar`.
    Raises :class:`NoPathError` when some required leg has no path.

    Refused (:class:`InputError` and subclasses): ``grid`` not an
    :class:`OccupancyGrid`; ``waypoints`` not finite ``(K, 2)`` points with
    ``2 <= K`` (at most 10,000; 200 with ``order="optimal"``); ``names`` not a
    sequence of ``K`` names; an unknown ``order``; unknown A* options; what
    :func:`astar` refuses.
    """
    check_grid(grid)
    if not isinstance(order, str) or order not in ("given", "optimal"):
        raise InputError(f"order must be 'given' or 'optimal', got {order!r}")
    _check_astar_options(astar_kwargs)
    P = _waypoints(waypoints, MAX_WAYPOINTS if order == "given" else MAX_PAIRWISE)
    K = len(P)
    if names is not None and (isinstance(names, (str, bytes, dict)) or not isinstance(names, Sequence)):
        raise InputError(f"names must be a sequence of {K} names, got {names!r}")
    names = [str(i) for i in range(K)] if names is None else [str(n) for n in names]
    if len(names) != K:
        raise InputError(f"names must have one entry per waypoint ({K}), got {len(names)}")
    if order == "given":
        seq = list(range(K))
        segs = []
        for a, b in zip(seq[:-1], seq[1:]):
            try:
                segs.append(astar(grid, P[a], P[b], **astar_kwargs))
            except NoPathError as exc:
                raise NoPathError(f"leg {names[a]} -> {names[b]}: {exc}") from None
        method = "given"
    elif order == "optimal":
        C, paths = pairwise_costs(grid, P, **astar_kwargs)
        res = shortest_order(cost=C, start=0, end=K - 1 if K > 1 else None)
        if not math.isfinite(res.cost):
            raise NoPathError("no order of the waypoints is connected by collision-free paths")
        seq = res.order
        segs = [paths[(a, b)] if (a, b) in paths else _reverse(paths[(b, a)])
                for a, b in zip(seq[:-1], seq[1:])]
        method = res.method
    else:
        raise InputError(f"order must be 'given' or 'optimal', got {order!r}")
    pts = [segs[0].points[:1]]
    idx = [0]
    for s in segs:
        pts.append(s.points[1:])
        idx.append(idx[-1] + len(s.points) - 1)
    return WaypointPlan(seq, segs, float(sum(s.cost for s in segs)), float(sum(s.length for s in segs)),
                        np.concatenate(pts), idx, names, method)
