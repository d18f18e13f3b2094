"""Inner balls: about each inner point of a robot geometry, the largest ball that stays inside the geometry.

The sphere pre-check (:mod:`.precheck_kernels`) finds a configuration in collision without coal when a ball
inside a robot geometry overlaps an obstacle, or a ball inside the other geometry of a self pair, by more than
its tolerance: the two shapes then share that overlap. The balls' centres are the inner points of
:func:`~.sphere_cover.geometry_inner_points` (placed in their joint frames by :mod:`.robot_spheres`); this
module gives their radii (m), the distance from the point to the geometry's boundary:

* a convex hull (coal ``Convex``, the hull of its points, as coal's GJK sees it): ``min_f -(a_f . p + b_f)``
  over the facets ``a_f . x + b_f <= 0`` (unit ``a_f``) of scipy's qhull of its points (facets from a hull
  algorithm, not normals of coal's triangles, which can be slivers); 0 when qhull cannot make them;
* a box of half extents ``h``: ``min_k (h_k - |p_k|)``; a sphere of radius ``r``: ``r - |p|``;
* a cylinder (radius ``r``, half length ``L``, axis z): ``min(r - |p_xy|, L - |p_z|)``; a capsule:
  ``r - |p - (0, 0, clip(p_z, -L, L))|``;
* any other shape: 0 (a point);

plus coal's swept-sphere radius, minus a rounding pad (:data:`INNER_PAD`, relative and absolute), never
below 0.
"""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin
from scipy.spatial import ConvexHull, QhullError

#: Rounding pad of an inner radius: ``r (1 - INNER_PAD) - INNER_PAD`` (relative, and m).
INNER_PAD = 1e-9


def _hull_radii(geometry: coal.ConvexBase, points: np.ndarray) -> np.ndarray:
    """:func:`inner_radii` of a convex hull (module docstring): the facets of scipy's qhull of its points;
    zeros when qhull cannot make them (a flat point set)."""
    try:
        planes = ConvexHull(np.asarray(geometry.points(), dtype=float)).equations
    except (QhullError, ValueError):
        return np.zeros(len(points))
    return -(points @ planes[:, :3].T + planes[:, 3]).max(axis=1)


def inner_radii(geometry: coal.CollisionGeometry, points: np.ndarray) -> np.ndarray:
    """``(k,)``: the radius (m) of the largest ball about each of ``points`` ``(k, 3)`` (the geometry's own
    frame, inside it) inside ``geometry`` (module docstring); 0 for a point outside or a shape without a
    closed form."""
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    if isinstance(geometry, coal.Convex) and geometry.num_points >= 4:
        r = _hull_radii(geometry, p)
    elif isinstance(geometry, coal.Box):
        r = (np.asarray(geometry.halfSide, dtype=float)[None, :] - np.abs(p)).min(axis=1)
    elif isinstance(geometry, coal.Sphere):
        r = float(geometry.radius) - np.linalg.norm(p, axis=1)
    elif isinstance(geometry, coal.Cylinder):
        r = np.minimum(float(geometry.radius) - np.hypot(p[:, 0], p[:, 1]),
                       float(geometry.halfLength) - np.abs(p[:, 2]))
    elif isinstance(geometry, coal.Capsule):
        half = float(geometry.halfLength)
        axis = np.column_stack([np.zeros(len(p)), np.zeros(len(p)), np.clip(p[:, 2], -half, half)])
        r = float(geometry.radius) - np.linalg.norm(p - axis, axis=1)
    else:
        return np.zeros(len(p))
    r = r + float(geometry.getSweptSphereRadius())
    return np.maximum(r * (1.0 - INNER_PAD) - INNER_PAD, 0.0)


def robot_inner_radii(geometry: pin.GeometryModel, inner: np.ndarray, inner_ranges: np.ndarray,
                      known: np.ndarray | None = None) -> np.ndarray:
    """``(I,)``: :func:`inner_radii` of the inner points ``inner`` ``(I, 3)`` (in their joint frames; rows
    ``inner_ranges[g]`` belong to geometry ``g`` of ``geometry``, as in
    :class:`~.robot_spheres.RobotSpheres`), each taken back to its geometry's frame by the geometry's
    placement. ``known``: the radii of the first rows, when the caller has them (the geometries whose rows
    they cover are not measured again; a model with carried objects reuses its bare model's)."""
    out = np.zeros(len(inner))
    done = 0 if known is None else len(known)
    out[:done] = known if known is not None else ()
    for g, obj in enumerate(geometry.geometryObjects):
        first, end = int(inner_ranges[g, 0]), int(inner_ranges[g, 1])
        if end > first and end > done:  # (rows all known: measured already)
            M = obj.placement
            local = (inner[first:end] - M.translation) @ M.rotation
            out[first:end] = inner_radii(obj.geometry, local)
    return out


__all__ = ["INNER_PAD", "inner_radii", "robot_inner_radii"]
