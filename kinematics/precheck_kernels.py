"""The compiled sphere pre-check of the collision scenes (Numba): certified free, certainly colliding.

A configuration is **certified collision free** when a lower bound of the
distance of every checked pair of a :class:`~.collision_scene.CollisionScene`
exceeds :data:`TOLERANCE`; coal then need not run on it. The bounds come from
spheres fixed in the joint frames that *contain* each robot geometry
(:mod:`.robot_spheres`), so a certified configuration is always one coal finds
free; a configuration that is not certified may still be free (coal decides).

**Lower bounds** for a sphere of centre ``c``, radius ``rho``:

* against a sphere of the robot (``c'``, ``rho'``): ``|c - c'| - rho - rho'``;
* against an obstacle, with ``p = R^T (c - t)`` the centre in the obstacle's
  frame (exact point distances minus ``rho``; rows of :mod:`.obstacle_table`):
  sphere of radius ``r`` ``|p| - r - rho``; box of half extents ``h``
  ``|max(|p| - h, 0)| - rho``; capsule (segment ``z`` in ``[-L, L]``)
  ``|p - (0, 0, clip(p_z, -L, L))| - r - rho``; cylinder
  ``|(max(sqrt(p_x^2 + p_y^2) - r, 0), max(|p_z| - L, 0))| - rho``; any other
  shape: its AABB sphere, as a sphere.

Each geometry's bounding sphere is tested first; its cover spheres only when
the bounding spheres of a pair are not apart.

**Certain collisions** (the other verdict, for configurations not certified):
when a ball inside a robot geometry (its inner points with their radii,
:mod:`.inner_balls`) reaches deeper than :data:`TOLERANCE` into an obstacle whose
exact distance the table has, or two inner balls of the geometries of a checked
self pair overlap by more than :data:`TOLERANCE`, the two shapes share that
region and coal would report the collision: :func:`certainly_colliding` answers
without it. :func:`classify_configuration` gives both verdicts (or "undecided")
on one forward kinematics; :func:`uncertified_pairs` lists the pairs the spheres
do not certify, the only ones an exact check of an undecided configuration needs.

**The kernels** (:func:`certify_configuration` for one configuration,
:func:`first_uncertified` and :func:`certify_configurations` over a batch in
one call) run the forward kinematics of the whole tree
(:func:`tree_placements`; joint ``j``'s world placement
``oMj = oM(parent) * Mj * exp(a_j q_j)``, as :mod:`kinserve.ik.lm.kernel`),
move the bounding spheres to the world (``c_world = oMj * c``; joint 0 is the
world) - a geometry's cover spheres only when one of its pairs needs them -
and test the scene's pairs, obstacle pairs first (a configuration in
collision usually hits an obstacle), stopping at the first pair they cannot
certify. Their arguments are two flat arrays (:func:`~.precheck_packing.pack`;
a compiled call pays per array argument), the robot half packed once per
layout, the obstacle rows (:mod:`.obstacle_table`, made with each shape) appended per scene. Each call
allocates its own workspace: one kernel may run on many threads at once.
The tree's forward kinematics is :mod:`.kernel_primitives`' (inlined); the cache
key covers every kernel file (:mod:`.kernel_cache`). Every kernel has its
signature: importing this module compiles them, or loads them from that cache,
so no call compiles anything.

Units: metres and radians.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .kernel_cache import B1, F1, F1_ANY, F2, F2_ANY, I1, I2, compiled, inline, jit
from .kernel_primitives import tree_placements_into
from .obstacle_table import BALL, BOX, CAPSULE, CYLINDER, EXACT, KIND, OBSTACLE_COLUMNS
from .precheck_verdicts import COLLIDING, FREE, UNDECIDED
from .serial_chain import REVOLUTE as _REVOLUTE

#: A pair is certified free when its distance lower bound exceeds this (m): ten times coal's GJK tolerance, so
#: that coal's contact test, whose distances are exact to about 1e-6 m on these shapes, agrees.
TOLERANCE = 1e-5

#: Pair kinds of the pair table (column 2).
SELF_PAIR, OBSTACLE_PAIR = 0, 1

_jit, _inline = jit, inline  # (kernel_cache's: one cache key over every kernel source)
_t = numba.types
_ONE_SIGNATURE = _t.boolean(F1, I1, F1_ANY, _t.float64)
_BATCH_SIGNATURE = _t.Array(_t.boolean, 1, "C")(F1, I1, F2_ANY, _t.float64)
_FIRST_SIGNATURE = _t.int64(F1, I1, F2_ANY, _t.int64, _t.float64)
_BOUNDS_SIGNATURE = _t.Array(_t.float64, 1, "C")(F1, I1, F1_ANY)


_TREE_SIGNATURE = _t.void(F2, I2, F1_ANY, _t.float64[:, ::1])


@compiled(_TREE_SIGNATURE)
def tree_placements(tree: np.ndarray, joints: np.ndarray, q: np.ndarray, X: np.ndarray) -> None:
    """World placements of every joint into ``X`` ``(J + 1, 12)``: row ``j`` = Pinocchio joint ``j``'s
    rotation (row-major) and translation, row 0 the universe (identity).
    ``oMj = oM(parent) * Mj * exp(a_j q_j)`` (:func:`.kernel_primitives.tree_placements_into`)."""
    tree_placements_into(tree, joints, q, X)


@_inline
def _unpack(floats, ints):
    """``(tree, joints, spheres, geoms, pairs, obstacles)``: views of the packed arrays
    (:func:`~.precheck_packing.pack`)."""
    J, S, G, P, O = ints[0], ints[1], ints[2], ints[3], ints[4]  # noqa: E741 - the packing's names
    tree = floats[:15 * J].reshape((J, 15))
    spheres = floats[16 * J:16 * J + 4 * S].reshape((S, 4))
    obstacles = floats[16 * J + 4 * S:16 * J + 4 * S + 16 * O].reshape((O, 16))
    joints = ints[5:5 + 3 * J].reshape((J, 3))
    geoms = ints[5 + 3 * J:5 + 3 * J + 5 * G].reshape((G, 5))
    pairs = ints[5 + 3 * J + 5 * G:5 + 3 * J + 5 * G + 4 * P].reshape((P, 4))
    return tree, joints, spheres, geoms, pairs, obstacles


@_inline
def _reach(floats, ints):
    """The packed :attr:`~.robot_spheres.RobotSpheres.reach` ``(J,)`` (:func:`~.precheck_packing.pack`; a
    view): only :func:`first_uncertified` reads it."""
    J = ints[0]
    return floats[15 * J:16 * J]


@_inline
def _workspace(n, S, G):
    """One allocation per call: joint placements ``X`` ``(n + 1, 12)``, world spheres ``W`` ``(S, 4)`` and the
    per-geometry stamps ``placed`` ``(G,)`` (-1: cover not placed yet)."""
    buffer = np.empty(12 * (n + 1) + 4 * S + G)
    X = buffer[:12 * (n + 1)].reshape((n + 1, 12))
    W = buffer[12 * (n + 1):12 * (n + 1) + 4 * S].reshape((S, 4))
    placed = buffer[12 * (n + 1) + 4 * S:]
    placed[:] = -1.0
    return X, W, placed


@_inline
def _place(X, j, spheres, s, W):
    """``W[s]`` = (world centre, radius) of sphere ``s``, fixed in joint ``j`` (placements ``X``)."""
    c0, c1, c2 = spheres[s, 0], spheres[s, 1], spheres[s, 2]
    for i in range(3):
        W[s, i] = X[j, 9 + i] + X[j, 3 * i] * c0 + X[j, 3 * i + 1] * c1 + X[j, 3 * i + 2] * c2
    W[s, 3] = spheres[s, 3]


@_inline
def _place_cover(X, spheres, geoms, g, W, placed, stamp):
    """The cover spheres of geometry ``g`` into ``W``, unless already placed for this configuration
    (``stamp``)."""
    if placed[g] != stamp:
        j = geoms[g, 0]
        for s in range(geoms[g, 1], geoms[g, 2]):
            _place(X, j, spheres, s, W)
        placed[g] = stamp


@_inline
def _slack(d2, need, m):
    """The margin ``m`` (m) after a test that passes when ``d2 > need^2`` (``d2``: a squared distance, m^2):
    ``min(m, sqrt(d2) - need)`` (at least 0) when it passes, -1.0 when it fails (also on NaN). The square
    root is taken only when the slack is below ``m``."""
    reach = need + m
    if d2 > reach * reach:
        return m
    if d2 > need * need:
        return max(math.sqrt(d2) - need, 0.0)
    return -1.0


@_inline
def _sphere_slack(W, i, j, tol, m):
    """:func:`_slack` of spheres ``i`` and ``j`` of ``W`` being farther apart than ``tol`` (m)."""
    dx, dy, dz = W[i, 0] - W[j, 0], W[i, 1] - W[j, 1], W[i, 2] - W[j, 2]
    return _slack(dx * dx + dy * dy + dz * dz, W[i, 3] + W[j, 3] + tol, m)


@_inline
def _obstacle_slack(W, i, obstacles, o, tol, m):
    """:func:`_slack` of sphere ``i`` of ``W`` being farther than ``tol`` (m) from obstacle ``o`` (module
    docstring: the squared distance of the centre to the obstacle's core against the sphere's radius plus
    ``tol`` plus the core's radius)."""
    dx, dy, dz = W[i, 0] - obstacles[o, 9], W[i, 1] - obstacles[o, 10], W[i, 2] - obstacles[o, 11]
    kind = obstacles[o, KIND]
    need = W[i, 3] + tol
    if kind == BALL:
        return _slack(dx * dx + dy * dy + dz * dz, need + obstacles[o, 13], m)
    # the centre in the obstacle's frame: p = R^T (c - t)
    px = obstacles[o, 0] * dx + obstacles[o, 3] * dy + obstacles[o, 6] * dz
    py = obstacles[o, 1] * dx + obstacles[o, 4] * dy + obstacles[o, 7] * dz
    pz = obstacles[o, 2] * dx + obstacles[o, 5] * dy + obstacles[o, 8] * dz
    if kind == BOX:
        ex = max(abs(px) - obstacles[o, 13], 0.0)
        ey = max(abs(py) - obstacles[o, 14], 0.0)
        ez = max(abs(pz) - obstacles[o, 15], 0.0)
        return _slack(ex * ex + ey * ey + ez * ez, need, m)
    if kind == CAPSULE:
        half = obstacles[o, 14]
        ez = pz - min(max(pz, -half), half)
        return _slack(px * px + py * py + ez * ez, need + obstacles[o, 13], m)
    # cylinder
    er = max(math.sqrt(px * px + py * py) - obstacles[o, 13], 0.0)
    ez = max(abs(pz) - obstacles[o, 14], 0.0)
    return _slack(er * er + ez * ez, need, m)


#: Factor on the displacement bound of :func:`first_uncertified` (rounding of the bound and of the margin).
LIPSCHITZ_SAFETY = 1.0 + 1e-9


#: The largest margin (m) :func:`_configuration_margin` reports: tests farther apart than this need no
#: square root.
MARGIN_CAP = 1.0


@_jit
def _configuration_margin(tree, joints, spheres, geoms, pairs, obstacles, q, tol, X, W, placed, stamp):
    """The certificate of ``q``: -1.0 when some pair's lower bound does not exceed ``tol``, else the margin
    ``m >= 0`` (m, at most :data:`MARGIN_CAP`): the smallest slack of the sphere tests that certified the
    pairs - every sphere may move by up to ``m / 2`` and those tests still pass (:func:`first_uncertified`).
    Forward kinematics into ``X``, the bounding spheres into ``W``, then per pair the bounding spheres and,
    when they are not apart, the cover spheres (placed on first need, marked with ``stamp`` in ``placed``)."""
    tree_placements(tree, joints, q, X)
    for g in range(geoms.shape[0]):
        _place(X, geoms[g, 0], spheres, g, W)
    m = MARGIN_CAP
    for p in range(pairs.shape[0]):
        a, b = pairs[p, 0], pairs[p, 1]
        if pairs[p, 2] == SELF_PAIR:
            r = _sphere_slack(W, a, b, tol, m)
            if r >= 0.0:
                m = r
                continue
            _place_cover(X, spheres, geoms, a, W, placed, stamp)
            _place_cover(X, spheres, geoms, b, W, placed, stamp)
            for i in range(geoms[a, 1], geoms[a, 2]):
                r = _sphere_slack(W, i, b, tol, m)
                if r >= 0.0:
                    m = r
                    continue
                for j in range(geoms[b, 1], geoms[b, 2]):
                    m = _sphere_slack(W, i, j, tol, m)
                    if m < 0.0:
                        return -1.0
        else:
            r = _obstacle_slack(W, a, obstacles, b, tol, m)
            if r >= 0.0:
                m = r
                continue
            _place_cover(X, spheres, geoms, a, W, placed, stamp)
            for i in range(geoms[a, 1], geoms[a, 2]):
                m = _obstacle_slack(W, i, obstacles, b, tol, m)
                if m < 0.0:
                    return -1.0
    return m


@compiled(_ONE_SIGNATURE)
def certify_configuration(floats: np.ndarray, ints: np.ndarray, q: np.ndarray, tol: float) -> bool:
    """True when configuration ``q`` is certified collision free (every pair's lower bound > ``tol``, m);
    False when it is not, or when ``q`` has not one entry per joint. ``floats, ints``:
    :func:`~.precheck_packing.pack`."""
    tree, joints, spheres, geoms, pairs, obstacles = _unpack(floats, ints)
    n = joints.shape[0]
    if q.shape[0] != n:
        return False
    X, W, placed = _workspace(n, spheres.shape[0], geoms.shape[0])
    margin = _configuration_margin(tree, joints, spheres, geoms, pairs, obstacles, q, tol, X, W, placed, 0)
    return margin >= 0.0


@compiled(_BATCH_SIGNATURE)
def certify_configurations(floats: np.ndarray, ints: np.ndarray, qs: np.ndarray, tol: float) -> np.ndarray:
    """:func:`certify_configuration` of every row of ``qs`` ``(N, nq)``: a boolean array ``(N,)``."""
    tree, joints, spheres, geoms, pairs, obstacles = _unpack(floats, ints)
    n = joints.shape[0]
    N = qs.shape[0]
    out = np.zeros(N, dtype=np.bool_)
    if qs.shape[1] != n:
        return out
    X, W, placed = _workspace(n, spheres.shape[0], geoms.shape[0])
    for k in range(N):
        out[k] = _configuration_margin(tree, joints, spheres, geoms, pairs, obstacles, qs[k], tol, X, W,
                                      placed, k) >= 0.0
    return out


@compiled(_FIRST_SIGNATURE)
def first_uncertified(floats: np.ndarray, ints: np.ndarray, qs: np.ndarray, start: int, tol: float) -> int:
    """Index of the first row of ``qs`` ``(N, nq)`` from ``start`` on that is not certified, ``N`` when every
    one is (``start`` when the rows have not one entry per joint).

    A row is certified by :func:`_configuration_margin` or, without forward kinematics, by the last row so
    certified (``q_ref``, margin ``m``) when ``2 sum_k R_k |q_k - q_ref,k| < m`` (``R``: the packed
    :attr:`~.robot_spheres.RobotSpheres.reach`): no sphere centre has moved by half the margin, so every test
    that certified ``q_ref`` still passes (the distance between two spheres, or from a sphere's centre to an
    obstacle, changes by at most the sum of the two displacements): the iterates of a converging solve lie
    close together.
    """
    tree, joints, spheres, geoms, pairs, obstacles = _unpack(floats, ints)
    n = joints.shape[0]
    N = qs.shape[0]
    if qs.shape[1] != n:
        return max(start, 0)
    reach = _reach(floats, ints)
    X, W, placed = _workspace(n, spheres.shape[0], geoms.shape[0])
    ref, m = -1, 0.0
    for k in range(max(start, 0), N):
        if ref >= 0:
            moved = 0.0
            for j in range(n):
                c = joints[j, 1]
                moved += reach[j] * abs(qs[k, c] - qs[ref, c])
            if 2.0 * moved * LIPSCHITZ_SAFETY < m:  # NaN: not skipped
                continue
        m = _configuration_margin(tree, joints, spheres, geoms, pairs, obstacles, qs[k], tol, X, W, placed, k)
        if m < 0.0:
            return k
        ref = k
    return N


@_inline
def _gap(W, i, j):
    """``|c_i - c_j| - r_i - r_j`` (m): a lower bound of the distance between what spheres ``i`` and ``j``
    hold."""
    dx, dy, dz = W[i, 0] - W[j, 0], W[i, 1] - W[j, 1], W[i, 2] - W[j, 2]
    return math.sqrt(dx * dx + dy * dy + dz * dz) - W[i, 3] - W[j, 3]


@_inline
def _obstacle_gap(W, i, obstacles, o):
    """The exact distance (m) from sphere ``i``'s centre to obstacle ``o`` (a BALL: to its sphere), minus the
    sphere's radius: a lower bound of the distance between what the sphere holds and the obstacle."""
    dx, dy, dz = W[i, 0] - obstacles[o, 9], W[i, 1] - obstacles[o, 10], W[i, 2] - obstacles[o, 11]
    kind = obstacles[o, KIND]
    if kind == BALL:
        return math.sqrt(dx * dx + dy * dy + dz * dz) - obstacles[o, 13] - W[i, 3]
    px = obstacles[o, 0] * dx + obstacles[o, 3] * dy + obstacles[o, 6] * dz
    py = obstacles[o, 1] * dx + obstacles[o, 4] * dy + obstacles[o, 7] * dz
    pz = obstacles[o, 2] * dx + obstacles[o, 5] * dy + obstacles[o, 8] * dz
    if kind == BOX:
        qx, qy, qz = abs(px) - obstacles[o, 13], abs(py) - obstacles[o, 14], abs(pz) - obstacles[o, 15]
        ex, ey, ez = max(qx, 0.0), max(qy, 0.0), max(qz, 0.0)
        return math.sqrt(ex * ex + ey * ey + ez * ez) + min(max(qx, qy, qz), 0.0) - W[i, 3]
    if kind == CAPSULE:
        half = obstacles[o, 14]
        ez = pz - min(max(pz, -half), half)
        return math.sqrt(px * px + py * py + ez * ez) - obstacles[o, 13] - W[i, 3]
    qr, qz = math.sqrt(px * px + py * py) - obstacles[o, 13], abs(pz) - obstacles[o, 14]
    er, ez = max(qr, 0.0), max(qz, 0.0)
    return math.sqrt(er * er + ez * ez) + min(max(qr, qz), 0.0) - W[i, 3]


@_inline
def _self_cover_gap(W, geoms, a, b):
    """``min_i max(gap(i, B_b), min_j gap(i, j))`` over the cover spheres ``i`` of geometry ``a`` and ``j`` of
    ``b`` (``B_b``: ``b``'s bounding sphere; placed in ``W``): a lower bound (m) of the distance between the
    two geometries."""
    parts = math.inf
    for i in range(geoms[a, 1], geoms[a, 2]):
        inner = math.inf
        for j in range(geoms[b, 1], geoms[b, 2]):
            inner = min(inner, _gap(W, i, j))
        parts = min(parts, max(_gap(W, i, b), inner))
    return parts


@compiled(_BOUNDS_SIGNATURE)
def pair_lower_bounds(floats: np.ndarray, ints: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Per pair of the scene (in the scene's order), the lower bound (m) of its distance at ``q`` that the
    certification tests against the tolerance: with ``B`` the bounding spheres, ``i``, ``j`` the cover
    spheres of the two geometries,

        self pair:      max(gap(B_a, B_b), min_i max(gap(i, B_b), min_j gap(i, j)))
        obstacle pair:  max(gap(B_a, O), min_i gap(i, O))

    (``gap``: centre distance minus radii; for an obstacle, the exact point distance minus the radius).
    :func:`certify_configuration` certifies ``q`` exactly when every entry exceeds its tolerance (it compares
    squares instead); this form is for tests and diagnostics.
    """
    tree, joints, spheres, geoms, pairs, obstacles = _unpack(floats, ints)
    n = joints.shape[0]
    X = np.empty((n + 1, 12))
    W = np.empty((spheres.shape[0], 4))
    tree_placements(tree, joints, q, X)
    for g in range(geoms.shape[0]):
        _place(X, geoms[g, 0], spheres, g, W)
        for s in range(geoms[g, 1], geoms[g, 2]):
            _place(X, geoms[g, 0], spheres, s, W)
    out = np.empty(pairs.shape[0])
    for p in range(pairs.shape[0]):
        a, b = pairs[p, 0], pairs[p, 1]
        if pairs[p, 2] == SELF_PAIR:
            out[pairs[p, 3]] = max(_gap(W, a, b), _self_cover_gap(W, geoms, a, b))
        else:
            parts = math.inf
            for i in range(geoms[a, 1], geoms[a, 2]):
                parts = min(parts, _obstacle_gap(W, i, obstacles, b))
            out[pairs[p, 3]] = max(_obstacle_gap(W, a, obstacles, b), parts)
    return out


@_inline
def _place_inner(X, spheres, geoms, W):
    """Every geometry's inner balls (centre in the world, radius) into their rows of ``W``."""
    for g in range(geoms.shape[0]):
        j = geoms[g, 0]
        for i in range(geoms[g, 3], geoms[g, 4]):
            _place(X, j, spheres, i, W)


@_jit
def _certain_hit(X, W, spheres, geoms, pairs, obstacles, tol):
    """True when a checked pair intersects for certain at the joint placements ``X``: an inner ball of a robot
    geometry reaches deeper than ``tol`` (m) into an obstacle whose exact distance the table has, or two
    inner balls of the geometries of a self pair overlap by more than ``tol`` (a ball inside each shape:
    the shapes share their overlap). Inner balls of radius 0 are points."""
    _place_inner(X, spheres, geoms, W)
    for p in range(pairs.shape[0]):
        a, b = pairs[p, 0], pairs[p, 1]
        if pairs[p, 2] == OBSTACLE_PAIR:
            if obstacles[b, KIND] == BALL and obstacles[b, EXACT] != 1.0:
                continue
            for i in range(geoms[a, 3], geoms[a, 4]):
                if _obstacle_gap(W, i, obstacles, b) < -tol:
                    return True
        else:
            for i in range(geoms[a, 3], geoms[a, 4]):
                for j in range(geoms[b, 3], geoms[b, 4]):
                    if _gap(W, i, j) < -tol:
                        return True
    return False


@compiled(_ONE_SIGNATURE)
def certainly_colliding(floats: np.ndarray, ints: np.ndarray, q: np.ndarray, tol: float) -> bool:
    """True when configuration ``q`` is in collision for certain (:func:`_certain_hit`: an inner ball of a
    robot geometry, :func:`~.sphere_cover.geometry_inner_points` with the radii packed beside them, deeper
    than ``tol`` (m) inside an obstacle of a checked pair whose exact signed distance the kernel has - every
    kind but a BALL that stands for another shape - or two inner balls of a checked self pair overlapping by
    more than ``tol``). Then the two shapes share that region: coal finds them in collision. False says
    nothing (coal decides), also when ``q`` has not one entry per joint. ``floats, ints``:
    :func:`~.precheck_packing.pack`."""
    tree, joints, spheres, geoms, pairs, obstacles = _unpack(floats, ints)
    n = joints.shape[0]
    if q.shape[0] != n:
        return False
    X, W, placed = _workspace(n, spheres.shape[0], geoms.shape[0])
    tree_placements(tree, joints, q, X)
    return _certain_hit(X, W, spheres, geoms, pairs, obstacles, tol)


_CLASSIFY_SIGNATURE = _t.int64(F1, I1, F1_ANY, _t.float64)


@compiled(_CLASSIFY_SIGNATURE)
def classify_configuration(floats: np.ndarray, ints: np.ndarray, q: np.ndarray, tol: float) -> int:
    """:data:`FREE` when :func:`certify_configuration` certifies ``q``, else :data:`COLLIDING` when
    :func:`certainly_colliding` finds it in collision, else :data:`UNDECIDED` (also when ``q`` has not one
    entry per joint): both tests on one forward kinematics, in one call. ``tol`` (m)."""
    tree, joints, spheres, geoms, pairs, obstacles = _unpack(floats, ints)
    n = joints.shape[0]
    if q.shape[0] != n:
        return UNDECIDED
    X, W, placed = _workspace(n, spheres.shape[0], geoms.shape[0])
    if _configuration_margin(tree, joints, spheres, geoms, pairs, obstacles, q, tol, X, W, placed, 0) >= 0.0:
        return FREE
    if _certain_hit(X, W, spheres, geoms, pairs, obstacles, tol):
        return COLLIDING
    return UNDECIDED


@_inline
def _pair_certified(X, W, spheres, geoms, pairs, obstacles, p, tol, placed, stamp):
    """Whether pair-table row ``p``'s lower bound exceeds ``tol`` (m) at the placements ``X`` (bounding
    spheres in ``W``): the tests of :func:`_configuration_margin` on this pair alone."""
    a, b = pairs[p, 0], pairs[p, 1]
    if pairs[p, 2] == SELF_PAIR:
        if _sphere_slack(W, a, b, tol, MARGIN_CAP) >= 0.0:
            return True
        _place_cover(X, spheres, geoms, a, W, placed, stamp)
        _place_cover(X, spheres, geoms, b, W, placed, stamp)
        for i in range(geoms[a, 1], geoms[a, 2]):
            if _sphere_slack(W, i, b, tol, MARGIN_CAP) >= 0.0:
                continue
            for j in range(geoms[b, 1], geoms[b, 2]):
                if _sphere_slack(W, i, j, tol, MARGIN_CAP) < 0.0:
                    return False
        return True
    if _obstacle_slack(W, a, obstacles, b, tol, MARGIN_CAP) >= 0.0:
        return True
    _place_cover(X, spheres, geoms, a, W, placed, stamp)
    for i in range(geoms[a, 1], geoms[a, 2]):
        if _obstacle_slack(W, i, obstacles, b, tol, MARGIN_CAP) < 0.0:
            return False
    return True


_PAIRS_SIGNATURE = _t.Array(_t.int64, 1, "C")(F1, I1, F1_ANY, _t.float64)


@compiled(_PAIRS_SIGNATURE)
def uncertified_pairs(floats: np.ndarray, ints: np.ndarray, q: np.ndarray, tol: float) -> np.ndarray:
    """The scene indices of the pairs whose lower bound at ``q`` does not exceed ``tol`` (m), in the pair
    table's order (obstacle pairs first): every other pair is certified free (:func:`certify_configuration`'s
    tests, pair by pair), so an exact check of these pairs alone decides ``q``. Every pair when ``q`` has not
    one entry per joint."""
    tree, joints, spheres, geoms, pairs, obstacles = _unpack(floats, ints)
    n, P = joints.shape[0], pairs.shape[0]
    out = np.empty(P, dtype=np.int64)
    if q.shape[0] != n:
        out[:] = pairs[:, 3]
        return out
    X, W, placed = _workspace(n, spheres.shape[0], geoms.shape[0])
    tree_placements(tree, joints, q, X)
    for g in range(geoms.shape[0]):
        _place(X, geoms[g, 0], spheres, g, W)
    k = 0
    for p in range(P):
        if not _pair_certified(X, W, spheres, geoms, pairs, obstacles, p, tol, placed, 0):
            out[k] = pairs[p, 3]
            k += 1
    return out[:k].copy()


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
def _motion_rates(joints, sphere_reach, pair_reach, S, qa, qb):
    """``(v, w)`` of the straight motion ``qa -> qb`` (``u = qb - qa``): per sphere row ``c``,
    ``v[c] = sum_k sphere_reach[c, k] |u_k|`` (m per unit of the motion's parameter; ``(S,)``, 0 beyond the
    table's rows), and per pair-table row ``p``, ``w[p] = sum_k pair_reach[p, k] |u_k|``."""
    n = joints.shape[0]
    du = np.empty(n)
    for k in range(n):
        du[k] = abs(qb[joints[k, 1]] - qa[joints[k, 1]])
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
            _place(X, geoms[g, 0], spheres, g, W)
            _axis_distances(X, tree, joints, W, geoms, g, du, ends[g])
    return ends


@_inline
def _tighten_rates(tree, joints, spheres, geoms, sphere_reach, pairs, pair_reach, qa, qb, v, w, X, W):
    """Lower the rates ``v`` (sphere rows) and ``w`` (self pairs) of :func:`_motion_rates` to bounds of this
    motion (placements ``X``, ``W`` used as scratch).

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
    du = np.empty(n)
    for k in range(n):
        du[k] = abs(qb[joints[k, 1]] - qa[joints[k, 1]])
    ends = _end_distances(tree, joints, spheres, geoms, qa, qb, du, X, W)
    joint_rate = np.zeros((G, n))  # per geometry and joint: the largest rate of its rows
    for g in range(min(G, rows)):
        for c in range(geoms[g, 1] - 1, min(geoms[g, 2], rows)):
            row = g if c < geoms[g, 1] else c  # the bounding sphere first, then the cover spheres
            dx, dy, dz = spheres[row, 0] - spheres[g, 0], spheres[row, 1] - spheres[g, 1], \
                spheres[row, 2] - spheres[g, 2]
            offset = math.sqrt(dx * dx + dy * dy + dz * dz)
            below, rate = 0.0, 0.0
            j = geoms[g, 0]
            while j > 0:
                k = j - 1
                reach = sphere_reach[row, k]
                if joints[k, 0] == _REVOLUTE:
                    reach = min(reach, 0.5 * ends[g, k] + offset + 0.5 * below)
                joint_rate[g, k] = max(joint_rate[g, k], reach)
                rate += reach * du[k]
                below += sphere_reach[row, k] * du[k]
                j = joints[k, 2]
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
    """The rates :func:`certify_motion` and :func:`motion_hard_pairs` advance with on ``qa -> qb``:
    ``[v (S,), w (P,)]``, per sphere row the bound (m per unit ``s``) of its centre's speed and per pair-table
    row the bound of a self pair's sphere gaps' rate (:func:`_motion_rates` lowered by
    :func:`_tighten_rates`); empty when the arguments do not fit."""
    tree, joints, spheres, geoms, pairs, obstacles = _unpack(floats, ints)
    if not _rates_fit(joints, spheres, geoms, pairs, sphere_reach, pair_reach, qa, qb):
        return np.zeros(0)
    v, w = _motion_rates(joints, sphere_reach, pair_reach, spheres.shape[0], qa, qb)
    X, W, placed = _workspace(joints.shape[0], spheres.shape[0], geoms.shape[0])
    _tighten_rates(tree, joints, spheres, geoms, sphere_reach, pairs, pair_reach, qa, qb, v, w, X, W)
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
    is at most ``sphere_reach[c, k] + r``; with ``C_k = sum_{j below k} (sphere_reach[c, j] + r) |u_j|``, over
    the stretch ``rho_k(x) <= (rho_k(c, lo) + rho_k(c, hi)) / 2 + r + C_k (hi - lo) / 2``. An obstacle pair:
    ``sum_k |u_k| bound_k`` over the joints carrying the geometry (a prismatic one: ``|u_k|``); a self pair:
    the two geometries' bounds on the joints carrying one of them and not the other (the joints carrying both
    move them rigidly together)."""
    tree, joints, spheres, geoms, pairs, obstacles = _unpack(floats, ints)
    n, G = joints.shape[0], geoms.shape[0]
    out = np.full(scene_pairs.shape[0], math.inf)
    if qa.shape[0] != n or qb.shape[0] != n or sphere_reach.shape[1] != n or sphere_reach.shape[0] < G:
        return out
    du = np.empty(n)
    for k in range(n):
        du[k] = abs(qb[joints[k, 1]] - qa[joints[k, 1]])
    X, W, placed = _workspace(n, spheres.shape[0], G)
    q_lo, q_hi = np.empty(n), np.empty(n)
    for i in range(n):
        q_lo[i] = qa[i] + lo * (qb[i] - qa[i])
        q_hi[i] = qa[i] + hi * (qb[i] - qa[i])
    ends = _end_distances(tree, joints, spheres, geoms, q_lo, q_hi, du, X, W)
    bound = np.full((G, n), -1.0)  # per geometry and joint carrying it: the rate of its points
    for g in range(G):
        r = spheres[g, 3]
        below = 0.0
        j = geoms[g, 0]
        while j > 0:
            k = j - 1
            if joints[k, 0] == _REVOLUTE:
                reach = sphere_reach[g, k] + r
                bound[g, k] = min(reach, 0.5 * ends[g, k] + r + 0.5 * (hi - lo) * below)
            else:
                reach = 1.0
                bound[g, k] = 1.0
            below += reach * du[k]
            j = joints[k, 2]
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
def _pair_radius(X, W, placed, stamp, spheres, geoms, pairs, obstacles, p, v, w, need, tol):
    """The certified radius of pair-table row ``p`` alone at the configuration placed in ``X`` / ``W``, for a
    motion whose sphere centres move by at most ``v[s]`` and whose self pairs' sphere gaps change by at most
    ``w[p]`` per unit of its parameter: its bounding spheres' radius, or, when that one is below ``need``,
    the larger of it and its cover spheres' (placed on first need, marked with ``stamp``; either family
    staying apart keeps the pair apart). :func:`_motion_radius` asks it of every pair with ``need`` = the
    running minimum, :func:`_pair_advance` of the pairs it advances."""
    a, b = pairs[p, 0], pairs[p, 1]
    if pairs[p, 2] == SELF_PAIR:
        r = _rate_radius(_gap(W, a, b) - tol, w[p])
        if r >= need:
            return r
        _place_cover(X, spheres, geoms, a, W, placed, stamp)
        _place_cover(X, spheres, geoms, b, W, placed, stamp)
        return max(r, _rate_radius(_self_cover_gap(W, geoms, a, b) - tol, w[p]))
    r = _rate_radius(_obstacle_gap(W, a, obstacles, b) - tol, v[a])
    if r >= need:
        return r
    _place_cover(X, spheres, geoms, a, W, placed, stamp)
    parts = math.inf
    for i in range(geoms[a, 1], geoms[a, 2]):
        parts = min(parts, _rate_radius(_obstacle_gap(W, i, obstacles, b) - tol, v[i]))
        if parts <= r:
            break
    return max(r, parts)


@_jit
def _motion_radius(tree, joints, spheres, geoms, pairs, obstacles, skip, q, v, w, limit, tol, X, W, placed,
                   stamp):
    """The certified radius at ``q`` of a motion whose sphere centres move by at most ``v[s]`` and whose self
    pairs' sphere gaps change by at most ``w[p]`` per unit of its parameter (:func:`certify_motion`), over
    the pairs ``skip`` leaves out, and the table row of the pair that decides it: ``(radius, row)``, ``limit``
    and -1 when no pair is smaller; a negative radius when the spheres of pair ``row`` are not apart. A
    pair's radius is that of its bounding spheres or, when that one is below the running minimum, the
    larger of it and the smallest radius of its cover spheres (either family staying apart keeps the pair
    apart)."""
    tree_placements(tree, joints, q, X)
    for g in range(geoms.shape[0]):
        _place(X, geoms[g, 0], spheres, g, W)
    best, decider = limit, -1
    for p in range(pairs.shape[0]):
        if skip[pairs[p, 3]]:
            continue
        r = _pair_radius(X, W, placed, stamp, spheres, geoms, pairs, obstacles, p, v, w, best, tol)
        if r < best:  # (a pair at or above the running minimum does not decide it: its covers are not asked)
            best, decider = r, p
            if r < 0.0:
                return -1.0, p
    return best, decider


_MOTION_SIGNATURE = _t.Array(_t.float64, 1, "C")(F1, I1, F2, F2, B1, F1_ANY, F1_ANY, _t.float64, _t.float64,
                                                 _t.int64)


@compiled(_MOTION_SIGNATURE)
def certify_motion(floats: np.ndarray, ints: np.ndarray, sphere_reach: np.ndarray, pair_reach: np.ndarray,
                   skip: np.ndarray, qa: np.ndarray, qb: np.ndarray, tol: float, min_step: float,
                   max_advances: int) -> np.ndarray:
    """Conservative advancement on the sphere bounds along the straight motion ``q(s) = qa + s (qb - qa)``,
    ``s`` in ``[0, 1]``: ``[lo, hi, advances]``, where ``[0, lo]`` and ``[hi, 1]`` are certified collision
    free (every pair's lower bound above ``tol``, m, at every ``s`` of them), every pair but those
    ``skip`` ``(P,)`` marks (by their index in the scene); the whole motion when ``lo >= hi``. ``stop``:
    the scene index of the pair that decided the last radius when the motion is not certified, else -1.
    Returns ``[lo, hi, advances, stop]``.

    Per unit ``s``, sphere centre ``c`` moves by at most ``v[c] = sum_k sphere_reach[c, k] |u_k|``
    (:func:`~.robot_spheres.sphere_reach`, ``u = qb - qa`` on joint ``k``'s coordinate), so a sphere's gap
    to an obstacle (1-Lipschitz in its centre) falls by at most ``v[c] |ds|``; a self pair's sphere gaps by
    at most ``w[p] = sum_k pair_reach[p, k] |u_k|`` (row ``p`` of the kernel's pair table; the joints
    carrying both geometries move them rigidly together and count 0). Both are then lowered to this motion's
    own bounds, from the centres' distances to the joint axes at its two ends (:func:`_tighten_rates`;
    :func:`motion_rates` returns them). A configuration ``q(s)`` therefore
    certifies ``|s' - s| <= rho`` (:func:`_motion_radius`); the advances alternate between the two ends,
    each from the end of the interval before it (no gap), and stop at ``lo >= hi``, at a radius below
    ``min_step`` (the spheres do not decide: an exact check may go on from ``lo`` and ``hi``) or after
    ``max_advances``.
    Nothing certified (``[0, 1, 0, -1]``) when ``qa`` or ``qb`` has not one entry per joint or the tables do
    not cover every sphere row and pair. ``floats, ints``: :func:`~.precheck_packing.pack`.
    """
    tree, joints, spheres, geoms, pairs, obstacles = _unpack(floats, ints)
    n = joints.shape[0]
    out = np.zeros(4)
    out[1], out[3] = 1.0, -1.0
    if skip.shape[0] != pairs.shape[0] or not _rates_fit(joints, spheres, geoms, pairs, sphere_reach,
                                                         pair_reach, qa, qb):
        return out
    v, w = _motion_rates(joints, sphere_reach, pair_reach, spheres.shape[0], qa, qb)
    X, W, placed = _workspace(n, spheres.shape[0], geoms.shape[0])
    _tighten_rates(tree, joints, spheres, geoms, sphere_reach, pairs, pair_reach, qa, qb, v, w, X, W)
    q = np.empty(n)
    lo, hi = 0.0, 1.0
    advances, last = 0, -1
    while advances < max_advances and lo < hi:
        from_lo = advances % 2 == 0
        s = lo if from_lo else hi
        for i in range(n):
            q[i] = qa[i] + s * (qb[i] - qa[i])
        limit = hi - lo
        rho, decider = _motion_radius(tree, joints, spheres, geoms, pairs, obstacles, skip, q, v, w, limit,
                                      tol, X, W, placed, advances)
        advances += 1
        last = decider
        if rho >= limit:
            lo = hi
        elif rho < min_step:
            break
        elif from_lo:
            lo += rho
        else:
            hi -= rho
    out[0], out[1], out[2] = lo, hi, advances
    if lo < hi and last >= 0:
        out[3] = pairs[last, 3]
    return out


#: Pairs :func:`motion_hard_pairs` re-evaluates at a point: those whose certified front lies within this
#: fraction of the side's last smallest radius (the others are certified well ahead).
PAIR_HORIZON = 0.5


@_jit
def _pair_advance(X, W, placed, stamp, spheres, geoms, pairs, obstacles, v, w, tol, min_step, live, m,
                  front, back, state, s, from_lo, horizon):
    """One advance of :func:`motion_hard_pairs` at ``s`` (placements in ``X`` / ``W``) over the open pairs
    ``live[:m]`` whose front (from below, ``from_lo``) or back lies within ``horizon`` of ``s``: their
    radius ``r`` certifies ``[s - r, s + r]``, joined to ``[0, front]`` / ``[back, 1]`` (``s`` is inside
    or at the end of it); a pair is certified (``state`` 1) when the two meet, hard (2) when ``r`` is below
    ``min_step``. Returns the smallest radius found (``inf``: none) and the number of new hard pairs."""
    best, hard = math.inf, 0
    for t in range(m):
        p = live[t]
        if from_lo:
            if front[p] > s + horizon:
                continue
            need = back[p] - s
        else:
            if back[p] < s - horizon:
                continue
            need = s - front[p]
        r = _pair_radius(X, W, placed, stamp, spheres, geoms, pairs, obstacles, p, v, w, need, tol)
        if r < min_step:
            state[p] = 2
            hard += 1
            continue
        best = min(best, r)
        if r >= need:
            state[p] = 1
        elif from_lo:
            front[p] = max(front[p], s + r)
        else:
            back[p] = min(back[p], s - r)
    return best, hard


@_inline
def _open_end(live, m, state, front, back, from_lo):
    """Keep the open pairs (``state`` 0) of ``live[:m]`` at its start: ``(their count, the end to advance
    from)``: the smallest front (``from_lo``) or the largest back."""
    s = math.inf if from_lo else -math.inf
    k = 0
    for t in range(m):
        p = live[t]
        if state[p] == 0:
            live[k] = p
            k += 1
            s = min(s, front[p]) if from_lo else max(s, back[p])
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

    Conservative advancement per pair (the rates ``v``, ``w`` and radii of :func:`certify_motion`): pair
    ``p`` is certified on ``[0, front[p]]`` and ``[back[p], 1]``; an advance from below evaluates at ``s``,
    the smallest front of the open pairs, the pairs whose front is within :data:`PAIR_HORIZON` of the last
    smallest radius of ``s`` (at least those at ``s``: ``s <= front[p]``, so a radius ``r`` at ``s`` extends
    the certified interval without a gap to ``s + r``); advances from above likewise, alternately. A pair is
    certified once ``front[p] >= back[p]`` (the two intervals cover ``[0, 1]``); a pair whose radius falls
    below ``min_step`` (fraction of the motion; also when its spheres are not apart) is hard, and so is
    every pair still open after ``max_advances``. A pair far from everything is done in one or two
    evaluations; only the close ones are advanced in small steps.
    """
    tree, joints, spheres, geoms, pairs, obstacles = _unpack(floats, ints)
    n, P = joints.shape[0], pairs.shape[0]
    out = np.full(max_hard + 4, -1.0)
    out[1], out[2], out[3] = 0.0, 0.0, 1.0
    if not _rates_fit(joints, spheres, geoms, pairs, sphere_reach, pair_reach, qa, qb):
        return out
    v, w = _motion_rates(joints, sphere_reach, pair_reach, spheres.shape[0], qa, qb)
    X, W, placed = _workspace(n, spheres.shape[0], geoms.shape[0])
    _tighten_rates(tree, joints, spheres, geoms, sphere_reach, pairs, pair_reach, qa, qb, v, w, X, W)
    front, back = np.zeros(P), np.ones(P)
    state = np.zeros(P, dtype=np.int64)  # 0 open, 1 certified, 2 hard
    live = np.arange(P)
    q = np.empty(n)
    m, hard, advances, steps = P, 0, 0, np.zeros(2)
    while hard <= max_hard:
        from_lo = advances % 2 == 0
        m, s = _open_end(live, m, state, front, back, from_lo)
        if m == 0:
            break
        if advances >= max_advances:  # the open pairs are hard
            hard += m
            for t in range(m):
                state[live[t]] = 2
            break
        for i in range(n):
            q[i] = qa[i] + s * (qb[i] - qa[i])
        tree_placements(tree, joints, q, X)
        for g in range(geoms.shape[0]):
            _place(X, geoms[g, 0], spheres, g, W)
        best, new = _pair_advance(X, W, placed, advances, spheres, geoms, pairs, obstacles, v, w, tol,
                                  min_step, live, m, front, back, state, s, from_lo, steps[advances % 2])
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


__all__ = ["BALL", "BOX", "CAPSULE", "COLLIDING", "CYLINDER", "EXACT", "FREE", "KIND", "LIPSCHITZ_SAFETY",
           "MARGIN_CAP", "OBSTACLE_COLUMNS", "OBSTACLE_PAIR", "PAIR_HORIZON", "SELF_PAIR", "TOLERANCE",
           "UNDECIDED", "certainly_colliding", "certify_configuration", "certify_configurations",
           "certify_motion", "classify_configuration", "first_uncertified", "geometry_pair_rates",
           "motion_hard_pairs", "motion_rates", "pair_lower_bounds", "tree_placements", "uncertified_pairs"]
