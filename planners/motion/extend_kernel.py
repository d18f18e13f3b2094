"""The compiled inner loop of RRT-Connect's extension step (Numba): nearest node, the step, its sphere checks.

:func:`nearest_node`: the index of the node of ``nodes[:size]`` ``(N, nq)`` closest to ``q`` (squared
Euclidean distance, the first one on ties) among those ``pruned`` does not mark; -1 when there is none.

:func:`extend_probe`: one extension step of a tree (:func:`~.rrt_connect.extend`) up to what only coal can
decide, in one call. From the nearest node ``q_near`` towards ``target`` (distance ``dist``) it steps to
``q_new = target`` when ``dist <= step``, else ``q_new = q_near + (target - q_near) step / dist`` (rad), and
asks the scene's sphere pre-check about ``q_new``
(:func:`~kinserve.kinematics.precheck_kernels.classify_configuration`, tolerance ``tol``, m): **certified
free**, **colliding** for certain (then nothing else is asked: the step is refused) or **uncertain**; then
about the points ``q_near + s (q_new - q_near)`` for each ``s`` of ``probes``
(:func:`~kinserve.kinematics.precheck_kernels.certify_configuration`): certified free or uncertain (coal
decides: the pre-check's spheres contain the robot's geometry, so a certified configuration is one coal
finds free, and its inner balls lie inside it, so a configuration colliding for certain is one coal finds in
collision). When every one is certified, it
also tells whether ``q_new``'s pair lower bounds
(:func:`~kinserve.kinematics.precheck_kernels.pair_lower_bounds`, m) all exceed ``need`` ``(P,)`` (the
distance each pair must keep at a node, in the scene's pair order: the clearance floor;
:func:`~kinserve.kinematics.precheck_kernels.pairs_keep`, which computes the cover spheres' bounds of the
close pairs only).

Its answer: ``(codes, q_new)``, ``codes`` ``(4 + len(probes),)`` int64:
``[near, kind, floor, end, probe_0, ...]`` with ``kind`` :data:`AT_TARGET` (``dist <= 1e-12``: nothing
else filled), :data:`ONTO` (``dist <= step``: ``q_new`` is the target) or :data:`TOWARDS`; ``floor``
1 when every bound exceeds its ``need``, 0 when one may not (coal decides), -1 when not asked;
``end``: :data:`FREE`, :data:`COLLIDES` (the ``probe_k`` are then -1) or :data:`UNCERTAIN`; ``probe_k``:
:data:`FREE` or :data:`UNCERTAIN`.
``near`` is -1 (and ``kind`` :data:`AT_TARGET`) when every node is pruned or ``size`` is 0.

The cache key covers every kernel source (:mod:`kinserve.kinematics.kernel_cache`); every kernel has its
signature: importing this module compiles them or loads them from that cache. Metres and radians.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from kinserve.kinematics.kernel_cache import B1, F1, F1_ANY, F2, I1, compiled
from kinserve.kinematics.precheck_kernels import certify_configuration, classify_configuration, pairs_keep
from kinserve.kinematics.precheck_verdicts import COLLIDING as _COLLIDING
from kinserve.kinematics.precheck_verdicts import FREE as _FREE

#: Verdicts of one configuration: certified free by the spheres, left to coal, in collision for certain.
FREE, UNCERTAIN, COLLIDES = 0, 1, 2
#: ``codes[1]`` of :func:`extend_probe`: the nearest node is the target itself (no step), a step short of
#: the target, a step onto it.
AT_TARGET, TOWARDS, ONTO = 0, 1, 2
#: Positions in ``codes`` of :func:`extend_probe`: nearest node, kind, floor test, verdict of ``q_new``
#: (the probes' verdicts follow it).
NEAR, KIND, FLOOR, END = 0, 1, 2, 3

_t = numba.types
_NEAREST_SIGNATURE = _t.int64(F2, B1, _t.int64, F1_ANY)
_OUT = _t.Tuple((_t.Array(_t.int64, 1, "C"), _t.Array(_t.float64, 1, "C")))
_EXTEND_SIGNATURE = _OUT(F1, I1, F2, B1, _t.int64, F1_ANY, _t.float64, _t.float64, F1_ANY, F1)


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


@compiled(_EXTEND_SIGNATURE)
def extend_probe(floats: np.ndarray, ints: np.ndarray, nodes: np.ndarray, pruned: np.ndarray, size: int,
                 target: np.ndarray, step: float, tol: float, need: np.ndarray,
                 probes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One extension step of a tree towards ``target`` up to what coal must decide: ``(codes, q_new)``
    (module docstring). ``floats, ints``: the scene's packed pre-check
    (:mod:`kinserve.kinematics.precheck_packing`); ``nodes`` ``(N, nq)`` with ``pruned`` ``(N,)``, the first
    ``size`` rows in use; ``step`` (rad), ``tol`` (m), ``need`` ``(P,)`` (m), ``probes`` (fractions of the
    step)."""
    n = nodes.shape[1]
    codes = np.full(4 + probes.shape[0], -1, dtype=np.int64)
    codes[KIND] = AT_TARGET
    near = nearest_node(nodes, pruned, size, target)
    codes[NEAR] = near
    q_new = np.empty(n)
    if near < 0:
        return codes, q_new
    dist2 = 0.0
    for c in range(n):
        d = target[c] - nodes[near, c]
        dist2 += d * d
    dist = math.sqrt(dist2)
    if dist <= 1e-12:
        return codes, q_new
    codes[KIND] = ONTO if dist <= step else TOWARDS
    f = 1.0 if dist <= step else step / dist
    for c in range(n):
        q_new[c] = target[c] if dist <= step else nodes[near, c] + (target[c] - nodes[near, c]) * f
    verdict = classify_configuration(floats, ints, q_new, tol)
    if verdict == _COLLIDING:
        codes[END] = COLLIDES
        return codes, q_new
    free = verdict == _FREE
    codes[END] = FREE if free else UNCERTAIN
    q = np.empty(n)
    for k in range(probes.shape[0]):
        s = probes[k]
        for c in range(n):
            q[c] = nodes[near, c] + s * (q_new[c] - nodes[near, c])
        ok = certify_configuration(floats, ints, q, tol)
        codes[END + 1 + k] = FREE if ok else UNCERTAIN
        free = free and ok
    if free:
        codes[FLOOR] = 1 if pairs_keep(floats, ints, q_new, need) else 0
    return codes, q_new


__all__ = ["AT_TARGET", "COLLIDES", "END", "FLOOR", "FREE", "KIND", "NEAR", "ONTO", "TOWARDS", "UNCERTAIN",
           "extend_probe", "nearest_node"]
