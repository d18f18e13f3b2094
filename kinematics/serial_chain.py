"""The serial chain from the root to one frame: its joints, and the same as flat arrays for compiled kernels.

:func:`joint_chain` lists the joints from the root to a frame and
:func:`joint_axis` reads a joint's kind and axis (used by the batch FK, the
batched LM and the planar closed form). :func:`serial_chain` reads a
Pinocchio model's path to a frame - every joint that moves the frame, in
order from the root - and packs it as

* ``geometry`` ``(n + 1, 15)``: row ``k < n`` is joint ``k``'s placement in
  its parent joint frame (rotation row-major, 9 numbers; translation, 3) and
  its unit axis in its own frame (3); row ``n`` is the frame's placement in
  its parent joint frame (axis entries zero);
* ``joints`` ``(n, 2)`` integers: the joint's kind (:data:`REVOLUTE` or
  :data:`PRISMATIC`) and its index in ``q`` (= its index in ``v``).

The compiled kernels of :mod:`kinserve.ik.lm.kernel` evaluate the chain from
these arrays (pose and Jacobian, checked against Pinocchio in the tests).
Units: metres and radians.

:func:`kinematic_tree` packs every joint of a model the same way (the whole
tree, for the compiled collision pre-check of :mod:`.precheck_kernels`):

* ``geometry`` ``(J, 15)``: row ``k`` is Pinocchio joint ``k + 1`` (rows as
  above: placement in its parent joint frame, unit axis);
* ``joints`` ``(J, 3)`` integers: kind, index in ``q``, and the Pinocchio
  index of the parent joint (``0`` = the universe; always below ``k + 1``, so
  rows taken in order see their parent's world placement already computed).

Only chains of one-degree-of-freedom revolute and prismatic joints (any
axis) are packed; any other joint on the path - for the tree, anywhere in the
model - (free-flyer, planar, spherical, continuous, mimic...) gives ``None``
and the caller keeps Pinocchio's own algorithms.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

#: Joint kinds of the ``joints`` array.
REVOLUTE, PRISMATIC = 0, 1

_AXES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}


def joint_axis(joint: pin.JointModel) -> tuple[str, np.ndarray] | None:
    """``('R' | 'P', unit axis in the joint frame)`` of a one-DOF Pinocchio joint model, else None.

    Revolute/prismatic joints about x, y, z and their unaligned variants;
    anything else (spherical, free-flyer, unbounded, composite...) is None.
    """
    short = joint.shortname()
    if short in ("JointModelRX", "JointModelRY", "JointModelRZ"):
        return "R", np.array(_AXES[short[-1]])
    if short in ("JointModelPX", "JointModelPY", "JointModelPZ"):
        return "P", np.array(_AXES[short[-1]])
    if short == "JointModelRevoluteUnaligned":
        return "R", np.asarray(joint.extract().axis, dtype=float).copy()
    if short == "JointModelPrismaticUnaligned":
        return "P", np.asarray(joint.extract().axis, dtype=float).copy()
    return None


def joint_chain(model: pin.Model, frame_id: int) -> list[int]:
    """Indices of the joints from the root to the parent joint of frame ``frame_id``, root first."""
    chain = []
    j = model.frames[frame_id].parentJoint
    while j > 0:
        chain.append(j)
        j = model.parents[j]
    chain.reverse()
    return chain


def serial_chain(model: pin.Model, frame_id: int) -> tuple[np.ndarray, np.ndarray] | None:
    """``(geometry, joints)`` of the path from the root to frame ``frame_id`` (module docstring), or None.

    None when a joint on the path is not a one-DoF revolute / prismatic joint,
    or when the model's configuration and velocity sizes differ (``q + dq``
    would not be the integration the kernels assume).
    """
    if model.nq != model.nv:
        return None
    frame = model.frames[frame_id]
    path = joint_chain(model, frame_id)
    geometry = np.zeros((len(path) + 1, 15))
    joints = np.zeros((len(path), 2), dtype=np.int64)
    for k, j in enumerate(path):
        kind_axis = joint_axis(model.joints[j])
        if kind_axis is None:
            return None
        kind, axis = kind_axis
        M = model.jointPlacements[j]
        geometry[k, :9] = M.rotation.reshape(9)
        geometry[k, 9:12] = M.translation
        geometry[k, 12:] = axis / np.linalg.norm(axis)
        joints[k] = REVOLUTE if kind == "R" else PRISMATIC, model.joints[j].idx_q
    geometry[-1, :9] = frame.placement.rotation.reshape(9)
    geometry[-1, 9:12] = frame.placement.translation
    return geometry, joints


def kinematic_tree(model: pin.Model) -> tuple[np.ndarray, np.ndarray] | None:
    """``(geometry, joints)`` of every joint of ``model`` (module docstring), or None.

    None when a joint is not a one-DoF revolute / prismatic joint, or when the
    configuration and velocity sizes differ. A model without joints gives
    arrays of zero rows.
    """
    if model.nq != model.nv:
        return None
    n = model.njoints - 1
    geometry = np.zeros((n, 15))
    joints = np.zeros((n, 3), dtype=np.int64)
    for j in range(1, model.njoints):
        kind_axis = joint_axis(model.joints[j])
        if kind_axis is None:
            return None
        kind, axis = kind_axis
        M = model.jointPlacements[j]
        row = geometry[j - 1]
        row[:9] = M.rotation.reshape(9)
        row[9:12] = M.translation
        row[12:] = axis / np.linalg.norm(axis)
        joints[j - 1] = REVOLUTE if kind == "R" else PRISMATIC, model.joints[j].idx_q, model.parents[j]
    return geometry, joints
