"""A* on occupancy grids: optimal costs equal networkx's on the same 8-connected graph; valid paths;
errors."""

import math

import networkx as nx
import numpy as np
import pytest

from kinserve.planners.errors import BlockedPointError, NoPathError
from kinserve.planners.mobile import mall
from kinserve.planners.mobile.astar import MOVES, astar
from kinserve.planners.mobile.maps import OccupancyGrid
from kinserve.planners.mobile.shapes import Circle, Rectangle

from lattice_graph import sparse_lattice_graph

SQ2 = math.sqrt(2.0)


def lattice_graph(grid, weight_into=None):
    """The same graph built independently: 8-connected, diagonals only past two free orthogonal cells."""
    F = grid.free
    ny, nx_ = F.shape
    G = nx.DiGraph() if weight_into is not None else nx.Graph()
    for i, j in np.argwhere(F):
        G.add_node((int(i), int(j)))
        for di, dj in MOVES:
            a, b = i + di, j + dj
            if not (0 <= a < ny and 0 <= b < nx_ and F[a, b]):
                continue
            if di and dj and not (F[i + di, j] and F[i, j + dj]):
                continue
            w = grid.resolution * (SQ2 if di and dj else 1.0)
            if weight_into is not None:
                w *= weight_into[a, b]
            G.add_edge((int(i), int(j)), (int(a), int(b)), weight=w)
    return G


def _random_grid(rng):
    W, H = int(rng.integers(6, 30)), int(rng.integers(6, 30))
    shapes = []
    for _ in range(int(rng.integers(0, 10))):
        x, y = rng.uniform(0, W), rng.uniform(0, H)
        if rng.random() < 0.6:
            w, h = rng.uniform(0.5, 7, 2)
            shapes.append(Rectangle(x, y, x + w, y + h))
        else:
            shapes.append(Circle(x, y, rng.uniform(0.5, 4)))
    res = float(rng.choice([1.0, 0.5]))
    return OccupancyGrid.from_shapes((W, H), shapes, resolution=res,
                                     inflation=float(rng.choice([0.0, 0.5, 1.0])))


def _check_path(grid, path, start, goal):
    np.testing.assert_allclose(path.points[0], start)
    np.testing.assert_allclose(path.points[-1], goal)
    steps = np.diff(path.cells, axis=0)
    assert np.all(np.abs(steps).max(axis=1) == 1)  # one lattice move per step
    assert grid.path_is_free(path.points)
    length = grid.resolution * np.sum(np.where(np.abs(steps).sum(axis=1) == 2, SQ2, 1.0))
    assert path.length == pytest.approx(length)


@pytest.mark.parametrize("seed", range(12))
def test_cost_equals_networkx_on_random_maps(seed):
    rng = np.random.default_rng(seed)
    grid = _random_grid(rng)
    G = lattice_graph(grid)
    free = np.argwhere(grid.free)
    if len(free) < 2:
        pytest.skip("map fully blocked")
    for _ in range(8):
        a, b = free[rng.integers(len(free))], free[rng.integers(len(free))]
        pa, pb = grid.index_to_world(*a)[0], grid.index_to_world(*b)[0]
        try:
            ref = nx.astar_path_length(G, tuple(a), tuple(b), weight="weight")
        except nx.NetworkXNoPath:
            ref = None
        for method in ("jps", "plain"):
            for heuristic in ("octile", "euclidean"):
                if ref is None:
                    with pytest.raises(NoPathError):
                        astar(grid, pa, pb, method=method, heuristic=heuristic)
                    continue
                p = astar(grid, pa, pb, method=method, heuristic=heuristic)
                assert p.cost == pytest.approx(ref, rel=1e-12, abs=1e-12)
                assert p.length == pytest.approx(p.cost)
                _check_path(grid, p, pa, pb)


@pytest.fixture(scope="module")
def s7():
    return mall.s7_map()


@pytest.fixture(scope="module")
def s7_graph(s7):
    return sparse_lattice_graph(s7)


def test_mall_legs_equal_networkx(s7, s7_graph):
    wp = mall.s7_waypoints()
    nx_ = s7.shape[1]

    def euclid(u, v):
        return math.dist(divmod(u, nx_), divmod(v, nx_))

    for a, b in zip(wp[:-1], wp[1:]):
        ia, ib = s7.world_to_index(np.array([a, b]))
        u, v = int(ia[0]) * nx_ + int(ib[0]), int(ia[1]) * nx_ + int(ib[1])
        ref = nx.astar_path_length(s7_graph, u, v, weight="weight", heuristic=euclid)
        p = astar(s7, a, b)
        assert p.cost == pytest.approx(ref, rel=1e-12)
        _check_path(s7, p, a, b)
        # never closer than the inflation to the raw obstacles at the lattice points
        assert s7.clearance(p.points).min() >= -1e-9


def test_proximity_cost_equals_networkx(s7):
    rng = np.random.default_rng(5)
    grid = _random_grid(rng)
    w, rngd = 2.0, 3.0
    pen = 1.0 + w * np.clip(1.0 - grid.distance_field() / rngd, 0.0, None) ** 2
    G = lattice_graph(grid, weight_into=pen)
    free = np.argwhere(grid.free)
    for _ in range(6):
        a, b = free[rng.integers(len(free))], free[rng.integers(len(free))]
        try:
            ref = nx.dijkstra_path_length(G, tuple(a), tuple(b), weight="weight")
        except nx.NetworkXNoPath:
            continue
        p = astar(grid, grid.index_to_world(*a)[0], grid.index_to_world(*b)[0], proximity_weight=w,
                  proximity_range=rngd)
        assert p.method == "plain" and p.cost == pytest.approx(ref, rel=1e-12)


def test_turn_penalty_equals_networkx_on_the_state_graph():
    grid = OccupancyGrid.from_shapes((14, 10), [Rectangle(4, 0, 6, 6), Circle(10, 6, 1.5)], resolution=1.0)
    pen = 0.7  # per radian
    G = nx.DiGraph()
    F = grid.free
    for i, j in np.argwhere(F):
        for k, (di, dj) in enumerate(MOVES):
            a, b = i + di, j + dj
            if not (0 <= a < F.shape[0] and 0 <= b < F.shape[1] and F[a, b]):
                continue
            if di and dj and not (F[i + di, j] and F[i, j + dj]):
                continue
            step = SQ2 if di and dj else 1.0
            G.add_edge(("s", i, j), ("n", a, b, k), weight=step)  # leaving the start: no turn
            for d_in in range(8):
                turn = min((k - d_in) % 8, (d_in - k) % 8) * math.pi / 4
                G.add_edge(("n", i, j, d_in), ("n", a, b, k), weight=step + pen * turn)
            G.add_edge(("n", a, b, k), ("g", a, b), weight=0.0)
    start, goal = (2, 1), (8, 12)
    ref = nx.dijkstra_path_length(G, ("s", *start), ("g", *goal))
    p = astar(grid, grid.index_to_world(*start)[0], grid.index_to_world(*goal)[0], turn_penalty=pen)
    assert p.cost == pytest.approx(ref, rel=1e-12)
    plain = astar(grid, grid.index_to_world(*start)[0], grid.index_to_world(*goal)[0])
    assert p.length >= plain.length - 1e-12  # turning less may cost length, never saves it


def test_blocked_and_unreachable_points_raise_clear_errors(s7):
    with pytest.raises(BlockedPointError, match=r"start \(240, 240\).*fountain"):
        astar(s7, (240, 240), (60, 60))
    with pytest.raises(BlockedPointError, match=r"goal \(500, 10\).*outside the map"):
        astar(s7, (60, 60), (500, 10))
    with pytest.raises(BlockedPointError, match="border"):
        astar(s7, (5, 200), (60, 60))
    walled = OccupancyGrid.from_shapes((20, 20), [Rectangle(9, -1, 11, 21, "wall")], resolution=1.0)
    with pytest.raises(NoPathError, match=r"start \(2, 2\) to goal \(18, 18\)"):
        astar(walled, (2, 2), (18, 18))


def test_start_equals_goal(s7):
    p = astar(s7, (60, 60), (60, 60))
    assert p.cost == 0.0 and len(p) == 1
