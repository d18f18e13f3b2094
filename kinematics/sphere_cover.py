"""Spheres that contain a coal geometry: its bounding sphere, its cover spheres and points inside it.

Every sphere's radius is the distance from its centre to the farthest point it
must hold, so containment is exact up to rounding, padded by :data:`PAD`; the
centres are only placed well (a centre placed badly gives a larger sphere, never
one that misses a point).

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
  in a triangulation; a compiled loop, :func:`plane_crossings`, over the pairs
  with one vertex on each side of a plane); the centre itself is placed by a
  Badoiu-Clarkson search for the smallest enclosing ball of the crossings of
  coal's hull triangle sides (fewer points);
* a sphere: itself; a cylinder of radius ``r`` and half length ``L``: ``k``
  slabs of half length ``h = L / k`` along its axis, spheres of radius
  ``sqrt(r^2 + h^2)`` at the slab centres; a capsule: the same for its
  cylinder plus a ball of radius ``r`` at each end of its segment;
* any other coal geometry: the sphere of its local AABB (``computeLocalAABB``,
  ``aabb_center``, ``aabb_radius``), one for the whole shape.

Each geometry also gets one **bounding sphere** (the same construction with a
single slab), and a coal swept-sphere radius is added to every radius.

**Inner points** (:func:`geometry_inner_points`): the mean of each slab's points
for a hull (vertices and crossings of vertex pairs, all in the hull: their mean
too), axis points for a cylinder or capsule, the centre of a sphere or box.

Units: metres.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import coal
import numba
import numpy as np

from .kernel_cache import F1, F2, compiled
from .obstacle_table import PAD, aabb_sphere

#: Largest number of cover spheres per robot geometry (pairs of geometries cost up to its square).
MAX_COVER_SPHERES = 8
#: Slab length of a cover, as a multiple of the geometry's radius about its axis: the sphere of a slab of a
#: cylinder of radius R is at most sqrt(1 + (SLAB_RATIO / 2)^2) R, 1.06 R at 0.7 (1.12 R at 1). On the
#: MotionBenchMaker Panda scenes, 0.7 and 8 spheres certify more configurations than 1.0 and 6 (median check
#: 3.8 -> 3.2 us, fewer reach coal) at a slightly higher cost for those that reach it (docs/benchmarks.md).
SLAB_RATIO = 0.7
#: Iterations of the Badoiu-Clarkson enclosing-ball search.
BALL_ITERATIONS = 64


class GeometrySpheres(NamedTuple):
    """The spheres of one geometry in its own frame: ``bounding`` ``(4,)`` and ``cover`` ``(k, 4)``
    (centre, radius; m) each containing the whole geometry, and ``inner`` ``(i, 3)`` points inside it."""

    bounding: np.ndarray
    cover: np.ndarray
    inner: np.ndarray


def enclosing_ball(points: np.ndarray, contain: np.ndarray | None = None) -> np.ndarray:
    """``(cx, cy, cz, r)``: a ball containing every point of ``contain`` ``(m, 3)`` (default ``points``), its
    centre placed for ``points`` ``(n, 3)`` (near the centre of their smallest enclosing ball).

    The centre starts at the points' bounding-box centre and moves by Badoiu-Clarkson steps (a
    ``1 / (i + 1)`` step towards the farthest point); the best centre seen is kept. The radius is the exact
    largest distance from it to the points of ``contain``, plus :data:`PAD`: containment never depends on
    the search.
    """
    centre = ball_centre(points)
    Q = np.asarray(points if contain is None else contain, dtype=float)
    return _ball(centre, float(((Q - centre) ** 2).sum(axis=1).max()))


def ball_centre(points: np.ndarray) -> np.ndarray:
    """The centre ``(3,)`` :func:`enclosing_ball` places for ``points`` ``(n, 3)``."""
    P = np.asarray(points, dtype=float)
    c = 0.5 * (P.min(axis=0) + P.max(axis=0))
    best_c, best_r = c, math.inf
    for i in range(1, BALL_ITERATIONS + 1):
        d2 = ((P - c) ** 2).sum(axis=1)
        far = int(d2.argmax())
        if d2[far] < best_r:
            best_c, best_r = c, float(d2[far])
        c = c + (P[far] - c) / (i + 1)
    return best_c


def _ball(centre: np.ndarray, farthest_squared: float) -> np.ndarray:
    """The ball of ``centre`` whose radius is ``sqrt(farthest_squared)`` (m^2), rounded up and padded."""
    return np.array([*centre, math.sqrt(farthest_squared) * (1.0 + 1e-12) + PAD])


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


def _slab_planes(V: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(s, planes)`` of a vertex set ``V`` ``(n, 3)``: the projections on the principal axis and the
    ``k + 1`` slab planes along it (module docstring)."""
    X = V - V.mean(axis=0)
    _, U = np.linalg.eigh(X.T @ X)
    a = U[:, -1]
    s = X @ a
    R = float(np.linalg.norm(X - np.outer(s, a), axis=1).max())
    lo, hi = float(s.min()), float(s.max())
    k = int(np.clip(math.ceil((hi - lo) / max(SLAB_RATIO * R, 1e-12)), 1, MAX_COVER_SPHERES))
    planes = lo + (hi - lo) * np.arange(k + 1) / k
    planes[0], planes[-1] = lo, hi
    return s, planes


_CROSSINGS_SIGNATURE = numba.types.void(F2, F1, F2, F1, numba.types.float64, F1, numba.types.float64[::1])


@compiled(_CROSSINGS_SIGNATURE)
def plane_crossings(below: np.ndarray, s_below: np.ndarray, above: np.ndarray, s_above: np.ndarray,
                    plane: float, centre: np.ndarray, out: np.ndarray) -> None:
    """Accumulate into ``out`` ``(5,)`` the crossings of the plane ``s = plane`` by every segment from a
    vertex of ``below`` ``(nb, 3)`` (projections ``s_below < plane``) to one of ``above`` ``(na, 3)``
    (``s_above > plane``): ``x = b + t (a - b)``, ``t = (plane - s_b) / (s_a - s_b)``.

    ``out[0] = max(out[0], max |x - centre|^2)`` (m^2), ``out[1:4] += sum x``, ``out[4] += nb * na``.
    """
    best, sx, sy, sz = out[0], 0.0, 0.0, 0.0
    c0, c1, c2 = centre[0], centre[1], centre[2]
    for i in range(below.shape[0]):
        b0, b1, b2 = below[i, 0], below[i, 1], below[i, 2]
        rise = plane - s_below[i]
        for j in range(above.shape[0]):
            t = rise / (s_above[j] - s_below[i])
            x0 = b0 + t * (above[j, 0] - b0)
            x1 = b1 + t * (above[j, 1] - b1)
            x2 = b2 + t * (above[j, 2] - b2)
            d = (x0 - c0) * (x0 - c0) + (x1 - c1) * (x1 - c1) + (x2 - c2) * (x2 - c2)
            best = max(best, d)
            sx += x0
            sy += x1
            sz += x2
    out[0] = best
    out[1] += sx
    out[2] += sy
    out[3] += sz
    out[4] += below.shape[0] * above.shape[0]


def _slab_sphere(V: np.ndarray, s: np.ndarray, lo: float, hi: float, centre: np.ndarray) -> np.ndarray:
    """``(r^2, sx, sy, sz, count)`` of the slab ``lo <= s <= hi`` of the hull of ``V``: the largest squared
    distance (m^2) from ``centre`` to its vertices and to every vertex pair's crossings of its two planes,
    and the sum and number of those points."""
    inside = V[(s >= lo) & (s <= hi)]
    out = np.zeros(5)
    if len(inside):
        out[0] = float(((inside - centre) ** 2).sum(axis=1).max())
        out[1:4], out[4] = inside.sum(axis=0), len(inside)
    for plane in (lo, hi):
        below, above = s < plane, s > plane
        if below.any() and above.any():
            plane_crossings(np.ascontiguousarray(V[below]), np.ascontiguousarray(s[below]),
                            np.ascontiguousarray(V[above]), np.ascontiguousarray(s[above]), float(plane),
                            np.ascontiguousarray(centre, dtype=float), out)
    return out


def polytope_cover(vertices: np.ndarray,
                   triangles: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(bounding (4,), cover (k, 4))`` spheres ``(centre, radius)`` containing the convex hull of
    ``vertices`` ``(n, 3)``, in the vertices' frame (module docstring: slabs along the principal axis).

    Each slab's sphere contains the vertices in the slab and the crossings of *every* vertex pair with the
    slab's planes - a superset of the extreme points of the hull's part in the slab, whatever the hull's
    edges are; ``triangles`` (the hull's faces, e.g. coal's, optional) only place the centre, on the
    crossings of their sides (fewer points, the same hull; without them, on every pair's crossings: for small
    vertex sets).
    """
    spheres = polytope_spheres(np.asarray(vertices, dtype=float), triangles)
    return spheres.bounding, spheres.cover


def polytope_inner_points(vertices: np.ndarray) -> np.ndarray:
    """Points ``(k, 3)`` inside the convex hull of ``vertices``, one per slab of :func:`polytope_cover`: the
    mean of the slab's points (its vertices and the crossings of every vertex pair with its planes, all in the
    hull; a mean of points of a convex set lies in it)."""
    return polytope_spheres(np.asarray(vertices, dtype=float), None).inner


def polytope_spheres(V: np.ndarray, triangles: np.ndarray | None) -> GeometrySpheres:
    """:func:`polytope_cover`'s spheres and :func:`polytope_inner_points`'s points of the hull of ``V``
    ``(n, 3)``, each slab's points visited once."""
    s, planes = _slab_planes(V)
    edges = np.array(np.triu_indices(len(V), 1)).T if triangles is None else triangle_sides(triangles)
    cover, inner = [], []
    for lo, hi in zip(planes[:-1], planes[1:]):
        centre = ball_centre(_slab_points(V, s, edges, lo, hi))
        slab = _slab_sphere(V, s, lo, hi, centre)
        cover.append(_ball(centre, slab[0]))
        inner.append(slab[1:4] / slab[4])
    return GeometrySpheres(enclosing_ball(V), np.array(cover), np.array(inner))


def _axis_cover(radius: float, half_length: float, end_balls: bool) -> tuple[np.ndarray, np.ndarray]:
    """Spheres of a cylinder (``end_balls``: capsule) of ``radius`` along local z from ``-half_length`` to
    ``+half_length``: slabs of half length ``h``, radius ``sqrt(radius^2 + h^2)``; a capsule adds its end
    balls."""
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


def convex_triangles(geometry: coal.ConvexBase) -> np.ndarray:
    """The vertex indices ``(F, 3)`` of the triangles of a coal convex hull (``polygons``)."""
    faces = [geometry.polygons(i) for i in range(geometry.num_polygons)]
    return np.array([(t[0], t[1], t[2]) for t in faces], dtype=np.int64).reshape(-1, 3)


def geometry_cover(geometry: coal.CollisionGeometry) -> tuple[np.ndarray, np.ndarray]:
    """``(bounding (4,), cover (k, 4))`` spheres (centre, radius; m) containing a coal geometry, in its own
    frame."""
    spheres = geometry_spheres(geometry)
    return spheres.bounding, spheres.cover


def geometry_inner_points(geometry: coal.CollisionGeometry) -> np.ndarray:
    """Points ``(k, 3)`` inside a coal geometry, in its own frame (``(0, 3)`` for a shape without a closed
    form): the centre of a sphere or box, the slab centres of a cylinder or capsule's axis, the slab means of
    :func:`polytope_inner_points` for a convex hull."""
    return geometry_spheres(geometry).inner


def geometry_spheres(geometry: coal.CollisionGeometry) -> GeometrySpheres:
    """:func:`geometry_cover`'s spheres and :func:`geometry_inner_points`'s points of a coal geometry in one
    pass (a hull's slabs are cut once), swept-sphere radius included."""
    spheres = _shape_spheres(geometry)
    swept = float(geometry.getSweptSphereRadius())
    if swept > 0.0:
        grow = np.array([0.0, 0.0, 0.0, swept])
        spheres = GeometrySpheres(spheres.bounding + grow, spheres.cover + grow, spheres.inner)
    return spheres


def _shape_spheres(geometry: coal.CollisionGeometry) -> GeometrySpheres:
    """:func:`geometry_spheres` before the swept-sphere radius."""
    if isinstance(geometry, coal.Sphere):
        ball = np.array([0.0, 0.0, 0.0, float(geometry.radius) + PAD])
        return GeometrySpheres(ball, ball[None, :], np.zeros((1, 3)))
    if isinstance(geometry, coal.Box):
        h = np.asarray(geometry.halfSide, dtype=float)
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * h
        bounding, cover = polytope_cover(corners)
        return GeometrySpheres(bounding, cover, np.zeros((1, 3)))
    if isinstance(geometry, (coal.Capsule, coal.Cylinder)):
        capsule = isinstance(geometry, coal.Capsule)
        bounding, cover = _axis_cover(geometry.radius, geometry.halfLength, capsule)
        inner = _axis_cover(geometry.radius, geometry.halfLength, False)[1][:, :3].copy()
        return GeometrySpheres(bounding, cover, inner)
    if isinstance(geometry, coal.Convex) and geometry.num_points >= 4:
        triangles = convex_triangles(geometry)
        vertices = np.asarray(geometry.points(), dtype=float)
        return polytope_spheres(vertices, triangles if len(triangles) else None)
    bounding = aabb_sphere(geometry)
    return GeometrySpheres(bounding, bounding[None, :], np.zeros((0, 3)))


__all__ = ["BALL_ITERATIONS", "MAX_COVER_SPHERES", "PAD", "SLAB_RATIO", "GeometrySpheres", "aabb_sphere",
           "ball_centre", "convex_triangles", "enclosing_ball", "geometry_cover", "geometry_inner_points",
           "geometry_spheres", "plane_crossings", "polytope_cover", "polytope_inner_points",
           "polytope_spheres", "triangle_sides"]
