"""The compiled RRT-Connect loop (Numba): the iterations of :func:`~.rrt_connect.rrt_connect`, many per call,
up to what only Python decides.

:func:`search_steps` runs the search's iterations on two trees, ``A`` (the start tree) and ``B`` (the goal
tree), each given by its node array ``(capacity, nq)``, its pruned mask and its parent array (``-1``: a
root); the numbers of nodes in use are in ``state``. An iteration draws nothing: it takes the next row of
``randoms`` (uniform samples in the joint limits, drawn by the caller) as ``q_rand``, **extends** the
active tree one step towards it and, when that step succeeds, **connects** the other tree to the new node
(steps until it reaches it or is stopped); then the trees swap roles. Each step is
:func:`~.extend_kernel.step_into`'s: the nearest node, the step of at most ``step`` rad, its end certified
above the clearance floor and its probe points free on the spheres, refused at a point in collision for
certain. A step whose points the spheres leave uncertain is **held**: the call returns, the caller decides
it with coal and calls again with its decision. Every decision is the one
:func:`~.rrt_connect.extend_exactly` takes, step by step.

``state`` (int64, read and written; the positions below):

* ``SIZE_A``, ``SIZE_B``: nodes in use of each tree;
* ``ACTIVE``: 0 when ``A`` extends this iteration, 1 when ``B`` does;
* ``PHASE``: :data:`EXTEND` (towards ``randoms[IT]``) or :data:`CONNECT` (the other tree towards node
  ``GROWN`` of the active one);
* ``IT``: the iteration's row of ``randoms``; ``GROWN``, ``JOINED``: the nodes that met (:data:`MET`);
* ``DECISION``: on entry, the caller's decision about the held step (:data:`ACCEPT`, :data:`REJECT`;
  :data:`NO_DECISION` when none is held); ``CHECKS``: configurations asked (added to, for the caller's
  count).

The call returns an event: :data:`BATCH_DONE` (every row of ``randoms`` used), :data:`FULL` (the tree
to grow has no free row: the caller grows its arrays and calls again, the step is made then), :data:`HELD`
(the step's ``q_new`` in ``held``, its codes and pair lists in ``codes`` / ``checks`` as
:func:`~.extend_kernel.step_into`'s), :data:`MET` (the trees met: node ``GROWN`` of the active tree and
``JOINED`` of the other are the same configuration; the caller certifies the two branches and, when that
fails, calls again with the decision :data:`REJECT`: the iteration ends) or :data:`UNFIT` (the buffers or
trees do not fit: nothing done).

The cache key covers every kernel source (:mod:`kinserve.kinematics.kernel_cache`); the kernel has its
signature: importing this module compiles it or loads it from that cache. Radians.
"""

from __future__ import annotations

import numba
import numpy as np

from kinserve.kinematics.kernel_cache import B1, F1, F2, I1, compiled, inline

from .extend_kernel import AT_TARGET, COLLIDES, END, KIND, NEAR, ONTO, UNCERTAIN, fits, step_into

#: Positions in ``state``.
SIZE_A, SIZE_B, ACTIVE, PHASE, IT, GROWN, JOINED, DECISION, CHECKS = range(9)
#: Length of ``state``.
STATE_LENGTH = 9
#: Phases of an iteration.
EXTEND, CONNECT = 0, 1
#: The caller's decision about a held step.
NO_DECISION, ACCEPT, REJECT = 0, 1, 2
#: Events :func:`search_steps` returns.
BATCH_DONE, FULL, HELD, MET, UNFIT = 0, 1, 2, 3, 4

# outcomes of one step
_TRAPPED, _REACHED_NODE, _ADDED, _HELD = 0, 1, 2, 3

_t = numba.types
_I1W, _F2W = _t.Array(_t.int64, 1, "C"), _t.Array(_t.float64, 2, "C")
_SEARCH_SIGNATURE = _t.int64(F1, I1, _F2W, B1, _I1W, _F2W, B1, _I1W,
                             F2, _t.float64, _t.float64, _t.float64, F1, _I1W, _t.Array(_t.float64, 1, "C"),
                             _I1W, _t.Array(_t.int64, 2, "C"))


@inline
def _end_iteration(state):
    """End the iteration in ``state``: the next row of ``randoms``, the trees swap roles, extend next."""
    state[IT] += 1
    state[ACTIVE] = 1 - state[ACTIVE]
    state[PHASE] = EXTEND


def grows_start_tree(state: np.ndarray) -> bool:
    """Whether the step in ``state`` (the one held, or the next) grows tree ``A``: the active tree extends,
    the other connects."""
    return bool((state[ACTIVE] == 0) == (state[PHASE] == EXTEND))


@inline
def _step_outcome(codes, probes):
    """The outcome of the step in ``codes`` (:func:`~.extend_kernel.step_into`) and the configurations it
    asked: the nearest node is the target (reached), a point in collision for certain (trapped), a point
    uncertain (held) or every point free (added)."""
    if codes[NEAR] < 0:
        return _TRAPPED, 0
    if codes[KIND] == AT_TARGET:
        return _REACHED_NODE, 0
    asked, uncertain = 0, False
    for k in range(1 + probes.shape[0]):
        verdict = codes[END + k]
        if verdict < 0:
            break
        asked += 1
        if verdict == COLLIDES:
            return _TRAPPED, asked
        uncertain = uncertain or verdict == UNCERTAIN
    return (_HELD if uncertain else _ADDED), asked


@inline
def _add(nodes, parents, size, q, parent):
    """Append node ``q`` with its ``parent`` at row ``size``; its index."""
    for c in range(nodes.shape[1]):
        nodes[size, c] = q[c]
    parents[size] = parent
    return size


@compiled(_SEARCH_SIGNATURE)
def search_steps(floats: np.ndarray, ints: np.ndarray, nodes_a: np.ndarray, pruned_a: np.ndarray,
                 parents_a: np.ndarray, nodes_b: np.ndarray, pruned_b: np.ndarray, parents_b: np.ndarray,
                 randoms: np.ndarray, step: float, tol: float, floor: float, probes: np.ndarray,
                 state: np.ndarray, held: np.ndarray, codes: np.ndarray, checks: np.ndarray) -> int:
    """Iterations of RRT-Connect from ``state`` until an event (module docstring). ``floats, ints``: the
    scene's packed pre-check; ``randoms`` ``(B, nq)``: the iterations' samples; ``step`` (rad), ``tol`` and
    ``floor`` (m) and ``probes`` as :func:`~.extend_kernel.step_into`'s; ``held`` ``(nq,)``: the held
    step's ``q_new``; ``codes``, ``checks``: :func:`~.extend_kernel.step_into`'s buffers."""
    nq = nodes_a.shape[1]
    if not fits(floats, ints, 1 + probes.shape[0], codes, checks) or state.shape[0] < STATE_LENGTH \
            or nodes_b.shape[1] != nq or randoms.shape[1] != nq or held.shape[0] != nq \
            or pruned_a.shape[0] < nodes_a.shape[0] or parents_a.shape[0] < nodes_a.shape[0] \
            or pruned_b.shape[0] < nodes_b.shape[0] or parents_b.shape[0] < nodes_b.shape[0]:
        return UNFIT
    while True:
        grows_a = (state[ACTIVE] == 0) == (state[PHASE] == EXTEND)  # (grows_start_tree)
        nodes, pruned, parents = (nodes_a, pruned_a, parents_a) if grows_a else (nodes_b, pruned_b, parents_b)
        at = SIZE_A if grows_a else SIZE_B
        decision = state[DECISION]
        state[DECISION] = NO_DECISION
        if decision == NO_DECISION:
            if state[PHASE] == EXTEND and state[IT] >= randoms.shape[0]:
                return BATCH_DONE
            if state[at] >= nodes.shape[0]:
                return FULL
            if state[PHASE] == EXTEND:
                target = randoms[state[IT]]
            else:
                target = nodes_b[state[GROWN]] if grows_a else nodes_a[state[GROWN]]
            step_into(floats, ints, nodes, pruned, state[at], target, step, tol, floor, probes, held, codes,
                      checks)
            outcome, asked = _step_outcome(codes, probes)
            state[CHECKS] += asked
            if outcome == _HELD:
                return HELD
        else:
            outcome = _ADDED if decision == ACCEPT else _TRAPPED
        if outcome == _TRAPPED:
            _end_iteration(state)
            continue
        if outcome == _REACHED_NODE:
            node, reached = codes[NEAR], True
        else:
            node = _add(nodes, parents, state[at], held, codes[NEAR])
            state[at] += 1
            reached = codes[KIND] == ONTO
        if state[PHASE] == EXTEND:
            state[GROWN] = node
            state[PHASE] = CONNECT
        elif reached:
            state[JOINED] = node
            return MET


__all__ = ["ACCEPT", "ACTIVE", "BATCH_DONE", "CHECKS", "CONNECT", "DECISION", "EXTEND", "FULL", "GROWN",
           "HELD", "IT", "JOINED", "MET", "NO_DECISION", "PHASE", "REJECT", "SIZE_A", "SIZE_B",
           "STATE_LENGTH", "UNFIT", "grows_start_tree", "search_steps"]
