"""``JointLimits``: ``lower <= q + dq <= upper`` on every iterate (always on).

A box on the step: ``lower - q <= dq <= upper - q``. The solvers also clip
every iterate into the limits (round-off), so the margin
``min_i min(q_i - lower_i, upper_i - q_i)`` is never negative.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from kinserve.ik.constraints.base import Constraint

if TYPE_CHECKING:  # annotations only
    import pinocchio as pin

    from kinserve.kinematics.robot import Robot


class JointLimits(Constraint):
    """The robot's position limits as a box on the step (added to every solve automatically)."""

    def __init__(self) -> None:
        super().__init__(name="joint limits")

    def rows(self, robot: Robot, data: pin.Data, q: np.ndarray,
             dt: float | None = None) -> tuple[np.ndarray | None, np.ndarray, np.ndarray]:
        """The box ``lower - q <= dq <= upper - q`` (``G=None``), widened to contain ``dq = 0``."""
        lb = robot.lower - q
        ub = robot.upper - q
        np.minimum(lb, 0.0, out=lb)  # q is inside the limits: guard against round-off
        np.maximum(ub, 0.0, out=ub)
        return None, lb, ub

    def margin(self, robot: Robot, data: pin.Data, q: np.ndarray) -> float:
        """``min_i min(q_i - lower_i, upper_i - q_i)`` (rad or m; negative outside the limits)."""
        return float(min((q - robot.lower).min(), (robot.upper - q).min()))

    def describe(self, robot: Robot, data: pin.Data, q: np.ndarray) -> str:
        """The joints outside their limits at ``q``, with value and limits ("" when there is none)."""
        bad = np.flatnonzero((q < robot.lower) | (q > robot.upper))
        return "; ".join(f"{robot.joint_names[i]}={q[i]:.6g} outside "
                         f"[{robot.lower[i]:.6g}, {robot.upper[i]:.6g}]" for i in bad)
