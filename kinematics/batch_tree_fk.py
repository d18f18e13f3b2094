"""World placements of every joint of a model for a batch of configurations (NumPy, vectorised over it).

For Pinocchio joint ``j`` with parent ``parent(j)``, placement ``M_j = (R_j, t_j)``
in its parent's frame and motion ``X_j(q)``:

    oMj(q) = oM(parent(j))(q) M_j X_j(q),    oM0 = identity (the world),

where a revolute joint about unit axis ``a`` turns by Rodrigues' formula
``Rot(a, q) = I + sin q [a]x + (1 - cos q) [a]x^2`` and a prismatic joint
translates by ``a q``. Joints are taken in Pinocchio's order (a parent comes
before its children), each step one product over all ``N`` configurations.
Trees of one-degree-of-freedom revolute and prismatic joints
(:func:`~.serial_chain.kinematic_tree`) take this path; any other model goes
through ``pinocchio.forwardKinematics`` one configuration at a time.
Units: metres, radians.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pinocchio as pin

from .serial_chain import REVOLUTE, kinematic_tree


class JointPlacements(NamedTuple):
    """``rotations`` ``(njoints, 3, 3, N)`` and ``translations`` ``(njoints, 3, N)`` (m) of every joint
    (index 0: the world) in the world frame; the configuration is the last axis (each entry of a placement is
    one contiguous array over the batch)."""

    rotations: np.ndarray
    translations: np.ndarray


def joint_placements(model: pin.Model, Q: np.ndarray) -> JointPlacements:
    """The world placement of every joint of ``model`` at each row of ``Q`` ``(N, nq)`` (module docstring).

    Each step multiplies by a constant matrix on the left of the batch (``(3, 3) @ (3, N)`` products) and by
    the joint's motion entry-wise."""
    Q = np.asarray(Q, dtype=float).reshape(-1, model.nq)
    packed = kinematic_tree(model)
    if packed is None:
        return _pinocchio_placements(model, Q)
    tree, joints = packed
    N = len(Q)
    R = np.empty((model.njoints, 3, 3, N))
    t = np.empty((model.njoints, 3, N))
    R[0], t[0] = np.eye(3)[:, :, None], 0.0
    for k, (kind, iq, parent) in enumerate(joints.tolist()):
        MR, Mt, a = tree[k, :9].reshape(3, 3), tree[k, 9:12], tree[k, 12:15]
        Rp = R[parent]
        t[k + 1] = t[parent] + np.einsum("ijn,j->in", Rp, Mt)
        T = right_product(Rp, MR)  # T = Rp MR
        if kind == REVOLUTE:
            K = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
            s, c = np.sin(Q[:, iq]), np.cos(Q[:, iq])
            R[k + 1] = T + s * right_product(T, K) + (1.0 - c) * right_product(T, K @ K)
        else:
            R[k + 1] = T
            t[k + 1] += np.einsum("ijn,j->in", T, a) * Q[:, iq]
    return JointPlacements(R, t)


def right_product(A: np.ndarray, M: np.ndarray) -> np.ndarray:
    """``A M`` for a batch of matrices ``A`` ``(3, 3, N)`` and one matrix ``M`` ``(3, 3)``:
    ``(A M)[i] = M^T A[i]`` row by row, three ``(3, 3) @ (3, N)`` products."""
    return np.matmul(M.T, A)


def _pinocchio_placements(model: pin.Model, Q: np.ndarray) -> JointPlacements:
    N = len(Q)
    R = np.empty((model.njoints, 3, 3, N))
    t = np.empty((model.njoints, 3, N))
    data = model.createData()
    for s in range(N):
        pin.forwardKinematics(model, data, Q[s])
        for j in range(model.njoints):
            R[j, :, :, s] = data.oMi[j].rotation
            t[j, :, s] = data.oMi[j].translation
    return JointPlacements(R, t)
