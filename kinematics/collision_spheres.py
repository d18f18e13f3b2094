"""A conservative pre-check of the collision scenes, compiled: spheres that contain the robot's geometry.

A configuration is **certified collision free** when a lower bound of the
distance of every checked pair of a :class:`~.collision_scene.CollisionScene`
exceeds :data:`TOLERANCE`; coal then need not run on it. The bounds come from
spheres fixed in the joint frames that *contain* each robot geometry, so a
certified configuration is always one coal finds free; a configuration that is
not certified may still be free (coal decides).

**Covers** (built once per robot, in Python; every sphere's radius is the
distance from its centre to the farthest point it must hold, so containment is
exact up to rounding, padded by :data:`PAD`):

* a convex polytope (a coal ``Convex`` - the robot's mesh hulls - or a
  ``Box``) with vertices ``V``: the principal axis ``a`` of ``V`` (eigenvector
  of the largest eigenvalue of the vertex scatter) through the vertex centroid
  ``m``; the projections ``s = a . (v - m)`` from ``s_min`` to ``s_max`` cut
  into ``k`` slabs of equal length,
  ``k = ceil((s_max - s_min) / (SLAB_RATIO * R))`` clipped to
  ``[1, MAX_COVER_SPHERES]``, ``R`` the largest vertex distance from the axis.
  The part of the polytope inside a slab is the convex hull of the vertices
  in the slab and of the points where the polytope's edges cross the slab's two
  planes; a ball contains a convex set exactly when it contains its extreme
  points, so the slab's sphere gets the radius of the farthest of those
  points from its centre. Those points are taken from the crossings of
  *every* pair of vertices with the planes (a superset of the edges: no trust
  in a triangulation); the centre itself is placed by a Badoiu-Clarkson
  search for the smallest enclosing ball of the crossings of coal's hull
  triangle sides (fewer points);
* a sphere: itself; a cylinder of radius ``r`` and half length ``L``: ``k``
  slabs of half length ``h = L / k`` along its axis, spheres of radius
  ``sqrt(r^2 + h^2)`` at the slab centres; a capsule: the same for its
  cylinder plus a ball of radius ``r`` at each end of its segment;
* any other coal geometry: the sphere of its local AABB (``computeLocalAABB``,
  ``aabb_center``, ``aabb_radius``), one for the whole shape.

Each geometry also gets one **bounding sphere** (the same construction with a
single slab) tested first; its cover spheres are tested only when the
bounding spheres of a pair are not apart. A coal swept-sphere radius is added
to every radius.

**Lower bounds** for a sphere of centre ``c``, radius ``rho``:

* against a sphere of the robot (``c'``, ``rho'``): ``|c - c'| - rho - rho'``;
* against an obstacle, with ``p = R^T (c - t)`` the centre in the obstacle's
  frame (exact point distances minus ``rho``): sphere of radius ``r``
  ``|p| - r - rho``; box of half extents ``h`` ``|max(|p| - h, 0)| - rho``;
  capsule (segment ``z`` in ``[-L, L]``) ``|p - (0, 0, clip(p_z, -L, L))| - r - rho``;
  cylinder ``|(max(sqrt(p_x^2 + p_y^2) - r, 0), max(|p_z| - L, 0))| - rho``;
  any other shape: its AABB sphere, as a sphere.

**Certain collisions** (the other verdict, for configurations not certified): each robot geometry also
gets points *inside* it (:func:`geometry_inner_points`: the mean of each slab's points for a hull, axis
points for a cylinder or capsule, the centre of a sphere or box); when one of them lies deeper than
:data:`TOLERANCE` inside an obstacle whose exact distance the table has, the two shapes share that point
and coal would report the collision: :func:`certainly_colliding` answers without it (on the Panda, 95 % of
the unconstrained answers put in collision by a 10 cm box on their elbow).

**The kernels** (:func:`certify_configuration` for one configuration,
:func:`first_uncertified` and :func:`certify_configurations` over a batch in
one call; Numba) run the forward kinematics of the whole tree
(:func:`~.serial_chain.kinematic_tree`; joint ``j``'s world placement
``oMj = oM(parent) * Mj * exp(a_j q_j)``, as :mod:`kinserve.ik.lm.kernel`),
move the bounding spheres to the world (``c_world = oMj * c``; joint 0 is the
world) - a geometry's cover spheres only when one of its pairs needs them -
and test the scene's pairs, obstacle pairs first (a configuration in
collision usually hits an obstacle), stopping at the first pair they cannot
certify. Their arguments are two flat arrays (:func:`pack`: a compiled call
costs ~50 ns per array argument), the robot half packed once per layout, the
obstacle rows added per scene (:func:`placed_floats`). Each call allocates
its own workspace: one kernel may run on many threads at once. Everything
the kernels call is in this file (Numba's on-disk cache is keyed by the
file). Measured on the Panda with the table and wall (76 pairs, 70 spheres):
~0.7 us per configuration in a batch, ~1.5 us for ``in_collision`` on a
certified configuration (coal: ~4 us).

Units: metres and radians.
"""

from __future__ import annotations

import math
import threading
import weakref
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import coal
import numba
import numpy as np
import pinocchio as pin

from .serial_chain import REVOLUTE as _REVOLUTE
from .serial_chain import kinematic_tree

if TYPE_CHECKING:
    from .collision_model import CollisionModel

#: A pair is certified free when its distance lower bound exceeds this (m): ten times coal's GJK tolerance, so
#: that coal's contact test, whose distances are exact to about 1e-6 m on these shapes, agrees.
TOLERANCE = 1e-5
#: Padding (m) added to every cover radius (rounding of the slab points and of the enclosing-ball distances).
PAD = 1e-9
#: Largest number of cover spheres per robot geometry (pairs of geometries cost up to its square).
MAX_COVER_SPHERES = 6
#: Slab length of a cover, as a multiple of the geometry's radius about its axis (1: the sphere of a slab of a
#: cylinder of radius R is at most sqrt(1.25) R).
SLAB_RATIO = 1.0
#: Iterations of the Badoiu-Clarkson enclosing-ball search.
BALL_ITERATIONS = 64

#: Obstacle kinds of the obstacle table (column :data:`KIND` of a row).
BALL, BOX, CAPSULE, CYLINDER = 0, 1, 2, 3
#: Columns of an obstacle row: rotation (row-major) 0-8, translation 9-11, kind 12, sizes 13-15 (a BALL: its
#: radius, then :data:`EXACT`).
KIND = 12
#: Column of a BALL row: 1 when the ball is the obstacle itself, 0 when it stands for a shape without a closed
#: form (its AABB sphere: a point inside it need not be inside the shape). Other kinds are always exact.
EXACT = 14
#: Pair kinds of the pair table (column 2).
SELF_PAIR, OBSTACLE_PAIR = 0, 1


# ====================================================================== covers (Python, once per robot)
def enclosing_ball(points: np.ndarray, contain: np.ndarray | None = None) -> np.ndarray:
    """``(cx, cy, cz, r)``: a ball containing every point of ``contain`` ``(m, 3)`` (default ``points``), its
    centre placed for ``points`` ``(n, 3)`` (near the centre of their smallest enclosing ball).

    The centre starts at the points' bounding-box centre and moves by Badoiu-Clarkson steps (a
    ``1 / (i + 1)`` step towards the farthest point); the best centre seen is kept. The radius is the exact
    largest distance from it to the points of ``contain``, plus :data:`PAD`: containment never depends on
    the search.
    """
    P = np.asarray(points, dtype=float)
    c = 0.5 * (P.min(axis=0) + P.max(axis=0))
    best_c, best_r = c, math.inf
    for i in range(1, BALL_ITERATIONS + 1):
        d2 = ((P - c) ** 2).sum(axis=1)
        far = int(d2.argmax())
        if d2[far] < best_r:
            best_c, best_r = c, float(d2[far])
        c = c + (P[far] - c) / (i + 1)
    Q = P if contain is None else np.asarray(contain, dtype=float)
    r = math.sqrt(float(((Q - best_c) ** 2).sum(axis=1).max()))
    return np.array([*best_c, r * (1.0 + 1e-12) + PAD])


def triangle_sides(triangles: np.ndarray) -> np.ndarray:
    """The distinct sides ``(E, 2)`` (vertex index pairs) of ``triangles`` ``(F, 3)``."""
    T = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    sides = np.sort(np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]]), axis=1)
    return np.unique(sides, axis=0)


def _slab_points(V: np.ndarray, s: np.ndarray, edges: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """The vertices with ``lo <= s <= hi`` and the points where the segments ``edges`` cross ``s = lo`` and
    ``s = hi`` (``s``: the vertices' projections on the axis)."""
    out = [V[(s >= lo) & (s <= hi)]]
    i, j = edges[:, 0], edges[:, 1]
    for plane in (lo, hi):
        si, sj = s[i] - plane, s[j] - plane
        cross = si * sj < 0.0
        t = si[cross] / (si[cross] - sj[cross])
        out.append(V[i[cross]] + t[:, None] * (V[j[cross]] - V[i[cross]]))
    return np.concatenate(out)


def _slab_planes(V: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(s, planes, every_pair)`` of a vertex set ``V`` ``(n, 3)``: the projections on the principal axis, the
    ``k + 1`` slab planes along it (module docstring) and every vertex pair ``(n (n - 1) / 2, 2)``."""
    X = V - V.mean(axis=0)
    _, U = np.linalg.eigh(X.T @ X)
    a = U[:, -1]
    s = X @ a
    R = float(np.linalg.norm(X - np.outer(s, a), axis=1).max())
    lo, hi = float(s.min()), float(s.max())
    k = int(np.clip(math.ceil((hi - lo) / max(SLAB_RATIO * R, 1e-12)), 1, MAX_COVER_SPHERES))
    planes = lo + (hi - lo) * np.arange(k + 1) / k
    planes[0], planes[-1] = lo, hi
    return s, planes, np.array(np.triu_indices(len(V), 1)).T


def polytope_cover(vertices: np.ndarray, triangles: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(bounding (4,), cover (k, 4))`` spheres ``(centre, radius)`` containing the convex hull of ``vertices``
    ``(n, 3)``, in the vertices' frame (module docstring: slabs along the principal axis).

    Each slab's sphere contains the vertices in the slab and the crossings of *every* vertex pair with the
    slab's planes - a superset of the extreme points of the hull's part in the slab, whatever the hull's
    edges are; ``triangles`` (the hull's faces, e.g. coal's, optional) only place the centre, on the
    crossings of their sides (fewer points, the same hull).
    """
    return _polytope_slabs(np.asarray(vertices, dtype=float), triangles)[:2]


def polytope_inner_points(vertices: np.ndarray) -> np.ndarray:
    """Points ``(k, 3)`` inside the convex hull of ``vertices``, one per slab of :func:`polytope_cover`: the mean
    of the slab's points (its vertices and the crossings of every vertex pair with its planes, all in the
    hull; a mean of points of a convex set lies in it)."""
    return _polytope_slabs(np.asarray(vertices, dtype=float), None)[2]


def _polytope_slabs(V: np.ndarray, triangles: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(bounding, cover, inner)`` of :func:`polytope_cover` and :func:`polytope_inner_points`, each slab's
    points computed once."""
    s, planes, every_pair = _slab_planes(V)
    sides = None if triangles is None else triangle_sides(triangles)
    cover, inner = [], []
    for lo, hi in zip(planes[:-1], planes[1:]):
        points = _slab_points(V, s, every_pair, lo, hi)
        cover.append(enclosing_ball(points if sides is None else _slab_points(V, s, sides, lo, hi), points))
        inner.append(points.mean(axis=0))
    return enclosing_ball(V), np.array(cover), np.array(inner)


def geometry_inner_points(geometry: coal.CollisionGeometry) -> np.ndarray:
    """Points ``(k, 3)`` inside a coal geometry, in its own frame (``(0, 3)`` for a shape without a closed
    form): the centre of a sphere or box, the slab centres of a cylinder or capsule's axis, the slab means of
    :func:`polytope_inner_points` for a convex hull. A point inside an obstacle is a collision for certain
    (:func:`certainly_colliding`)."""
    return geometry_spheres(geometry)[2]


def _axis_cover(radius: float, half_length: float, end_balls: bool) -> tuple[np.ndarray, np.ndarray]:
    """Spheres of a cylinder (``end_balls``: capsule) of ``radius`` along local z from ``-half_length`` to
    ``+half_length``: slabs of half length ``h``, radius ``sqrt(radius^2 + h^2)``; a capsule adds its end balls."""
    r, L = float(radius), float(half_length)
    k = int(np.clip(math.ceil(2.0 * L / max(SLAB_RATIO * r, 1e-12)), 1, MAX_COVER_SPHERES))
    h = L / k
    z = -L + h * (2 * np.arange(k) + 1)
    cover = [np.array([0.0, 0.0, zi, math.hypot(r, h) + PAD]) for zi in z]
    if end_balls:
        cover += [np.array([0.0, 0.0, -L, r + PAD]), np.array([0.0, 0.0, L, r + PAD])]
        bounding = np.array([0.0, 0.0, 0.0, L + r + PAD])
    else:
        bounding = np.array([0.0, 0.0, 0.0, math.hypot(r, L) + PAD])
    return bounding, np.array(cover)


def aabb_sphere(geometry: coal.CollisionGeometry) -> np.ndarray:
    """``(centre, radius)`` of coal's local AABB sphere of ``geometry`` (computed when missing)."""
    if geometry.aabb_radius < 0.0:
        geometry.computeLocalAABB()
    return np.array([*np.asarray(geometry.aabb_center, dtype=float), float(geometry.aabb_radius) + PAD])


def geometry_cover(geometry: coal.CollisionGeometry) -> tuple[np.ndarray, np.ndarray]:
    """``(bounding (4,), cover (k, 4))`` spheres (centre, radius; m) containing a coal geometry, in its own frame."""
    return geometry_spheres(geometry)[:2]


def geometry_spheres(geometry: coal.CollisionGeometry) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(bounding, cover, inner)``: :func:`geometry_cover`'s spheres and :func:`geometry_inner_points`'s
    points of a coal geometry in one pass (a hull's slabs are cut once)."""
    inner = np.zeros((0, 3))
    if isinstance(geometry, coal.Sphere):
        ball = np.array([0.0, 0.0, 0.0, float(geometry.radius) + PAD])
        bounding, cover, inner = ball, ball[None, :], np.zeros((1, 3))
    elif isinstance(geometry, coal.Box):
        h = np.asarray(geometry.halfSide, dtype=float)
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * h
        bounding, cover = polytope_cover(corners)
        inner = np.zeros((1, 3))
    elif isinstance(geometry, (coal.Capsule, coal.Cylinder)):
        bounding, cover = _axis_cover(geometry.radius, geometry.halfLength, isinstance(geometry, coal.Capsule))
        inner = _axis_cover(geometry.radius, geometry.halfLength, False)[1][:, :3].copy()
    elif isinstance(geometry, coal.Convex) and geometry.num_points >= 4:
        V = np.asarray(geometry.points(), dtype=float)
        triangles = [list(geometry.polygons(i)[k] for k in range(3)) for i in range(geometry.num_polygons)]
        bounding, cover, inner = _polytope_slabs(V, np.array(triangles, dtype=np.int64) if triangles else None)
    else:
        bounding = aabb_sphere(geometry)
        cover = bounding[None, :]
    swept = float(geometry.getSweptSphereRadius())
    if swept > 0.0:
        bounding, cover = bounding + [0, 0, 0, swept], cover + [0, 0, 0, swept]
    return bounding, cover, inner


def _moved(spheres: np.ndarray, placement: pin.SE3) -> np.ndarray:
    """Spheres ``(n, 4)`` moved by ``placement`` (centres; radii unchanged)."""
    out = spheres.copy()
    out[:, :3] = spheres[:, :3] @ placement.rotation.T + placement.translation
    return out


@dataclass(frozen=True)
class RobotSpheres:
    """The robot half of the pre-check: its kinematic tree and the spheres of every geometry.

    * ``tree``, ``joints``: :func:`~.serial_chain.kinematic_tree`;
    * ``spheres`` ``(G + S, 4)``: centre in the geometry's joint frame and radius (m); row ``g < G`` is
      geometry ``g``'s bounding sphere, the cover spheres follow;
    * ``geoms`` ``(G, 3)`` integers: the geometry's Pinocchio joint (0 = fixed in the world), first and
      end row of its cover spheres in ``spheres``;
    * ``inner`` ``(I, 3)``: points inside the geometries (:func:`geometry_inner_points`) in their joint
      frames, ``inner_ranges`` ``(G, 2)`` the first and end row of each geometry's;
    * ``reach`` ``(J,)``: per joint, a bound (m per unit of the joint's coordinate) of how far a change of
      that coordinate moves any sphere centre (:func:`joint_reach`).
    """

    tree: np.ndarray
    joints: np.ndarray
    spheres: np.ndarray
    geoms: np.ndarray
    inner: np.ndarray
    inner_ranges: np.ndarray
    reach: np.ndarray


#: Stands for an unbounded reach (a prismatic joint without limits below a revolute one): finite, so that a
#: zero change of that joint's coordinate still contributes zero.
UNBOUNDED_REACH = 1e30


def joint_reach(tree: np.ndarray, joints: np.ndarray, spheres: np.ndarray, geoms: np.ndarray,
                lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """``R`` ``(J,)``: changing joint ``k``'s coordinate by ``dq`` moves no sphere centre farther than
    ``R[k] |dq|`` (m), whatever the other coordinates; so ``sum_k R[k] |q'_k - q_k|`` bounds every centre's
    displacement between ``q`` and ``q'`` (change the coordinates one at a time: triangle inequality).

    Revolute ``k``: a centre turns about the joint's axis, which passes through the joint's origin, along an
    arc of radius at most its distance to that origin, itself at most the centre's offset in its own joint
    frame plus the offsets ``|t_m|`` of the joints ``m`` on the path down to that frame (plus the largest
    travel ``max(|lower|, |upper|)`` of a prismatic joint on it; :data:`UNBOUNDED_REACH` without limits).
    Prismatic ``k``: everything below translates by exactly ``|dq|``: ``R[k] = 1``. ``lower``, ``upper``: the
    model's limits, indexed by the joints' configuration index (``joints[:, 1]``).
    """
    J = len(joints)
    reach = np.zeros(J)
    for g in range(len(geoms)):
        row = int(geoms[g, 0])  # the geometry's joint (placement row; 0 = the world)
        rows = [g, *range(int(geoms[g, 1]), int(geoms[g, 2]))]
        offset = max(float(np.linalg.norm(spheres[s, :3])) for s in rows)
        while row > 0:
            k = row - 1
            if joints[k, 0] != _REVOLUTE:
                reach[k] = max(reach[k], 1.0)
                travel = max(abs(float(lower[joints[k, 1]])), abs(float(upper[joints[k, 1]])))
                offset += travel if math.isfinite(travel) else UNBOUNDED_REACH
            else:
                reach[k] = max(reach[k], offset)
            offset += float(np.linalg.norm(tree[k, 9:12]))
            row = int(joints[k, 2])
    return np.minimum(reach, UNBOUNDED_REACH)


def robot_spheres(model: pin.Model, geometry: pin.GeometryModel) -> RobotSpheres | None:
    """The :class:`RobotSpheres` of a model and its collision ``GeometryModel``; None when the tree has other
    joints than one-DoF revolute / prismatic ones or a cover is not finite (e.g. a half-space)."""
    packed = kinematic_tree(model)
    if packed is None:
        return None
    bounds, covers, joints, inner = [], [], [], []
    for g in geometry.geometryObjects:
        bounding, cover, points = geometry_spheres(g.geometry)
        bounds.append(_moved(bounding[None, :], g.placement)[0])
        covers.append(_moved(cover, g.placement))
        joints.append(int(g.parentJoint))
        inner.append(points @ g.placement.rotation.T + g.placement.translation if len(points) else points)
    G = len(bounds)
    spheres = np.concatenate([np.array(bounds).reshape(-1, 4), *covers]) if G else np.zeros((0, 4))
    if not np.all(np.isfinite(spheres)):
        return None
    ends = G + np.cumsum([len(c) for c in covers], dtype=np.int64)
    geoms = np.column_stack([np.array(joints, dtype=np.int64), ends - [len(c) for c in covers], ends]) \
        if G else np.zeros((0, 3), dtype=np.int64)
    inner_ends = np.cumsum([len(p) for p in inner], dtype=np.int64)
    inner_ranges = np.column_stack([inner_ends - [len(p) for p in inner], inner_ends]) if G \
        else np.zeros((0, 2), dtype=np.int64)
    points = np.concatenate(inner).reshape(-1, 3) if G else np.zeros((0, 3))
    if not np.all(np.isfinite(points)):
        return None
    reach = joint_reach(packed[0], packed[1], spheres, geoms, model.lowerPositionLimit, model.upperPositionLimit)
    return RobotSpheres(packed[0], packed[1], np.ascontiguousarray(spheres), np.ascontiguousarray(geoms),
                        np.ascontiguousarray(points), np.ascontiguousarray(inner_ranges.astype(np.int64)), reach)


_ROBOTS: "weakref.WeakKeyDictionary[CollisionModel, RobotSpheres | None]" = weakref.WeakKeyDictionary()
_ROBOTS_LOCK = threading.Lock()


def robot_spheres_of(cmodel: "CollisionModel") -> RobotSpheres | None:
    """:func:`robot_spheres` of a :class:`~.collision_model.CollisionModel` (its hull geometry), built once per
    model (a weak reference to it keys the cache)."""
    with _ROBOTS_LOCK:
        if cmodel in _ROBOTS:
            return _ROBOTS[cmodel]
    value = robot_spheres(cmodel.model, cmodel.geometry)
    with _ROBOTS_LOCK:
        _ROBOTS[cmodel] = value
    return value


def obstacle_template(geometry: coal.CollisionGeometry) -> tuple[np.ndarray, np.ndarray]:
    """``(row (16,), centre (3,))``: the obstacle table row of a coal geometry before its pose (kind and sizes;
    module docstring's bounds) and the point of its frame that the row's translation must hold (zero, or
    the centre of the AABB sphere that stands for a shape without a closed form)."""
    row = np.zeros(16)
    centre = np.zeros(3)
    swept = float(geometry.getSweptSphereRadius())
    if swept == 0.0 and isinstance(geometry, coal.Box):
        row[KIND], row[13:16] = BOX, np.asarray(geometry.halfSide, dtype=float)
    elif swept == 0.0 and isinstance(geometry, (coal.Capsule, coal.Cylinder)):
        row[KIND] = CAPSULE if isinstance(geometry, coal.Capsule) else CYLINDER
        row[13], row[14] = float(geometry.radius), float(geometry.halfLength)
    elif isinstance(geometry, coal.Sphere):
        row[KIND], row[13], row[EXACT] = BALL, float(geometry.radius) + swept, 1.0
    else:
        ball = aabb_sphere(geometry)
        row[KIND], row[13], centre = BALL, ball[3] + swept, ball[:3]
    return row, centre


def obstacle_rows(templates: np.ndarray, centres: np.ndarray, poses: Any) -> np.ndarray:
    """The obstacle table ``(O, 16)``: the rows of :func:`obstacle_template` placed at ``poses`` (``O`` 4x4
    world poses): rotation (row-major) and translation ``t + R centre`` (:func:`placed_floats`)."""
    P = np.ascontiguousarray(np.asarray(poses, dtype=float).reshape(-1, 4, 4))
    return placed_floats(np.zeros(0), templates, centres, P).reshape(-1, 16)


def obstacle_row(geometry: coal.CollisionGeometry, placement: pin.SE3) -> np.ndarray:
    """The obstacle table row ``(16,)`` of a coal geometry at ``placement``: rotation, translation, kind, sizes."""
    row, centre = obstacle_template(geometry)
    return obstacle_rows(row[None, :], centre[None, :], placement.homogeneous[None])[0]


def pack(robot: RobotSpheres, pairs: np.ndarray, obstacles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The kernels' two arguments ``(floats, ints)``, flat (a compiled call costs ~50 ns per array argument):

    * ``floats``: ``tree`` ``(J, 15)``, ``reach`` ``(J,)``, ``spheres`` ``(S, 4)`` (the robot's spheres, then its
      inner points with radius 0), ``obstacles`` ``(O, 16)``, row-major, in turn;
    * ``ints``: ``(J, S, G, P, O)``, then ``joints`` ``(J, 3)``, ``geoms`` ``(G, 5)`` (joint, first and end
      cover row, first and end inner point row), ``pairs`` ``(P, 4)``.

    :func:`_unpack` gives the arrays back inside the kernels (views, no copy).
    """
    n_spheres = len(robot.spheres)
    rows = np.concatenate([robot.spheres, np.column_stack([robot.inner, np.zeros(len(robot.inner))])])
    geoms = np.column_stack([robot.geoms, robot.inner_ranges + n_spheres]).astype(np.int64)
    J, S, G, P, O = len(robot.joints), len(rows), len(robot.geoms), len(pairs), len(obstacles)
    floats = np.concatenate([robot.tree.ravel(), robot.reach, rows.ravel(), np.asarray(obstacles, dtype=float).ravel()])
    ints = np.concatenate([np.array([J, S, G, P, O], dtype=np.int64), robot.joints.ravel(), geoms.ravel(),
                           np.asarray(pairs, dtype=np.int64).ravel()])
    return floats, ints


class ScenePrecheck:
    """The pre-check of one :class:`~.collision_layout.SceneLayout`: the robot's spheres, the layout's pair
    table ``(P, 4)`` (robot geometry, other geometry or obstacle index, :data:`SELF_PAIR` /
    :data:`OBSTACLE_PAIR`, index of the pair in the scene) and its obstacle geometries; :meth:`arguments`
    adds a scene's obstacle poses."""

    def __init__(self, robot: RobotSpheres, pairs: np.ndarray, n_robot: int, obstacle_geometries: list,
                 obstacles: tuple = ()) -> None:
        self.robot = robot
        pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
        first = np.where(pairs[:, 0] < n_robot, pairs[:, 0], pairs[:, 1])  # the robot geometry first
        second = np.where(pairs[:, 0] < n_robot, pairs[:, 1], pairs[:, 0])
        obstacle = second >= n_robot
        table = np.column_stack([first, np.where(obstacle, second - n_robot, second),
                                 np.where(obstacle, OBSTACLE_PAIR, SELF_PAIR), np.arange(len(pairs))]).astype(np.int64)
        # obstacle pairs first (a configuration in collision usually hits an obstacle: found sooner), each
        # kind in the scene's order; the verdict does not depend on the order
        self.pairs = np.ascontiguousarray(table[np.argsort(~obstacle, kind="stable")])
        made = [obstacle_template(g) for g in obstacle_geometries]
        self.templates = np.array([row for row, _ in made]).reshape(-1, 16)
        self.centres = np.array([centre for _, centre in made]).reshape(-1, 3)
        # everything but the obstacle poses, packed once: a scene adds its rows (a few microseconds)
        self._robot_floats, self._ints = pack(robot, self.pairs, self.templates)
        self._robot_floats = self._robot_floats[:len(self._robot_floats) - self.templates.size]
        # the layout's own obstacles (shapes with a 4x4 ``pose``) placed once: a scene sharing some of them
        # copies their rows and places only the others
        self._reference = tuple(obstacles)
        self._reference_floats = self._floats([shape.pose for shape in obstacles]) if obstacles else None
        self._centred = ~self.centres.any(axis=1)

    def _floats(self, poses: Any) -> np.ndarray:
        P = np.asarray(poses, dtype=float).reshape(-1, 4, 4)
        return placed_floats(self._robot_floats, self.templates, self.centres, P)

    def arguments(self, obstacles: Any) -> tuple:
        """``(certify_configuration, first_uncertified, floats, ints, tolerance, certainly_colliding)`` for
        ``obstacles`` (one
        per obstacle geometry: shapes with a 4x4 world ``pose``); ``floats, ints``: :func:`pack`. The rows
        of the obstacles that are the layout's own (same objects) are copied, the others placed."""
        if self._reference_floats is None or len(obstacles) != len(self._reference):
            floats = self._floats([shape.pose for shape in obstacles])
        else:
            floats = self._reference_floats.copy()
            start = len(self._robot_floats)
            for k, (shape, own) in enumerate(zip(obstacles, self._reference)):
                if shape is not own:
                    T = shape.pose
                    row = floats[start + 16 * k:start + 16 * k + 16]
                    row[:9] = T[:3, :3].reshape(9)
                    row[9:12] = T[:3, 3] if self._centred[k] else T[:3, 3] + T[:3, :3] @ self.centres[k]
        return certify_configuration, first_uncertified, floats, self._ints, TOLERANCE, certainly_colliding


# ====================================================================== the kernel (Numba)
_jit = numba.njit(cache=True, nogil=True, error_model="numpy")
#: Small helpers are inlined into their callers at Numba's IR level (a call passes whole array structures).
_inline = numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")
_t = numba.types
_F1 = _t.Array(_t.float64, 1, "C", readonly=True)
_I1 = _t.Array(_t.int64, 1, "C", readonly=True)
_F2 = _t.Array(_t.float64, 2, "C", readonly=True)
_I2 = _t.Array(_t.int64, 2, "C", readonly=True)
_Q1 = _t.Array(_t.float64, 1, "A", readonly=True)
_Q2 = _t.Array(_t.float64, 2, "A", readonly=True)
_ONE_SIGNATURE = _t.boolean(_F1, _I1, _Q1, _t.float64)
_BATCH_SIGNATURE = _t.Array(_t.boolean, 1, "C")(_F1, _I1, _Q2, _t.float64)
_FIRST_SIGNATURE = _t.int64(_F1, _I1, _Q2, _t.int64, _t.float64)
_BOUNDS_SIGNATURE = _t.Array(_t.float64, 1, "C")(_F1, _I1, _Q1)
_PLACED_SIGNATURE = _t.Array(_t.float64, 1, "C")(_F1, _F2, _F2, _t.Array(_t.float64, 3, "A", readonly=True))


@numba.njit(_PLACED_SIGNATURE, cache=True, nogil=True, error_model="numpy")
def placed_floats(head: np.ndarray, templates: np.ndarray, centres: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """``head`` followed by the obstacle rows ``templates`` ``(O, 16)`` placed at ``poses`` ``(O, 4, 4)``:
    rotation (row-major) into columns 0-8, ``t + R centre`` into 9-11 (a scene's floats in one call)."""
    H = head.shape[0]
    out = np.empty(H + 16 * templates.shape[0])
    out[:H] = head
    for o in range(templates.shape[0]):
        row = out[H + 16 * o:H + 16 * (o + 1)]
        row[:] = templates[o]
        for i in range(3):
            for c in range(3):
                row[3 * i + c] = poses[o, i, c]
            row[9 + i] = poses[o, i, 3] + poses[o, i, 0] * centres[o, 0] + poses[o, i, 1] * centres[o, 1] \
                + poses[o, i, 2] * centres[o, 2]
    return out
_TREE_SIGNATURE = _t.void(_F2, _I2, _Q1, _t.float64[:, ::1])


@numba.njit(_TREE_SIGNATURE, cache=True, nogil=True, error_model="numpy")
def tree_placements(tree: np.ndarray, joints: np.ndarray, q: np.ndarray, X: np.ndarray) -> None:
    """World placements of every joint into ``X`` ``(J + 1, 12)``: row ``j`` = Pinocchio joint ``j``'s rotation
    (row-major) and translation, row 0 the universe (identity). ``oMj = oM(parent) * Mj * exp(a_j q_j)``."""
    for c in range(12):
        X[0, c] = 0.0
    X[0, 0] = X[0, 4] = X[0, 8] = 1.0
    for k in range(joints.shape[0]):
        g = tree[k]
        P = X[joints[k, 2]]
        out = X[k + 1]
        # out.t = P.t + P.R Mk.t ; T = P.R Mk.R (kept in out.R for now)
        for i in range(3):
            p0, p1, p2 = P[3 * i], P[3 * i + 1], P[3 * i + 2]
            out[9 + i] = P[9 + i] + p0 * g[9] + p1 * g[10] + p2 * g[11]
            for c in range(3):
                out[3 * i + c] = p0 * g[c] + p1 * g[3 + c] + p2 * g[6 + c]
        ax, ay, az = g[12], g[13], g[14]
        qk = q[joints[k, 1]]
        if joints[k, 0] == _REVOLUTE:  # R = T Rot(a, q), Rodrigues
            s, c = math.sin(qk), math.cos(qk)
            v = 1.0 - c
            r00, r01, r02 = c + v * ax * ax, v * ax * ay - s * az, v * ax * az + s * ay
            r10, r11, r12 = v * ax * ay + s * az, c + v * ay * ay, v * ay * az - s * ax
            r20, r21, r22 = v * ax * az - s * ay, v * ay * az + s * ax, c + v * az * az
            for i in range(3):
                t0, t1, t2 = out[3 * i], out[3 * i + 1], out[3 * i + 2]
                out[3 * i] = t0 * r00 + t1 * r10 + t2 * r20
                out[3 * i + 1] = t0 * r01 + t1 * r11 + t2 * r21
                out[3 * i + 2] = t0 * r02 + t1 * r12 + t2 * r22
        else:  # prismatic: t += T a q, R = T
            for i in range(3):
                out[9 + i] += (out[3 * i] * ax + out[3 * i + 1] * ay + out[3 * i + 2] * az) * qk


@_inline
def _unpack(floats, ints):
    """``(tree, joints, spheres, geoms, pairs, obstacles)``: views of the packed arrays (:func:`pack`)."""
    J, S, G, P, O = ints[0], ints[1], ints[2], ints[3], ints[4]
    tree = floats[:15 * J].reshape((J, 15))
    spheres = floats[16 * J:16 * J + 4 * S].reshape((S, 4))
    obstacles = floats[16 * J + 4 * S:16 * J + 4 * S + 16 * O].reshape((O, 16))
    joints = ints[5:5 + 3 * J].reshape((J, 3))
    geoms = ints[5 + 3 * J:5 + 3 * J + 5 * G].reshape((G, 5))
    pairs = ints[5 + 3 * J + 5 * G:5 + 3 * J + 5 * G + 4 * P].reshape((P, 4))
    return tree, joints, spheres, geoms, pairs, obstacles


@_inline
def _reach(floats, ints):
    """The packed :func:`joint_reach` ``(J,)`` (:func:`pack`; a view): only :func:`first_uncertified` reads it."""
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
    """The cover spheres of geometry ``g`` into ``W``, unless already placed for this configuration (``stamp``)."""
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


@numba.njit(_ONE_SIGNATURE, cache=True, nogil=True, error_model="numpy")
def certify_configuration(floats: np.ndarray, ints: np.ndarray, q: np.ndarray, tol: float) -> bool:
    """True when configuration ``q`` is certified collision free (every pair's lower bound > ``tol``, m);
    False when it is not, or when ``q`` has not one entry per joint. ``floats, ints``: :func:`pack`."""
    tree, joints, spheres, geoms, pairs, obstacles = _unpack(floats, ints)
    n = joints.shape[0]
    if q.shape[0] != n:
        return False
    X, W, placed = _workspace(n, spheres.shape[0], geoms.shape[0])
    return _configuration_margin(tree, joints, spheres, geoms, pairs, obstacles, q, tol, X, W, placed, 0) >= 0.0


@numba.njit(_BATCH_SIGNATURE, cache=True, nogil=True, error_model="numpy")
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
        out[k] = _configuration_margin(tree, joints, spheres, geoms, pairs, obstacles, qs[k], tol, X, W, placed,
                                      k) >= 0.0
    return out


@numba.njit(_FIRST_SIGNATURE, cache=True, nogil=True, error_model="numpy")
def first_uncertified(floats: np.ndarray, ints: np.ndarray, qs: np.ndarray, start: int, tol: float) -> int:
    """Index of the first row of ``qs`` ``(N, nq)`` from ``start`` on that is not certified, ``N`` when every
    one is (``start`` when the rows have not one entry per joint).

    A row is certified by :func:`_configuration_margin` or, without forward kinematics, by the last row so
    certified (``q_ref``, margin ``m``) when ``2 sum_k R_k |q_k - q_ref,k| < m`` (``R``: the packed
    :func:`joint_reach`): no sphere centre has moved by half the margin, so every test that certified
    ``q_ref`` still passes (the distance between two spheres, or from a sphere's centre to an obstacle, changes
    by at most the sum of the two displacements). The iterates of a converging solve lie close together:
    on the Panda's IK paths about a fifth of the rows need no forward kinematics.
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
    """``|c_i - c_j| - r_i - r_j`` (m): a lower bound of the distance between what spheres ``i`` and ``j`` hold."""
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


@numba.njit(_BOUNDS_SIGNATURE, cache=True, nogil=True, error_model="numpy")
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
            parts = math.inf
            for i in range(geoms[a, 1], geoms[a, 2]):
                inner = math.inf
                for j in range(geoms[b, 1], geoms[b, 2]):
                    inner = min(inner, _gap(W, i, j))
                parts = min(parts, max(_gap(W, i, b), inner))
            out[pairs[p, 3]] = max(_gap(W, a, b), parts)
        else:
            parts = math.inf
            for i in range(geoms[a, 1], geoms[a, 2]):
                parts = min(parts, _obstacle_gap(W, i, obstacles, b))
            out[pairs[p, 3]] = max(_obstacle_gap(W, a, obstacles, b), parts)
    return out


@numba.njit(_ONE_SIGNATURE, cache=True, nogil=True, error_model="numpy")
def certainly_colliding(floats: np.ndarray, ints: np.ndarray, q: np.ndarray, tol: float) -> bool:
    """True when configuration ``q`` is in collision for certain: a point inside a robot geometry (its inner
    points, :func:`geometry_inner_points`) lies deeper than ``tol`` (m) inside an obstacle of a checked pair
    whose exact signed distance the kernel has (every kind but a BALL that stands for another shape). Then
    the two shapes share that point: coal finds them in collision. False says nothing (coal decides), also
    when ``q`` has not one entry per joint. ``floats, ints``: :func:`pack`."""
    tree, joints, spheres, geoms, pairs, obstacles = _unpack(floats, ints)
    n = joints.shape[0]
    if q.shape[0] != n:
        return False
    X, W, placed = _workspace(n, spheres.shape[0], geoms.shape[0])
    tree_placements(tree, joints, q, X)
    for p in range(pairs.shape[0]):
        if pairs[p, 2] != OBSTACLE_PAIR:
            continue
        a, o = pairs[p, 0], pairs[p, 1]
        if obstacles[o, KIND] == BALL and obstacles[o, EXACT] != 1.0:
            continue
        j = geoms[a, 0]
        for i in range(geoms[a, 3], geoms[a, 4]):
            _place(X, j, spheres, i, W)  # radius 0: the gap is the point's signed distance
            if _obstacle_gap(W, i, obstacles, o) < -tol:
                return True
    return False


def certify(arguments: tuple, qs: Any) -> np.ndarray:
    """:func:`certify_configurations` with :meth:`ScenePrecheck.arguments` on configurations ``qs`` (a sequence
    of ``(nq,)`` float arrays or an ``(N, nq)`` array): per configuration, True when certified free."""
    floats, ints, tol = arguments[2:5]
    Q = np.asarray(qs, dtype=float)
    return certify_configurations(floats, ints, Q.reshape(len(Q), -1), tol)


__all__ = ["TOLERANCE", "RobotSpheres", "ScenePrecheck", "certainly_colliding", "certify", "certify_configuration",
           "certify_configurations", "enclosing_ball", "first_uncertified", "geometry_cover", "geometry_inner_points",
           "geometry_spheres", "obstacle_row",
           "obstacle_rows", "obstacle_template", "pack", "pair_lower_bounds", "placed_floats", "polytope_cover",
           "robot_spheres", "robot_spheres_of", "tree_placements"]
