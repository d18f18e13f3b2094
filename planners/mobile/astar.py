"""A* on an :class:`~planners.mobile.maps.OccupancyGrid` (8-connected lattice).

Graph: every free lattice point; moves to the 8 neighbours, a straight step
costs ``res`` and a diagonal step ``res sqrt(2)``; a diagonal step is allowed
only when both orthogonal neighbours it passes are free (no cutting of
blocked corners, so the path is free at every point by the map's raster rule).

Search: A* with ``f = g + h`` and ties broken towards the larger ``g``
(the node nearer the goal). Heuristics, both admissible and consistent:

* ``"euclidean"``: ``res |p - goal|`` (as SCENARIOS.md S7 asks);
* ``"octile"`` (default): ``res (max(di, dj) + (sqrt 2 - 1) min(di, dj))``,
  the exact obstacle-free 8-connected distance; it dominates the Euclidean one
  and so expands fewer nodes for the same optimal cost.

For the pure distance cost the search uses *jump point search* (Harabor &
Grastien 2011; the no-corner-cutting rules of their 2014 paper): A* whose
successors are the next "jump points" along straight and diagonal runs,
found by scanning; it returns a path of the same (optimal) cost as plain A*
while pushing far fewer nodes. Straight scans run in C over precomputed byte
masks (``bytes.find``), so a whole row is skipped in one call.

Optional costs (then plain A* is used, still optimal for the stated cost):

* ``turn_penalty`` (cost units per radian of heading change, in 45 degree
  steps): the search state becomes (lattice point, arrival direction);
* ``proximity_weight``: a step into a point at distance ``d`` from the nearest
  blocked point costs ``step (1 + w max(0, 1 - d / proximity_range)^2)``
  (distance transform of the grid); keeps the path away from obstacles.

Start and goal are snapped to their nearest lattice points; a start/goal
outside the map or in an inflated obstacle raises
:class:`~planners.errors.BlockedPointError`, and two free points in different
free regions raise :class:`~planners.errors.NoPathError` (checked up front by
labelling the 4-connected free regions, which are exactly the regions
reachable without corner cutting).
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy import ndimage

from kinserve.kinematics.errors import InputError
from kinserve.kinematics.validation import as_nonnegative, as_positive

from ..errors import BlockedPointError, NoPathError
from ._checks import as_point
from .maps import OccupancyGrid, check_grid

SQRT2 = math.sqrt(2.0)
HEURISTICS = ("octile", "euclidean")
#: (di, dj) of the 8 moves; index = direction id.
MOVES = ((0, 1), (1, 1), (1, 0), (1, -1), (0, -1), (-1, -1), (-1, 0), (-1, 1))


@dataclass(frozen=True)
class GridPath:
    """An A* result: every lattice point along the path, start and goal included.

    ``cost`` is the minimised objective (world units, plus penalties);
    ``length`` the geometric length; ``expanded`` the number of nodes closed.
    """

    points: np.ndarray
    cells: np.ndarray
    cost: float
    length: float
    expanded: int
    method: str

    def __len__(self) -> int:
        return len(self.points)


# ------------------------------------------------------------------ helpers
class _Lattice:
    """Padded flat views of a grid shared by the searches (built once per grid, cached)."""

    def __init__(self, grid: OccupancyGrid):
        self.source = grid.free
        P = np.pad(grid.free, 1, constant_values=False)
        self.H, self.W = P.shape
        self.free = P.tobytes()
        self.res = grid.resolution
        self.labels = None
        self._stops = None
        self._P = P

    def stops(self):
        """Byte masks of the cells where a straight scan stops (blocked or jump point), per direction."""
        if self._stops is None:
            P = self._P
            nb = ~P
            # moving east (+j): forced if a side cell is free and the cell behind it is blocked
            fE = np.zeros_like(P)
            fE[1:-1, 1:-1] = (P[2:, 1:-1] & nb[2:, :-2]) | (P[:-2, 1:-1] & nb[:-2, :-2])
            fW = np.zeros_like(P)
            fW[1:-1, 1:-1] = (P[2:, 1:-1] & nb[2:, 2:]) | (P[:-2, 1:-1] & nb[:-2, 2:])
            fN = np.zeros_like(P)  # moving +i
            fN[1:-1, 1:-1] = (P[1:-1, 2:] & nb[:-2, 2:]) | (P[1:-1, :-2] & nb[:-2, :-2])
            fS = np.zeros_like(P)
            fS[1:-1, 1:-1] = (P[1:-1, 2:] & nb[2:, 2:]) | (P[1:-1, :-2] & nb[2:, :-2])
            self._stops = (
                (nb | fE).tobytes(),
                (nb | fW).tobytes(),
                np.ascontiguousarray((nb | fN).T).tobytes(),
                np.ascontiguousarray((nb | fS).T).tobytes(),
            )
        return self._stops

    def component_labels(self):
        if self.labels is None:
            self.labels, _ = ndimage.label(self._P)
        return self.labels


def _lattice(grid: OccupancyGrid) -> _Lattice:
    """The search structures of ``grid``, cached on it (rebuilt if ``grid.free`` was replaced).

    Grids are not meant to be edited in place after construction; build a new
    one (or assign a new ``free`` array) to change the obstacles.
    """
    lat = getattr(grid, "_astar_lattice", None)
    if lat is None or lat.source is not grid.free:
        lat = _Lattice(grid)
        grid._astar_lattice = lat
    return lat


def _describe_block(grid: OccupancyGrid, p: np.ndarray) -> str:
    b = grid.bounds
    if not (b[0] <= p[0] <= b[2] and b[1] <= p[1] <= b[3]):
        return f"outside the map bounds {b}"
    names = [getattr(s, "name", "") or type(s).__name__ for s in grid.shapes
             if float(s.signed_distance(p[0], p[1])) < grid.inflation]
    if names:
        return f"inside the inflated obstacle(s) {', '.join(names)} (inflation {grid.inflation:g})"
    border = min(p[0] - b[0], b[2] - p[0], p[1] - b[1], b[3] - p[1])
    if border < grid.border_clearance:
        return f"closer than {grid.border_clearance:g} to the map border"
    return "on a blocked lattice point"


def snap(grid: OccupancyGrid, point: ArrayLike, name: str) -> tuple[int, int]:
    """Nearest lattice ``(i, j)`` of a world point; :class:`BlockedPointError` if it is not free,
    :class:`ShapeError` / :class:`NonFiniteError` if it is not a finite ``(x, y)`` with ``|x| <= 1e6``."""
    p = as_point(point, name)
    i, j = (int(v[0]) for v in grid.world_to_index(p))
    ny, nx = grid.free.shape
    if not (0 <= i < ny and 0 <= j < nx) or not grid.free[i, j]:
        raise BlockedPointError(f"{name} ({p[0]:g}, {p[1]:g}) is not free: {_describe_block(grid, p)}")
    return i, j


def octile(di: float, dj: float) -> float:
    """Octile distance in lattice steps: ``max + (sqrt 2 - 1) min`` of ``|di|, |dj|``."""
    di, dj = abs(di), abs(dj)
    return max(di, dj) + (SQRT2 - 1.0) * min(di, dj)


# ---------------------------------------------------------------------- API
def astar(
    grid: OccupancyGrid,
    start: ArrayLike,
    goal: ArrayLike,
    *,
    heuristic: str = "octile",
    turn_penalty: float = 0.0,
    proximity_weight: float = 0.0,
    proximity_range: float | None = None,
    method: str = "auto",
) -> GridPath:
    """Optimal 8-connected path from ``start`` to ``goal`` (world points) on ``grid``.

    ``method``: ``"auto"`` (jump point search for the pure distance cost,
    plain A* otherwise), ``"jps"`` or ``"plain"``. See the module docstring
    for the costs and the heuristics.

    Refused (:class:`InputError` and subclasses): ``grid`` not an
    :class:`OccupancyGrid`; ``start`` / ``goal`` not finite ``(x, y)`` points
    with ``|x| <= 1e6`` (:class:`BlockedPointError` when outside the map or
    blocked); unknown ``heuristic`` / ``method``; ``turn_penalty`` /
    ``proximity_weight`` negative, non-finite or above 1e6;
    ``proximity_range`` not in ``(0, 1e6]``.
    """
    check_grid(grid)
    if not isinstance(heuristic, str) or heuristic not in HEURISTICS:
        raise InputError(f"heuristic must be one of {HEURISTICS}, got {heuristic!r}")
    if not isinstance(method, str) or method not in ("auto", "jps", "plain"):
        raise InputError(f"method must be 'auto', 'jps' or 'plain', got {method!r}")
    turn_penalty = as_nonnegative(turn_penalty, "turn_penalty")
    proximity_weight = as_nonnegative(proximity_weight, "proximity_weight")
    if proximity_range is not None:
        proximity_range = as_positive(proximity_range, "proximity_range")
    plain_cost = turn_penalty == 0 and proximity_weight == 0
    if method == "jps" and not plain_cost:
        raise InputError("jump point search needs the pure distance cost (turn_penalty = proximity_weight "
                         "= 0)")
    si, sj = snap(grid, start, "start")
    gi, gj = snap(grid, goal, "goal")
    lat = _lattice(grid)
    labels = lat.component_labels()
    if labels[si + 1, sj + 1] != labels[gi + 1, gj + 1]:
        s, g = grid.index_to_world(si, sj)[0], grid.index_to_world(gi, gj)[0]
        raise NoPathError(
            f"no path from start ({s[0]:g}, {s[1]:g}) to goal ({g[0]:g}, {g[1]:g}): "
            "they lie in different free regions of the map"
        )
    W = lat.W
    s_flat, g_flat = (si + 1) * W + sj + 1, (gi + 1) * W + gj + 1
    euclid = heuristic == "euclidean"
    if plain_cost and method in ("auto", "jps"):
        nodes, cost, expanded = _jps(lat, s_flat, g_flat, euclid)
        used = "jps"
    else:
        prox = None
        if proximity_weight > 0:
            rng = (proximity_range if proximity_range is not None
                   else max(3.0 * grid.inflation, 5.0 * grid.resolution))
            if not rng > 0:  # the default is positive: resolution > 0
                raise InputError(f"proximity_range must be a finite number > 0, got {proximity_range!r}")
            d = grid.distance_field()
            pen = 1.0 + proximity_weight * np.clip(1.0 - d / rng, 0.0, None) ** 2
            prox = np.pad(pen, 1, constant_values=1.0).ravel().tolist()
        nodes, cost, expanded = _plain(lat, s_flat, g_flat, euclid, turn_penalty, prox)
        used = "plain"
    cells = _expand(nodes, W)
    pts = grid.index_to_world(cells[:, 0], cells[:, 1])
    steps = np.abs(np.diff(cells, axis=0))
    length = (float(grid.resolution * np.sum(np.where(steps.sum(axis=1) == 2, SQRT2, 1.0)))
              if len(cells) > 1 else 0.0)
    return GridPath(pts, cells, float(cost), length, expanded, used)


def path_length_lower_bound(grid: OccupancyGrid, start: ArrayLike, goal: ArrayLike) -> float:
    """Octile distance between the snapped points: no 8-connected path is shorter.

    Refuses what :func:`astar` refuses for ``grid``, ``start`` and ``goal``."""
    check_grid(grid)
    si, sj = snap(grid, start, "start")
    gi, gj = snap(grid, goal, "goal")
    return grid.resolution * octile(gi - si, gj - sj)


# ----------------------------------------------------------------- internals
def _expand(nodes: list[int], W: int) -> np.ndarray:
    """Lattice cells (unpadded ``(i, j)``) along straight/diagonal runs between consecutive nodes."""
    out = []
    for a, b in zip(nodes[:-1], nodes[1:]):
        ai, aj = divmod(a, W)
        bi, bj = divmod(b, W)
        n = max(abs(bi - ai), abs(bj - aj))
        di, dj = (bi > ai) - (bi < ai), (bj > aj) - (bj < aj)
        out.extend((ai + k * di - 1, aj + k * dj - 1) for k in range(n))
    bi, bj = divmod(nodes[-1], W)
    out.append((bi - 1, bj - 1))
    return np.array(out, dtype=np.int64)


def _plain(lat: _Lattice, s: int, g: int, euclid: bool, turn_penalty: float, prox):
    """Plain A*; the state is the lattice point, or (point, arrival direction) with a turn penalty."""
    W, free, res = lat.W, lat.free, lat.res
    gi, gj = divmod(g, W)
    offs = [di * W + dj for di, dj in MOVES]
    side = [(0, 0) if (di == 0 or dj == 0) else (di * W, dj) for di, dj in MOVES]
    step = [res * (SQRT2 if (di and dj) else 1.0) for di, dj in MOVES]
    turn_cost = [turn_penalty * (math.pi / 4.0) * min(k, 8 - k) for k in range(8)]
    with_dir = turn_penalty > 0
    sqrt = math.sqrt
    K = SQRT2 - 2.0

    def h(n):
        i, j = divmod(n, W)
        di = i - gi if i > gi else gi - i
        dj = j - gj if j > gj else gj - j
        if euclid:
            return res * sqrt(di * di + dj * dj)
        return res * (di + dj + K * (di if di < dj else dj))

    D = 9 if with_dir else 1
    start_state = s * D + (8 if with_dir else 0)
    gcost = {start_state: 0.0}
    parent = {start_state: -1}
    closed = set()
    heap = [(h(s), 0.0, start_state)]
    pop, push = heapq.heappop, heapq.heappush
    expanded = 0
    goal_state = None
    while heap:
        _, negg, st = pop(heap)
        if st in closed:
            continue
        n, d_in = divmod(st, D) if with_dir else (st, 8)
        if n == g:
            goal_state = st
            break
        closed.add(st)
        expanded += 1
        gn = gcost[st]
        for k in range(8):
            m = n + offs[k]
            if not free[m]:
                continue
            o1, o2 = side[k]
            if o1 and not (free[n + o1] and free[n + o2]):
                continue
            c = step[k]
            if prox is not None:
                c *= prox[m]
            if with_dir and d_in != 8:
                dk = (k - d_in) % 8
                c += turn_cost[dk]
            ms = m * D + k if with_dir else m
            if ms in closed:
                continue
            ng = gn + c
            old = gcost.get(ms)
            if old is None or ng < old:
                gcost[ms] = ng
                parent[ms] = st
                push(heap, (ng + h(m), -ng, ms))
    if goal_state is None:  # cannot happen after the component check; kept as a guard
        raise NoPathError("no path found")
    chain = []
    st = goal_state
    while st != -1:
        chain.append(st // D if with_dir else st)
        st = parent[st]
    return chain[::-1], gcost[goal_state], expanded


def _jps(lat: _Lattice, s: int, g: int, euclid: bool):
    """Jump point search (no corner cutting); returns (jump points, cost, expanded)."""
    W, H, free, res = lat.W, lat.H, lat.free, lat.res
    stopE, stopW, stopN, stopS = lat.stops()
    gi, gj = divmod(g, W)
    g_t = gj * H + gi  # goal in the transposed layout
    sqrt = math.sqrt
    K = SQRT2 - 2.0

    def h(n):
        i, j = divmod(n, W)
        di = i - gi if i > gi else gi - i
        dj = j - gj if j > gj else gj - j
        if euclid:
            return res * sqrt(di * di + dj * dj)
        return res * (di + dj + K * (di if di < dj else dj))

    # straight scans: return the jump point reached from cell n (n itself included), or -1
    def scan_e(n):
        stop = stopE.find(1, n)
        if gi * W <= n <= g < stop:
            return g
        return stop if free[stop] else -1

    def scan_w(n):
        stop = stopW.rfind(1, 0, n + 1)
        if stop < g <= n and g // W == n // W:
            return g
        return stop if free[stop] else -1

    def scan_n(n):
        i, j = divmod(n, W)
        t = j * H + i
        stop = stopN.find(1, t)
        if j == gj and t <= g_t < stop:
            return g
        if not free[(stop % H) * W + j] or stop // H != j:
            return -1
        return (stop % H) * W + j

    def scan_s(n):
        i, j = divmod(n, W)
        t = j * H + i
        stop = stopS.rfind(1, 0, t + 1)
        if j == gj and stop < g_t <= t:
            return g
        if stop // H != j or not free[(stop % H) * W + j]:
            return -1
        return (stop % H) * W + j

    def straight(n, di, dj):
        if dj == 1:
            return scan_e(n)
        if dj == -1:
            return scan_w(n)
        if di == 1:
            return scan_n(n)
        return scan_s(n)

    def jump(n, di, dj):
        """Jump from n's neighbour in direction (di, dj); -1 if none."""
        if di == 0 or dj == 0:
            m = n + di * W + dj
            return straight(m, di, dj) if free[m] else -1
        ow, oj = di * W, dj
        while True:
            # the diagonal step n -> m needs both orthogonal neighbours free
            if not (free[n + ow] and free[n + oj]):
                return -1
            m = n + ow + oj
            if not free[m]:
                return -1
            if m == g:
                return m
            if ((free[m + oj] and straight(m + oj, 0, dj) != -1)
                or (free[m + ow] and straight(m + ow, di, 0) != -1)):
                return m
            n = m

    gcost = {s: 0.0}
    parent = {s: -1}
    closed = set()
    heap = [(h(s), 0.0, s)]
    pop, push = heapq.heappop, heapq.heappush
    expanded = 0
    all_dirs = MOVES
    while heap:
        _, _, n = pop(heap)
        if n in closed:
            continue
        if n == g:
            break
        closed.add(n)
        expanded += 1
        p = parent[n]
        if p == -1:
            dirs = all_dirs
        else:
            ni, nj = divmod(n, W)
            pi_, pj = divmod(p, W)
            di, dj = (ni > pi_) - (ni < pi_), (nj > pj) - (nj < pj)
            if di and dj:
                dirs = ((di, 0), (0, dj), (di, dj))
            elif dj:  # horizontal: natural + both sides and the diagonals towards them
                dirs = ((0, dj), (1, 0), (-1, 0), (1, dj), (-1, dj))
            else:
                dirs = ((di, 0), (0, 1), (0, -1), (di, 1), (di, -1))
        gn = gcost[n]
        for di, dj in dirs:
            m = jump(n, di, dj)
            if m == -1 or m in closed:
                continue
            mi, mj = divmod(m, W)
            ni, nj = divmod(n, W)
            a, b = abs(mi - ni), abs(mj - nj)
            ng = gn + res * (a + b + K * (a if a < b else b))
            old = gcost.get(m)
            if old is None or ng < old:
                gcost[m] = ng
                parent[m] = n
                push(heap, (ng + h(m), -ng, m))
    if g not in gcost:
        raise NoPathError("no path found")
    chain = []
    n = g
    while n != -1:
        chain.append(n)
        n = parent[n]
    return chain[::-1], gcost[g], expanded
