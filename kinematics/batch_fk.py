"""Forward kinematics of one frame for a whole batch of configurations at once.

For the chain of joints ``j_1 ... j_k`` from the root to the frame's parent
joint, with fixed placements ``M_i = (R_i, p_i)`` (joint in its parent joint)
and joint motions ``X_i(q)``:

    oMf(q) = M_1 X_1(q) M_2 X_2(q) ... M_k X_k(q) F

where ``F`` is the frame's placement in its parent joint. A revolute joint
about unit axis ``a`` moves by ``X = (Rot(a, q), 0)`` with Rodrigues'
formula ``Rot(a, q) = I + sin q [a]x + (1 - cos q) [a]x^2``; a prismatic
joint by ``X = (I, a q)``. Every product is evaluated for all N
configurations with NumPy, so the per-configuration cost is a few hundred
nanoseconds instead of a Python call into Pinocchio per configuration.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from .errors import ModelError
from .serial_chain import OTHER, REVOLUTE, JointTable, joint_table


class ChainFK:
    """Vectorised FK of frame ``frame_id`` of ``model``; call with ``Q`` (N, nq).

    Built from the model's :class:`~.serial_chain.JointTable` (``table``, read from ``model`` when not
    given): the rows of the joints on the path to the frame and the frame's placement. Raises
    :class:`~.errors.ModelError` when a joint on the path is not a one-DoF revolute / prismatic joint."""

    def __init__(self, model: pin.Model, frame_id: int, table: JointTable | None = None):
        table = joint_table(model) if table is None else table
        chain = table.chain(frame_id)
        if chain is None:
            other = next(r for r in table.path_to(frame_id) if table.joints[r, 0] == OTHER)
            raise ModelError("batch FK supports revolute and prismatic joints only, "
                             f"got {model.joints[other + 1].shortname()}")
        geometry, joints = chain
        self.steps = []
        for row, (kind, iq) in zip(geometry[:-1], joints.tolist()):
            MR, Mp, axis = row[:9].reshape(3, 3).copy(), row[9:12].copy(), row[12:15].copy()
            K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
            # M_R Rot(a, q) = M_R + sin q (M_R K) + (1 - cos q) (M_R K^2): one stacked product per joint
            self.steps.append((iq, kind, Mp, MR, MR @ K, MR @ K @ K, MR @ axis))
        self.frame_R = geometry[-1, :9].reshape(3, 3).copy()
        self.frame_p = geometry[-1, 9:12].copy()

    def __call__(self, Q: np.ndarray) -> np.ndarray:
        """World poses ``(N, 4, 4)`` of the frame at the configurations ``Q`` ``(N, nq)``."""
        N = Q.shape[0]
        R = np.broadcast_to(np.eye(3), (N, 3, 3))
        p = np.zeros((N, 3))
        for iq, kind, Mp, MR, MRK, MRK2, MRa in self.steps:
            p = p + R @ Mp
            qi = Q[:, iq]
            if kind == REVOLUTE:
                A = MR + np.sin(qi)[:, None, None] * MRK + (1.0 - np.cos(qi))[:, None, None] * MRK2
                R = R @ A
            else:
                p = p + (R @ MRa) * qi[:, None]
                R = R @ MR
        T = np.zeros((N, 4, 4))
        T[:, :3, 3] = p + R @ self.frame_p
        T[:, :3, :3] = R @ self.frame_R
        T[:, 3, 3] = 1.0
        return T
