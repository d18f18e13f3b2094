"""The compiled extension step of RRT-Connect (kinserve.planners.motion.extend_kernel) against Python.

``nearest_node`` against a NumPy scan; the extension step (``step_into`` inside ``search_steps``) against the
step computed in NumPy and the pre-check's own kernels called one point at a time (verdicts and the pairs left
to coal; a point in collision for certain also by coal's test of every pair); ``exact_verdict``'s decisions
about the steps left uncertain against coal's;
``rrt_connect.search_with_kernel`` (the compiled loop, coal on the held steps) against ``search_step_by_step``
(``extend_exactly``: the scene's collision test, clearance and probes one by one) from the same trees and
seed: the same results and trees.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from kinserve import ik, robots
from kinserve.kinematics.precheck_kernels import (
    certainly_colliding,
    certify_configuration,
    pair_lower_bounds,
    uncertified_pairs,
)
from kinserve.planners.motion.clearance import CLEARANCE_FLOOR, ClearanceOracle
from kinserve.planners.motion.edges import PROBE_FRACTIONS, PROBES, EdgeCertifier
from kinserve.planners.motion.extend_kernel import (
    AT_TARGET,
    COLLIDES,
    END,
    FREE,
    KIND,
    NEAR,
    ONTO,
    STEP_FREE,
    STEP_REFUSED,
    STEP_UNDECIDED,
    TOWARDS,
    UNCERTAIN,
    nearest_node,
    probe_segment,
)
from kinserve.planners.motion.reach import pair_reach
from kinserve.planners.motion.rrt_connect import SearchBudget, search_step_by_step, search_with_kernel
from kinserve.planners.motion.search_kernel import (
    BATCH_DONE,
    FULL,
    GROWN,
    HELD,
    SIZE_A,
    SIZE_B,
    STATE_LENGTH,
    UNFIT,
    search_steps,
)
from kinserve.planners.motion.search_tree import SearchTree

from motion_scenes import shelf_scene


@pytest.fixture(scope="module")
def setting():
    robot = robots.load("panda")
    scene = robot.collision_scene(shelf_scene())
    return robot, EdgeCertifier(ClearanceOracle(scene), pair_reach(robot.model, scene))


def test_nearest_node_is_the_first_closest_row_not_pruned():
    rng = np.random.default_rng(5)
    for trial in range(200):
        size = int(rng.integers(1, 40))
        nodes = rng.normal(size=(size + 7, 3))
        nodes[size // 2] = nodes[0]  # a tie: the first one wins
        pruned = rng.random(size + 7) < 0.3
        pruned[int(rng.integers(size))] = False  # at least one candidate
        q = nodes[0] + rng.normal(scale=0.01 if trial % 2 else 1.0, size=3)
        d2 = np.where(pruned[:size], np.inf, ((nodes[:size] - q) ** 2).sum(axis=1))
        assert nearest_node(nodes, pruned, size, q) == int(np.argmin(d2))
    assert nearest_node(nodes, np.ones(len(nodes), dtype=bool), size, q) == -1
    assert nearest_node(nodes, pruned, 0, q) == -1


def _tree(robot, rng, n):
    """Free-or-not random nodes in the joint limits (the kernel does not care whether they are free)."""
    nodes = robot.lower + (robot.upper - robot.lower) * rng.random((n + 5, robot.nq))
    pruned = rng.random(n + 5) < 0.2
    pruned[0] = False
    return nodes, pruned


def _buffers(certifier, short: int = 0):
    """Fresh output buffers of the compiled probes for the certifier's scene (``short``: that many pair
    columns too few)."""
    P = len(certifier.oracle.scene.pairs)
    return (np.full(END + 1 + len(PROBES), -7, dtype=np.int64),
            np.full((1 + len(PROBES), P + 1 - short), -7, dtype=np.int64))


def _one_step(certifier, nodes, pruned, n, target, step, codes, checks):
    """One extension step of the tree ``nodes`` (``pruned``, ``n`` in use) towards ``target`` through
    ``search_steps``: the other tree has one node and no free row, so the search returns right after that
    step (trapped: BATCH_DONE; held: HELD; a node added or the target reached: FULL, the connect's tree
    full) with its codes, pair lists and ``q_new`` (the held buffer) as the step left them."""
    pre = certifier.oracle.precheck
    nq = nodes.shape[1]
    parents = np.full(len(nodes), -1, dtype=np.int64)
    other = np.zeros((1, nq))
    state = np.zeros(STATE_LENGTH, dtype=np.int64)
    state[SIZE_A], state[SIZE_B] = n, 1
    held = np.full(nq, np.nan)
    event = search_steps(pre.floats, pre.ints, nodes, pruned, parents, other, np.zeros(1, dtype=bool),
                         np.full(1, -1, dtype=np.int64), target[None, :].copy(), step, pre.tolerance,
                         CLEARANCE_FLOOR, np.array(PROBES), state, held, codes, checks)
    return event, held, state


def test_buffers_too_small_are_refused_without_a_write(setting):
    """Buffers that cannot hold every pair of the scene: nothing written (UNFIT / False)."""
    robot, certifier = setting
    pre = certifier.oracle.precheck
    nodes, pruned = _tree(robot, np.random.default_rng(3), 5)
    codes, checks = _buffers(certifier, short=1)
    event, held, state = _one_step(certifier, nodes, pruned, 5, robot.upper.copy(), 0.5, codes, checks)
    assert event == UNFIT and np.isnan(held).all() and state[SIZE_A] == 5
    assert not probe_segment(pre.floats, pre.ints, nodes[0], nodes[1], PROBE_FRACTIONS, pre.tolerance, codes,
                             checks)
    assert (codes == -7).all() and (checks == -7).all()


def test_the_step_matches_numpy_and_the_precheck_point_by_point(setting):
    """The compiled extension step (``step_into``, through ``search_steps``: ``_one_step``) against the step
    computed in NumPy and the pre-check's kernels called one point at a time: the nearest node, the kind of
    step, ``q_new``, the verdicts in order up to the first point in collision for certain (``q_new``
    certified with the clearance floor, the probes with the tolerance; a point in collision for certain
    also by coal's test of every pair), the pairs left to coal, and the event each outcome gives."""
    robot, certifier = setting
    pre = certifier.oracle.precheck
    rng = np.random.default_rng(11)
    kinds = set()
    colliding = 0
    floors = 0
    uncertain = 0
    for trial in range(300):
        n = int(rng.integers(1, 30))
        nodes, pruned = _tree(robot, rng, n)
        step = 0.5 if trial % 3 else 3.0  # some steps reach the target
        target = robot.lower + (robot.upper - robot.lower) * rng.random(robot.nq)
        if trial % 50 == 0:
            target = nodes[0].copy()  # the nearest node is the target itself
        codes, checks = _buffers(certifier)
        event, q_new, state = _one_step(certifier, nodes, pruned, n, target, step, codes, checks)
        near = nearest_node(nodes, pruned, n, target)
        assert codes[NEAR] == near
        delta = target - nodes[near]
        dist = np.linalg.norm(delta)
        kinds.add(int(codes[KIND]))
        if dist <= 1e-12:
            assert codes[KIND] == AT_TARGET  # reached: the connect next
            assert event == FULL and state[GROWN] == near
            continue
        assert codes[KIND] == (ONTO if dist <= step else TOWARDS)
        expected = target if dist <= step else nodes[near] + delta * (step / dist)
        np.testing.assert_allclose(q_new, expected, rtol=0, atol=1e-12)
        points = [q_new] + [nodes[near] + s * (q_new - nodes[near]) for s in PROBES]
        verdicts, pairs = [], []
        for k, p in enumerate(points):  # in order, up to the first point in collision for certain
            keep = CLEARANCE_FLOOR if k == 0 else pre.tolerance  # the new node keeps the floor
            if certify_configuration(pre.floats, pre.ints, p, keep):
                verdicts.append(FREE), pairs.append([])
                if k == 0:
                    assert np.all(pair_lower_bounds(pre.floats, pre.ints, p) > CLEARANCE_FLOOR)
                    floors += 1
            elif certainly_colliding(pre.floats, pre.ints, p, pre.tolerance):
                verdicts.append(COLLIDES)
                assert certifier.oracle.scene.colliding(p)  # coal on every pair agrees
                colliding += 1
                break
            else:
                listed = uncertified_pairs(pre.floats, pre.ints, p, keep).tolist()
                verdicts.append(UNCERTAIN), pairs.append(listed)
        verdicts += [-1] * (len(points) - len(verdicts))  # refused: no point after it asked
        assert codes[END:].tolist() == verdicts
        if COLLIDES in verdicts:  # trapped: the iteration ends, the tree unchanged
            assert event == BATCH_DONE and state[SIZE_A] == n
        elif UNCERTAIN in verdicts:  # held for coal
            assert event == HELD and state[SIZE_A] == n
        else:  # added, then the connect finds the other tree full
            assert event == FULL and state[SIZE_A] == n + 1 and state[GROWN] == n
            np.testing.assert_array_equal(nodes[n], q_new)
        for k, listed in enumerate(pairs):  # the pairs coal must check: the pre-check's own list
            if verdicts[k] == UNCERTAIN:
                assert listed and checks[k, 1:1 + checks[k, 0]].tolist() == listed
                uncertain += 1
    assert kinds == {AT_TARGET, TOWARDS, ONTO}
    assert colliding > 10  # the refusal was met
    assert uncertain > 10  # and the pair lists were compared
    assert floors > 10  # new nodes certified above the floor


def test_keeps_is_coal_distance_of_the_listed_pairs_at_their_need(setting):
    """``ClearanceOracle.keeps`` against coal's distances of every pair: True exactly when each listed pair's
    distance is at least its need (pairs in collision never keep it); both answers seen."""
    robot, certifier = setting
    oracle = certifier.oracle
    scene = oracle.scene
    data, gd = scene.model.createData(), pin.GeometryData(scene.geometry)
    rng = np.random.default_rng(12)
    seen = set()
    for _ in range(200):
        q = robot.lower + (robot.upper - robot.lower) * rng.random(robot.nq)
        pin.computeDistances(scene.model, data, scene.geometry, gd, q)
        d = np.array([r.min_distance for r in gd.distanceResults])
        listed = np.sort(rng.choice(len(d), size=int(rng.integers(1, 6)), replace=False))
        need = np.full(len(d), CLEARANCE_FLOOR)
        if rng.random() < 0.5:  # one listed pair asked for just more, or just less, than its distance
            k = int(listed[0])
            need[k] = d[k] + (1e-7 if rng.random() < 0.5 else -1e-7)
        keeps = oracle.keeps(q, listed, need)
        assert keeps == bool(np.all(d[listed] >= need[listed]))
        seen.add(keeps)
    assert seen == {True, False}


def _free(robot, certifier, rng):
    """A random configuration free of collision and above the clearance floor."""
    for _ in range(1000):
        q = robot.lower + (robot.upper - robot.lower) * rng.random(robot.nq)
        if not certifier.in_collision(q) and certifier.clear(certifier.clearance(q)):
            return q
    raise AssertionError("no free configuration drawn")


def _search(search, robot, certifier, start, goals, seed, iterations):
    """``search`` from fresh trees (capacity 4: they must grow) with its own generator."""
    trees = [SearchTree(robot.nq, capacity=4, clearance=certifier.clearance) for _ in range(2)]
    trees[0].add(certifier.clearance(start), -1)
    for q in goals:
        trees[1].add(certifier.clearance(q), -1)
    found = search(trees[0], trees[1], robot.lower, robot.upper, certifier, np.random.default_rng(seed),
                   SearchBudget(iterations, None))
    return found, trees


def test_the_compiled_search_takes_the_python_search_steps(setting):
    """``search_with_kernel`` (compiled loop, coal on the held steps, samples in batches) against
    ``search_step_by_step`` (``extend_exactly``: the scene's collision test, clearance and probes one at a
    time; a sample per iteration) from the same trees and seed: the same result (path, goal, iterations,
    nodes) and the same trees (nodes, parents, pruned nodes), paths found and budgets spent both seen."""
    robot, certifier = setting
    rng = np.random.default_rng(3)
    outcomes = set()
    for trial in range(10):
        start = _free(robot, certifier, rng)
        goals = [_free(robot, certifier, rng) for _ in range(1 + trial % 2)]
        iterations = 3 + 13 * trial  # short budgets stop inside a batch, long ones span several
        (fast, fast_trees), (slow, slow_trees) = (
            _search(search, robot, certifier, start, goals, 100 + trial, iterations)
            for search in (search_with_kernel, search_step_by_step))
        assert (fast.goal, fast.iterations, fast.nodes) == (slow.goal, slow.iterations, slow.nodes)
        np.testing.assert_allclose(fast.path, slow.path, rtol=0, atol=1e-12)
        for a, b in zip(fast_trees, slow_trees):
            assert a.size == b.size
            np.testing.assert_allclose(a.points[:a.size], b.points[:b.size], rtol=0, atol=1e-12)
            assert a.parents[:a.size].tolist() == b.parents[:b.size].tolist()
            assert a.pruned[:a.size].tolist() == b.pruned[:b.size].tolist()
        outcomes.add(fast.goal >= 0)
        assert fast.goal >= 0 or fast.iterations == iterations
    assert outcomes == {True, False}


def test_the_compiled_search_takes_the_python_search_steps_through_failed_branches(monkeypatch):
    """Forty 1 cm balls that the probes (an eighth of a step apart) step over: the trees meet on branches
    whose certificates fail (pruned, the search goes on). The compiled search and the Python one give the
    same results and trees through those failures, and failures occur."""
    import kinserve.planners.motion.rrt_connect as rrt

    robot = robots.load("panda")
    rng = np.random.default_rng(5)
    balls = [ik.Sphere(rng.uniform([0.2, -0.5, 0.1], [0.7, 0.5, 0.8]), 0.01) for _ in range(40)]
    scene = robot.collision_scene(balls)
    certifier = EdgeCertifier(ClearanceOracle(scene), pair_reach(robot.model, scene))
    verdicts = []
    certify_branch = rrt.certify_branch
    monkeypatch.setattr(rrt, "certify_branch", lambda *a: verdicts.append(certify_branch(*a)) or verdicts[-1])
    for trial in range(2):
        start, goal = _free(robot, certifier, rng), _free(robot, certifier, rng)
        (fast, fast_trees), (slow, slow_trees) = (
            _search(search, robot, certifier, start, [goal], trial, 300)
            for search in (search_with_kernel, search_step_by_step))
        assert (fast.goal, fast.iterations, fast.nodes) == (slow.goal, slow.iterations, slow.nodes)
        np.testing.assert_allclose(fast.path, slow.path, rtol=0, atol=1e-12)
        for a, b in zip(fast_trees, slow_trees):
            assert a.size == b.size and a.pruned[:a.size].tolist() == b.pruned[:b.size].tolist()
    print(f"{verdicts.count(False)} of {len(verdicts)} branch certificates failed")
    assert verdicts.count(False) >= 2  # branches refused (each search met them: at least one each)


def test_probe_segment_and_blocked_match_the_precheck_and_coal_point_by_point(setting):
    """``probe_segment`` against the pre-check's kernels at each probe point (verdicts in order up to the
    first point in collision for certain, the pair lists of the uncertain ones), and
    ``EdgeCertifier.blocked`` (compiled probes, the compiled distances or coal on the listed pairs) against
    the scene's own collision test at every probe point."""
    robot, certifier = setting
    pre = certifier.oracle.precheck
    scene = certifier.oracle.scene
    rng = np.random.default_rng(13)
    seen = {FREE: 0, UNCERTAIN: 0, COLLIDES: 0}
    blocked = 0
    for _ in range(300):
        qa = robot.lower + (robot.upper - robot.lower) * rng.random(robot.nq)
        qb = qa + rng.normal(scale=0.4, size=robot.nq)
        codes, checks = _buffers(certifier)
        assert probe_segment(pre.floats, pre.ints, qa, qb, PROBE_FRACTIONS, pre.tolerance, codes, checks)
        verdicts = codes[END:END + len(PROBES)]
        expected = []
        for k, s in enumerate(PROBES):
            p = qa + s * (qb - qa)
            if certify_configuration(pre.floats, pre.ints, p, pre.tolerance):
                expected.append(FREE)
            elif certainly_colliding(pre.floats, pre.ints, p, pre.tolerance):
                expected.append(COLLIDES)
            else:
                expected.append(UNCERTAIN)
                listed = uncertified_pairs(pre.floats, pre.ints, p, pre.tolerance).tolist()
                assert checks[k, 1:1 + checks[k, 0]].tolist() == listed
            seen[expected[-1]] += 1
            if expected[-1] == COLLIDES:
                break
        expected += [-1] * (len(PROBES) - len(expected))
        assert verdicts.tolist() == expected
        reference = any(scene.in_collision(qa + s * (qb - qa)) for s in PROBES)
        assert certifier.blocked(qa, qb) == reference
        blocked += reference
    assert min(seen.values()) > 10 and 20 < blocked < 280, (seen, blocked)


def test_the_compiled_distances_decide_held_steps_as_coal_does(setting):
    """Steps the spheres leave uncertain in the shelf scene: where ``exact_verdict`` decides (the new node
    surely below or above its floor, the probe points surely apart), coal's decision (``held_free``'s coal
    path: the node's pair distances against the floor, the probe points' collision tests) is the same; it
    accepts and refuses steps, and leaves some to coal."""
    robot, certifier = setting
    oracle = certifier.oracle
    rng = np.random.default_rng(21)
    seen = {STEP_FREE: 0, STEP_REFUSED: 0, STEP_UNDECIDED: 0}
    for _ in range(4000):
        if min(seen.values()) >= 3 and sum(seen.values()) >= 60:
            break
        nodes, pruned = _tree(robot, rng, 1)
        pruned[:] = False
        codes, checks = _buffers(certifier)
        target = robot.lower + (robot.upper - robot.lower) * rng.random(robot.nq)
        event, held, _ = _one_step(certifier, nodes, pruned, 1, target, 0.5, codes, checks)
        if event != HELD:
            continue
        certifier.codes[:], certifier.checks[:] = codes, checks
        q_near = nodes[codes[NEAR]]
        verdict = certifier.step_verdict(q_near, held)
        seen[verdict] += 1
        if verdict == STEP_UNDECIDED:
            continue
        low = checks[0, 1:1 + checks[0, 0]]
        keeps = codes[END] != UNCERTAIN or oracle.keeps(held, low, certifier.end_need)
        verdicts = codes[END:END + 1 + len(PROBES)].tolist()
        verdicts[0] = FREE
        apart = not oracle.coal_decides(lambda k: q_near + PROBES[k - 1] * (held - q_near), verdicts, checks)
        assert (verdict == STEP_FREE) == (keeps and apart)
        if verdict == STEP_REFUSED:
            assert not keeps
    assert min(seen.values()) >= 3, seen
