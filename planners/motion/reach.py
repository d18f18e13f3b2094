"""How far a joint change can move the robot's collision geometry: the reach table of a scene's pairs.

For a robot geometry ``g`` carried by joint ``j`` with a bounding ball of centre
``c`` and radius ``r`` in ``j``'s frame, and a joint ``k`` on the path from ``j`` to
the root, ``R_g[k]`` bounds the distance from ``k``'s axis to any point of ``g``:

* revolute ``k``: the distance to the joint's origin, at most
  ``|c| + r + sum |t_m|`` over the joints ``m`` from ``j`` up to (not including)
  ``k`` (``t_m``: joint ``m``'s placement offset in its parent's frame), plus the
  largest travel ``max(|lower|, |upper|)`` of a prismatic joint among them; a
  turn by ``dq`` moves every point of ``g`` along an arc of length at most
  ``R_g[k] |dq|``;
* prismatic ``k``: ``R_g[k] = 1`` (everything below translates by ``|dq|``).

Changing the coordinates one at a time (triangle inequality), a joint change
``dq`` moves every point of ``g`` by at most ``sum_k R_g[k] |dq_k|``. For a pair of a
scene (:class:`~kinserve.kinematics.collision_scene.CollisionScene`), its signed
distance is 1-Lipschitz in the displacement of either body, so it changes by at
most ``sum_k W[p, k] |dq_k|`` with ``W[p] = R_a`` for robot geometry ``a`` against an
obstacle, and ``W[p] = (R_a + R_b)`` on the joints that carry exactly one of
``a``, ``b`` for a self pair (a joint that carries both moves them rigidly together:
their distance does not change). Geometries of the fixed base have ``R = 0``.

Units: metres per radian (revolute), metres per metre (prismatic).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin

from kinserve.kinematics.collision_model import bounding_sphere
from kinserve.kinematics.errors import ModelError

REVOLUTE_JOINTS = ("JointModelRX", "JointModelRY", "JointModelRZ", "JointModelRevoluteUnaligned")
PRISMATIC_JOINTS = ("JointModelPX", "JointModelPY", "JointModelPZ", "JointModelPrismaticUnaligned")


def joint_kinds(model: pin.Model) -> list[str]:
    """``"revolute"`` or ``"prismatic"`` for each joint of ``model`` but the universe (index ``j - 1``).

    :class:`ModelError` naming the joint for any other kind (the reach bound covers one-DoF revolute and
    prismatic joints).
    """
    kinds = []
    for j in range(1, model.njoints):
        kind = model.joints[j].shortname()
        if kind in REVOLUTE_JOINTS:
            kinds.append("revolute")
        elif kind in PRISMATIC_JOINTS:
            kinds.append("prismatic")
        else:
            raise ModelError(f"joint {model.names[j]!r} is a {kind}: the motion planner bounds the motion of "
                             "one-DoF revolute and prismatic joints only")
    return kinds


def geometry_reach(model: pin.Model, joint: int, centre: np.ndarray, radius: float,
                   kinds: list[str]) -> np.ndarray:
    """``R_g`` ``(nq,)`` (see the module docstring) of a geometry on Pinocchio joint ``joint`` whose
    bounding ball has ``centre`` (in the joint's frame, m) and ``radius`` (m); zeros for ``joint == 0``."""
    reach = np.zeros(model.nq)
    offset = float(np.linalg.norm(centre)) + float(radius)
    j = int(joint)
    while j > 0:
        iq = model.joints[j].idx_q
        if kinds[j - 1] == "revolute":
            reach[iq] = max(reach[iq], offset)
        else:
            reach[iq] = 1.0
            offset += max(abs(float(model.lowerPositionLimit[iq])), abs(float(model.upperPositionLimit[iq])))
        offset += float(np.linalg.norm(model.jointPlacements[j].translation))
        j = int(model.parents[j])
    return reach


def carrying_joints(model: pin.Model, joint: int) -> np.ndarray:
    """Boolean ``(nq,)``: the coordinates of the joints on the path from Pinocchio joint ``joint`` to the
    root (those that move a body fixed to ``joint``)."""
    mask = np.zeros(model.nq, dtype=bool)
    j = int(joint)
    while j > 0:
        mask[model.joints[j].idx_q] = True
        j = int(model.parents[j])
    return mask


def pair_reach(model: pin.Model, scene: Any) -> np.ndarray:
    """``W`` ``(P, nq)``: per checked pair of ``scene`` (a
    :class:`~kinserve.kinematics.collision_scene.CollisionScene` of ``model``'s robot), the bound of the
    change of its signed distance per unit change of each coordinate (module docstring):
    ``|d_p(q') - d_p(q)| <= W[p] . |q' - q|``."""
    kinds = joint_kinds(model)
    objects = scene.geometry.geometryObjects
    n_robot = scene.n_robot
    reach, carried = [], []
    for g in range(n_robot):
        obj = objects[g]
        centre, radius = bounding_sphere(obj.geometry, pin.SE3(obj.placement))
        reach.append(geometry_reach(model, obj.parentJoint, centre, radius, kinds))
        carried.append(carrying_joints(model, obj.parentJoint))
    W = np.zeros((len(scene.pairs), model.nq))
    for p, (a, b) in enumerate(np.asarray(scene.pairs, dtype=int).reshape(-1, 2)):
        if a >= n_robot:
            a, b = b, a
        if b >= n_robot:  # robot geometry a against an obstacle
            W[p] = reach[a]
        else:
            W[p] = np.where(carried[a] & carried[b], 0.0, reach[a] + reach[b])
    return W


__all__ = ["PRISMATIC_JOINTS", "REVOLUTE_JOINTS", "carrying_joints", "geometry_reach", "joint_kinds",
           "pair_reach"]
