"""The arguments of :class:`~kinserve.ik.constraints.obstacles.ObstacleAvoidance`, checked and coerced.

* obstacles: a shape of :mod:`kinserve.kinematics.shapes`, a ``{"kind": ...}`` dict, a
  ``{"center", "radius"}`` dict or a ``(center, radius)`` pair (a sphere), or a sequence of those;
* lengths (link radius, margin, influence): finite numbers ``>= 0`` in metres;
* the velocity-damper gain ``xi`` in ``(0, 1]``;
* frame names: one name or a sequence of names.

Invalid input raises :class:`~kinserve.kinematics.errors.InputError` naming the argument.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from kinserve.kinematics.errors import InputError, NonFiniteError
from kinserve.kinematics.shapes import Shape, Sphere, as_shape
from kinserve.kinematics.validation import MAX_ABS

#: The kinds an obstacle dict may name.
OBSTACLE_KINDS = ("sphere", "box", "capsule", "cylinder", "mesh")


def as_obstacle(value: Any, name: str = "obstacle") -> Shape:
    """A shape from a shape, a ``{"kind": ...}`` dict, a ``{"center", "radius"}`` dict or a
    ``(center, radius)`` pair."""
    if isinstance(value, Shape):
        return value
    if isinstance(value, dict) and "kind" not in value:
        if "center" in value and "radius" in value:
            return Sphere(value["center"], value["radius"], value.get("frames"))
        raise InputError(f"{name} dict needs a 'kind' ({', '.join(OBSTACLE_KINDS)}) "
                         f"or 'center' and 'radius', got keys {sorted(value)}")
    if isinstance(value, dict):
        return as_shape(value, name)
    try:
        center, radius = value
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a shape (ik.Sphere, ik.Box, ik.Capsule, ik.Cylinder, ik.Mesh), "
                         f"a dict or a (center, radius) pair, got {value!r}") from None
    return Sphere(center, radius)


def obstacle_list(obstacles: Any, name: str = "obstacles") -> list[Shape]:
    """``obstacles`` (one obstacle or a sequence of them, see :func:`as_obstacle`) as a list of shapes."""
    if isinstance(obstacles, (Shape, dict)):
        obstacles = [obstacles]
    try:
        items = list(obstacles)
    except TypeError:
        raise InputError(f"{name} must be a sequence of shapes, got {obstacles!r}") from None
    return [o if isinstance(o, Shape) else as_obstacle(o, f"{name}[{i}]") for i, o in enumerate(items)]


def non_negative(value: Any, name: str) -> float:
    """``value`` as a float, checked finite, ``>= 0`` and at most :data:`MAX_ABS` (a length in m).
    Refused: non-numbers and bools (:class:`InputError`), NaN, infinities and larger values
    (:class:`NonFiniteError`), negative values."""
    if type(value) is float and 0.0 <= value <= MAX_ABS:  # the common case, checked in one test
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise InputError(f"{name} must be a number >= 0 (m), got {value!r}")
    v = float(value)
    if not math.isfinite(v) or v > MAX_ABS:
        raise NonFiniteError(f"{name} must be a finite number >= 0 (m) at most {MAX_ABS:g}, got {value!r}")
    if v < 0.0:
        raise InputError(f"{name} must be a finite number >= 0 (m), got {value!r}")
    return v


def damper_gain(value: Any, name: str = "gain") -> float:
    """The velocity-damper gain ``xi`` as a float, checked in ``(0, 1]``."""
    if type(value) is float and 0.0 < value <= 1.0:  # the common case, checked in one test
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)) \
            or not (0.0 < value <= 1.0):
        raise InputError(f"{name} (velocity damper xi) must be in (0, 1], got {value!r}")
    return float(value)


def frame_names(frames: Sequence[str] | str | None, name: str = "tool_frames") -> tuple[str, ...] | None:
    """One frame name or a sequence of them as a tuple of names (None stays None: the default)."""
    if frames is None:
        return None
    if isinstance(frames, str):
        return (frames,)
    if type(frames) is tuple and len(frames) == 1 and type(frames[0]) is str:  # the common case: one name
        return frames
    try:
        names = tuple(frames)
    except TypeError:
        raise InputError(f"{name} must be a frame name or a sequence of frame names, "
                         f"got {frames!r}") from None
    if not all(isinstance(f, str) for f in names):
        raise InputError(f"{name} must hold frame names (str), got {frames!r}")
    return names
