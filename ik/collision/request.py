"""The collision part of an IK request: ``self_collision``, ``obstacles`` and ``collision_margin``,
validated."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, NamedTuple

from kinserve.ik.constraints.collision import check_length
from kinserve.kinematics.shapes import Shape, as_obstacles
from kinserve.kinematics.validation import as_flag


class CollisionRequest(NamedTuple):
    """Validated collision options of one solve.

    ``obstacles``: shapes of :mod:`kinserve.kinematics.shapes` (``spheres=`` given with collision options
    join them); ``self_collision``: keep the robot's checked link pairs apart; ``margin`` (m): the clearance
    kept from obstacles and between checked pairs.
    """

    self_collision: bool
    obstacles: tuple[Shape, ...]
    margin: float


def collision_request(self_collision: Any = False, obstacles: Sequence[Any] = (), collision_margin: Any = 0.0,
                      spheres: Sequence[Any] = ()) -> CollisionRequest:
    """Validate the collision options of ``ik.solve`` (errors name the argument and the expected form)."""
    obs = as_obstacles(obstacles)
    if spheres is not None and (type(spheres) is not tuple or spheres):
        obs += as_obstacles(spheres, "spheres")
    self_collision = as_flag(self_collision, "self_collision")
    margin = 0.0 if type(collision_margin) is float and collision_margin == 0.0 \
        else check_length(collision_margin, "collision margin")
    return CollisionRequest(self_collision, tuple(obs), margin)
