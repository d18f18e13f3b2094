"""The obstacle table of the compiled pre-check: one row of 16 numbers per obstacle.

A row (columns of :mod:`.precheck_kernels`): the obstacle's world rotation
(row-major, 0-8) and translation (9-11), its kind (:data:`~.precheck_kernels.KIND`:
``BALL``, ``BOX``, ``CAPSULE``, ``CYLINDER``) and its sizes (13-15): a box its
half extents, a capsule or cylinder its radius and half length (along its local
z), a ball its radius then :data:`~.precheck_kernels.EXACT` (1: the ball is the
obstacle; 0: it stands for a shape without a closed form - a mesh, anything with
a swept-sphere radius but a sphere - as the sphere of its local AABB, whose centre
the row's translation then holds).

The kind and sizes depend on the shape only (:func:`obstacle_template`); a
scene places the templates at its obstacles' poses (:func:`obstacle_rows`).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import coal
import numpy as np
import pinocchio as pin

from .precheck_kernels import BALL, BOX, CAPSULE, CYLINDER, EXACT, KIND, OBSTACLE_COLUMNS, placed_floats
from .sphere_cover import aabb_sphere


class ObstacleTemplate(NamedTuple):
    """An obstacle's row before its pose: ``row`` ``(16,)`` (kind and sizes) and ``centre`` ``(3,)``, the
    point of the obstacle's frame the row's translation must hold (zero, or the centre of the AABB sphere that
    stands for a shape without a closed form)."""

    row: np.ndarray
    centre: np.ndarray


def obstacle_template(geometry: coal.CollisionGeometry) -> ObstacleTemplate:
    """The :class:`ObstacleTemplate` of a coal geometry (module docstring's kinds)."""
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


def obstacle_rows(templates: np.ndarray, centres: np.ndarray, poses: Any) -> np.ndarray:
    """The obstacle table ``(O, 16)``: the rows ``templates`` ``(O, 16)`` of :func:`obstacle_template`
    placed at ``poses`` (``O`` 4x4 world poses): rotation (row-major) and translation ``t + R centre``."""
    P = np.ascontiguousarray(np.asarray(poses, dtype=float).reshape(-1, 4, 4))
    table = placed_floats(np.zeros(0), np.ascontiguousarray(templates, dtype=float),
                          np.ascontiguousarray(centres, dtype=float), P)
    return table.reshape(-1, OBSTACLE_COLUMNS)


def obstacle_row(geometry: coal.CollisionGeometry, placement: pin.SE3) -> np.ndarray:
    """The obstacle table row ``(16,)`` of a coal geometry at ``placement``: rotation, translation, kind,
    sizes."""
    template = obstacle_template(geometry)
    return obstacle_rows(template.row[None, :], template.centre[None, :], placement.homogeneous[None])[0]


__all__ = ["ObstacleTemplate", "obstacle_row", "obstacle_rows", "obstacle_template"]
