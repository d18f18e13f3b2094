"""A pose on the command line, the same in every sub-command that takes one (``ik``, ``plan``).

``--xyz X Y Z`` (m) with the orientation as ``--quat QX QY QZ QW`` (a unit quaternion in Pinocchio's and
ROS's order, x y z w) or ``--rpy ROLL PITCH YAW`` (rad; ``R = Rz(yaw) Ry(pitch) Rx(roll)``), not both.
Without either the orientation is left free (position only). The numbers must be finite; the pose is built
by the library's own rule, :func:`kinserve.pose` (a quaternion whose norm is more than
``QUATERNION_TOL`` = 1e-3 from 1 is refused, the rest normalised).
"""

from __future__ import annotations

import argparse

import numpy as np

from kinserve.kinematics.errors import InputError
from kinserve.kinematics.validation import make_pose, unit_quaternion

from .cli_types import Numbers

#: The orientation components left free when a pose has no ``--quat`` / ``--rpy``.
ORIENTATION = ("roll", "pitch", "yaw")


def add_pose_args(p: argparse.ArgumentParser, what: str = "target") -> None:
    """Add ``--xyz``, ``--quat`` and ``--rpy`` (the two orientations mutually exclusive) to ``p``."""
    g = p.add_argument_group(f"{what} pose", "--xyz with --quat or --rpy; --xyz alone leaves the "
                                             "orientation free")
    g.add_argument("--xyz", action=Numbers, counts=(3,), form="X Y Z",
                   help=f"{what} position of the frame in the world (m) (default: none)")
    one = g.add_mutually_exclusive_group()
    one.add_argument("--quat", action=Numbers, counts=(4,), form="QX QY QZ QW",
                     help=f"{what} orientation, unit quaternion in x y z w order (Pinocchio, ROS) "
                          "(default: orientation free)")
    one.add_argument("--rpy", action=Numbers, counts=(3,), form="ROLL PITCH YAW",
                     help=f"{what} orientation, R = Rz(yaw) Ry(pitch) Rx(roll) (rad) "
                          "(default: orientation free)")


def pose_from_args(args: argparse.Namespace) -> tuple[np.ndarray, tuple[str, ...]] | None:
    """``(4x4 pose, components left free)`` from ``--xyz`` [``--quat`` | ``--rpy``], None without ``--xyz``.

    The free components are ``("roll", "pitch", "yaw")`` without an orientation, else ``()``.
    :class:`InputError` for ``--quat`` / ``--rpy`` without ``--xyz`` or a quaternion that is not unit.
    """
    quat, rpy = getattr(args, "quat", None), getattr(args, "rpy", None)
    if args.xyz is None:
        if quat is not None or rpy is not None:
            raise InputError(f"{'--quat' if quat is not None else '--rpy'} needs --xyz X Y Z (the position)")
        return None
    if quat is not None:
        quat = unit_quaternion(quat, "--quat")
    T = make_pose(args.xyz, quat=quat, rpy=rpy)
    return T, (() if quat is not None or rpy is not None else ORIENTATION)
