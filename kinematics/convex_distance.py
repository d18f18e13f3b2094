"""Distances between convex shapes, compiled: GJK with a certified lower bound (Numba).

The motion certificates (:mod:`.motion_kernels`) advance along a motion on the
distances of the few pairs the sphere bounds cannot certify; this module gives
those distances without leaving compiled code.

**Shapes.** A robot geometry is a finite point set ``P`` (its *core*) grown by a
radius ``r`` (:mod:`.hull_table`: a hull's vertices, a box's corners, a sphere's
centre, a capsule's segment ends). The shape is the set of points within ``r`` of
``conv(P)``, so its distance to another shape is the distance between the two
cores less both radii. An obstacle is read from its row of the obstacle table (:mod:`.obstacle_table`): a
box, a capsule (a segment grown by its radius), a cylinder or an exact ball (a
point grown by its radius); a ball that stands for another shape is
unsupported.

**GJK** (Gilbert, Johnson & Keerthi 1988) on the Minkowski difference
``D = A - B`` of the two cores: the point ``v`` of the current simplex closest to
the origin (Ericson, *Real-Time Collision Detection*, 5.1.5, for a triangle;
the faces the origin lies outside of, for a tetrahedron), the support point
``w = s_A(-v) - s_B(v)`` (the point of ``D`` farthest along ``-v``), ``w`` joins
the simplex. Every point ``x`` of ``D`` has ``x . v / |v| >= w . v / |v|``, so
``w . v / |v|`` is a **lower bound** of the distance between the cores (the
plane through ``w`` normal to ``v`` separates ``D`` from the origin), and ``|v|``
an upper bound. The kernel returns the largest lower bound met; it stops when
the two bounds are within :data:`GJK_ACCURACY` (m), after
:data:`GJK_ITERATIONS`, or with 0 when the simplex encloses the origin (the
cores intersect). A lower bound is what a certificate needs: rounding aside
(about 1e-15 m), it never exceeds the true distance, however the iteration
ends.

Units: metres.
"""

from __future__ import annotations

import math

import numpy as np

from .hull_table import VERTICES
from .kernel_cache import inline, leaf
from .obstacle_table import BALL, BOX, CAPSULE, CYLINDER, EXACT, KIND
from .precheck_kernels import SELF_PAIR

#: GJK stops when its upper and lower bounds of a distance are this close (m).
GJK_ACCURACY = 1e-8
#: Most GJK iterations of one distance (the bound reached is returned).
GJK_ITERATIONS = 64
#: A tetrahedron whose volume (6 V) is below this fraction of the product of its three edge lengths from
#: its first vertex is flat: its faces are searched instead of the origin being declared inside.
FLAT_TETRAHEDRON = 1e-9


@inline
def obstacle_radius(obstacles: np.ndarray, o: int) -> float:
    """The radius (m) obstacle ``o``'s core is grown by: a ball's or a capsule's radius, 0 for a box or a
    cylinder; -1 when the obstacle is not supported (a ball standing for another shape)."""
    kind = obstacles[o, KIND]
    if kind == BOX or kind == CYLINDER:
        return 0.0
    if kind == CAPSULE:
        return obstacles[o, 13]
    if kind == BALL and obstacles[o, EXACT] == 1.0:
        return obstacles[o, 13]
    return -1.0


@inline
def _support_points(points, first, end, X, j, dx, dy, dz):
    """The point of core ``points[first:end]`` (in joint ``j``'s frame, placements ``X``) farthest along the
    world direction ``d``, in the world."""
    lx = X[j, 0] * dx + X[j, 3] * dy + X[j, 6] * dz  # R^T d
    ly = X[j, 1] * dx + X[j, 4] * dy + X[j, 7] * dz
    lz = X[j, 2] * dx + X[j, 5] * dy + X[j, 8] * dz
    best, k = -math.inf, first
    for i in range(first, end):
        s = points[i, 0] * lx + points[i, 1] * ly + points[i, 2] * lz
        if s > best:
            best, k = s, i
    px, py, pz = points[k, 0], points[k, 1], points[k, 2]
    return (X[j, 9] + X[j, 0] * px + X[j, 1] * py + X[j, 2] * pz,
            X[j, 10] + X[j, 3] * px + X[j, 4] * py + X[j, 5] * pz,
            X[j, 11] + X[j, 6] * px + X[j, 7] * py + X[j, 8] * pz)


@inline
def _support_obstacle(obstacles, o, dx, dy, dz):
    """The point of obstacle ``o``'s core farthest along the world direction ``d``, in the world."""
    lx = obstacles[o, 0] * dx + obstacles[o, 3] * dy + obstacles[o, 6] * dz  # R^T d
    ly = obstacles[o, 1] * dx + obstacles[o, 4] * dy + obstacles[o, 7] * dz
    lz = obstacles[o, 2] * dx + obstacles[o, 5] * dy + obstacles[o, 8] * dz
    kind = obstacles[o, KIND]
    px, py, pz = 0.0, 0.0, 0.0
    if kind == BOX:
        px = obstacles[o, 13] if lx >= 0.0 else -obstacles[o, 13]
        py = obstacles[o, 14] if ly >= 0.0 else -obstacles[o, 14]
        pz = obstacles[o, 15] if lz >= 0.0 else -obstacles[o, 15]
    elif kind == CAPSULE:
        pz = obstacles[o, 14] if lz >= 0.0 else -obstacles[o, 14]
    elif kind == CYLINDER:
        rho = math.sqrt(lx * lx + ly * ly)
        if rho > 0.0:
            px, py = obstacles[o, 13] * lx / rho, obstacles[o, 13] * ly / rho
        pz = obstacles[o, 14] if lz >= 0.0 else -obstacles[o, 14]
    return (obstacles[o, 9] + obstacles[o, 0] * px + obstacles[o, 1] * py + obstacles[o, 2] * pz,
            obstacles[o, 10] + obstacles[o, 3] * px + obstacles[o, 4] * py + obstacles[o, 5] * pz,
            obstacles[o, 11] + obstacles[o, 6] * px + obstacles[o, 7] * py + obstacles[o, 8] * pz)


@inline
def _support_difference(points, geoms, X, a, b, obstacles, other_is_obstacle, dx, dy, dz):
    """The point of ``D = A - B`` farthest along ``d``: ``s_A(d) - s_B(-d)``; ``A`` robot geometry ``a``,
    ``B`` obstacle ``b`` or robot geometry ``b``."""
    ax, ay, az = _support_points(points, geoms[a, 1], geoms[a, 2], X, geoms[a, 3], dx, dy, dz)
    if other_is_obstacle:
        bx, by, bz = _support_obstacle(obstacles, b, -dx, -dy, -dz)
    else:
        bx, by, bz = _support_points(points, geoms[b, 1], geoms[b, 2], X, geoms[b, 3], -dx, -dy, -dz)
    return ax - bx, ay - by, az - bz


@inline
def _keep(S, T, first, m):
    """``S[:m]`` = ``T[first:first + m]`` (the points of the feature that holds the closest point)."""
    for r in range(m):
        for c in range(3):
            S[r, c] = T[first + r, c]


@inline
def _vertex(T, x, y, z):
    """The closest point is the vertex ``(x, y, z)``: it alone is the feature (``T[0]``)."""
    T[0, 0], T[0, 1], T[0, 2] = x, y, z
    return x, y, z, 1


@inline
def _on_edge(T, px, py, pz, qx, qy, qz, t):
    """The closest point is ``p + t (q - p)`` on edge ``p q``: the edge is the feature (``T[:2]``)."""
    T[0, 0], T[0, 1], T[0, 2] = px, py, pz
    T[1, 0], T[1, 1], T[1, 2] = qx, qy, qz
    return px + t * (qx - px), py + t * (qy - py), pz + t * (qz - pz), 2


@leaf
def closest_on_triangle(S: np.ndarray, T: np.ndarray, i: int, j: int, k: int) -> tuple:
    """The point of triangle ``S[i], S[j], S[k]`` closest to the origin (Ericson 5.1.5): ``(x, y, z, m)``,
    and the ``m`` vertices of the feature it lies on (vertex, edge or face) written into ``T[:m]``."""
    ax, ay, az = S[i, 0], S[i, 1], S[i, 2]
    bx, by, bz = S[j, 0], S[j, 1], S[j, 2]
    cx, cy, cz = S[k, 0], S[k, 1], S[k, 2]
    abx, aby, abz = bx - ax, by - ay, bz - az
    acx, acy, acz = cx - ax, cy - ay, cz - az
    d1 = -(abx * ax + aby * ay + abz * az)
    d2 = -(acx * ax + acy * ay + acz * az)
    if d1 <= 0.0 and d2 <= 0.0:
        return _vertex(T, ax, ay, az)
    d3 = -(abx * bx + aby * by + abz * bz)
    d4 = -(acx * bx + acy * by + acz * bz)
    if d3 >= 0.0 and d4 <= d3:
        return _vertex(T, bx, by, bz)
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        return _on_edge(T, ax, ay, az, bx, by, bz, d1 / (d1 - d3))
    d5 = -(abx * cx + aby * cy + abz * cz)
    d6 = -(acx * cx + acy * cy + acz * cz)
    if d6 >= 0.0 and d5 <= d6:
        return _vertex(T, cx, cy, cz)
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        return _on_edge(T, ax, ay, az, cx, cy, cz, d2 / (d2 - d6))
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and d4 - d3 >= 0.0 and d5 - d6 >= 0.0:
        return _on_edge(T, bx, by, bz, cx, cy, cz, (d4 - d3) / ((d4 - d3) + (d5 - d6)))
    den = va + vb + vc
    if not den > 0.0:  # a degenerate (flat) triangle: its first vertex
        return _vertex(T, ax, ay, az)
    v, w = vb / den, vc / den
    T[0, 0], T[0, 1], T[0, 2] = ax, ay, az
    T[1, 0], T[1, 1], T[1, 2] = bx, by, bz
    T[2, 0], T[2, 1], T[2, 2] = cx, cy, cz
    return ax + abx * v + acx * w, ay + aby * v + acy * w, az + abz * v + acz * w, 3


@inline
def _closest_on_segment(S):
    """The point of segment ``S[0], S[1]`` closest to the origin: ``(x, y, z, m)``, ``S[:m]`` its
    feature."""
    ax, ay, az = S[0, 0], S[0, 1], S[0, 2]
    ux, uy, uz = S[1, 0] - ax, S[1, 1] - ay, S[1, 2] - az
    t = -(ax * ux + ay * uy + az * uz)
    l2 = ux * ux + uy * uy + uz * uz
    if t <= 0.0 or not l2 > 0.0:
        return ax, ay, az, 1
    if t >= l2:
        S[0, 0], S[0, 1], S[0, 2] = S[1, 0], S[1, 1], S[1, 2]
        return S[0, 0], S[0, 1], S[0, 2], 1
    t /= l2
    return ax + t * ux, ay + t * uy, az + t * uz, 2


_FACES = np.array([[0, 1, 2, 3], [0, 1, 3, 2], [0, 2, 3, 1], [1, 2, 3, 0]], dtype=np.int64)
_FACES.setflags(write=False)


@inline
def _face_sides(S: np.ndarray, f: int) -> tuple[float, float, float]:
    """Face ``f`` of tetrahedron ``S[:4]`` (:data:`_FACES`: three vertices ``i, j, k`` and the fourth ``o``)
    with normal ``n = (S[j] - S[i]) x (S[k] - S[i])``: ``(n . (0 - S[i]), n . (S[o] - S[i]), |n|)``, the
    origin's and the fourth vertex's sides of its plane (same sign: same side) and the normal's length."""
    i, j, k, o = _FACES[f, 0], _FACES[f, 1], _FACES[f, 2], _FACES[f, 3]
    ux, uy, uz = S[j, 0] - S[i, 0], S[j, 1] - S[i, 1], S[j, 2] - S[i, 2]
    wx, wy, wz = S[k, 0] - S[i, 0], S[k, 1] - S[i, 1], S[k, 2] - S[i, 2]
    nx, ny, nz = uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx
    side_origin = -(nx * S[i, 0] + ny * S[i, 1] + nz * S[i, 2])
    side_o = nx * (S[o, 0] - S[i, 0]) + ny * (S[o, 1] - S[i, 1]) + nz * (S[o, 2] - S[i, 2])
    return side_origin, side_o, math.sqrt(nx * nx + ny * ny + nz * nz)


@leaf
def closest_on_simplex(S: np.ndarray, n: int, T: np.ndarray) -> tuple:
    """The point of simplex ``S[:n]`` (1 to 4 points) closest to the origin: ``(x, y, z, m)`` with
    ``S[:m]`` reduced to the points of its feature; ``m = 4`` when the tetrahedron encloses the origin
    (``T``: scratch, at least 7 rows)."""
    if n == 1:
        return S[0, 0], S[0, 1], S[0, 2], 1
    if n == 2:
        return _closest_on_segment(S)
    if n == 3:
        x, y, z, m = closest_on_triangle(S, T, 0, 1, 2)
        _keep(S, T, 0, m)
        return x, y, z, m
    # tetrahedron: the closest point lies on a face the origin is outside of, or the origin is inside
    e1x, e1y, e1z = S[1, 0] - S[0, 0], S[1, 1] - S[0, 1], S[1, 2] - S[0, 2]
    e2x, e2y, e2z = S[2, 0] - S[0, 0], S[2, 1] - S[0, 1], S[2, 2] - S[0, 2]
    e3x, e3y, e3z = S[3, 0] - S[0, 0], S[3, 1] - S[0, 1], S[3, 2] - S[0, 2]
    volume = e1x * (e2y * e3z - e2z * e3y) - e1y * (e2x * e3z - e2z * e3x) + e1z * (e2x * e3y - e2y * e3x)
    scale = (math.sqrt(e1x * e1x + e1y * e1y + e1z * e1z) * math.sqrt(e2x * e2x + e2y * e2y + e2z * e2z)
             * math.sqrt(e3x * e3x + e3y * e3y + e3z * e3z))
    flat = not abs(volume) > FLAT_TETRAHEDRON * scale
    best, bx, by, bz, bm = math.inf, 0.0, 0.0, 0.0, 0
    for f in range(4):
        i, j, k = _FACES[f, 0], _FACES[f, 1], _FACES[f, 2]
        # is the origin on the other side of face (i, j, k) than the fourth vertex?
        side_origin, side_o, _ = _face_sides(S, f)
        if not flat and side_origin * side_o >= 0.0:
            continue
        x, y, z, m = closest_on_triangle(S, T, i, j, k)
        d2 = x * x + y * y + z * z
        if d2 < best:
            best, bx, by, bz, bm = d2, x, y, z, m
            for r in range(m):
                for c in range(3):
                    T[4 + r, c] = T[r, c]
    if bm == 0:
        return 0.0, 0.0, 0.0, 4
    _keep(S, T, 4, bm)
    return bx, by, bz, bm


@leaf
def core_distance_bound(points: np.ndarray, geoms: np.ndarray, X: np.ndarray, a: int, b: int,
                        obstacles: np.ndarray, other_is_obstacle: bool, S: np.ndarray, T: np.ndarray,
                        guess: np.ndarray, above: float, below: float) -> float:
    """A lower bound (m) of the distance between the core of robot geometry ``a`` and that of obstacle
    ``b`` (``other_is_obstacle``) or robot geometry ``b``, at the joint placements ``X`` (module docstring:
    GJK's largest lower bound, 0 when the cores intersect). ``points``, ``geoms``: the
    :class:`~.hull_table.HullTable`'s; ``S``, ``T``: scratch ``(4, 3)`` and ``(7, 3)``; ``guess`` ``(3,)``:
    the direction to start from (the last call's closest point of ``A - B`` for a nearby configuration:
    GJK then needs few iterations; zeros: any), overwritten with this call's, whose norm is an **upper
    bound** of the distance between the cores (a point of ``A - B``; zeros when they intersect). ``above``
    and ``below`` (m) end the iteration early, for a caller that asks only whether the distance exceeds a
    threshold: it stops once the lower bound exceeds ``above`` or the upper bound is at most ``below``
    (``inf`` and ``-inf``: the accuracy alone ends it). When it ends on intersecting cores (``guess`` zeros),
    ``S`` holds the tetrahedron of ``A - B`` that encloses the origin, or NaN in its last row when there is
    none (:func:`enclosed_depth` reads it)."""
    gx, gy, gz = guess[0], guess[1], guess[2]
    if not gx * gx + gy * gy + gz * gz > 0.0:
        gx, gy, gz = 1.0, 0.0, 0.0
    vx, vy, vz = _support_difference(points, geoms, X, a, b, obstacles, other_is_obstacle, -gx, -gy, -gz)
    S[0, 0], S[0, 1], S[0, 2] = vx, vy, vz
    n = 1
    lower = -math.inf
    for _ in range(GJK_ITERATIONS):
        vn = math.sqrt(vx * vx + vy * vy + vz * vz)
        guess[0], guess[1], guess[2] = vx, vy, vz
        if not vn > 0.0:  # the origin on the simplex: no enclosing tetrahedron in S (NaN marks it)
            S[3, 0] = math.nan
            return 0.0
        if vn <= below:
            return lower
        wx, wy, wz = _support_difference(points, geoms, X, a, b, obstacles, other_is_obstacle, -vx, -vy, -vz)
        bound = (vx * wx + vy * wy + vz * wz) / vn
        if bound > lower:
            lower = bound
        if vn - lower <= GJK_ACCURACY or lower > above:
            return lower
        S[n, 0], S[n, 1], S[n, 2] = wx, wy, wz
        vx, vy, vz, n = closest_on_simplex(S, n + 1, T)
        if n == 4:
            guess[0], guess[1], guess[2] = 0.0, 0.0, 0.0
            return min(lower, 0.0)
    return lower


@inline
def enclosed_depth(S: np.ndarray) -> float:
    """How deep (m) the origin lies inside the tetrahedron ``S[:4]``: its distance to the nearest face plane,
    0 when it is not strictly inside (or the tetrahedron is flat, or holds NaN). For a tetrahedron of points
    of ``A - B`` (:func:`core_distance_bound`'s, on intersecting cores) this is a **lower bound of the
    penetration depth**: the ball of that radius about the origin lies in ``conv(A - B)``, so ``A`` must
    move at least that far to leave ``B``."""
    depth = math.inf
    for f in range(4):
        side_origin, side_o, norm = _face_sides(S, f)
        if not (side_origin * side_o > 0.0 and norm > 0.0):
            return 0.0
        depth = min(depth, abs(side_origin) / norm)
    return depth


@inline
def pair_measured(hull_geoms: np.ndarray, pairs: np.ndarray, obstacles: np.ndarray, p: int) -> bool:
    """Whether row ``p`` of the pre-check's pair table joins two shapes this module measures: a robot
    geometry with a core (:data:`~.hull_table.VERTICES`) and another one, or an obstacle
    :func:`obstacle_radius` supports."""
    if hull_geoms[pairs[p, 0], 0] != VERTICES:
        return False
    if pairs[p, 2] == SELF_PAIR:
        return hull_geoms[pairs[p, 1], 0] == VERTICES
    return obstacle_radius(obstacles, pairs[p, 1]) >= 0.0


@inline
def pair_distance_bounds(points: np.ndarray, hull_geoms: np.ndarray, radius: np.ndarray, pairs: np.ndarray,
                         obstacles: np.ndarray, p: int, X: np.ndarray, S: np.ndarray, T: np.ndarray,
                         guess: np.ndarray, above: float, below: float) -> tuple[float, float]:
    """``(lower, upper)`` bounds (m) of the distance between the two shapes of pair-table row ``p`` at the
    joint placements ``X``: :func:`core_distance_bound` and the norm it leaves in ``guess`` (its start,
    overwritten), less the radii the cores are grown by; ``(nan, nan)`` when the pair is not
    :func:`pair_measured`. ``points, hull_geoms, radius``: the :class:`~.hull_table.HullTable`. ``above``,
    ``below`` (m, between the shapes): :func:`core_distance_bound`'s early ends (``inf``, ``-inf``: none)."""
    if not pair_measured(hull_geoms, pairs, obstacles, p):
        return math.nan, math.nan
    a, b = pairs[p, 0], pairs[p, 1]
    own = pairs[p, 2] == SELF_PAIR
    grown = radius[a] + (radius[b] if own else obstacle_radius(obstacles, b))
    lower = core_distance_bound(points, hull_geoms, X, a, b, obstacles, not own, S, T, guess, above + grown,
                                below + grown)
    upper = math.sqrt(guess[0] * guess[0] + guess[1] * guess[1] + guess[2] * guess[2])
    return lower - grown, upper - grown


__all__ = ["FLAT_TETRAHEDRON", "GJK_ACCURACY", "GJK_ITERATIONS", "closest_on_simplex", "closest_on_triangle",
           "core_distance_bound", "enclosed_depth", "obstacle_radius", "pair_distance_bounds",
           "pair_measured"]
