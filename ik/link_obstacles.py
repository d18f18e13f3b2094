"""The ``spheres`` / ``obstacles`` / ``link_radius`` arguments of ``ik.solve`` as one bound obstacle
constraint."""

from __future__ import annotations

from typing import Any

from kinserve.ik.constraints import as_sphere
from kinserve.ik.constraints.obstacle_arguments import non_negative
from kinserve.ik.constraints.obstacles import ObstacleAvoidance, as_obstacle
from kinserve.kinematics.errors import InputError
from kinserve.kinematics.robot import Robot
from kinserve.kinematics.shapes import Shape


def _group(name: str, group: Any) -> list[Any]:
    """The items of one argument (a shape, a dict spec or a sequence of them)."""
    if group is None or (type(group) is tuple and not group):
        return []
    if isinstance(group, (str, bytes)):
        raise InputError(f"{name} must be a sequence of shapes (ik.Sphere, ik.Box, ...), got {group!r}")
    if isinstance(group, (Shape, dict)):
        return [group]
    try:
        return list(group)
    except TypeError:
        return [group]


def link_obstacles(robot: Robot, spheres: Any, obstacles: Any, link_radius: Any,
                   frame: str) -> ObstacleAvoidance | None:
    """One :class:`ObstacleAvoidance` of ``spheres`` (``ik.Sphere`` or ``(center, radius)``) and ``obstacles``
    (any shape or its ``to_dict()`` form) bound to ``robot``, keeping them clear of the link capsules of
    radius
    ``link_radius`` (m) up to ``frame``; None when there is no obstacle. ``link_radius`` is checked
    (a finite number in ``[0, 1e6]``) even then."""
    if type(spheres) is tuple and not spheres and type(obstacles) is tuple and not obstacles \
            and type(link_radius) in (float, int) and link_radius == 0:
        return None
    items = [as_sphere(s) for s in _group("spheres", spheres)]
    items += [ob if isinstance(ob, Shape) else as_obstacle(ob, f"obstacles[{i}]")
              for i, ob in enumerate(_group("obstacles", obstacles))]
    if not items:
        if not (type(link_radius) in (float, int) and link_radius == 0):
            non_negative(link_radius, "link_radius")  # validated even without obstacles
        return None
    return ObstacleAvoidance(items, link_radius=link_radius, tool_frames=(frame,)).bind(robot)
