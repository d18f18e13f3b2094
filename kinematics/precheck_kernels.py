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
certify. Their arguments are two flat arrays (:mod:`.precheck_packing`; a
compiled call pays per array argument): the integer array, which holds the
robot's floats too, is packed once per robot and shared by every scene; the float
array is the scene's obstacle rows (:mod:`.obstacle_table`, made with each shape).
Each call allocates its own workspace: one kernel may run on many threads at once.
The tree's forward kinematics is :mod:`.kernel_primitives`' (inlined); the cache
key covers every kernel file (:mod:`.kernel_cache`). Every kernel has its
signature: importing this module compiles them, or loads them from that cache,
so no call compiles anything. The primitives the motion certificates
(:mod:`.motion_kernels`) share with these kernels are public names: :func:`unpack`, :func:`workspace`,
:func:`place_sphere`, :func:`place_cover`, :func:`sphere_gap`, :func:`obstacle_gap`, :func:`self_cover_gap`;
the screened LM start (:mod:`kinserve.ik.lm.screened_kernel`) checks its start and its rows in one workspace
(:func:`packed_workspace`, :func:`first_uncertified_in`).

Units: metres and radians.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .kernel_cache import F1, F1_ANY, F2, F2_ANY, I1, I2, compiled, inline, jit, leaf
from .kernel_primitives import float_rows_view, rows_view, tree_placements_into
from .magnitude import MAX_ABS
from .obstacle_table import BALL, BOX, CAPSULE, CYLINDER, EXACT, KIND, OBSTACLE_COLUMNS
from .precheck_packing import HEADER, OBSTACLE_PAIR, SELF_PAIR
from .precheck_verdicts import COLLIDING, FREE, PACKED_PAIRS, PAIR_BITS, UNDECIDED

#: A pair is certified free when its distance lower bound exceeds this (m): ten times coal's GJK tolerance, so
#: that coal's contact test, whose distances are exact to about 1e-6 m on these shapes, agrees.
TOLERANCE = 1e-5


_jit, _inline, _leaf = jit, inline, leaf  # (kernel_cache's: one cache key over every kernel source)
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
def _robot_floats_start(J, G):
    """Index in ``ints`` of the robot's first float word: after the header, ``joints`` ``(J, 3)`` and
    ``geoms`` ``(G, 5)`` (:mod:`~.precheck_packing`; its ``robot_floats_span`` is the Python twin)."""
    return HEADER + 3 * J + 5 * G


@_inline
def unpack(floats: np.ndarray, ints: np.ndarray) -> tuple[np.ndarray, ...]:
    """``(tree, joints, spheres, geoms, pairs, obstacles)``: views of the packed arrays
    (:mod:`~.precheck_packing`): the obstacles are ``floats``' rows, the robot's floats a float64 view of
    their words in ``ints``, the pairs the last ``N + M O`` rows of the pair table. Raises ValueError when
    the table holds fewer obstacles."""
    J, S, G, M, N = ints[0], ints[1], ints[2], ints[3], ints[4]  # noqa: E741 - the packing's names
    O = floats.shape[0] // 16  # noqa: E741
    P = N + M * O
    start = _robot_floats_start(J, G)
    table = start + 16 * J + 4 * S
    if ints.shape[0] - 4 * P < table:
        raise ValueError("pre-check: the pair table holds fewer obstacles than the float array")
    tree = float_rows_view(ints[start:], J, 15)
    spheres = float_rows_view(ints[start + 16 * J:], S, 4)
    obstacles = rows_view(floats, O, 16)
    joints = rows_view(ints[HEADER:], J, 3)
    geoms = rows_view(ints[HEADER + 3 * J:], G, 5)
    pairs = rows_view(ints[ints.shape[0] - 4 * P:], P, 4)
    return tree, joints, spheres, geoms, pairs, obstacles


@_inline
def _reach(floats, ints):
    """The packed :attr:`~.robot_spheres.RobotSpheres.reach` ``(J,)`` (:func:`~.precheck_packing.pack`; a
    float64 view of its words in ``ints``): only :func:`first_uncertified` reads it."""
    J, G = ints[0], ints[2]
    return float_rows_view(ints[_robot_floats_start(J, G) + 15 * J:], 1, J)[0]


@_inline
def workspace(n: int, S: int, G: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One allocation per call: joint placements ``X`` ``(n + 1, 12)``, world spheres ``W`` ``(S + 1, 4)``
    (row ``S``: the moving geometries' group sphere, :func:`place_group_sphere`) and the per-geometry stamps
    ``placed`` ``(G,)`` (-1: cover not placed yet)."""
    rows = S + 1
    buffer = np.empty(12 * (n + 1) + 4 * rows + G)
    X = rows_view(buffer, n + 1, 12)
    W = rows_view(buffer[12 * (n + 1):], rows, 4)
    placed = buffer[12 * (n + 1) + 4 * rows:]
    placed[:] = -1.0
    return X, W, placed


@_inline
def obstacle_block(pairs: np.ndarray) -> int:
    """``M``, the rows of the pair table's first obstacle (0 when the table starts with a self pair): every
    obstacle's block lists the same ``M`` moving geometries in the same order (:mod:`.precheck_packing`)."""
    M = 0
    while M < pairs.shape[0] and pairs[M, 2] == OBSTACLE_PAIR and pairs[M, 1] == pairs[0, 1]:
        M += 1
    return M


@_inline
def place_group_sphere(W: np.ndarray, pairs: np.ndarray, M: int, row: int) -> None:
    """``W[row]`` = a sphere that contains the bounding spheres (placed in ``W``) of the geometries of the
    first ``M`` rows of ``pairs`` (the moving geometries): centred in their bounding box, its radius the
    largest ``|c_g - c| + r_g``, rounded up. Any NaN or infinity among them makes the radius NaN (no test
    passes)."""
    lx, ly, lz = math.inf, math.inf, math.inf
    hx, hy, hz = -math.inf, -math.inf, -math.inf
    for r in range(M):
        g = pairs[r, 0]
        rad = W[g, 3]
        lx, ly, lz = min(lx, W[g, 0] - rad), min(ly, W[g, 1] - rad), min(lz, W[g, 2] - rad)
        hx, hy, hz = max(hx, W[g, 0] + rad), max(hy, W[g, 1] + rad), max(hz, W[g, 2] + rad)
    cx, cy, cz = 0.5 * (lx + hx), 0.5 * (ly + hy), 0.5 * (lz + hz)
    radius, total = 0.0, 0.0
    for r in range(M):
        g = pairs[r, 0]
        dx, dy, dz = W[g, 0] - cx, W[g, 1] - cy, W[g, 2] - cz
        reach = math.sqrt(dx * dx + dy * dy + dz * dz) + W[g, 3]
        radius = max(radius, reach)
        total += reach  # (NaN or infinite when any is)
    W[row, 0], W[row, 1], W[row, 2] = cx, cy, cz
    W[row, 3] = radius * (1.0 + 1e-12) if total < math.inf else math.nan


@_inline
def place_sphere(X: np.ndarray, j: int, spheres: np.ndarray, s: int, W: np.ndarray) -> None:
    """``W[s]`` = (world centre, radius) of sphere ``s``, fixed in joint ``j`` (placements ``X``)."""
    c0, c1, c2 = spheres[s, 0], spheres[s, 1], spheres[s, 2]
    for i in range(3):
        W[s, i] = X[j, 9 + i] + X[j, 3 * i] * c0 + X[j, 3 * i + 1] * c1 + X[j, 3 * i + 2] * c2
    W[s, 3] = spheres[s, 3]


@_inline
def place_bounding_spheres(tree: np.ndarray, joints: np.ndarray, spheres: np.ndarray, geoms: np.ndarray,
                           q: np.ndarray, X: np.ndarray, W: np.ndarray) -> None:
    """The joint placements of configuration ``q`` into ``X`` (inlined
    :func:`.kernel_primitives.tree_placements_into`), then each geometry's bounding sphere into its row of
    ``W``."""
    tree_placements_into(tree, joints, q, X)
    for g in range(geoms.shape[0]):
        place_sphere(X, geoms[g, 0], spheres, g, W)


@_inline
def place_scene_spheres(tree: np.ndarray, joints: np.ndarray, spheres: np.ndarray, geoms: np.ndarray,
                        pairs: np.ndarray, q: np.ndarray, X: np.ndarray, W: np.ndarray) -> int:
    """:func:`place_bounding_spheres`, then, when the pair table starts with obstacle blocks, the moving
    geometries' group sphere into ``W``'s last row (:func:`place_group_sphere`). Returns ``M``
    (:func:`obstacle_block`): what the tests that read the group sphere need."""
    place_bounding_spheres(tree, joints, spheres, geoms, q, X, W)
    M = obstacle_block(pairs)
    if M > 0:
        place_group_sphere(W, pairs, M, spheres.shape[0])
    return M


@_inline
def place_cover(X: np.ndarray, spheres: np.ndarray, geoms: np.ndarray, g: int, W: np.ndarray,
                placed: np.ndarray, stamp: int) -> None:
    """The cover spheres of geometry ``g`` into ``W``, unless already placed for this configuration
    (``stamp``)."""
    if placed[g] != stamp:
        j = geoms[g, 0]
        for s in range(geoms[g, 1], geoms[g, 2]):
            place_sphere(X, j, spheres, s, W)
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


@_inline
def _obstacle_rows_margin(X, W, spheres, geoms, pairs, obstacles, lo, hi, tol, m, placed, stamp):
    """:func:`_configuration_margin`'s tests of the obstacle rows ``lo..hi - 1`` of ``pairs``: the margin
    ``m`` lowered to their slacks, or ``-1 - p`` when row ``p`` is the first of them not certified."""
    for p in range(lo, hi):
        a, b = pairs[p, 0], pairs[p, 1]
        r = _obstacle_slack(W, a, obstacles, b, tol, m)
        if r >= 0.0:
            m = r
            continue
        place_cover(X, spheres, geoms, a, W, placed, stamp)
        for i in range(geoms[a, 1], geoms[a, 2]):
            m = _obstacle_slack(W, i, obstacles, b, tol, m)
            if m < 0.0:
                return -1.0 - p
    return m


@_leaf
def _configuration_margin(tree, joints, spheres, geoms, pairs, obstacles, q, tol, X, W, placed, stamp):
    """The certificate of ``q``: ``-1 - p`` (negative) when some pair's lower bound does not exceed ``tol``,
    ``p`` the first such row of ``pairs`` (every row before it is certified: :func:`uncertified_from`),
    else the margin ``m >= 0`` (m, at most :data:`MARGIN_CAP`): the smallest slack of the sphere tests
    that certified the pairs - every sphere may move by up to ``m / 2`` and those tests still pass
    (:func:`first_uncertified`). Forward kinematics into ``X``, the bounding spheres into ``W``, then per
    pair the bounding spheres and, when they are not apart, the cover spheres (placed on first need,
    marked with ``stamp`` in ``placed``).

    The obstacle rows come in blocks, one per obstacle, each pairing it with the same ``M`` moving geometries
    (:func:`obstacle_block`): a block is certified at once when the **group sphere** of those geometries
    (:func:`place_group_sphere`, placed here: it contains their bounding spheres) is apart from the
    obstacle - then every bounding sphere is, by at least the group's slack, which still holds after each
    sphere moves by up to ``m / 2``. Otherwise its rows are tested one by one. Most obstacles of a cluttered
    scene are away from the arm (on the MotionBenchMaker scenes this leaves a fifth of the obstacle tests:
    docs/benchmarks.md)."""
    M = place_scene_spheres(tree, joints, spheres, geoms, pairs, q, X, W)
    m = MARGIN_CAP
    start = 0
    if M > 0:  # obstacle blocks: the group sphere first, each geometry only when it touches the obstacle
        group = spheres.shape[0]
        while start < pairs.shape[0] and pairs[start, 2] == OBSTACLE_PAIR:
            r = _obstacle_slack(W, group, obstacles, pairs[start, 1], tol, m)
            if r >= 0.0:
                m = r
                start += M
                continue
            m = _obstacle_rows_margin(X, W, spheres, geoms, pairs, obstacles, start,
                                      min(start + M, pairs.shape[0]), tol, m, placed, stamp)
            if m < 0.0:
                return m
            start += M
    for p in range(start, pairs.shape[0]):
        a, b = pairs[p, 0], pairs[p, 1]
        if pairs[p, 2] == SELF_PAIR:
            r = _sphere_slack(W, a, b, tol, m)
            if r >= 0.0:
                m = r
                continue
            place_cover(X, spheres, geoms, a, W, placed, stamp)
            place_cover(X, spheres, geoms, b, W, placed, stamp)
            for i in range(geoms[a, 1], geoms[a, 2]):
                r = _sphere_slack(W, i, b, tol, m)
                if r >= 0.0:
                    m = r
                    continue
                for j in range(geoms[b, 1], geoms[b, 2]):
                    m = _sphere_slack(W, i, j, tol, m)
                    if m < 0.0:
                        return -1.0 - p
        else:  # (an obstacle row after the blocks: not in the packing's tables)
            m = _obstacle_rows_margin(X, W, spheres, geoms, pairs, obstacles, p, p + 1, tol, m, placed, stamp)
            if m < 0.0:
                return m
    return m


@compiled(_ONE_SIGNATURE)
def certify_configuration(floats: np.ndarray, ints: np.ndarray, q: np.ndarray, tol: float) -> bool:
    """True when configuration ``q`` is certified collision free (every pair's lower bound > ``tol``, m);
    False when it is not, or when ``q`` has not one entry per joint. ``floats, ints``:
    :func:`~.precheck_packing.pack`."""
    tree, joints, spheres, geoms, pairs, obstacles = unpack(floats, ints)
    n = joints.shape[0]
    if q.shape[0] != n:
        return False
    X, W, placed = workspace(n, spheres.shape[0], geoms.shape[0])
    margin = _configuration_margin(tree, joints, spheres, geoms, pairs, obstacles, q, tol, X, W, placed, 0)
    return margin >= 0.0


@compiled(_BATCH_SIGNATURE)
def certify_configurations(floats: np.ndarray, ints: np.ndarray, qs: np.ndarray, tol: float) -> np.ndarray:
    """:func:`certify_configuration` of every row of ``qs`` ``(N, nq)``: a boolean array ``(N,)``."""
    tree, joints, spheres, geoms, pairs, obstacles = unpack(floats, ints)
    n = joints.shape[0]
    N = qs.shape[0]
    out = np.zeros(N, dtype=np.bool_)
    if qs.shape[1] != n:
        return out
    X, W, placed = workspace(n, spheres.shape[0], geoms.shape[0])
    for k in range(N):
        out[k] = _configuration_margin(tree, joints, spheres, geoms, pairs, obstacles, qs[k], tol, X, W,
                                      placed, k) >= 0.0
    return out


@_inline
def packed_workspace(ints: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`workspace` of the packed arrays' robot (its header: joints, spheres, geometries)."""
    return workspace(ints[0], ints[1], ints[2])


@_inline
def first_uncertified_in(floats: np.ndarray, ints: np.ndarray, qs: np.ndarray, start: int, tol: float,
                         X: np.ndarray, W: np.ndarray, placed: np.ndarray, stamp: int) -> int:
    """:func:`first_uncertified` in the caller's workspace (:func:`packed_workspace`), row ``k`` marked with
    the stamp ``stamp + k``: a caller that checks several batches in one workspace starts each batch's stamps
    after the last one used."""
    tree, joints, spheres, geoms, pairs, obstacles = unpack(floats, ints)
    n = joints.shape[0]
    N = qs.shape[0]
    if qs.shape[1] != n:
        return max(start, 0)
    reach = _reach(floats, ints)
    ref, m = -1, 0.0
    for k in range(max(start, 0), N):
        if ref >= 0:
            moved = 0.0
            for j in range(n):
                c = joints[j, 1]
                moved += reach[j] * abs(qs[k, c] - qs[ref, c])
            if 2.0 * moved * LIPSCHITZ_SAFETY < m:  # NaN: not skipped
                continue
        m = _configuration_margin(tree, joints, spheres, geoms, pairs, obstacles, qs[k], tol, X, W, placed,
                                  stamp + k)
        if m < 0.0:
            return k
        ref = k
    return N


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
    X, W, placed = packed_workspace(ints)
    return first_uncertified_in(floats, ints, qs, start, tol, X, W, placed, 0)


@_inline
def sphere_gap(W: np.ndarray, i: int, j: int) -> float:
    """``|c_i - c_j| - r_i - r_j`` (m): a lower bound of the distance between what spheres ``i`` and ``j``
    hold."""
    dx, dy, dz = W[i, 0] - W[j, 0], W[i, 1] - W[j, 1], W[i, 2] - W[j, 2]
    return math.sqrt(dx * dx + dy * dy + dz * dz) - W[i, 3] - W[j, 3]


@_inline
def obstacle_gap(W: np.ndarray, i: int, obstacles: np.ndarray, o: int) -> float:
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
def self_cover_gap(W: np.ndarray, geoms: np.ndarray, a: int, b: int) -> float:
    """``min_i max(gap(i, B_b), min_j gap(i, j))`` over the cover spheres ``i`` of geometry ``a`` and ``j`` of
    ``b`` (``B_b``: ``b``'s bounding sphere; placed in ``W``): a lower bound (m) of the distance between the
    two geometries."""
    parts = math.inf
    for i in range(geoms[a, 1], geoms[a, 2]):
        inner = math.inf
        for j in range(geoms[b, 1], geoms[b, 2]):
            inner = min(inner, sphere_gap(W, i, j))
        parts = min(parts, max(sphere_gap(W, i, b), inner))
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
    squares instead); this form gives the values (a
    :class:`~kinserve.planners.motion.clearance.Clearance`'s first bounds, tests and diagnostics).
    """
    tree, joints, spheres, geoms, pairs, obstacles = unpack(floats, ints)
    n = joints.shape[0]
    X = np.empty((n + 1, 12))
    W = np.empty((spheres.shape[0], 4))
    tree_placements(tree, joints, q, X)
    for g in range(geoms.shape[0]):
        place_sphere(X, geoms[g, 0], spheres, g, W)
        for s in range(geoms[g, 1], geoms[g, 2]):
            place_sphere(X, geoms[g, 0], spheres, s, W)
    out = np.empty(pairs.shape[0])
    for p in range(pairs.shape[0]):
        a, b = pairs[p, 0], pairs[p, 1]
        if pairs[p, 2] == SELF_PAIR:
            out[pairs[p, 3]] = max(sphere_gap(W, a, b), self_cover_gap(W, geoms, a, b))
        else:
            parts = math.inf
            for i in range(geoms[a, 1], geoms[a, 2]):
                parts = min(parts, obstacle_gap(W, i, obstacles, b))
            out[pairs[p, 3]] = max(obstacle_gap(W, a, obstacles, b), parts)
    return out


@_inline
def _place_inner(X, spheres, geoms, g, W, inner):
    """Geometry ``g``'s inner balls (centre in the world, radius) into their rows of ``W``, unless
    ``inner[g]`` says they are there already (then set)."""
    if not inner[g]:
        j = geoms[g, 0]
        for i in range(geoms[g, 3], geoms[g, 4]):
            place_sphere(X, j, spheres, i, W)
        inner[g] = True


@_leaf
def _certain_hit_marked(X, W, spheres, geoms, pairs, obstacles, M, tol, inner):
    """True when a checked pair intersects for certain at the joint placements ``X`` (each geometry's
    bounding sphere and the group sphere of the ``M`` rows of an obstacle block placed in ``W``,
    :func:`place_scene_spheres`): an inner ball of a robot geometry
    reaches deeper than ``tol`` (m) into an obstacle whose exact distance the table has, or two inner balls
    of the geometries of a self pair overlap by more than ``tol`` (a ball inside each shape: the shapes
    share their overlap). Inner balls of radius 0 are points.

    A pair whose bounding spheres are apart (gap ``>= 0``) is not asked further: an inner ball lies inside
    its geometry, so inside the bounding sphere, and its gap (centre distance minus radius, 1-Lipschitz in
    the centre) is at least the bounding sphere's; nor an obstacle block whose group sphere
    (:func:`place_group_sphere`) is apart from the obstacle. The inner balls are placed on first need;
    ``inner`` ``(G,)`` (all False on entry, the caller's) marks the geometries whose balls are placed."""
    group = spheres.shape[0]
    p = -1
    while p + 1 < pairs.shape[0]:
        p += 1
        a, b = pairs[p, 0], pairs[p, 1]
        if pairs[p, 2] == OBSTACLE_PAIR:
            if M > 0 and p % M == 0 and obstacle_gap(W, group, obstacles, b) >= 0.0:
                p += M - 1  # (the block's rows: the obstacle's M pairs)
                continue
            if obstacles[b, KIND] == BALL and obstacles[b, EXACT] != 1.0:
                continue
            if obstacle_gap(W, a, obstacles, b) >= 0.0:
                continue
            _place_inner(X, spheres, geoms, a, W, inner)
            for i in range(geoms[a, 3], geoms[a, 4]):
                if obstacle_gap(W, i, obstacles, b) < -tol:
                    return True
        else:
            if sphere_gap(W, a, b) >= 0.0:
                continue
            _place_inner(X, spheres, geoms, a, W, inner)
            _place_inner(X, spheres, geoms, b, W, inner)
            for i in range(geoms[a, 3], geoms[a, 4]):
                for j in range(geoms[b, 3], geoms[b, 4]):
                    if sphere_gap(W, i, j) < -tol:
                        return True
    return False


@_inline
def _certain_hit(X, W, spheres, geoms, pairs, obstacles, M, tol):
    """:func:`_certain_hit_marked` with its inner-ball marks made here (the leaf allocates none)."""
    inner = np.zeros(geoms.shape[0], dtype=np.bool_)
    return _certain_hit_marked(X, W, spheres, geoms, pairs, obstacles, M, tol, inner)


@compiled(_ONE_SIGNATURE)
def certainly_colliding(floats: np.ndarray, ints: np.ndarray, q: np.ndarray, tol: float) -> bool:
    """True when configuration ``q`` is in collision for certain (:func:`_certain_hit`: an inner ball of a
    robot geometry, :func:`~.sphere_cover.geometry_inner_points` with the radii packed beside them, deeper
    than ``tol`` (m) inside an obstacle of a checked pair whose exact signed distance the kernel has - every
    kind but a BALL that stands for another shape - or two inner balls of a checked self pair overlapping by
    more than ``tol``). Then the two shapes share that region: coal finds them in collision. False says
    nothing (coal decides), also when ``q`` has not one entry per joint. ``floats, ints``:
    :func:`~.precheck_packing.pack`."""
    tree, joints, spheres, geoms, pairs, obstacles = unpack(floats, ints)
    n = joints.shape[0]
    if q.shape[0] != n:
        return False
    X, W, placed = workspace(n, spheres.shape[0], geoms.shape[0])
    M = place_scene_spheres(tree, joints, spheres, geoms, pairs, q, X, W)
    return _certain_hit(X, W, spheres, geoms, pairs, obstacles, M, tol)


_CLASSIFY_SIGNATURE = _t.int64(F1, I1, F1_ANY, _t.float64)


@_inline
def _pair_certified(X, W, spheres, geoms, pairs, obstacles, p, tol, placed, stamp):
    """Whether pair-table row ``p``'s lower bound exceeds ``tol`` (m) at the placements ``X`` (bounding
    spheres in ``W``): the tests of :func:`_configuration_margin` on this pair alone."""
    a, b = pairs[p, 0], pairs[p, 1]
    if pairs[p, 2] == SELF_PAIR:
        if _sphere_slack(W, a, b, tol, MARGIN_CAP) >= 0.0:
            return True
        place_cover(X, spheres, geoms, a, W, placed, stamp)
        place_cover(X, spheres, geoms, b, W, placed, stamp)
        for i in range(geoms[a, 1], geoms[a, 2]):
            if _sphere_slack(W, i, b, tol, MARGIN_CAP) >= 0.0:
                continue
            for j in range(geoms[b, 1], geoms[b, 2]):
                if _sphere_slack(W, i, j, tol, MARGIN_CAP) < 0.0:
                    return False
        return True
    if _obstacle_slack(W, a, obstacles, b, tol, MARGIN_CAP) >= 0.0:
        return True
    place_cover(X, spheres, geoms, a, W, placed, stamp)
    for i in range(geoms[a, 1], geoms[a, 2]):
        if _obstacle_slack(W, i, obstacles, b, tol, MARGIN_CAP) < 0.0:
            return False
    return True


@_leaf
def _next_uncertified(X, W, spheres, geoms, pairs, obstacles, p, M, tol, placed):
    """The first row from ``p`` on whose lower bound at the placements ``X`` (bounding spheres in ``W``, the
    group sphere in its row when ``M > 0``) does not exceed ``tol`` (m), ``P`` when none: an obstacle block
    (``M`` rows from a multiple of ``M``) whose group sphere is apart from the obstacle is skipped whole,
    other rows are asked :func:`_pair_certified`."""
    group = spheres.shape[0]
    while p < pairs.shape[0]:
        if M > 0 and p % M == 0 and pairs[p, 2] == OBSTACLE_PAIR \
                and _obstacle_slack(W, group, obstacles, pairs[p, 1], tol, MARGIN_CAP) >= 0.0:
            p += M
            continue
        if not _pair_certified(X, W, spheres, geoms, pairs, obstacles, p, tol, placed, 0):
            return p
        p += 1
    return pairs.shape[0]


@_inline
def uncertified_from(X: np.ndarray, W: np.ndarray, spheres: np.ndarray, geoms: np.ndarray,
                     pairs: np.ndarray, obstacles: np.ndarray, start: int, M: int, tol: float,
                     placed: np.ndarray, out: np.ndarray, limit: int) -> int:
    """The scene indices of the pairs from row ``start`` on (the rows before it certified) whose lower bound
    at the placements ``X`` (bounding spheres and the group sphere of the ``M`` rows of an obstacle block in
    ``W``: :func:`place_scene_spheres`) does not exceed ``tol`` (m) into ``out``, in the pair table's order,
    stopping at the ``limit``-th; returns how many (``limit``: there may be more)."""
    k, p = 0, start
    while k < limit:
        p = _next_uncertified(X, W, spheres, geoms, pairs, obstacles, p, M, tol, placed)
        if p >= pairs.shape[0]:
            break
        out[k] = pairs[p, 3]
        k += 1
        p += 1
    return k


@_inline
def pairs_to_check(floats: np.ndarray, ints: np.ndarray, q: np.ndarray, keep: float, tol: float,
                   out: np.ndarray) -> int:
    """What coal must check at ``q``, on one forward kinematics: 0 when every pair's lower bound exceeds
    ``keep`` (m, at least ``tol``; :func:`certify_configuration`'s test with that tolerance: with ``keep =
    tol``, ``q`` is certified free), -1 when ``q`` is in collision for certain at depth ``tol``
    (:func:`certainly_colliding`'s test), else the number ``k`` of pairs whose lower bound does not exceed
    ``keep``, their scene indices written into ``out[:k]`` in the pair table's order (``out``: at least one
    entry per pair; every other pair is at least ``keep`` apart). With ``keep = tol``,
    :func:`classify_configuration`'s verdict with the pair list of :func:`uncertified_pairs` (the cover
    spheres the first test placed are reused); every pair when ``q`` has not one entry per joint."""
    tree, joints, spheres, geoms, pairs, obstacles = unpack(floats, ints)
    n = joints.shape[0]
    if q.shape[0] != n:
        out[:pairs.shape[0]] = pairs[:, 3]
        return pairs.shape[0]
    X, W, placed = workspace(n, spheres.shape[0], geoms.shape[0])
    m = _configuration_margin(tree, joints, spheres, geoms, pairs, obstacles, q, keep, X, W, placed, 0)
    if m >= 0.0:
        return 0
    M = obstacle_block(pairs)  # (the group sphere: placed by the certificate)
    if _certain_hit(X, W, spheres, geoms, pairs, obstacles, M, tol):  # (no pair list to make then)
        return -1
    return uncertified_from(X, W, spheres, geoms, pairs, obstacles, int(-1.0 - m), M, keep, placed, out,
                            pairs.shape[0])


@_inline
def _bounded(q: np.ndarray) -> bool:
    """Whether ``q·q < MAX_ABS**2`` (:data:`~.magnitude.MAX_ABS`): then every entry is finite with ``|q_i| <=
    MAX_ABS`` (NaN and inf fail it), the sufficient test of :func:`~.validation.as_vector`."""
    s = 0.0
    for i in range(q.shape[0]):
        s += q[i] * q[i]
    return s < MAX_ABS * MAX_ABS


@compiled(_CLASSIFY_SIGNATURE)
def classify_configuration(floats: np.ndarray, ints: np.ndarray, q: np.ndarray, tol: float) -> int:
    """:data:`FREE` when :func:`certify_configuration` certifies ``q``, else :data:`COLLIDING` when
    :func:`certainly_colliding` finds it in collision, else undecided: both tests on one forward kinematics,
    in one call. ``tol`` (m). An undecided verdict carries the pairs coal must check when there are at most
    :data:`~.precheck_verdicts.PACKED_PAIRS` of them: ``UNDECIDED + sum_k (p_k + 1) << (2 + 20 k)`` over the
    scene indices ``p_k`` of :func:`uncertified_pairs`'s list (read with
    :func:`~.precheck_verdicts.carried_pairs`); it is exactly :data:`UNDECIDED` when there are more, when the
    scene has ``2**20 - 1`` pairs or more (ask :func:`uncertified_pairs` then), and when ``q`` has not one
    entry per joint or is not surely bounded (:func:`_bounded`: the caller's input check decides it). The list
    starts at the pair the certificate failed on (the rows before it are certified: not tested again), skips
    the obstacle blocks the group sphere certifies, and stops at the fourth uncertified pair."""
    tree, joints, spheres, geoms, pairs, obstacles = unpack(floats, ints)
    n = joints.shape[0]
    if q.shape[0] != n or not _bounded(q):
        return UNDECIDED
    X, W, placed = workspace(n, spheres.shape[0], geoms.shape[0])
    m = _configuration_margin(tree, joints, spheres, geoms, pairs, obstacles, q, tol, X, W, placed, 0)
    if m >= 0.0:
        return FREE
    M = obstacle_block(pairs)  # (the group sphere: placed by the certificate)
    if _certain_hit(X, W, spheres, geoms, pairs, obstacles, M, tol):
        return COLLIDING
    if pairs.shape[0] >= (1 << PAIR_BITS) - 1:
        return UNDECIDED
    found = np.empty(PACKED_PAIRS + 1, dtype=np.int64)
    # from the row the certificate failed on: the rows before it are certified
    k = uncertified_from(X, W, spheres, geoms, pairs, obstacles, int(-1.0 - m), M, tol, placed, found,
                         PACKED_PAIRS + 1)
    if k > PACKED_PAIRS:
        return UNDECIDED
    code = UNDECIDED
    for i in range(k):
        code |= (found[i] + 1) << (2 + PAIR_BITS * i)
    return code


_PAIRS_SIGNATURE = _t.Array(_t.int64, 1, "C")(F1, I1, F1_ANY, _t.float64)


@compiled(_PAIRS_SIGNATURE)
def uncertified_pairs(floats: np.ndarray, ints: np.ndarray, q: np.ndarray, tol: float) -> np.ndarray:
    """The scene indices of the pairs whose lower bound at ``q`` does not exceed ``tol`` (m), in the pair
    table's order (obstacle pairs first): every other pair is certified free (:func:`certify_configuration`'s
    tests, pair by pair), so an exact check of these pairs alone decides ``q``. Every pair when ``q`` has not
    one entry per joint."""
    tree, joints, spheres, geoms, pairs, obstacles = unpack(floats, ints)
    n, P = joints.shape[0], pairs.shape[0]
    out = np.empty(P, dtype=np.int64)
    if q.shape[0] != n:
        out[:] = pairs[:, 3]
        return out
    X, W, placed = workspace(n, spheres.shape[0], geoms.shape[0])
    M = place_scene_spheres(tree, joints, spheres, geoms, pairs, q, X, W)
    k = uncertified_from(X, W, spheres, geoms, pairs, obstacles, 0, M, tol, placed, out, P)
    return out[:k].copy()


__all__ = ["BALL", "BOX", "CAPSULE", "COLLIDING", "CYLINDER", "EXACT", "FREE", "KIND", "LIPSCHITZ_SAFETY",
           "MARGIN_CAP", "OBSTACLE_COLUMNS", "OBSTACLE_PAIR", "SELF_PAIR", "TOLERANCE", "UNDECIDED",
           "certainly_colliding", "certify_configuration", "certify_configurations",
           "classify_configuration", "first_uncertified", "first_uncertified_in", "obstacle_gap",
           "obstacle_block", "packed_workspace", "pair_lower_bounds", "pairs_to_check",
           "place_bounding_spheres", "place_cover", "place_group_sphere", "place_scene_spheres",
           "place_sphere", "self_cover_gap", "sphere_gap", "tree_placements", "uncertified_from",
           "uncertified_pairs", "unpack", "workspace"]
