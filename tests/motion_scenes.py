"""Scenes, problems and an independent collision check for the tests of ``planners.plan_motion``.

The independent check does not use the planner's collision model: it builds the
Panda's collision geometry from its URDF with ``pinocchio.buildGeomFromUrdfString``
(the original triangle meshes as coal BVH models, not the convex hulls the
planner uses), adds the obstacles as ``coal.Box`` objects fixed to the world, the
self pairs of the robot's SRDF (by geometry name) and every moving geometry
against every obstacle, and answers with ``pinocchio.computeCollisions``.
"""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin

from kinserve import ik

#: Max-norm joint step (rad) of the dense samples of a path.
DENSE_STEP = 5e-4


def box(size, xyz) -> ik.Box:
    """An axis-aligned box of full edges ``size`` (m) centred at ``xyz``."""
    T = np.eye(4)
    T[:3, 3] = xyz
    return ik.Box(size=size, pose=T)


def shelf_scene() -> list:
    """A table, a pillar in front of the Panda, a side wall and a shelf overhead."""
    return [box((1.6, 1.6, 0.04), (0.3, 0.0, -0.03)),
            box((0.15, 0.15, 0.9), (0.45, 0.0, 0.45)),
            box((0.8, 0.05, 0.5), (0.3, 0.4, 0.25)),
            box((0.6, 0.6, 0.03), (0.45, -0.3, 0.8))]


def straight_line_collides(robot, obstacles, a, b, n: int = 64) -> bool:
    """True when one of ``n`` evenly spaced points of ``a -> b`` is in collision."""
    return any(robot.in_collision(a + s * (b - a), obstacles) for s in np.linspace(0.0, 1.0, n))


def blocked_problems(robot, obstacles, n: int, seed: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """``n`` (start, goal) pairs, both at least 1 cm from any collision, whose straight line collides."""
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < n:
        a, b = robot.random_q(rng), robot.random_q(rng)
        if any(robot.in_collision(q, obstacles) or robot.min_distance(q, obstacles) < 0.01 for q in (a, b)):
            continue
        if straight_line_collides(robot, obstacles, a, b):
            out.append((a, b))
    return out


def dense(points: np.ndarray, step: float = DENSE_STEP) -> np.ndarray:
    """Samples of the polyline ``points`` ``(k, nq)``, consecutive samples at most ``step`` apart in every
    joint (max-norm), both ends of every segment included."""
    out = [points[:1]]
    for a, b in zip(points[:-1], points[1:]):
        n = max(1, int(np.ceil(np.max(np.abs(b - a)) / step)))
        out.append(a + np.linspace(0.0, 1.0, n + 1)[1:, None] * (b - a))
    return np.concatenate(out)


class IndependentCheck:
    """The robot's collision geometry from its URDF (meshes as BVH), the obstacles, the SRDF self pairs and
    the obstacle pairs of the moving geometries; :meth:`colliding` answers with ``computeCollisions``."""

    def __init__(self, robot, obstacles, self_collision: bool = True) -> None:
        urdf = robot.source if robot.resolve_meshes is None else robot.resolve_meshes(robot.source)
        gm = pin.buildGeomFromUrdfString(robot.model, urdf, pin.GeometryType.COLLISION,
                                         package_dirs=list(robot.package_dirs))
        #: The coal type of every robot geometry (meshes stay triangle soups: ``BVHModel...``, not hulls).
        self.kinds = [type(g.geometry).__name__ for g in gm.geometryObjects]
        moving = [g for g in range(gm.ngeoms) if gm.geometryObjects[g].parentJoint != 0]
        if self_collision:
            names = robot.collision.geometry_names
            for i, j in robot.collision.self_pairs:
                gm.addCollisionPair(pin.CollisionPair(gm.getGeometryId(names[i]), gm.getGeometryId(names[j])))
        for k, shape in enumerate(obstacles):
            placed = pin.GeometryObject(f"obstacle{k}", 0, 0, pin.SE3(shape.pose), coal.Box(*shape.size))
            idx = gm.addGeometryObject(placed)
            for g in moving:
                gm.addCollisionPair(pin.CollisionPair(g, idx))
        self.model = robot.model
        self.data = robot.model.createData()
        self.geometry = gm
        self.geometry_data = pin.GeometryData(gm)

    def colliding(self, q: np.ndarray) -> bool:
        """True when any pair intersects at ``q``."""
        return bool(pin.computeCollisions(self.model, self.data, self.geometry, self.geometry_data, q, True))

    def first_collision(self, Q: np.ndarray) -> int:
        """Index of the first row of ``Q`` in collision, -1 when none is."""
        for i, q in enumerate(Q):
            if self.colliding(q):
                return i
        return -1
