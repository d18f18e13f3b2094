"""Bidirectional RRT-Connect in joint space (Kuffner & LaValle 2000) with a goal set and certified edges.

One tree grows from the start, one from every goal (each goal a root). An
iteration draws ``q_rand`` uniformly in the joint limits, **extends** the active
tree one step towards it (at most ``step`` rad, Euclidean) and, when that step
succeeds, **connects** the other tree to the new node (steps until it reaches
the node or is stopped); then the trees swap roles. A step is kept only when its
end is free (the scene's cheap collision test first, then its pair distances
above the floor) and the cheap test finds its edge's probe points free
(:meth:`~.edges.EdgeCertifier.blocked`). With the scene's sphere pre-check, the
iterations run in a compiled loop (:func:`~.search_kernel.search_steps`, on
:data:`BATCH` samples drawn at a time): per step it finds the nearest node, makes
the step, refuses it when the spheres find the new node in collision for
certain, and certifies the new node's pair bounds above the clearance floor and
the probe points free on the spheres; a step the spheres leave uncertain comes
back to Python (:func:`held_free`), where the pairs the spheres left are decided
on the compiled distances of the shapes when those are clear-cut
(:func:`~.extend_kernel.exact_verdict`), by coal otherwise (their distances at the
new node, against the floor; their collision tests at the probe points), and the
meeting of the trees comes back for the branches' certificates. The decisions are
those of the tests one by one (:func:`search_step_by_step`, the path of scenes
without a pre-check). A node's
pair bounds (its :class:`~.clearance.Clearance`) are made only when read: most
nodes never lie on a path.

**Lazy certificates**: an edge is certified (:class:`~.edges.EdgeCertifier`) only
when it lies on a candidate path, once the trees meet: every edge of the path not
certified yet, from the roots outwards; the first one that fails prunes its node
and everything grown from it (:meth:`~.search_tree.SearchTree.prune`) and the
search goes on. Most edges of the trees never lie on a candidate path and are
never certified; every edge of a returned path is. Before the first iteration
the start is joined straight to each goal, nearest first.

Deterministic: every random draw comes from the ``numpy.random.Generator`` passed
in (the compiled loop draws its samples :data:`BATCH` at a time: the same values
in the same order, the last batch in part unused). The budget is an iteration
count, a wall-clock time, or both (the first one spent ends the search; the
compiled loop reads the clock between batches); with the count alone the answer
depends only on the inputs and the generator.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from .clearance import CLEARANCE_FLOOR, Clearance
from .edges import PROBE_FRACTIONS, PROBES, EdgeCertifier
from .extend_kernel import END, FREE, NEAR, STEP_FREE, STEP_UNDECIDED, UNCERTAIN
from .search_kernel import (
    ACCEPT,
    ACTIVE,
    BATCH_DONE,
    CHECKS,
    DECISION,
    FULL,
    GROWN,
    HELD,
    IT,
    JOINED,
    MET,
    REJECT,
    SIZE_A,
    SIZE_B,
    STATE_LENGTH,
    grows_start_tree,
    search_steps,
)
from .search_tree import SearchTree

#: Default extension step (rad, Euclidean norm of the joint change).
STEP = 0.5
#: Goals tried by a straight edge from the start before the search (nearest first).
DIRECT_GOALS = 3
#: Iterations per batch of samples of the compiled search (the clock is read between batches).
BATCH = 16

TRAPPED, ADVANCED, REACHED = 0, 1, 2


@dataclass(frozen=True)
class SearchBudget:
    """``max_iterations`` (None: no count) and ``max_time`` (s; None: no clock) of one search."""

    max_iterations: int | None
    max_time: float | None


class SearchResult(NamedTuple):
    """``path`` ``(m, nq)`` from the start to goal ``goal`` (its index in the goals given) with the
    :class:`~.clearance.Clearance` of each waypoint; empty and ``goal = -1`` when none was found.
    ``iterations``: samples drawn; ``nodes``: nodes of both trees."""

    path: np.ndarray
    clearances: list[Clearance]
    goal: int
    iterations: int
    nodes: int


class _Step(NamedTuple):
    status: int
    node: int


def held_free(tree: SearchTree, near: int, q_new: np.ndarray, certifier: EdgeCertifier, codes: np.ndarray,
              checks: np.ndarray) -> bool:
    """The decision about a step the spheres left uncertain (:data:`~.search_kernel.HELD`): from node
    ``near`` of ``tree`` to ``q_new``, with the verdicts in ``codes`` and the pairs left to coal in
    ``checks`` (:func:`~.extend_kernel.step_into`'s). True when ``q_new``'s uncertain pairs keep the
    clearance floor and no uncertain probe point is in collision: the compiled distances decide where they
    are clear-cut (:meth:`~.edges.EdgeCertifier.step_verdict`, coal's decision too), coal's distances and
    collision tests otherwise."""
    q_near = tree.node(near)
    verdict = certifier.step_verdict(q_near, q_new)
    if verdict != STEP_UNDECIDED:
        return verdict == STEP_FREE
    oracle = certifier.oracle
    verdicts = codes[END:END + 1 + len(PROBES)].tolist()
    if verdicts[0] == UNCERTAIN \
            and not oracle.keeps(q_new, checks[0, 1:1 + checks[0, 0]], certifier.end_need):
        return False
    u = q_new - q_near
    verdicts[0] = FREE  # (decided)
    return not oracle.coal_decides(lambda k: q_near + PROBES[k - 1] * u, verdicts, checks)


def extend_exactly(tree: SearchTree, target: np.ndarray, certifier: EdgeCertifier, step: float) -> _Step:
    """:func:`extend` one test at a time (the scene's collision test, clearance, probe points): the scenes
    without a sphere pre-check, and the reference of the compiled step."""
    near = tree.nearest(target)
    q_near = tree.node(near)
    delta = target - q_near
    dist = float(np.linalg.norm(delta))
    if dist <= 1e-12:
        return _Step(REACHED, near)
    reached = dist <= step
    q_new = target.copy() if reached else q_near + delta * (step / dist)
    if certifier.in_collision(q_new):
        return _Step(TRAPPED, -1)
    c_new = certifier.clearance(q_new)
    if not certifier.clear(c_new) or certifier.blocked(q_near, q_new):
        return _Step(TRAPPED, -1)
    k = tree.add(c_new, near, certified=False)
    return _Step(REACHED if reached else ADVANCED, k)


def certify_branch(tree: SearchTree, node: int, certifier: EdgeCertifier) -> bool:
    """Certify the edges from ``tree``'s root to ``node`` that are not yet, root first: True when all are;
    at the first that fails, its node is pruned with everything grown from it and False."""
    for k in reversed(tree.branch(node)):
        if tree.certified(k):
            continue
        if not certifier.certify(tree.clearance(tree.parent(k)), tree.clearance(k), probe=False):
            tree.prune(k)
            return False
        tree.mark_certified(k)
    return True


def connect(tree: SearchTree, target: np.ndarray, certifier: EdgeCertifier, step: float) -> _Step:
    """Steps of ``tree`` towards ``target`` (:func:`extend_exactly`) until it reaches it (REACHED) or is
    stopped (TRAPPED)."""
    while True:
        result = extend_exactly(tree, target, certifier, step)
        if result.status != ADVANCED:
            return result


def _joined(start_tree: SearchTree, goal_tree: SearchTree, active: SearchTree, grown: int, joined: int,
            iterations: int) -> SearchResult:
    """The path start root -> meeting node -> goal root: node ``grown`` of the ``active`` tree (the one that
    extended) and node ``joined`` of the other one are the same configuration."""
    start_node, goal_node = (grown, joined) if active is start_tree else (joined, grown)
    head = start_tree.branch(start_node)[::-1]
    tail = goal_tree.branch(goal_node)[1:]
    path = np.array([start_tree.node(k) for k in head] + [goal_tree.node(k) for k in tail])
    clear = [start_tree.clearance(k) for k in head] + [goal_tree.clearance(k) for k in tail]
    return SearchResult(path, clear, goal_tree.root(goal_node), iterations, start_tree.size + goal_tree.size)


def _direct(start: Clearance, goals: list[Clearance], certifier: EdgeCertifier) -> int:
    """Index of the first goal (nearest first, :data:`DIRECT_GOALS` of them) joined to the start by a
    certified straight edge, -1 when none is."""
    gaps = [float(np.linalg.norm(g.q - start.q)) for g in goals]
    for g in np.argsort(gaps, kind="stable")[:DIRECT_GOALS]:
        if certifier.certify(start, goals[g]):
            return int(g)
    return -1


def search_step_by_step(start_tree: SearchTree, goal_tree: SearchTree, lower: np.ndarray, upper: np.ndarray,
                        certifier: EdgeCertifier, rng: np.random.Generator, budget: SearchBudget,
                        step: float = STEP) -> SearchResult:
    """The search in Python, one test at a time (:func:`extend_exactly`): the scenes without a sphere
    pre-check, and the reference of :func:`search_with_kernel` (the same decisions, the same draws)."""
    nq = start_tree.points.shape[1]
    active, other = start_tree, goal_tree
    deadline = None if budget.max_time is None else time.perf_counter() + budget.max_time
    span = upper - lower
    iterations = 0
    while budget.max_iterations is None or iterations < budget.max_iterations:
        if deadline is not None and time.perf_counter() > deadline:
            break
        iterations += 1
        q_rand = lower + span * rng.random(nq)
        grown = extend_exactly(active, q_rand, certifier, step)
        if grown.status != TRAPPED:
            joined = connect(other, active.node(grown.node), certifier, step)
            if joined.status == REACHED and certify_branch(active, grown.node, certifier) \
                    and certify_branch(other, joined.node, certifier):
                return _joined(start_tree, goal_tree, active, grown.node, joined.node, iterations)
        active, other = other, active
    return SearchResult(np.zeros((0, nq)), [], -1, iterations, start_tree.size + goal_tree.size)


def search_with_kernel(start_tree: SearchTree, goal_tree: SearchTree, lower: np.ndarray, upper: np.ndarray,
                       certifier: EdgeCertifier, rng: np.random.Generator, budget: SearchBudget,
                       step: float = STEP) -> SearchResult:
    """The search in the compiled loop (:func:`~.search_kernel.search_steps`), :data:`BATCH` iterations
    per batch of samples; coal's decisions (:func:`held_free`), the branch certificates and the budget
    here, between its calls. The scene needs a sphere pre-check."""
    pre = certifier.oracle.precheck
    nq = start_tree.points.shape[1]
    trees = (start_tree, goal_tree)
    state = np.zeros(STATE_LENGTH, dtype=np.int64)
    state[SIZE_A], state[SIZE_B] = start_tree.size, goal_tree.size
    held = np.empty(nq)
    codes, checks = certifier.codes, certifier.checks
    deadline = None if budget.max_time is None else time.perf_counter() + budget.max_time
    span = upper - lower
    randoms = np.empty((0, nq))
    begun = 0  # iterations of the batches before this one
    while True:
        event = search_steps(pre.floats, pre.ints, start_tree.points, start_tree.pruned, start_tree.parents,
                             goal_tree.points, goal_tree.pruned, goal_tree.parents, randoms, float(step),
                             pre.tolerance, CLEARANCE_FLOOR, PROBE_FRACTIONS, state, held, codes, checks)
        certifier.oracle.checks += int(state[CHECKS])
        state[CHECKS] = 0
        start_tree.size, goal_tree.size = int(state[SIZE_A]), int(state[SIZE_B])
        if event == BATCH_DONE:
            begun += len(randoms)
            left = None if budget.max_iterations is None else budget.max_iterations - begun
            if left == 0 or (deadline is not None and time.perf_counter() > deadline):
                break
            randoms = lower + span * rng.random((BATCH if left is None else min(BATCH, left), nq))
            state[IT] = 0
        elif event == FULL:
            start_tree.reserve()
            goal_tree.reserve()
        elif event == HELD:
            tree = start_tree if grows_start_tree(state) else goal_tree
            free = held_free(tree, int(codes[NEAR]), held, certifier, codes, checks)
            state[DECISION] = ACCEPT if free else REJECT
        elif event == MET:
            active, other = trees if state[ACTIVE] == 0 else trees[::-1]
            grown, joined = int(state[GROWN]), int(state[JOINED])
            if certify_branch(active, grown, certifier) and certify_branch(other, joined, certifier):
                return _joined(start_tree, goal_tree, active, grown, joined, begun + int(state[IT]) + 1)
            state[DECISION] = REJECT  # the iteration ends
        else:
            raise RuntimeError("search_steps: the trees or the certifier's buffers do not fit its scene")
    return SearchResult(np.zeros((0, nq)), [], -1, begun, start_tree.size + goal_tree.size)


def rrt_connect(start: Clearance, goals: list[Clearance], lower: np.ndarray, upper: np.ndarray,
                certifier: EdgeCertifier, rng: np.random.Generator, budget: SearchBudget,
                step: float = STEP) -> SearchResult:
    """A certified path from ``start`` to one of ``goals`` (free configurations above the clearance floor,
    with their clearances) inside ``[lower, upper]``, or an empty :class:`SearchResult` when the budget runs
    out (module docstring): :func:`search_with_kernel` on a scene with a sphere pre-check, else
    :func:`search_step_by_step`."""
    g = _direct(start, goals, certifier)
    if g >= 0:
        return SearchResult(np.array([start.q, goals[g].q]), [start, goals[g]], g, 0, 2)
    nq = len(start.q)
    start_tree = SearchTree(nq, clearance=certifier.clearance)
    goal_tree = SearchTree(nq, clearance=certifier.clearance)
    start_tree.add(start, -1)
    for c in goals:
        goal_tree.add(c, -1)
    search = search_step_by_step if certifier.oracle.precheck is None else search_with_kernel
    return search(start_tree, goal_tree, lower, upper, certifier, rng, budget, step)


__all__ = ["ADVANCED", "BATCH", "DIRECT_GOALS", "REACHED", "STEP", "TRAPPED", "SearchBudget", "SearchResult",
           "certify_branch", "connect", "extend_exactly", "held_free", "rrt_connect", "search_step_by_step",
           "search_with_kernel"]
