"""The obstacle table of the compiled pre-check: one row of 16 numbers per obstacle, and its encoding.

A row (read by :mod:`.precheck_kernels`): the obstacle's world rotation
(row-major, 0-8) and translation (9-11), its kind (column :data:`KIND`:
:data:`BALL`, :data:`BOX`, :data:`CAPSULE`, :data:`CYLINDER`) and its sizes
(13-15): a box its half extents, a capsule or cylinder its radius and half
length (along its local z), a ball its radius then :data:`EXACT` (1: the ball
is the obstacle; 0: it stands for a shape without a closed form - a mesh,
anything with a swept-sphere radius but a sphere - as the sphere of its local
AABB, whose centre the row's translation then holds).

The kind and sizes depend on the shape only (:func:`obstacle_template`); the row
places the template at the obstacle's pose (:func:`obstacle_row`). Every
:class:`~.shapes.Shape` computes its row when it is made
(:attr:`~.shapes.Shape.obstacle_row`), so a scene of new shapes only
concatenates their rows. This module owns the encoding: the compiled kernels
import its constants (it is one of the kernel cache's files,
:data:`~.kernel_cache.KERNEL_FILES`). NumPy only: ``import kinserve`` and
making a shape load no compiled kernel.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

#: Obstacle kinds of the obstacle table (column :data:`KIND` of a row).
BALL, BOX, CAPSULE, CYLINDER = 0, 1, 2, 3
#: Columns of an obstacle row: rotation (row-major) 0-8, translation 9-11, kind 12, sizes 13-15 (a BALL: its
#: radius, then :data:`EXACT`).
KIND = 12
#: Column of a BALL row: 1 when the ball is the obstacle itself, 0 when it stands for a shape without a closed
#: form (its AABB sphere: a point inside it need not be inside the shape). Other kinds are always exact.
EXACT = 14
#: Width of an obstacle row.
OBSTACLE_COLUMNS = 16
#: Padding (m) added to the radius of every containing sphere against rounding: the AABB spheres here
#: (:func:`aabb_sphere`) and the robot's cover spheres (:mod:`.sphere_cover`).
PAD = 1e-9


class ObstacleTemplate(NamedTuple):
    """An obstacle's row before its pose: ``row`` ``(16,)`` (kind and sizes) and ``centre`` ``(3,)``, the
    point of the obstacle's frame the row's translation must hold (zero, or the centre of the AABB sphere that
    stands for a shape without a closed form)."""

    row: np.ndarray
    centre: np.ndarray


def aabb_sphere(geometry: Any) -> np.ndarray:
    """``(centre, radius)`` ``(4,)`` (m, the geometry's own frame) of coal's local AABB sphere of ``geometry``
    (computed when missing), the radius padded by :data:`PAD`."""
    if geometry.aabb_radius < 0.0:
        geometry.computeLocalAABB()
    return np.array([*np.asarray(geometry.aabb_center, dtype=float), float(geometry.aabb_radius) + PAD])


def obstacle_template(geometry: Any) -> ObstacleTemplate:
    """The :class:`ObstacleTemplate` of a coal geometry (module docstring's kinds)."""
    import coal  # with Pinocchio; imported here so that this module stays importable without it

    row = np.zeros(OBSTACLE_COLUMNS)
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
    return ObstacleTemplate(row, centre)


def obstacle_row(geometry: Any, pose: Any) -> np.ndarray:
    """The obstacle table row ``(16,)`` of a coal geometry at ``pose`` (a 4x4 world pose or a
    ``pinocchio.SE3``): the :func:`obstacle_template`'s kind and sizes, the pose's rotation (row-major) and
    the translation ``t + R centre``."""
    T = np.asarray(pose.homogeneous if hasattr(pose, "homogeneous") else pose, dtype=float)
    template = obstacle_template(geometry)
    row = template.row
    row[0:9] = T[:3, :3].ravel()
    row[9:12] = T[:3, 3] + T[:3, :3] @ template.centre
    return row


__all__ = ["BALL", "BOX", "CAPSULE", "CYLINDER", "EXACT", "KIND", "OBSTACLE_COLUMNS", "PAD",
           "ObstacleTemplate", "aabb_sphere", "obstacle_row", "obstacle_template"]
