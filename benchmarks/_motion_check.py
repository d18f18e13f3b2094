"""An independent dense check of joint-space paths: Pinocchio + coal on the dataset's own meshes.

Nothing of kinserve's collision model is used (no convex hulls, no sphere covers, no certificates): the
robot's collision geometry is the URDF's meshes as Pinocchio loads them (coal ``BVHModelOBBRSS``
triangle meshes), the self pairs are every pair of geometries on different joints minus the SRDF's
``<disable_collisions>``, and each obstacle is a coal primitive fixed in the world, paired with every
robot geometry (obstacle-obstacle pairs never count: the scenes' table legs touch the table top).

A path ``q_0 .. q_k`` is checked as straight segments, each sampled at ``n = ceil(max_i |dq_i| / step)``
equal steps (``step`` = 0.5 mrad by default: no joint moves more than that between two checks), both
ends included; a configuration is invalid when any pair is in collision (coal's ``collide`` behind its
dynamic AABB tree broad phase, through ``pinocchio.computeCollisions``) or a joint is outside its limits.
"""

from __future__ import annotations

import math
from pathlib import Path

import coal
import numpy as np
import pinocchio as pin

#: Largest joint motion (rad) between two checked configurations.
DENSE_STEP = 5e-4


def _primitive(shape: dict):
    """The coal geometry and placement of a shape's ``to_dict()`` (box, cylinder, sphere)."""
    kind = shape["kind"]
    if kind == "sphere":
        return coal.Sphere(float(shape["radius"])), pin.SE3(np.eye(3), np.asarray(shape["center"], float))
    T = np.asarray(shape["pose"], dtype=float)
    placement = pin.SE3(T[:3, :3].copy(), T[:3, 3].copy())
    if kind == "box":
        return coal.Box(*[float(v) for v in shape["size"]]), placement
    if kind == "cylinder":
        return coal.Cylinder(float(shape["radius"]), float(shape["length"])), placement
    raise ValueError(f"the dense check knows boxes, cylinders and spheres, got {kind!r}")


class DenseChecker:
    """Dense collision check of paths of one robot model among one scene's obstacles (module docstring)."""

    def __init__(self, urdf: str | Path, package_dir: str | Path, srdf: str | Path | None,
                 step: float = DENSE_STEP) -> None:
        self.model = pin.buildModelFromUrdf(str(urdf))
        self.robot_geometry = pin.buildGeomFromUrdf(self.model, str(urdf), pin.COLLISION,
                                                    package_dirs=[str(package_dir)])
        self.robot_geometry.addAllCollisionPairs()
        if srdf is not None:
            pin.removeCollisionPairs(self.model, self.robot_geometry, str(srdf))
        self.self_pairs = len(self.robot_geometry.collisionPairs)
        self.data = self.model.createData()
        self.lower = np.array(self.model.lowerPositionLimit)
        self.upper = np.array(self.model.upperPositionLimit)
        self.step = float(step)
        self.set_obstacles([])

    def set_obstacles(self, shapes: list[dict]) -> None:
        """Replace the world's obstacles (shape dicts); robot-obstacle pairs for every robot geometry."""
        geom = self.robot_geometry.copy()
        robot_ids = range(len(self.robot_geometry.geometryObjects))
        for k, shape in enumerate(shapes):
            g, placement = _primitive(shape)
            obj = pin.GeometryObject(f"obstacle_{k}", 0, 0, placement, g)
            oid = geom.addGeometryObject(obj)
            for rid in robot_ids:
                geom.addCollisionPair(pin.CollisionPair(rid, oid))
        self.geometry = geom
        self.geometry_data = pin.GeometryData(geom)
        self.broadphase = pin.BroadPhaseManager_DynamicAABBTreeCollisionManager(self.model, geom,
                                                                                self.geometry_data)

    def in_collision(self, q: np.ndarray) -> bool:
        """Whether ``q`` is outside the limits or any checked pair collides (coal's dynamic AABB tree
        skips the pairs whose world bounding boxes are apart, then ``collide`` on the others)."""
        if np.any(q < self.lower - 1e-12) or np.any(q > self.upper + 1e-12):
            return True
        pin.forwardKinematics(self.model, self.data, q)
        pin.updateGeometryPlacements(self.model, self.data, self.geometry, self.geometry_data)
        self.broadphase.update(False)
        return bool(pin.computeCollisions(self.broadphase, True))

    def in_collision_every_pair(self, q: np.ndarray) -> bool:
        """:meth:`in_collision` without the broad phase: ``collide`` on every checked pair (a reference)."""
        if np.any(q < self.lower - 1e-12) or np.any(q > self.upper + 1e-12):
            return True
        return bool(pin.computeCollisions(self.model, self.data, self.geometry, self.geometry_data, q, True))

    def samples(self, path: np.ndarray) -> int:
        """How many configurations :meth:`first_invalid` checks along ``path``."""
        path = np.asarray(path, dtype=float)
        steps = [max(1, math.ceil(np.max(np.abs(b - a)) / self.step)) for a, b in zip(path[:-1], path[1:])]
        return int(sum(steps)) + 1

    def first_invalid(self, path: np.ndarray) -> tuple[int, float] | None:
        """``(segment, fraction)`` of the first invalid configuration along ``path`` ``(k, nq)``, or None when
        every sampled configuration is valid."""
        path = np.asarray(path, dtype=float)
        if len(path) == 0:
            return None
        if self.in_collision(path[0]):
            return 0, 0.0
        for s, (a, b) in enumerate(zip(path[:-1], path[1:])):
            n = max(1, math.ceil(np.max(np.abs(b - a)) / self.step))
            for k in range(1, n + 1):
                if self.in_collision(a + (k / n) * (b - a)):
                    return s, k / n
        return None
