"""The cores of a robot's collision geometries, in its joints' frames: the table of the compiled distances.

:mod:`.convex_distance` measures the distance between two convex shapes as the
distance between their *cores*, finite point sets, less the radii the cores are
grown by. A coal ``Convex`` hull's core is its vertices, a ``Box``'s its eight
corners, a ``Sphere``'s its centre (grown by its radius), a ``Capsule``'s the two
ends of its segment (grown by its radius); coal's swept-sphere radius adds to the
radius. Other geometries (cylinders, cones, meshes that are not hulls...) have no
core here: :data:`UNSUPPORTED`. :func:`hull_table` stores every core in the frame
of its geometry's joint, so that a joint placement places it. NumPy only; the
compiled code reads the kinds (this file is one of the kernel cache's,
:data:`~.kernel_cache.KERNEL_FILES`). Units: metres.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

#: Kinds of the robot geometries in :class:`HullTable`.
VERTICES, UNSUPPORTED = 0, -1


class HullTable(NamedTuple):
    """The cores of a robot's geometries (module docstring), for the compiled distances.

    ``points`` ``(V, 3)``: every core's points in the frame of its geometry's joint, geometry after
    geometry; ``geoms`` ``(G, 4)`` int64: per geometry its kind (:data:`VERTICES` or :data:`UNSUPPORTED`),
    the first and end rows of its points and its Pinocchio joint; ``radius`` ``(G,)``: the radius (m) each
    core is grown by.
    """

    points: np.ndarray
    geoms: np.ndarray
    radius: np.ndarray


def core_points(geometry: Any) -> tuple[np.ndarray, float] | None:
    """``(points (k, 3), radius)`` of a coal geometry in its own frame (module docstring), or None when it
    has no such form."""
    import coal

    swept = float(geometry.getSweptSphereRadius())
    if isinstance(geometry, coal.Convex):
        return np.asarray(geometry.points(), dtype=float).reshape(-1, 3), swept
    if isinstance(geometry, coal.Box):
        h = np.asarray(geometry.halfSide, dtype=float)
        signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
        return signs * h, swept
    if isinstance(geometry, coal.Sphere):
        return np.zeros((1, 3)), float(geometry.radius) + swept
    if isinstance(geometry, coal.Capsule):
        half = float(geometry.halfLength)
        return np.array([[0.0, 0.0, -half], [0.0, 0.0, half]]), float(geometry.radius) + swept
    return None


def hull_table(objects: Any) -> HullTable:
    """The :class:`HullTable` of the robot geometries ``objects`` (``pinocchio.GeometryObject``, in the
    order of the geometries), each core placed in its joint's frame by the object's placement."""
    points, geoms, radius = [], [], []
    row = 0
    for obj in objects:
        core = core_points(obj.geometry)
        if core is None:
            geoms.append((UNSUPPORTED, row, row, obj.parentJoint))
            radius.append(0.0)
            continue
        local, r = core
        M = obj.placement
        placed = local @ np.asarray(M.rotation).T + np.asarray(M.translation)
        points.append(placed)
        geoms.append((VERTICES, row, row + len(placed), obj.parentJoint))
        radius.append(r)
        row += len(placed)
    stacked = np.concatenate(points) if points else np.zeros((0, 3))
    return HullTable(np.ascontiguousarray(stacked, dtype=float),
                     np.ascontiguousarray(np.array(geoms, dtype=np.int64).reshape(-1, 4)),
                     np.ascontiguousarray(radius, dtype=float))


__all__ = ["UNSUPPORTED", "VERTICES", "HullTable", "core_points", "hull_table"]
