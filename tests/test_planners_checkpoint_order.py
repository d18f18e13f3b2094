"""Checkpoint ordering: Held-Karp equals brute force; the heuristic's bound holds; Euclidean, not squared."""

import itertools

import numpy as np
import pytest

from kinserve.kinematics import se3
from kinserve.kinematics.errors import InputError, ShapeError
from kinserve.planners.checkpoint_order import euclidean_cost_matrix, path_cost, shortest_order


def _brute(C, start=0, end=None, tour=False):
    n = len(C)
    mid = [i for i in range(n) if i != start and (end is None or i != end)]
    best = np.inf
    for p in itertools.permutations(mid):
        o = [start, *p] + ([end] if end is not None else [])
        best = min(best, path_cost(C, o, tour))
    return best


@pytest.mark.parametrize("seed", range(6))
def test_held_karp_equals_brute_force(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 8))
    pts = rng.uniform(-1, 1, (n, 3))
    C = euclidean_cost_matrix(pts)
    r = shortest_order(pts)
    assert r.optimal and sorted(r.order) == list(range(n)) and r.order[0] == 0
    assert r.cost == pytest.approx(_brute(C)) and r.cost == pytest.approx(path_cost(C, r.order))
    if n >= 3:
        r = shortest_order(pts, start=1, end=n - 1)
        assert r.order[0] == 1 and r.order[-1] == n - 1
        assert r.cost == pytest.approx(_brute(C, 1, n - 1))
    r = shortest_order(pts, return_to_start=True)
    assert r.cost == pytest.approx(_brute(C, tour=True))


def test_asymmetric_user_costs():
    rng = np.random.default_rng(7)
    C = rng.uniform(0, 10, (7, 7))
    np.fill_diagonal(C, 0)
    r = shortest_order(cost=C, end=3)
    assert r.cost == pytest.approx(_brute(C, 0, 3))


def test_poses_and_cost_function():
    rng = np.random.default_rng(3)
    poses = np.array([se3.pose(p=rng.uniform(-1, 1, 3)) for _ in range(6)])
    r1 = shortest_order(poses)
    r2 = shortest_order(poses, cost=lambda a, b: float(np.linalg.norm(a[:3, 3] - b[:3, 3])))
    assert r1.order == r2.order and r1.cost == pytest.approx(r2.cost)


def test_euclidean_metric_not_squared():
    # squared distances prefer many short hops; travelled distance does not
    pts = np.array([[0.0, 0], [1, 0], [2, 0], [1.5, 0.2], [-2.0, 0]])
    r = shortest_order(pts)
    C = euclidean_cost_matrix(pts)
    sq = shortest_order(cost=C**2)
    assert r.cost == pytest.approx(_brute(C))
    assert path_cost(C, r.order) <= path_cost(C, sq.order) + 1e-12


@pytest.mark.parametrize("n", [13, 30])
def test_heuristic_above_the_exact_limit(n):
    rng = np.random.default_rng(n)
    pts = rng.uniform(0, 1, (n, 2))
    r = shortest_order(pts, end=n - 1)
    assert r.method == "nn+2opt" and sorted(r.order) == list(range(n))
    assert r.order[0] == 0 and r.order[-1] == n - 1
    assert r.lower_bound <= r.cost and 1.0 <= r.gap_bound < 2.0
    # a 2-opt local optimum: no single segment reversal improves it
    C = euclidean_cost_matrix(pts)
    for i in range(1, n - 2):
        for k in range(i + 1, n - 1):
            cand = r.order[:i] + r.order[i : k + 1][::-1] + r.order[k + 1 :]
            assert path_cost(C, cand) >= r.cost - 1e-9


def test_heuristic_close_to_exact_on_12_points():
    rng = np.random.default_rng(11)
    pts = rng.uniform(0, 1, (12, 2))
    exact = shortest_order(pts)
    heur = shortest_order(pts, exact_limit=4)
    assert exact.optimal and not heur.optimal
    assert exact.cost <= heur.cost <= exact.cost * heur.gap_bound + 1e-12
    assert heur.lower_bound <= exact.cost + 1e-12


def test_bad_inputs():
    with pytest.raises(ShapeError):
        shortest_order(cost=np.ones((3, 4)))
    with pytest.raises(InputError, match="start"):
        shortest_order(np.zeros((3, 2)), start=5)
    with pytest.raises(InputError, match="end must differ"):
        shortest_order(np.zeros((3, 2)), end=0)
    with pytest.raises(InputError, match="not both"):
        shortest_order(np.zeros((3, 2)), end=2, return_to_start=True)
    with pytest.raises(InputError, match=">= 0"):
        shortest_order(cost=-np.ones((3, 3)))


def _reference_two_opt(C, order, last, closed, max_moves=None):
    """First-improvement 2-opt written one move at a time, each move's change from whole path costs (at most
    ``max_moves`` moves)."""
    o = list(order)
    for _ in itertools.count() if max_moves is None else range(max_moves):
        base = path_cost(C, o, closed)
        move = next(((i, k) for i in range(1, last - 1) for k in range(i + 1, last)
                     if path_cost(C, o[:i] + o[i:k + 1][::-1] + o[k + 1:], closed) < base - 1e-9), None)
        if move is None:
            return o
        i, k = move
        o[i:k + 1] = o[i:k + 1][::-1]
    return o


@pytest.mark.parametrize("max_rounds", [0, 1, 2, 5])
def test_two_opt_makes_at_most_max_rounds_moves_the_reference_makes_first(max_rounds):
    """``max_rounds`` bounds the reversals (the compiled loop's count); the moves made are the reference's
    first ones, on asymmetric integer costs (many equal changes: the first in (i, k) order is taken)."""
    from kinserve.planners.checkpoint_order import two_opt

    rng = np.random.default_rng(11)
    n = 14
    C = rng.integers(1, 6, (n, n)).astype(float)
    start = list(range(n))
    full = _reference_two_opt(C, start, n, False)
    assert full != start  # the instance has moves to make
    order, _ = two_opt(C, start, False, False, max_rounds=max_rounds)
    assert order == _reference_two_opt(C, start, n, False, max_moves=max_rounds)
    assert two_opt(C, start, False, False)[0] == full


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("mode", ["open", "closed", "fixed_end"])
def test_two_opt_leaves_no_improving_reversal_and_matches_one_move_at_a_time(seed, mode):
    """two_opt (one NumPy expression per segment start) finds the same moves as the one-at-a-time
    reference, and no reversal of its answer lowers the path cost (checked from whole path costs)."""
    from kinserve.planners.checkpoint_order import _nearest_neighbour, two_opt

    rng = np.random.default_rng(seed)
    n = 9 + seed
    C = euclidean_cost_matrix(rng.uniform(0, 10, (n, 2))) + (rng.uniform(0, 1, (n, n)) if seed % 2 else 0.0)
    closed, fixed = mode == "closed", mode == "fixed_end"
    last = n - 1 if fixed else n
    start = _nearest_neighbour(C, 0, n - 1 if fixed else None, closed)
    order, cost = two_opt(C, start, fixed, closed)
    assert sorted(order) == list(range(n)) and order[0] == 0 and (not fixed or order[-1] == n - 1)
    assert cost == pytest.approx(path_cost(C, order, closed), abs=1e-12)
    base = path_cost(C, order, closed)
    for i, k in itertools.combinations(range(1, last), 2):
        assert path_cost(C, order[:i] + order[i:k + 1][::-1] + order[k + 1:], closed) >= base - 1e-9
    assert order == _reference_two_opt(C, start, last, closed)


def _reference_nearest_neighbour(C, start, end, closed):
    """The greedy order, one Python comparison at a time: the cheapest unvisited point, the lowest index on
    ties (the key ``(cost, index)``); a fixed end of an open path last."""
    left = set(range(len(C))) - {start} - ({end} if end is not None and not closed else set())
    order = [start]
    while left:
        order.append(min(left, key=lambda j: (C[order[-1], j], j)))
        left.remove(order[-1])
    return order + ([end] if end is not None and not closed else [])


@pytest.mark.parametrize("seed", range(40))
def test_nearest_neighbour_is_the_greedy_order_with_ties_and_forbidden_moves(seed):
    """The NumPy greedy order equals the reference on Euclidean, asymmetric, small-integer (many ties) and
    partly forbidden (inf) costs, open, closed and with a fixed end."""
    from kinserve.planners.checkpoint_order import _nearest_neighbour

    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 60))
    kind = seed % 4
    C = (euclidean_cost_matrix(rng.uniform(0, 10, (n, 2))) if kind == 0 else
         rng.uniform(0, 5, (n, n)) if kind == 1 else rng.integers(0, 3, (n, n)).astype(float))
    if kind == 3:
        C[rng.uniform(size=(n, n)) < 0.3] = np.inf
    start, end = int(rng.integers(n)), int(rng.integers(n))
    for e, closed in ((None, False), (None, True), (end, False)):
        if e == start:
            continue
        assert _nearest_neighbour(C, start, e, closed) == _reference_nearest_neighbour(C, start, e, closed)


@pytest.mark.parametrize("seed", range(20))
def test_spanning_tree_bound_is_scipys_minimum_spanning_tree(seed):
    """Prim's weight equals scipy's Kruskal on min(C, C^T), on Euclidean, asymmetric and tied integer costs
    with zeros; 0 with an infinite cost. scipy reads a cost below about 1e-8 as no edge, so it is given the
    costs plus 1 (every spanning tree has n - 1 edges: its weight grows by exactly n - 1)."""
    from scipy.sparse.csgraph import minimum_spanning_tree

    from kinserve.planners.checkpoint_order import spanning_tree_bound

    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 80))
    C = (euclidean_cost_matrix(rng.uniform(0, 10, (n, 3))) if seed % 3 == 0 else
         rng.uniform(0, 5, (n, n)) if seed % 3 == 1 else rng.integers(0, 4, (n, n)).astype(float))
    S = np.minimum(C, C.T) + 1.0
    np.fill_diagonal(S, 0.0)
    kruskal = float(minimum_spanning_tree(S).sum()) - (n - 1)
    assert spanning_tree_bound(C) == pytest.approx(kruskal, rel=1e-12, abs=1e-9)
    C[0, n - 1] = C[n - 1, 0] = np.inf
    assert spanning_tree_bound(C) == 0.0
    assert spanning_tree_bound(np.zeros((1, 1))) == 0.0


@pytest.mark.parametrize("seed", range(40))
def test_the_bound_holds_with_repeated_points(seed):
    """Checkpoints visited twice (zero costs): the heuristic's lower bound stays at most the exact optimum
    (Held-Karp), so ``cost <= optimum x gap_bound``. With scipy's spanning tree, which reads costs below
    about 1e-8 as no edge, the bound passed the optimum on 42 of 300 such instances, with gap_bound 1.0."""
    rng = np.random.default_rng(seed)
    base = rng.integers(0, 4, (6, 2)).astype(float)
    points = np.vstack([base, base[:4]])
    heuristic, exact = shortest_order(points, exact_limit=0), shortest_order(points)
    assert exact.method == "held-karp" and heuristic.method == "nn+2opt"
    assert heuristic.lower_bound <= exact.cost + 1e-12
    assert heuristic.cost <= exact.cost * heuristic.gap_bound + 1e-12


@pytest.mark.parametrize("value", ["no", 0, 1, None, float("nan")])
def test_return_to_start_must_be_true_or_false(value):
    """Above the exact limit the flag reached the compiled 2-opt, which raised Numba's TypeError ("No matching
    definition for argument type(s) ..."); below it any truthy value closed the tour. Each entry point now
    names the argument; NumPy's bools are flags."""
    from kinserve.kinematics.errors import InputError
    from kinserve.planners.checkpoint_order import held_karp

    points = np.random.default_rng(0).uniform(0, 1, (15, 2))
    C = euclidean_cost_matrix(points)
    calls = (lambda v: shortest_order(points, return_to_start=v),
             lambda v: shortest_order(points[:5], return_to_start=v),
             lambda v: path_cost(C, [0, 1, 2], v), lambda v: held_karp(C[:5, :5], 0, None, v))
    for call in calls:
        with pytest.raises(InputError, match="return_to_start must be True or False"):
            call(value)
    closed = shortest_order(points, return_to_start=True)
    assert shortest_order(points, return_to_start=np.bool_(True)).cost == closed.cost
