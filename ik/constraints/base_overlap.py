"""Obstacles inside the robot's fixed base: the check a collision scene gets once, and the memory of the
obstacles found clear of it.

The fixed base cannot move out of an obstacle that overlaps it, so no configuration is collision free and a
solve could only fail slowly: :func:`check_base_overlap` refuses such a scene at once with an
:class:`InputError` naming the obstacle and the base geometry. An obstacle overlaps a base geometry when
coal's signed distance between them is below ``-BASE_TOLERANCE``; coal is asked only where the obstacle's
bounding ball (:meth:`~kinserve.kinematics.shapes.Shape.bounding_ball`) meets the ball of a base geometry
(:meth:`~kinserve.kinematics.collision_model.CollisionModel.base_spheres`).

An obstacle found clear is remembered by value (shapes are immutable and hash by value; meshes never, their
check is not worth the memory) in a :class:`BaseClearance`, one per robot held by its IK state
(``kinserve.ik.state.IKState.base_clearance``), so a table or a wall shared by many scenes is checked once.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Iterable
from typing import Any

import coal

from kinserve.kinematics.errors import InputError

#: An obstacle may overlap the fixed base by at most this much (m) (the Panda's base mesh reaches 0.03 mm
#: below its mounting plane, so a table under it touches it); deeper means the base is inside it.
BASE_TOLERANCE = 1e-3
#: Obstacles a :class:`BaseClearance` remembers before it starts afresh.
BASE_CLEAR_SIZE = 256


class BaseClearance:
    """The obstacles (by value) found clear of the fixed base of one collision model.

    Held by the robot's IK state and shared by its threads (updates under :attr:`lock`); a different
    collision model (the robot's was rebuilt) starts the memory afresh, and so does one more than
    ``size`` obstacles.
    """

    def __init__(self, size: int = BASE_CLEAR_SIZE) -> None:
        self.size = size
        self.lock = threading.Lock()
        self.model: Any = None  #: the collision model the shapes were checked against
        self.shapes: set = set()

    def holds(self, model: Any, shape: Any) -> bool:
        """Whether ``shape`` was found clear of the base of ``model``."""
        return self.model is model and shape in self.shapes

    def remember(self, model: Any, shapes: Iterable) -> None:
        """Record ``shapes`` (not meshes) as clear of the base of ``model``."""
        shapes = list(shapes)
        with self.lock:
            if self.model is not model:
                self.model, self.shapes = model, set()
            if len(self.shapes) + len(shapes) > self.size:
                self.shapes = set()
            self.shapes.update(shapes)


class _BaseDistance:
    """coal's signed distance (m) between base geometry ``i`` of a collision model and obstacle slot ``k`` of
    a scene (the layout's geometry of that slot - the same shape and size - at the scene's pose of it); the
    request and result objects are made on the first query and reused."""

    def __init__(self, model: Any, scene: Any) -> None:
        self.model, self.scene = model, scene
        self.request = self.result = self.objects = None

    def __call__(self, i: int, slot: int) -> float:
        if self.request is None:
            self.request, self.result = coal.DistanceRequest(), coal.DistanceResult()
            self.objects = self.model.geometry.geometryObjects
        g = self.objects[i]
        geometry, placement = self.scene.layout.obstacle_geometries[slot], self.scene.placements[slot]
        self.result.clear()
        return coal.distance(g.geometry, coal.Transform3s(g.placement.rotation, g.placement.translation),
                             geometry, coal.Transform3s(placement.rotation, placement.translation),
                             self.request, self.result)


def check_base_overlap(robot: Any, scene: Any, known: tuple = (), clear: BaseClearance | None = None) -> None:
    """:class:`InputError` when an obstacle of ``scene`` overlaps a geometry fixed to the world by more than
    :data:`BASE_TOLERANCE` (module docstring).

    ``clear``: the robot's memory of obstacles found clear (looked up and updated; None = none). With
    ``known`` (the obstacles of a scene already checked, in their places), an obstacle that is ``known[k]``
    itself is skipped and nothing is looked up or remembered (the others are moved copies, usually seen
    once).
    """
    model = robot.collision
    base = model.base_spheres()
    if not base or not scene.obstacles:
        return
    memory = clear if not known else None
    distance = _BaseDistance(model, scene)
    newly = []
    for slot, shape in enumerate(scene.obstacles):
        if slot < len(known) and known[slot] is shape:
            continue
        mesh = shape.kind == "mesh"
        if not mesh and memory is not None and memory.holds(model, shape):
            continue
        _check_obstacle(scene, base, slot, shape, distance)
        if not mesh:
            newly.append(shape)
    if newly and memory is not None:
        memory.remember(model, newly)


def _check_obstacle(scene: Any, base: list, slot: int, shape: Any, distance: _BaseDistance) -> None:
    """:class:`InputError` when obstacle ``slot`` (``shape``) overlaps a base geometry ``(i, centre, radius)``
    of ``base`` by more than :data:`BASE_TOLERANCE`; coal is asked only where the bounding balls meet."""
    c_ob, r_ob = shape.bounding_ball()
    for i, c, r in base:
        if math.dist(c, c_ob) > r + r_ob:  # balls apart: no overlap at all (GJK not needed)
            continue
        d = distance(i, slot)
        if d < -BASE_TOLERANCE:
            raise InputError(
                f"{scene.geometry_owner[scene.n_robot + slot]} overlaps the robot's fixed base "
                f"({scene.geometry_owner[i]}) by {-d:.4g} m; the base cannot move out of it"
            )
