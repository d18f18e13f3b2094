"""Obstacles on the command line, the same in every sub-command (``ik``, ``collide``, ``view``, ``reach``,
``plan``).

* ``--sphere CX CY CZ R``: centre and radius (m);
* ``--box CX CY CZ SX SY SZ [ROLL PITCH YAW]``: centre, full edge lengths (m) and optionally the box's
  rotation ``R = Rz(yaw) Ry(pitch) Rx(roll)`` (rad; default axis-aligned);
* ``--cylinder CX CY CZ R L [ROLL PITCH YAW]``: centre, radius, length (m), axis along the (rotated) z;
* ``--scene FILE.yaml``: the collision objects of a MoveIt ``PlanningScene`` YAML
  (:func:`kinserve.planners.read_planning_scene`: boxes, spheres, cylinders).

Each is repeatable. The numbers may also be one comma-separated token (``--sphere 0.5,0,0.4,0.1``). The
obstacles keep the order of the command line (a scene's objects in the file's order), so the k-th one given
is ``obstacle[k]`` in the collision pairs.
"""

from __future__ import annotations

import argparse

import numpy as np

from kinserve.kinematics import se3
from kinserve.kinematics.shapes import Box, Cylinder, Shape, Sphere

from .cli_types import Numbers

#: The destination (``args.obstacles``) the obstacle options append ``(kind, value)`` to, in order.
DEST = "obstacles"


class SceneFile(argparse.Action):
    """``--scene FILE``: appends ``("scene", FILE)`` to ``args.obstacles`` (read after parsing)."""

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        """Append the file name in command-line order."""
        items = list(getattr(namespace, self.dest, None) or [])
        setattr(namespace, self.dest, [*items, ("scene", values)])


def add_obstacle_args(p: argparse.ArgumentParser, use: str = "") -> None:
    """Add ``--sphere``, ``--box``, ``--cylinder`` and ``--scene`` to ``p`` (one argument group).

    ``use``: what the sub-command does with them, appended to the group's description.
    """
    g = p.add_argument_group("obstacles", "each repeatable; the k-th given is obstacle[k] in collision "
                                          "pairs" + (f"; {use}" if use else ""))
    g.add_argument("--sphere", action=Numbers, dest=DEST, kind="sphere", counts=(4,), form="CX CY CZ R",
                   help="sphere: centre and radius (m); also one token CX,CY,CZ,R (default: none)")
    g.add_argument("--box", action=Numbers, dest=DEST, kind="box", counts=(6, 9),
                   form="CX CY CZ SX SY SZ [ROLL PITCH YAW]",
                   help="box: centre and full edge lengths (m), optionally rotated by "
                        "Rz(yaw) Ry(pitch) Rx(roll) (rad) (default: none)")
    g.add_argument("--cylinder", action=Numbers, dest=DEST, kind="cylinder", counts=(5, 8),
                   form="CX CY CZ R L [ROLL PITCH YAW]",
                   help="cylinder: centre, radius and length (m), axis along z, optionally rotated as "
                        "--box (default: none)")
    g.add_argument("--scene", action=SceneFile, dest=DEST, metavar="FILE.yaml",
                   help="MoveIt PlanningScene YAML: its collision objects (boxes, spheres, cylinders) "
                        "(default: none)")


def _placed(v: np.ndarray, n: int) -> np.ndarray:
    """The pose of a centre ``v[:3]`` rotated by the roll-pitch-yaw ``v[n:n + 3]`` when given."""
    R = se3.matrix_from_rpy(*v[n:n + 3]) if v.size == n + 3 else None
    return se3.pose(R, v[:3])


def obstacle(kind: str, value) -> list[Shape]:
    """The shapes of one obstacle option: ``(kind, numbers)`` from :class:`Numbers` or ``("scene", file)``.

    :class:`~kinserve.kinematics.errors.InputError` for a bad size (radius <= 0, ...) or an unreadable
    scene, naming it.
    """
    if kind == "sphere":
        return [Sphere(value[:3], value[3])]
    if kind == "box":
        return [Box(_placed(value, 6), value[3:6])]
    if kind == "cylinder":
        return [Cylinder(_placed(value, 5), value[3], value[4])]
    from kinserve.planners import read_planning_scene

    return read_planning_scene(str(value))


def obstacles_from_args(args: argparse.Namespace) -> list[Shape]:
    """The obstacles given by :func:`add_obstacle_args`' options, in command-line order (metres)."""
    return [shape for kind, value in getattr(args, DEST, None) or [] for shape in obstacle(kind, value)]
