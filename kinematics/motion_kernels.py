"""The compiled certificates of straight motions on the sphere bounds (Numba): the rates, the advancement.

A straight joint-space motion ``q(s) = qa + s (qb - qa)``, ``s`` in ``[0, 1]``, is
certified collision free on a stretch of ``s`` when every checked pair's lower
bound (:mod:`.precheck_kernels`: spheres fixed in the joint frames that contain
the robot's geometries, against each other and the obstacles) stays above the
tolerance there. A configuration with bound ``d`` (minus the tolerance) certifies
``|s' - s| <= d / rate`` when the bound falls by at most ``rate`` per unit ``s``.

**Rates.** Per sphere centre, the global bound ``sum_k sphere_reach[c, k] |u_k|``
(:func:`~.robot_spheres.sphere_reach`), lowered to the motion's own from the
centres' distances to the joint axes at its two ends (:func:`motion_rates`); per
self pair, the two geometries' rates on the joints carrying one of them and not the
other. :func:`geometry_pair_rates` gives the same bound for the shapes themselves
(not their spheres), for the exact stage that advances on coal's distances.

**Advancement.** :func:`motion_hard_pairs`: from both ends with look-ahead, pair by pair, each with
its own certified ends, handing over the pairs whose spheres cannot decide.
:func:`advance_on_distances`: the advancement of those handed-over pairs on the
distances of the shapes themselves (:mod:`.convex_distance`: GJK's lower bound
between the convex cores, less their radii), the algorithm of
:func:`kinserve.planners.motion.edges.advance` in one compiled call.

Each kernel has its signature: importing this module compiles them or loads them
from the kernel set's cache (:mod:`.kernel_cache`, whose key covers this file).
Metres and radians.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .convex_distance import pair_distance_bounds, pair_measured
from .kernel_cache import F1, F1_ANY, F2, I1, I2, compiled, inline, leaf
from .precheck_kernels import (
    LIPSCHITZ_SAFETY,
    SELF_PAIR,
    TOLERANCE,
    obstacle_gap,
    place_bounding_spheres,
    place_cover,
    place_sphere,
    self_cover_gap,
    sphere_gap,
    tree_placements,
    unpack,
    workspace,
)
from .serial_chain import REVOLUTE as _REVOLUTE

_inline, _leaf = inline, leaf  # (kernel_cache's: one cache key over every kernel source)
_t = numba.types


@_inline
def _rate_radius(gap, rate):
    """The largest ``|ds|`` over which a bound ``gap`` (m, minus the tolerance) that falls by at most ``rate``
    (m per unit ``s``) stays positive: ``gap / rate``; ``inf`` when it does not fall and is positive, -1 when
    it is not positive (the spheres tell nothing)."""
    if gap <= 0.0:
        return -1.0
    if rate <= 0.0:
        return math.inf
    return gap / rate


@_inline
def _rates_fit(joints, spheres, geoms, pairs, sphere_reach, pair_reach, qa, qb):
    """True when ``qa``, ``qb`` have one entry per joint and the rate tables cover every joint, sphere row
    (bounding and cover spheres) and pair of the packed scene."""
    n = joints.shape[0]
    rows = sphere_reach.shape[0]
    if qa.shape[0] != n or qb.shape[0] != n or sphere_reach.shape[1] != n or pair_reach.shape[1] != n \
            or pair_reach.shape[0] != pairs.shape[0] or rows > spheres.shape[0]:
        return False
    for g in range(geoms.shape[0]):
        if geoms[g, 2] > rows or g >= rows:  # a sphere without its rates
            return False
    return True


@_inline
def _joint_steps(joints, qa, qb):
    """``du`` ``(J,)``: ``|u_k|`` of the straight motion ``qa -> qb`` (``u = qb - qa``) on each tree row's
    coordinate."""
    du = np.empty(joints.shape[0])
    for k in range(joints.shape[0]):
        du[k] = abs(qb[joints[k, 1]] - qa[joints[k, 1]])
    return du


@_inline
def _motion_rates(joints, sphere_reach, pair_reach, S, du):
    """``(v, w)`` of the straight motion whose joint steps are ``du`` (:func:`_joint_steps`): per sphere row
    ``c``, ``v[c] = sum_k sphere_reach[c, k] du[k]`` (m per unit of the motion's parameter; ``(S,)``, 0
    beyond the table's rows), and per pair-table row ``p``, ``w[p] = sum_k pair_reach[p, k] du[k]``."""
    n = joints.shape[0]
    v = np.zeros(S)
    for c in range(sphere_reach.shape[0]):
        acc = 0.0
        for k in range(n):
            acc += sphere_reach[c, k] * du[k]
        v[c] = acc
    w = np.zeros(pair_reach.shape[0])
    for p in range(pair_reach.shape[0]):
        acc = 0.0
        for k in range(n):
            acc += pair_reach[p, k] * du[k]
        w[p] = acc
    return v, w


@_inline
def _axis_distances(X, tree, joints, W, geoms, g, du, out):
    """Add to ``out[k]`` the distance (m) of geometry ``g``'s bounding-sphere centre (placed in ``W``) from
    the axis of each revolute joint ``k`` carrying it that the motion turns (``du[k] > 0``), at the
    placements ``X``: ``|a_k x (c - o_k)|``, ``a_k`` the joint's unit axis in the world, ``o_k`` its
    origin."""
    cx, cy, cz = W[g, 0], W[g, 1], W[g, 2]
    j = geoms[g, 0]
    while j > 0:
        k = j - 1
        if joints[k, 0] == _REVOLUTE and du[k] > 0.0:
            x = X[j]
            ax, ay, az = tree[k, 12], tree[k, 13], tree[k, 14]
            wx = x[0] * ax + x[1] * ay + x[2] * az
            wy = x[3] * ax + x[4] * ay + x[5] * az
            wz = x[6] * ax + x[7] * ay + x[8] * az
            dx, dy, dz = cx - x[9], cy - x[10], cz - x[11]
            ex, ey, ez = wy * dz - wz * dy, wz * dx - wx * dz, wx * dy - wy * dx
            out[k] += math.sqrt(ex * ex + ey * ey + ez * ez)
        j = joints[k, 2]


@_inline
def _end_distances(tree, joints, spheres, geoms, qa, qb, du, X, W):
    """``(G, J)``: per geometry and joint, ``rho_k(qa) + rho_k(qb)``, the distances (m) of the geometry's
    bounding-sphere centre from revolute joint ``k``'s axis at the two configurations
    (:func:`_axis_distances`; 0 where the joint does not carry it, is prismatic or does not turn). ``X``,
    ``W``: scratch."""
    ends = np.zeros((geoms.shape[0], joints.shape[0]))
    for q in (qa, qb):
        tree_placements(tree, joints, q, X)
        for g in range(geoms.shape[0]):
            place_sphere(X, geoms[g, 0], spheres, g, W)
            _axis_distances(X, tree, joints, W, geoms, g, du, ends[g])
    return ends


@_inline
def _chain_rate(joints, geoms, sphere_reach, du, ends, g, row, extra, offset, span, joint_rate):
    """``sum_k du[k] bound_k`` over the joints ``k`` carrying geometry ``g``, for a point of sphere row
    ``row`` at ``offset`` (m) from the geometry's bounding centre, on a stretch ``span`` of the motion long;
    ``joint_rate[g, k]`` is raised to each ``bound_k``.

    Revolute ``k``: ``R_k = sphere_reach[row, k] + extra`` bounds the point's distance from the joint's
    axis anywhere; along the stretch it is at most ``ends[g, k] / 2 + offset + span C_k / 2`` (``ends``:
    :func:`_end_distances`, ``C_k = sum_{j below k} R_j du[j]``), and ``bound_k`` is the smaller of the two.
    Prismatic ``k``: ``bound_k = R_k = sphere_reach[row, k]`` (1)."""
    below, rate = 0.0, 0.0
    j = geoms[g, 0]
    while j > 0:
        k = j - 1
        if joints[k, 0] == _REVOLUTE:
            full = sphere_reach[row, k] + extra
            bound = min(full, 0.5 * ends[g, k] + offset + 0.5 * span * below)
        else:
            full = bound = sphere_reach[row, k]
        joint_rate[g, k] = max(joint_rate[g, k], bound)
        rate += bound * du[k]
        below += full * du[k]
        j = joints[k, 2]
    return rate


@_inline
def _tighten_rates(tree, joints, spheres, geoms, sphere_reach, pairs, pair_reach, qa, qb, du, v, w, X, W):
    """Lower the rates ``v`` (sphere rows) and ``w`` (self pairs) of :func:`_motion_rates` to bounds of this
    motion (``du``: its joint steps, :func:`_joint_steps`; placements ``X``, ``W`` used as scratch).

    Along ``q(s) = qa + s u`` a sphere centre ``c`` moves at speed at most ``sum_k |u_k| rho_k(s)``,
    ``rho_k`` its distance from revolute joint ``k``'s axis (1 for a prismatic joint). ``rho_k`` changes
    only as ``c`` moves relative to joint ``k``'s body, by the joints below ``k``: by at most
    ``C_k = sum_{j below k} sphere_reach[c, j] |u_j|`` per unit ``s``. So over the motion ``rho_k <=
    (rho_k(0) + rho_k(1) + C_k) / 2`` (the two ends' bounds ``rho_k(0) + s C_k`` and ``rho_k(1) + (1 - s)
    C_k`` meet there), and never above ``sphere_reach[c, k]``. ``rho_k`` is measured at both ends for each
    geometry's bounding-sphere centre; a cover sphere at ``d`` from it (fixed in the same frame) is at most
    ``d`` farther from any axis. A self pair's gaps change at most as fast as the two geometries' spheres
    move on the joints carrying one of them and not the other: the same per-joint bounds with the
    geometry's largest rates. The results are constant rates over the whole motion, at most the global
    ones: the advancement is unchanged, its steps longer."""
    n, G = joints.shape[0], geoms.shape[0]
    rows = sphere_reach.shape[0]
    ends = _end_distances(tree, joints, spheres, geoms, qa, qb, du, X, W)
    joint_rate = np.zeros((G, n))  # per geometry and joint: the largest rate of its rows
    for g in range(min(G, rows)):
        for c in range(geoms[g, 1] - 1, min(geoms[g, 2], rows)):
            row = g if c < geoms[g, 1] else c  # the bounding sphere first, then the cover spheres
            dx, dy, dz = spheres[row, 0] - spheres[g, 0], spheres[row, 1] - spheres[g, 1], \
                spheres[row, 2] - spheres[g, 2]
            offset = math.sqrt(dx * dx + dy * dy + dz * dz)
            rate = _chain_rate(joints, geoms, sphere_reach, du, ends, g, row, 0.0, offset, 1.0, joint_rate)
            v[row] = min(v[row], rate * LIPSCHITZ_SAFETY)
    for p in range(pairs.shape[0]):
        a, b = pairs[p, 0], pairs[p, 1]
        if pairs[p, 2] != SELF_PAIR or a >= rows or b >= rows:
            continue
        rate = 0.0
        for k in range(n):
            if pair_reach[p, k] > 0.0:  # a joint carrying one of the two and not the other
                rate += (joint_rate[a, k] + joint_rate[b, k]) * du[k]
        w[p] = min(w[p], rate * LIPSCHITZ_SAFETY)


_RATES_SIGNATURE = _t.Array(_t.float64, 1, "C")(F1, I1, F2, F2, F1_ANY, F1_ANY)


@compiled(_RATES_SIGNATURE)
def motion_rates(floats: np.ndarray, ints: np.ndarray, sphere_reach: np.ndarray, pair_reach: np.ndarray,
                 qa: np.ndarray, qb: np.ndarray) -> np.ndarray:
    """The rates :func:`motion_hard_pairs` advances with on ``qa -> qb``:
    ``[v (S,), w (P,)]``, per sphere row the bound (m per unit ``s``) of its centre's speed and per pair-table
    row the bound of a self pair's sphere gaps' rate (:func:`_motion_rates` lowered by
    :func:`_tighten_rates`); empty when the arguments do not fit."""
    tree, joints, spheres, geoms, pairs, obstacles = unpack(floats, ints)
    if not _rates_fit(joints, spheres, geoms, pairs, sphere_reach, pair_reach, qa, qb):
        return np.zeros(0)
    du = _joint_steps(joints, qa, qb)
    v, w = _motion_rates(joints, sphere_reach, pair_reach, spheres.shape[0], du)
    X, W, placed = workspace(joints.shape[0], spheres.shape[0], geoms.shape[0])
    _tighten_rates(tree, joints, spheres, geoms, sphere_reach, pairs, pair_reach, qa, qb, du, v, w, X, W)
    return np.concatenate((v, w))


_GEOMETRY_RATES_SIGNATURE = _t.Array(_t.float64, 1, "C")(F1, I1, F2, F1_ANY, F1_ANY, _t.float64, _t.float64,
                                                         I1)


@compiled(_GEOMETRY_RATES_SIGNATURE)
def geometry_pair_rates(floats: np.ndarray, ints: np.ndarray, sphere_reach: np.ndarray, qa: np.ndarray,
                        qb: np.ndarray, lo: float, hi: float, scene_pairs: np.ndarray) -> np.ndarray:
    """Per scene pair of ``scene_pairs`` (indices), a bound ``w`` (m per unit ``s``) of how fast the distance
    between its two *shapes* (the robot geometries, not their spheres) can change on the stretch ``s`` in
    ``[lo, hi]`` of the straight motion ``q(s) = qa + s (qb - qa)``: ``inf`` for a pair the scene's table
    lacks or when the arguments do not fit (``qa``, ``qb`` not one entry per joint, the rate table short).

    The bounds of :func:`_tighten_rates` for every point ``x`` of a geometry: within its bounding sphere
    (centre ``c``, radius ``r``), so ``rho_k(x) <= rho_k(c) + r`` and its distance from joint ``k``'s origin
    is at most ``sphere_reach[c, k] + r``; with ``C_k = sum_{j below k} R_j |u_j|`` (``R_j =
    sphere_reach[c, j] + r`` for a revolute ``j``, 1 for a prismatic one), over the stretch ``rho_k(x) <=
    (rho_k(c, lo) + rho_k(c, hi)) / 2 + r + C_k (hi - lo) / 2``. An obstacle pair: ``sum_k |u_k| bound_k``
    over the joints carrying the geometry (a prismatic one: ``|u_k|``); a self pair: the two geometries'
    bounds on the joints carrying one of them and not the other (the joints carrying both move them rigidly
    together)."""
    tree, joints, spheres, geoms, pairs, obstacles = unpack(floats, ints)
    n, G = joints.shape[0], geoms.shape[0]
    out = np.full(scene_pairs.shape[0], math.inf)
    if qa.shape[0] != n or qb.shape[0] != n or sphere_reach.shape[1] != n or sphere_reach.shape[0] < G:
        return out
    du = _joint_steps(joints, qa, qb)
    X, W, placed = workspace(n, spheres.shape[0], G)
    q_lo, q_hi = np.empty(n), np.empty(n)
    for i in range(n):
        q_lo[i] = qa[i] + lo * (qb[i] - qa[i])
        q_hi[i] = qa[i] + hi * (qb[i] - qa[i])
    ends = _end_distances(tree, joints, spheres, geoms, q_lo, q_hi, du, X, W)
    bound = np.full((G, n), -1.0)  # per geometry and joint carrying it: the rate of its points
    for g in range(G):
        r = spheres[g, 3]  # every point of the geometry: within r of its bounding centre
        _chain_rate(joints, geoms, sphere_reach, du, ends, g, g, r, r, hi - lo, bound)
    for t in range(scene_pairs.shape[0]):
        for p in range(pairs.shape[0]):
            if pairs[p, 3] != scene_pairs[t]:
                continue
            a, b = pairs[p, 0], pairs[p, 1]
            rate = 0.0
            for k in range(n):
                ka = bound[a, k] >= 0.0
                kb = pairs[p, 2] == SELF_PAIR and bound[b, k] >= 0.0
                if ka and not kb:
                    rate += bound[a, k] * du[k]
                elif kb and not ka:
                    rate += bound[b, k] * du[k]
            out[t] = rate * LIPSCHITZ_SAFETY
            break
    return out


@_inline
def _pair_radius(X, W, placed, stamp, spheres, geoms, pairs, obstacles, p, v, w, enough, tol):
    """The certified radius of pair-table row ``p`` alone at the configuration placed in ``X`` / ``W``, for a
    motion whose sphere centres move by at most ``v[s]`` and whose self pairs' sphere gaps change by at most
    ``w[p]`` per unit of its parameter: its bounding spheres' radius, or, when that one is below ``enough``,
    the larger of it and its cover spheres' (placed on first need, marked with ``stamp``; either family
    staying apart keeps the pair apart). :func:`_pair_advance` asks it of the pairs it advances."""
    a, b = pairs[p, 0], pairs[p, 1]
    if pairs[p, 2] == SELF_PAIR:
        r = _rate_radius(sphere_gap(W, a, b) - tol, w[p])
        if r >= enough:
            return r
        place_cover(X, spheres, geoms, a, W, placed, stamp)
        place_cover(X, spheres, geoms, b, W, placed, stamp)
        return max(r, _rate_radius(self_cover_gap(W, geoms, a, b) - tol, w[p]))
    r = _rate_radius(obstacle_gap(W, a, obstacles, b) - tol, v[a])
    if r >= enough:
        return r
    place_cover(X, spheres, geoms, a, W, placed, stamp)
    parts = math.inf
    for i in range(geoms[a, 1], geoms[a, 2]):
        parts = min(parts, _rate_radius(obstacle_gap(W, i, obstacles, b) - tol, v[i]))
        if parts <= r:
            break
    return max(r, parts)


#: Pairs :func:`motion_hard_pairs` re-evaluates at a point: those whose certified front lies within this
#: fraction of the side's last smallest radius (the others are certified well ahead).
PAIR_HORIZON = 0.5
#: Look-ahead of an advance: the next point from one side lies this fraction of its pair's last radius
#: beyond the pair's certified end, so that the ball there covers new ground on both of its sides (a radius
#: of at least that fraction joins it to the certified end).
LOOKAHEAD = 0.6
#: An advance asks a pair's cover spheres only when its bounding spheres' radius is below this fraction of
#: what the pair needs to be certified (and below twice the hand-over step): a radius above it is progress
#: enough, and the covers cost several sphere tests each.
COVER_FRACTION = 0.1


@_leaf
def _pair_advance(X, W, placed, stamp, spheres, geoms, pairs, obstacles, v, w, tol, min_step, live, m,
                  front, back, last, state, s, from_lo, horizon):
    """One advance of :func:`motion_hard_pairs` at ``s`` (placements in ``X`` / ``W``) over the open pairs
    ``live[:m]`` whose front (from below, ``from_lo``) or back lies within ``horizon`` of ``s`` (``s`` may
    lie beyond it: the look-ahead). A pair's radius ``r`` certifies ``[s - r, s + r]``; that ball is joined
    to ``[0, front]`` when ``s - r <= front`` and to ``[back, 1]`` when ``s + r >= back``, and otherwise not
    kept (the pair's next point from this side is then its end itself: ``last`` 0). A pair is certified
    (``state`` 1) when the two meet, hard (2) when ``r`` is below ``min_step``; its cover spheres are asked
    only when the bounding spheres' radius is below :data:`COVER_FRACTION` of what it needs (the distance
    from ``s`` to the farther certified end). ``last`` ``(2P,)``: per pair the radius of its last joined
    ball from below, then from above. Returns the smallest radius found (``inf``: none) and the number of
    new hard pairs."""
    best, hard = math.inf, 0
    P = front.shape[0]
    for t in range(m):
        p = live[t]
        if from_lo:
            if front[p] > s + horizon:
                continue
        elif back[p] < s - horizon:
            continue
        need = max(back[p] - s, s - front[p])
        enough = min(need, max(COVER_FRACTION * need, 2.0 * min_step))
        r = _pair_radius(X, W, placed, stamp, spheres, geoms, pairs, obstacles, p, v, w, enough, tol)
        if r < min_step:
            state[p] = 2
            hard += 1
            continue
        best = min(best, r)
        joins_lo, joins_hi = s - r <= front[p], s + r >= back[p]
        if joins_lo and joins_hi:
            state[p] = 1
            continue
        if joins_lo:
            front[p] = max(front[p], s + r)
        if joins_hi:
            back[p] = min(back[p], s - r)
        side = p if from_lo else P + p
        last[side] = r if (joins_lo if from_lo else joins_hi) else 0.0
    return best, hard


@_inline
def _open_end(live, m, state, front, back, last, from_lo):
    """Keep the open pairs (``state`` 0) of ``live[:m]`` at its start: ``(their count, the point to advance
    from)``: the smallest ``front + LOOKAHEAD last`` (``from_lo``; at most the pair's back) or the largest
    ``back - LOOKAHEAD last``."""
    s = math.inf if from_lo else -math.inf
    P = front.shape[0]
    k = 0
    for t in range(m):
        p = live[t]
        if state[p] == 0:
            live[k] = p
            k += 1
            if from_lo:
                s = min(s, min(front[p] + LOOKAHEAD * last[p], back[p]))
            else:
                s = max(s, max(back[p] - LOOKAHEAD * last[P + p], front[p]))
    return k, s


_HARD_SIGNATURE = _t.Array(_t.float64, 1, "C")(F1, I1, F2, F2, F1_ANY, F1_ANY, _t.float64, _t.float64,
                                             _t.int64, _t.int64)


@compiled(_HARD_SIGNATURE)
def motion_hard_pairs(floats: np.ndarray, ints: np.ndarray, sphere_reach: np.ndarray, pair_reach: np.ndarray,
                      qa: np.ndarray, qb: np.ndarray, tol: float, min_step: float, max_advances: int,
                      max_hard: int) -> np.ndarray:
    """The pairs the sphere bounds cannot certify over the straight motion ``q(s) = qa + s (qb - qa)``,
    ``s`` in ``[0, 1]``: ``[h, advances, lo, hi, pair, ...]`` with the scene indices of the ``h`` hard
    pairs (every other pair's lower bound stays above ``tol``, m, over the whole motion; the hard ones too
    on ``[0, lo)`` and ``(hi, 1]``: an exact check need only cover ``[lo, hi]``), or ``h = -1`` when more
    than ``max_hard`` pairs are hard (or the arguments do not fit: ``[-1, 0, 0, 1, ...]``). Length
    ``max_hard + 4``, -1 where unused.

    Per unit ``s``, sphere centre ``c`` moves by at most ``v[c] = sum_k sphere_reach[c, k] |u_k|``
    (:func:`~.robot_spheres.sphere_reach`, ``u = qb - qa`` on joint ``k``'s coordinate), so a sphere's gap
    to an obstacle (1-Lipschitz in its centre) falls by at most ``v[c] |ds|``; a self pair's sphere gaps by
    at most ``w[p] = sum_k pair_reach[p, k] |u_k|`` (row ``p`` of the kernel's pair table; the joints
    carrying both geometries move them rigidly together and count 0). Both are then lowered to this motion's
    own bounds, from the centres' distances to the joint axes at its two ends (:func:`_tighten_rates`;
    :func:`motion_rates` returns them). A configuration ``q(s)`` therefore certifies a pair on
    ``|s' - s| <= rho`` (:func:`_pair_radius`).

    Conservative advancement per pair, with look-ahead: pair ``p`` is certified on ``[0, front[p]]`` and
    ``[back[p], 1]``; an advance from below evaluates at ``s``, the smallest ``front[p] + LOOKAHEAD r_p``
    of the open pairs (``r_p``: the radius of the pair's last ball joined from below, 0 at first), the
    pairs whose front is within :data:`PAIR_HORIZON` of the last smallest radius of ``s``. A radius ``r``
    at ``s`` certifies ``[s - r, s + r]``; it extends ``[0, front[p]]`` to ``s + r`` when ``s - r <=
    front[p]`` (no gap), else it is dropped and the pair's next point is its front itself. Each ball thus
    counts on both of its sides, not only ahead of the front: on a pair whose radius changes slowly, a point
    gains ``(1 + LOOKAHEAD) r`` instead of ``r``. Advances from above likewise, alternately. A pair is
    certified once ``front[p] >= back[p]`` (the two intervals cover ``[0, 1]``); a pair whose radius falls
    below ``min_step`` (fraction of the motion; also when its spheres are not apart) is hard, and so is
    every pair still open after ``max_advances``. A pair far from everything is done in one or two
    evaluations; only the close ones are advanced in small steps.
    """
    tree, joints, spheres, geoms, pairs, obstacles = unpack(floats, ints)
    n, P = joints.shape[0], pairs.shape[0]
    out = np.full(max_hard + 4, -1.0)
    out[1], out[2], out[3] = 0.0, 0.0, 1.0
    if not _rates_fit(joints, spheres, geoms, pairs, sphere_reach, pair_reach, qa, qb):
        return out
    du = _joint_steps(joints, qa, qb)
    v, w = _motion_rates(joints, sphere_reach, pair_reach, spheres.shape[0], du)
    X, W, placed = workspace(n, spheres.shape[0], geoms.shape[0])
    _tighten_rates(tree, joints, spheres, geoms, sphere_reach, pairs, pair_reach, qa, qb, du, v, w, X, W)
    front, back = np.zeros(P), np.ones(P)
    state = np.zeros(P, dtype=np.int64)  # 0 open, 1 certified, 2 hard
    live = np.arange(P)
    last = np.zeros(2 * P)  # per pair, its last joined radius from below, then from above
    q = np.empty(n)
    m, hard, advances, steps = P, 0, 0, np.zeros(2)
    while hard <= max_hard:
        from_lo = advances % 2 == 0
        m, s = _open_end(live, m, state, front, back, last, from_lo)
        if m == 0:
            break
        if advances >= max_advances:  # the open pairs are hard
            hard += m
            for t in range(m):
                state[live[t]] = 2
            break
        for i in range(n):
            q[i] = qa[i] + s * (qb[i] - qa[i])
        place_bounding_spheres(tree, joints, spheres, geoms, q, X, W)
        best, new = _pair_advance(X, W, placed, advances, spheres, geoms, pairs, obstacles, v, w, tol,
                                  min_step, live, m, front, back, last, state, s, from_lo,
                                  steps[advances % 2])
        hard += new
        if best < math.inf:
            steps[advances % 2] = PAIR_HORIZON * best
        advances += 1
    out[1] = advances
    if hard > max_hard:
        return out
    out[0], lo, hi = hard, 1.0, 0.0
    k = 4
    for p in range(P):
        if state[p] == 2:
            out[k] = pairs[p, 3]
            lo, hi = min(lo, front[p]), max(hi, back[p])
            k += 1
    out[2], out[3] = (lo, hi) if hard else (1.0, 0.0)
    return out


#: The advancement (:func:`advance_on_distances`, :func:`kinserve.planners.motion.edges.advance`) gives up
#: when, at the pace of its last :data:`PACE_WINDOW` advances, the open stretch would take more than
#: :data:`PACE_MARGIN` times the advances it has left: the budget would almost always refuse the motion
#: anyway.
PACE_WINDOW = 4
PACE_MARGIN = 2.0
#: The advancement's answers: certified, refused, and (:func:`advance_on_distances`) a pair it cannot measure
#: (the caller's exact check decides then); :func:`advance_ask`'s "ask the radius at ``state[ASKED]``".
CERTIFIED, REFUSED, NOT_MEASURED, ASK = 1, 0, -1, 2
#: The advancement's state, a float array of :data:`ADVANCE_STATE`: the certified ends ``lo``, ``hi``, the
#: radii of the last balls that moved them, the number of advances made, the point asked, then the open
#: stretch ``hi - lo`` before each of the last ``PACE_WINDOW + 1`` advances (a ring).
LO, HI, RADIUS_LO, RADIUS_HI, MADE, ASKED, OPENED = 0, 1, 2, 3, 4, 5, 6
ADVANCE_STATE = OPENED + PACE_WINDOW + 1

_STATE = _t.Array(_t.float64, 1, "C")


@_inline
def _begin(state, lo, hi, last_lo, last_hi):
    """The state of an advancement certified on ``[0, lo]`` and ``[hi, 1]``, the last balls' radii
    ``last_lo`` / ``last_hi``."""
    state[LO], state[HI], state[RADIUS_LO], state[RADIUS_HI], state[MADE], state[ASKED] = \
        lo, hi, last_lo, last_hi, 0.0, math.nan
    state[OPENED] = hi - lo


@_inline
def _ask(state, max_advances):
    """The next step of the advancement (:func:`kinserve.planners.motion.edges.advance`'s rules):
    :data:`CERTIFIED` when the ends have met, :data:`REFUSED` when ``max_advances`` are made or the pace rule
    gives up, else :data:`ASK` with the point to ask in ``state[ASKED]``: from below on even advances
    (``lo + LOOKAHEAD r_lo``, at most ``hi``), from above on odd ones."""
    lo, hi, k = state[LO], state[HI], int(state[MADE])
    if lo >= hi:
        return CERTIFIED
    if k >= max_advances:
        return REFUSED
    if k >= PACE_WINDOW:
        closed = state[OPENED + (k - PACE_WINDOW) % (PACE_WINDOW + 1)] - (hi - lo)
        if (hi - lo) * PACE_WINDOW > PACE_MARGIN * closed * (max_advances - k):
            return REFUSED
    if k % 2 == 0:
        state[ASKED] = min(lo + LOOKAHEAD * state[RADIUS_LO], hi)
    else:
        state[ASKED] = max(hi - LOOKAHEAD * state[RADIUS_HI], lo)
    return ASK


@_inline
def _answer(state, r):
    """Take the radius ``r`` of the ball at ``state[ASKED]``: :data:`REFUSED` when ``r < 0`` (or NaN); else
    the ball moves ``lo`` when it reaches back to it (to ``s + r``) and ``hi`` likewise, and :data:`ASK`."""
    if not r >= 0.0:
        return REFUSED
    s, lo, hi, k = state[ASKED], state[LO], state[HI], int(state[MADE])
    joins_lo, joins_hi = s - r <= lo, s + r >= hi
    if joins_lo:
        lo = max(lo, s + r)
    if joins_hi:
        hi = min(hi, s - r)
    if k % 2 == 0:
        state[RADIUS_LO] = r if joins_lo else 0.0
    else:
        state[RADIUS_HI] = r if joins_hi else 0.0
    state[LO], state[HI], state[MADE] = lo, hi, k + 1
    state[OPENED + (k + 1) % (PACE_WINDOW + 1)] = hi - lo
    return ASK


@compiled(_t.void(_STATE, _t.float64, _t.float64, _t.float64, _t.float64))
def advance_begin(state: np.ndarray, lo: float, hi: float, last_lo: float, last_hi: float) -> None:
    """Start an advancement in ``state`` (:data:`ADVANCE_STATE` floats): certified on ``[0, lo]`` and
    ``[hi, 1]``, the last balls' radii ``last_lo`` / ``last_hi``."""
    _begin(state, lo, hi, last_lo, last_hi)


@compiled(_t.int64(_STATE, _t.int64))
def advance_ask(state: np.ndarray, max_advances: int) -> int:
    """:data:`CERTIFIED`, :data:`REFUSED`, or :data:`ASK` for the radius at ``state[ASKED]`` (the rules of
    :func:`kinserve.planners.motion.edges.advance`)."""
    return _ask(state, max_advances)


@compiled(_t.int64(_STATE, _t.float64))
def advance_answer(state: np.ndarray, r: float) -> int:
    """Take the radius ``r`` at ``state[ASKED]``: :data:`REFUSED` when it is negative, else :data:`ASK`."""
    return _answer(state, r)


_ADVANCE_SIGNATURE = _t.int64(F1, I1, F2, I2, F1, I1, F1_ANY, F1_ANY, F1, F1, F1, _t.float64, _t.float64,
                              _t.int64, _t.Array(_t.int64, 1, "C"))


@_inline
def _distance_radius(tree, joints, pairs, obstacles, points, hull_geoms, radius, rows, need, inverse, offset,
                     q, X, S, T, guesses, counts):
    """The certified radius ``min_j (d_j - TOLERANCE) inverse[j] + offset[j]`` at ``q`` of the pairs
    ``rows`` (the shapes' distance lower bounds ``d_j``, m), or -1 when one is below ``need[j]``
    (``guesses[j]``: pair ``j``'s GJK start, :func:`~.convex_distance.core_distance_bound`)."""
    tree_placements(tree, joints, q, X)
    rho = math.inf
    for j in range(rows.shape[0]):
        d, _ = pair_distance_bounds(points, hull_geoms, radius, pairs, obstacles, rows[j], X, S, T,
                                    guesses[j], math.inf, -math.inf)
        counts[1] += 1
        if not d >= need[j]:  # (NaN: refused)
            return -1.0
        r = (d - TOLERANCE) * inverse[j] + offset[j]
        if r < rho:
            rho = r
    return rho


@compiled(_ADVANCE_SIGNATURE)
def advance_on_distances(floats: np.ndarray, ints: np.ndarray, points: np.ndarray, hull_geoms: np.ndarray,
                         radius: np.ndarray, rows: np.ndarray, qa: np.ndarray, u: np.ndarray,
                         need: np.ndarray, inverse: np.ndarray, offset: np.ndarray, lo: float, hi: float,
                         max_advances: int, counts: np.ndarray) -> int:
    """Conservative advancement of ``qa + s u`` on ``[lo, hi]`` (``[0, lo)`` and ``(hi, 1]`` certified
    already) on the distances of the pairs at rows ``rows`` of the scene's pair table (``floats, ints``: its
    packed pre-check; ``points, hull_geoms, radius``: the robot's
    :class:`~.hull_table.HullTable`): per pair ``j`` the rates of the motion as ``need[j]`` (m, the
    distance it must keep), ``inverse[j]`` and ``offset[j]`` (:class:`~kinserve.planners.motion.clearance.
    PairRates`). :data:`CERTIFIED` when every pair stays apart over the stretch, :data:`REFUSED` when a
    point asked is too close or the ``max_advances`` advances (or the pace rule) run out, the algorithm and
    the decisions of :func:`kinserve.planners.motion.edges.advance` on the radii a coal step would give
    with these distances; :data:`NOT_MEASURED` (nothing asked) when a pair joins a shape
    :mod:`.convex_distance` does not measure. ``counts`` += (advances, pair distances). The steps are
    :func:`advance_ask` / :func:`advance_answer`'s."""
    tree, joints, spheres, geoms, pairs, obstacles = unpack(floats, ints)
    n = joints.shape[0]
    if qa.shape[0] != n or u.shape[0] != n or hull_geoms.shape[0] < geoms.shape[0] \
            or need.shape[0] < rows.shape[0] or inverse.shape[0] < rows.shape[0] \
            or offset.shape[0] < rows.shape[0] or counts.shape[0] < 2:
        return NOT_MEASURED
    for j in range(rows.shape[0]):
        p = rows[j]
        if p < 0 or p >= pairs.shape[0] or not pair_measured(hull_geoms, pairs, obstacles, p):
            return NOT_MEASURED
    X = np.empty((n + 1, 12))
    S, T = np.empty((4, 3)), np.empty((7, 3))
    q = np.empty(n)
    guesses = np.zeros((2, rows.shape[0], 3))  # per side, each pair's last closest point of A - B
    state = np.empty(ADVANCE_STATE)
    _begin(state, lo, hi, 0.0, 0.0)
    while True:
        step = _ask(state, max_advances)
        if step != ASK:
            return step
        s = state[ASKED]
        for c in range(n):
            q[c] = qa[c] + s * u[c]
        counts[0] += 1
        side = int(state[MADE]) % 2
        r = _distance_radius(tree, joints, pairs, obstacles, points, hull_geoms, radius, rows, need, inverse,
                             offset, q, X, S, T, guesses[side], counts)
        if _answer(state, r) == REFUSED:
            return REFUSED


__all__ = ["ADVANCE_STATE", "ASK", "ASKED", "CERTIFIED", "COVER_FRACTION", "HI", "LO", "LOOKAHEAD", "MADE",
           "NOT_MEASURED", "OPENED", "PACE_MARGIN", "PACE_WINDOW", "PAIR_HORIZON", "RADIUS_HI", "RADIUS_LO",
           "REFUSED", "advance_answer", "advance_ask", "advance_begin", "advance_on_distances",
           "geometry_pair_rates", "motion_hard_pairs", "motion_rates"]
