"""The planner's compiled probes (Numba): RRT-Connect's extension step (nearest node, the step, its sphere
checks) and the probe points of a motion.

:func:`nearest_node`: the index of the node of ``nodes[:size]`` ``(N, nq)`` closest to ``q`` (squared
Euclidean distance, the first one on ties) among those ``pruned`` does not mark; -1 when there is none.

:func:`step_into`: one extension step of a tree up to what only coal can decide (inlined into the search's
compiled loop, :func:`~.search_kernel.search_steps`). From the nearest node ``q_near`` towards ``target``
(distance ``dist``) it steps to ``q_new = target`` when ``dist <= step``, else ``q_new = q_near + (target -
q_near) step / dist`` (rad), and asks the scene's sphere pre-check about ``q_new`` and then about the points
``q_near + s (q_new - q_near)`` for each ``s`` of ``probes``
(:func:`~kinserve.kinematics.precheck_kernels.pairs_to_check`, one forward kinematics per point; tolerance
``tol``, m): **certified free**, **colliding** for certain (then nothing more is asked: the step is refused)
or **uncertain**, with the pairs coal must check there (every other pair is certified free: the pre-check's
spheres contain the robot's geometry, and its inner balls lie inside it, so a configuration colliding for
certain is one coal finds in collision). ``q_new``, a new node, must also keep the clearance floor: it is
certified with ``floor`` (m) instead of ``tol``, so **free** there means every pair's lower bound exceeds the
floor, and its uncertain pairs are those whose bound does not (coal's distances decide them against the
floor).

Its answer, into the caller's buffers: ``q_new`` ``(nq,)``, and (owned by the planner's
:class:`~.edges.EdgeCertifier`, written on every call) ``codes`` ``(3 + len(probes),)`` int64:
``[near, kind, end, probe_0, ...]`` with ``kind`` :data:`AT_TARGET` (``dist <= 1e-12``: nothing
else filled), :data:`ONTO` (``dist <= step``: ``q_new`` is the target) or :data:`TOWARDS`;
``end`` and ``probe_k``: :data:`FREE`, :data:`UNCERTAIN` or :data:`COLLIDES` (-1: not asked, after a point
colliding for certain). ``checks`` ``(1 + len(probes), P + 1)``: row ``k`` (0: ``q_new``, then the probes)
holds, for an uncertain point, the number ``c`` of pairs coal must check there, then their scene indices in
``[1, c]`` (the other rows are not written).
``near`` is -1 (and ``kind`` :data:`AT_TARGET`) when every node is pruned or ``size`` is 0.

:func:`probe_segment`: the same verdicts (from ``codes[END]`` on) and pair lists at the probe points
``qa + s (qb - qa)`` of a motion (the cheap test that refuses a motion before its certificate:
:meth:`~.edges.EdgeCertifier.blocked`).

:func:`exact_verdict`: the decision about an uncertain step on the distances of the shapes themselves
(:mod:`kinserve.kinematics.convex_distance`: GJK's lower and upper bounds between the convex shapes), taken
only where it is clear-cut - :data:`EXACT_MARGIN` from the threshold - so that it is coal's decision too; the
others are left to coal.

The cache key covers every kernel source (:mod:`kinserve.kinematics.kernel_cache`); every kernel has its
signature: importing this module compiles them or loads them from that cache. Metres and radians.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from kinserve.kinematics.convex_distance import pair_distance_bounds
from kinserve.kinematics.kernel_cache import B1, F1, F1_ANY, F2, I1, I2, compiled, inline
from kinserve.kinematics.precheck_kernels import pairs_to_check, tree_placements, unpack

#: Verdicts of one configuration: certified free by the spheres, left to coal, in collision for certain.
FREE, UNCERTAIN, COLLIDES = 0, 1, 2
#: ``codes[1]`` of :func:`step_into`: the nearest node is the target itself (no step), a step short of
#: the target, a step onto it.
AT_TARGET, TOWARDS, ONTO = 0, 1, 2
#: Positions in ``codes`` of :func:`step_into`: nearest node, kind, verdict of ``q_new`` (the probes'
#: verdicts follow it).
NEAR, KIND, END = 0, 1, 2

_t = numba.types
_NEAREST_SIGNATURE = _t.int64(F2, B1, _t.int64, F1_ANY)
#: The caller's buffers (written): ``codes`` and ``checks``. One array returned at most: each array a
#: compiled call returns costs an unpickling of its type when it is boxed.
_CODES, _CHECKS = _t.Array(_t.int64, 1, "C"), _t.Array(_t.int64, 2, "C")
_SEGMENT_SIGNATURE = _t.boolean(F1, I1, F1_ANY, F1_ANY, F1, _t.float64, _CODES, _CHECKS)


@compiled(_NEAREST_SIGNATURE)
def nearest_node(nodes: np.ndarray, pruned: np.ndarray, size: int, q: np.ndarray) -> int:
    """Index of the row of ``nodes[:size]`` closest to ``q`` (squared Euclidean, first on ties) among those
    ``pruned`` does not mark; -1 when none (module docstring)."""
    best, k = math.inf, -1
    for i in range(min(size, nodes.shape[0], pruned.shape[0])):
        if pruned[i]:
            continue
        d2 = 0.0
        for c in range(nodes.shape[1]):
            d = nodes[i, c] - q[c]
            d2 += d * d
        if d2 < best or k < 0:
            best, k = d2, i
    return k


@inline
def _judge(floats, ints, q, keep, tol, codes, checks, k):
    """Point ``k`` of the step (0: ``q_new``, then the probes) at configuration ``q``, certified with
    ``keep`` (m; in collision for certain at depth ``tol``): its verdict into ``codes[END + k]`` and, when
    uncertain, the pairs coal must check into row ``k`` of ``checks`` (count first; the rows of other points
    are left unwritten)."""
    found = pairs_to_check(floats, ints, q, keep, tol, checks[k, 1:])
    if found < 0:
        codes[END + k] = COLLIDES
    else:
        checks[k, 0] = found
        codes[END + k] = FREE if found == 0 else UNCERTAIN


@inline
def fits(floats: np.ndarray, ints: np.ndarray, rows: int, codes: np.ndarray, checks: np.ndarray) -> bool:
    """Whether ``codes`` has ``END + rows`` entries and ``checks`` ``rows`` rows of one count and one entry
    per pair of the scene."""
    return (codes.shape[0] >= END + rows and checks.shape[0] >= rows
            and checks.shape[1] >= unpack(floats, ints)[4].shape[0] + 1)


@inline
def step_into(floats: np.ndarray, ints: np.ndarray, nodes: np.ndarray, pruned: np.ndarray, size: int,
              target: np.ndarray, step: float, tol: float, floor: float, probes: np.ndarray,
              q_new: np.ndarray, codes: np.ndarray, checks: np.ndarray) -> None:
    """One extension step of the tree ``nodes`` ``(N, nq)`` (``pruned`` ``(N,)``, the first ``size`` rows in
    use) towards ``target`` up to what coal must decide, into ``q_new``, ``codes`` and ``checks`` (module
    docstring; the buffers fit: :func:`fits`). ``floats, ints``: the scene's packed pre-check
    (:mod:`kinserve.kinematics.precheck_packing`); ``step`` (rad), ``tol`` (m), ``floor`` (m, the distance
    ``q_new``'s pairs must keep, at least ``tol``), ``probes`` (fractions of the step)."""
    n = nodes.shape[1]
    codes[:END + 1 + probes.shape[0]] = -1
    codes[KIND] = AT_TARGET
    near = nearest_node(nodes, pruned, size, target)
    codes[NEAR] = near
    if near < 0:
        return
    dist2 = 0.0
    for c in range(n):
        d = target[c] - nodes[near, c]
        dist2 += d * d
    dist = math.sqrt(dist2)
    if dist <= 1e-12:
        return
    codes[KIND] = ONTO if dist <= step else TOWARDS
    f = 1.0 if dist <= step else step / dist
    for c in range(n):
        q_new[c] = target[c] if dist <= step else nodes[near, c] + (target[c] - nodes[near, c]) * f
    _judge(floats, ints, q_new, max(floor, tol), tol, codes, checks, 0)
    if codes[END] == COLLIDES:
        return
    q = np.empty(n)
    for k in range(probes.shape[0]):
        s = probes[k]
        for c in range(n):
            q[c] = nodes[near, c] + s * (q_new[c] - nodes[near, c])
        _judge(floats, ints, q, tol, tol, codes, checks, 1 + k)
        if codes[END + 1 + k] == COLLIDES:
            return


@compiled(_SEGMENT_SIGNATURE)
def probe_segment(floats: np.ndarray, ints: np.ndarray, qa: np.ndarray, qb: np.ndarray, probes: np.ndarray,
                  tol: float, codes: np.ndarray, checks: np.ndarray) -> bool:
    """The sphere pre-check at the points ``qa + s (qb - qa)``, ``s`` in ``probes`` (rad; tolerance ``tol``,
    m), in one call, into the caller's buffers: ``codes[END + k]`` the verdict of point ``k``, :data:`FREE`,
    :data:`UNCERTAIN` or :data:`COLLIDES` (-1 after a point colliding for certain: not asked), ``checks`` as
    :func:`step_into`'s (row ``k``: for an uncertain point, the number of pairs coal must check there,
    then their scene indices). False (nothing written) when the buffers are smaller than
    :func:`step_into` needs with these probes."""
    n = qa.shape[0]
    if not fits(floats, ints, 1 + probes.shape[0], codes, checks):
        return False
    codes[END:END + probes.shape[0]] = -1
    q = np.empty(n)
    for k in range(probes.shape[0]):
        s = probes[k]
        for c in range(n):
            q[c] = qa[c] + s * (qb[c] - qa[c])
        _judge(floats, ints, q, tol, tol, codes, checks, k)
        if codes[END + k] == COLLIDES:
            break
    return True


#: :func:`exact_verdict` decides a pair only when its distance bounds lie at least this far (m) from the
#: threshold: coal's distances are within about 1e-6 m of the true ones, GJK's bounds (of which the lower is
#: used) within 1e-8 m of each other or returned as they are, so coal would decide the same.
EXACT_MARGIN = 1e-5
#: Answers of :func:`exact_verdict`: every uncertain point of the step is free (``q_new`` above its floor),
#: ``q_new`` is below its floor, or coal must decide.
STEP_FREE, STEP_REFUSED, STEP_UNDECIDED = 1, 0, -1

_VERDICT_SIGNATURE = _t.int64(F1, I1, F2, I2, F1, I1, F1_ANY, F1_ANY, F1, _t.boolean, F1, I1, I2)


@compiled(_VERDICT_SIGNATURE)
def exact_verdict(floats: np.ndarray, ints: np.ndarray, points: np.ndarray, hull_geoms: np.ndarray,
                  radius: np.ndarray, table_rows: np.ndarray, q_near: np.ndarray, q_new: np.ndarray,
                  probes: np.ndarray, with_node: bool, need: np.ndarray, codes: np.ndarray,
                  checks: np.ndarray) -> int:
    """The decision about the points :func:`step_into` (``with_node``) or :func:`probe_segment` left uncertain
    (``codes``, ``checks``: its answer; from ``q_near`` to ``q_new``, the probe points at the fractions
    ``probes``, after ``q_new`` itself with ``with_node``) on the distances of the shapes (``points,
    hull_geoms, radius``: the robot's :class:`~kinserve.kinematics.hull_table.HullTable`; ``table_rows``: the
    pair-table row of each scene pair; ``need`` ``(P,)``: the distance each scene pair must keep at ``q_new``,
    m). :data:`STEP_REFUSED` when an uncertain pair of ``q_new`` is surely below its need (its distance's
    upper bound below ``need - EXACT_MARGIN``); :data:`STEP_FREE` when every uncertain pair of ``q_new`` is
    surely above it (lower bound at least ``need + EXACT_MARGIN``) and every uncertain pair of every
    uncertain probe point surely apart (lower bound above :data:`EXACT_MARGIN`); :data:`STEP_UNDECIDED`
    otherwise (a pair closer to its threshold, one not measured: coal decides)."""
    tree, joints, spheres, geoms, pairs, obstacles = unpack(floats, ints)
    n = joints.shape[0]
    first = 1 if with_node else 0  # the point of probes[0]
    if q_near.shape[0] != n or q_new.shape[0] != n or hull_geoms.shape[0] < geoms.shape[0] \
            or table_rows.shape[0] != pairs.shape[0] or need.shape[0] < pairs.shape[0] \
            or codes.shape[0] < END + first + probes.shape[0] or checks.shape[0] < first + probes.shape[0]:
        return STEP_UNDECIDED
    X = np.empty((n + 1, 12))
    S, T = np.empty((4, 3)), np.empty((7, 3))
    guess = np.zeros(3)
    q = np.empty(n)
    free = True
    for k in range(first + probes.shape[0]):
        if codes[END + k] != UNCERTAIN:
            continue
        node = k < first
        if node:
            for c in range(n):
                q[c] = q_new[c]
        else:
            for c in range(n):
                q[c] = q_near[c] + probes[k - first] * (q_new[c] - q_near[c])
        tree_placements(tree, joints, q, X)
        for i in range(1, 1 + checks[k, 0]):
            pair = checks[k, i]
            if pair < 0 or pair >= pairs.shape[0]:
                return STEP_UNDECIDED
            guess[:] = 0.0  # (no start: the pairs of a step are measured once each)
            lower, upper = pair_distance_bounds(points, hull_geoms, radius, pairs, obstacles,
                                                table_rows[pair], X, S, T, guess, math.inf, -math.inf)
            if node and upper < need[pair] - EXACT_MARGIN:
                return STEP_REFUSED
            threshold = need[pair] if node else 0.0
            if not lower >= threshold + EXACT_MARGIN:  # (NaN: not measured)
                free = False
    return STEP_FREE if free else STEP_UNDECIDED


__all__ = ["AT_TARGET", "COLLIDES", "END", "EXACT_MARGIN", "FREE", "KIND", "NEAR", "ONTO", "STEP_FREE",
           "STEP_REFUSED", "STEP_UNDECIDED", "TOWARDS", "UNCERTAIN", "exact_verdict", "fits", "nearest_node",
           "probe_segment", "step_into"]
