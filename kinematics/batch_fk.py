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
from .serial_chain import joint_axis, joint_chain


class ChainFK:
    """Vectorised FK of frame ``frame_id`` of ``model``; call with ``Q`` (N, nq)."""

    def __init__(self, model: pin.Model, frame_id: int):
        frame = model.frames[frame_id]
        chain = joint_chain(model, frame_id)
        self.steps = []
        for j in chain:
            info = joint_axis(model.joints[j])
            if info is None:
                raise ModelError("batch FK supports revolute and prismatic joints only, "
                                 f"got {model.joints[j].shortname()}")
            kind, axis = info
            M = model.jointPlacements[j]
            MR = M.rotation.copy()
            K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
            # M_R Rot(a, q) = M_R + sin q (M_R K) + (1 - cos q) (M_R K^2): one stacked product per joint
            self.steps.append((model.joints[j].idx_q, kind, M.translation.copy(), MR, MR @ K, MR @ K @ K,
                               MR @ axis))
        F = frame.placement
        self.frame_R = F.rotation.copy()
        self.frame_p = F.translation.copy()

    def __call__(self, Q: np.ndarray) -> np.ndarray:
        """World poses ``(N, 4, 4)`` of the frame at the configurations ``Q`` ``(N, nq)``."""
        N = Q.shape[0]
        R = np.broadcast_to(np.eye(3), (N, 3, 3))
        p = np.zeros((N, 3))
        for iq, kind, Mp, MR, MRK, MRK2, MRa in self.steps:
            p = p + R @ Mp
            qi = Q[:, iq]
            if kind == "R":
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
