"""Carried objects: a shape held by one frame of the robot, moving with it.

``robot.attach(name, shape, frame, pose_in_frame, touch_links)`` (see
:meth:`~.collision_queries.CollisionQueries.attach`) makes an :class:`AttachedObject`: the
shape's geometry is fixed to ``frame``'s parent joint, so at ``q`` its world pose is
``fk(q, frame) @ pose_in_frame @ shape pose`` (``placement = pose_in_frame @ shape pose``).
The robot's collision model then holds it as one more robot geometry
(:meth:`~.collision_model.CollisionModel.with_attached`), named ``"attached:<name>"`` in
pair names:

* against obstacles: always checked (like every geometry on a moving joint; a frame fixed to
  the world is refused);
* against the robot's own links (when self-collision is checked): every link except the
  ``touch_links`` (default: the link the frame belongs to - name a gripper's fingers when
  they move on joints of their own) and the links on the same rigid body (Pinocchio joint:
  they cannot move relative to it);
* two attached objects on different bodies are checked against each other; on one body, not.

Units: metres; poses are 4x4 homogeneous matrices.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from .errors import InputError
from .shapes import Shape, as_shape
from .validation import as_pose

#: Prefix of an attached object's name in collision pair names.
ATTACHED_PREFIX = "attached:"


@dataclass(frozen=True, eq=False)
class AttachedObject:
    """A shape carried by ``frame``: ``name``, ``shape`` (a kinserve shape), ``frame``, ``pose_in_frame``
    (4x4), ``touch_links`` (link names it may touch) and ``placement`` (4x4: the pose of the shape's
    geometry in the frame, ``pose_in_frame @ shape pose``)."""

    name: str
    shape: Shape
    frame: str
    pose_in_frame: np.ndarray
    touch_links: tuple[str, ...]
    placement: np.ndarray

    def __setstate__(self, state: dict) -> None:
        """Unpickling: the poses read-only again (as :func:`attached_object` makes them)."""
        for key in ("pose_in_frame", "placement"):
            state[key] = np.array(state[key], dtype=float)
            state[key].flags.writeable = False
        self.__dict__.update(state)

    @property
    def link_name(self) -> str:
        """Its name in collision pair names: ``"attached:<name>"``."""
        return ATTACHED_PREFIX + self.name

    def to_dict(self) -> dict:
        """Plain data: name, the shape's ``to_dict()``, frame, pose_in_frame (nested lists), touch_links."""
        return {"name": self.name, "shape": self.shape.to_dict(), "frame": self.frame,
                "pose_in_frame": self.pose_in_frame.tolist(), "touch_links": list(self.touch_links)}


def attached_object(name: Any, shape: Any, frame: str, pose_in_frame: Any, touch_links: Any,
                    links: Iterable[str], default_touch: str | None) -> AttachedObject:
    """The validated :class:`AttachedObject` (``frame`` already checked by the robot; ``links``: the robot's
    collision link names; ``default_touch``: the collision link ``frame`` belongs to, None when it has no
    collision geometry).

    :class:`InputError` for an empty or non-string name, a shape that is not a shape (or a mesh: carried
    objects are primitives), a bad pose, or a touch link the robot does not have.
    """
    if not isinstance(name, str) or not name.strip():
        raise InputError(f"attach: name must be a non-empty string, got {name!r}")
    shape = as_shape(shape, f"attach({name!r}): shape")
    if shape.kind == "mesh":
        raise InputError(f"attach({name!r}): a carried object must be a sphere, box, capsule or cylinder, "
                         "got a mesh")
    T = np.eye(4) if pose_in_frame is None else as_pose(pose_in_frame, f"attach({name!r}): pose_in_frame")
    known = set(links)
    if touch_links is None:
        touch = () if default_touch is None else (default_touch,)
    elif isinstance(touch_links, str):
        touch = (touch_links,)
    elif isinstance(touch_links, (list, tuple, set, frozenset)):
        touch = tuple(touch_links)
    else:
        raise InputError(f"attach({name!r}): touch_links must be a link name or a list of link names, "
                         f"got {type(touch_links).__name__} {touch_links!r}")
    for link in touch:
        if not isinstance(link, str) or link not in known:
            raise InputError(f"attach({name!r}): touch link {link!r} is not a collision link of the robot; "
                             f"expected some of {sorted(known)}")
    placement = T @ shape.placement().homogeneous
    T = T.copy()
    T.flags.writeable = False
    placement.flags.writeable = False
    return AttachedObject(name, shape, frame, T, touch, placement)


__all__ = ["ATTACHED_PREFIX", "AttachedObject", "attached_object"]
