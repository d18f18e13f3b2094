"""What obstacle avoidance needs of a shape's geometry beyond its closed forms: bounds and coal placements.

* bounds of a box, cylinder or mesh in its own frame - the corners ``(lo, hi)`` of its bounding box
  (:func:`local_extent`) and the radius of a ball about its pose's origin that contains it
  (:func:`bounding_radius`): the cheap lower bounds that decide which pairs need coal;
* coal placements: a pose as a ``coal.Transform3s`` (:func:`coal_transform`), and the capsule core
  (radius 0) standing for a link segment ``[a, a + ab]`` - its geometry (:func:`segment_core`) and its
  placement, centred at the midpoint with its z axis along ``ab`` (:func:`segment_transform`, or as a
  ``pinocchio.SE3`` in a joint's frame: :func:`axis_placement`).
"""

from __future__ import annotations

import math

import coal
import numpy as np
import pinocchio as pin

from kinserve.kinematics.shapes import Box, Cylinder, Mesh, Shape

#: Segments shorter than this (m) are points: their core has no direction.
POINT_LENGTH = 1e-12


def local_extent(shape: Shape) -> tuple[np.ndarray, np.ndarray]:
    """Corners ``(lo, hi)`` (m) of the bounding box of a box, cylinder or mesh in its own frame."""
    if isinstance(shape, Box):
        h = shape.half_extents
    elif isinstance(shape, Cylinder):
        h = np.array([shape.radius, shape.radius, 0.5 * shape.length])
    else:  # mesh: the hull's vertices
        return shape.hull_vertices.min(axis=0), shape.hull_vertices.max(axis=0)
    return -h, h


def bounding_radius(shape: Shape) -> float:
    """Radius (m) of a ball about the shape's pose origin containing a box, cylinder or mesh."""
    if isinstance(shape, Box):
        x, y, z = shape.size  # half the diagonal, on floats (cheaper than a NumPy norm)
        return 0.5 * math.sqrt(x * x + y * y + z * z)
    if isinstance(shape, Cylinder):
        return math.hypot(shape.radius, 0.5 * shape.length)
    if isinstance(shape, Mesh):
        return float(np.linalg.norm(shape.hull_vertices, axis=1).max())
    raise TypeError(f"bounding_radius: a box, cylinder or mesh expected, got {type(shape).__name__}")


def coal_transform(T: np.ndarray) -> coal.Transform3s:
    """The pose ``T`` (4x4) as a ``coal.Transform3s``."""
    tf = coal.Transform3s()
    tf.setRotation(np.ascontiguousarray(T[:3, :3]))
    tf.setTranslation(np.ascontiguousarray(T[:3, 3]))
    return tf


def segment_core(length: float) -> coal.Capsule:
    """The coal capsule core (radius 0) of a segment of ``length`` (m), centred, along its z axis."""
    return coal.Capsule(0.0, length)


def segment_transform(a: np.ndarray, ab: np.ndarray, length: float) -> coal.Transform3s:
    """coal placement of the core of ``[a, a + ab]`` (``length = |ab|``): centre at the midpoint, z along
    ``ab``.

    Plain floats: on one 3-vector they are several times cheaper than NumPy's cross products.
    """
    tf = coal.Transform3s()
    if length > POINT_LENGTH:
        zx, zy, zz = (ab / length).tolist()
        hx, hy = (1.0, 0.0) if abs(zx) < 0.9 else (0.0, 1.0)
        xx, xy, xz = hy * zz, -hx * zz, hx * zy - hy * zx  # h x z with h = (hx, hy, 0)
        n = math.sqrt(xx * xx + xy * xy + xz * xz)
        xx, xy, xz = xx / n, xy / n, xz / n
        yx, yy, yz = zy * xz - zz * xy, zz * xx - zx * xz, zx * xy - zy * xx  # z x x
        tf.setRotation(np.array([[xx, yx, zx], [xy, yy, zy], [xz, yz, zz]]))
    tf.setTranslation(a + 0.5 * ab)
    return tf


def axis_placement(a: np.ndarray, ab: np.ndarray, length: float) -> pin.SE3:
    """:func:`segment_transform` as a ``pinocchio.SE3`` (for a segment given in its joint's frame)."""
    tf = segment_transform(a, ab, length)
    return pin.SE3(np.array(tf.getRotation()), np.array(tf.getTranslation()))
