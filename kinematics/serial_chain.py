"""One encoding of a model's joints for the compiled kernels and the batch FK: :class:`JointTable`.

:func:`joint_table` is the one reader of a Pinocchio model's joints and frames. Its table has a row per
joint (row ``k`` is Pinocchio joint ``k + 1``):

* ``geometry`` ``(J, 15)``: the joint's placement in its parent joint frame (rotation row-major, 9
  numbers; translation, 3) and its unit axis in its own frame (3);
* ``joints`` ``(J, 3)`` integers: the joint's kind (:data:`REVOLUTE`, :data:`PRISMATIC`, or
  :data:`OTHER` for any joint the kernels do not model: free-flyer, planar, spherical, continuous,
  helical, mimic...; its geometry row is then zero), its index in ``q`` and the Pinocchio index of its
  parent joint (``0`` = the universe; always below ``k + 1``, so rows taken in order see their parent's
  world placement already computed);

and a row per frame: ``frame_parent`` ``(F,)`` (the frame's parent joint) and ``frame_placement``
``(F, 12)`` (its placement in that joint's frame, rotation row-major then translation).

The three uses derive from it:

* :func:`kinematic_tree` / :meth:`JointTable.tree` - every joint, ``(geometry (J, 15), joints (J, 3))``,
  for the compiled collision pre-check (:mod:`.precheck_kernels`), the clearance kernel, the robot's
  spheres and the batch tree FK; None when any joint is :data:`OTHER`;
* :func:`serial_chain` / :meth:`JointTable.serial` - the path from the root to one frame,
  ``geometry`` ``(n + 1, 15)`` (the tree's rows of the joints on the path, root first, then the frame's
  placement with zero axis) and ``joints`` ``(n, 2)`` (kind, index in ``q``: the tree's first two
  columns), for the compiled LM of :mod:`kinserve.ik.lm.kernel`; None when a joint on the path is
  :data:`OTHER`;
* :class:`~.batch_fk.ChainFK` - the NumPy batch FK of one frame, built from :meth:`JointTable.chain`.

The compiled kernels also assume ``q + dq`` is the integration: :func:`kinematic_tree` and
:func:`serial_chain` give None when the model's configuration and velocity sizes differ
(``JointTable.same_sizes`` false). :func:`joint_axis` reads one joint's kind and axis for the table; the
planar closed form reads its chain from the table too. Units: metres and radians.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

#: Joint kinds of the ``joints`` array; OTHER: a joint the kernels do not model.
REVOLUTE, PRISMATIC, OTHER = 0, 1, -1

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


@dataclass(frozen=True, eq=False)
class JointTable:
    """Every joint and frame of one model (module docstring); built by :func:`joint_table`."""

    geometry: np.ndarray  #: ``(J, 15)``: placement in the parent joint frame, unit axis
    joints: np.ndarray  #: ``(J, 3)`` int64: kind, index in ``q``, parent Pinocchio joint
    frame_parent: np.ndarray  #: ``(F,)`` int64: each frame's parent Pinocchio joint
    frame_placement: np.ndarray  #: ``(F, 12)``: each frame's placement in its parent joint frame
    same_sizes: bool  #: the model's ``nq == nv``

    def path_to(self, frame_id: int) -> list[int]:
        """Rows of the joints from the root to frame ``frame_id``'s parent joint, root first (each row's
        parent column names the previous row's joint)."""
        rows = []
        j = int(self.frame_parent[frame_id])
        while j > 0:
            rows.append(j - 1)
            j = int(self.joints[j - 1, 2])
        rows.reverse()
        return rows

    def chain(self, frame_id: int) -> tuple[np.ndarray, np.ndarray] | None:
        """``(geometry (n + 1, 15), joints (n, 2))`` of the path to frame ``frame_id`` (the layout of
        :func:`serial_chain`) whatever the model's sizes, or None when a joint on the path is
        :data:`OTHER`."""
        rows = self.path_to(frame_id)
        if (self.joints[rows, 0] == OTHER).any():
            return None
        geometry = np.zeros((len(rows) + 1, 15))
        geometry[:-1] = self.geometry[rows]
        geometry[-1, :12] = self.frame_placement[frame_id]
        return geometry, np.ascontiguousarray(self.joints[rows, :2])

    def serial(self, frame_id: int) -> tuple[np.ndarray, np.ndarray] | None:
        """:meth:`chain`, or None when the model's ``nq != nv`` (what the compiled LM reads)."""
        return self.chain(frame_id) if self.same_sizes else None

    def tree(self) -> tuple[np.ndarray, np.ndarray] | None:
        """``(geometry (J, 15), joints (J, 3))`` of every joint, or None when a joint is :data:`OTHER` or
        the model's ``nq != nv``."""
        if not self.same_sizes or (self.joints[:, 0] == OTHER).any():
            return None
        return self.geometry, self.joints


def joint_table(model: pin.Model) -> JointTable:
    """The :class:`JointTable` of ``model``: the one place the kernels' arrays are read from a model."""
    n = model.njoints - 1
    geometry = np.zeros((n, 15))
    joints = np.zeros((n, 3), dtype=np.int64)
    for j in range(1, model.njoints):
        kind_axis = joint_axis(model.joints[j])
        joints[j - 1, 1:] = model.joints[j].idx_q, model.parents[j]
        if kind_axis is None:
            joints[j - 1, 0] = OTHER
            continue
        kind, axis = kind_axis
        M = model.jointPlacements[j]
        row = geometry[j - 1]
        row[:9] = M.rotation.reshape(9)
        row[9:12] = M.translation
        row[12:] = axis / np.linalg.norm(axis)
        joints[j - 1, 0] = REVOLUTE if kind == "R" else PRISMATIC
    frame_parent = np.array([f.parentJoint for f in model.frames], dtype=np.int64)
    frame_placement = np.zeros((model.nframes, 12))
    for f, frame in enumerate(model.frames):
        frame_placement[f, :9] = frame.placement.rotation.reshape(9)
        frame_placement[f, 9:] = frame.placement.translation
    return JointTable(geometry, joints, frame_parent, frame_placement, model.nq == model.nv)


def serial_chain(model: pin.Model, frame_id: int) -> tuple[np.ndarray, np.ndarray] | None:
    """``(geometry, joints)`` of the path from the root to frame ``frame_id`` (module docstring), or None.

    None when a joint on the path is not a one-DoF revolute / prismatic joint,
    or when the model's configuration and velocity sizes differ (``q + dq``
    would not be the integration the kernels assume).
    """
    return joint_table(model).serial(frame_id)


def kinematic_tree(model: pin.Model) -> tuple[np.ndarray, np.ndarray] | None:
    """``(geometry, joints)`` of every joint of ``model`` (module docstring), or None.

    None when a joint is not a one-DoF revolute / prismatic joint, or when the
    configuration and velocity sizes differ. A model without joints gives
    arrays of zero rows.
    """
    return joint_table(model).tree()
