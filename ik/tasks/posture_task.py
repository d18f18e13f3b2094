"""``PostureTask``: pull the joints towards a reference configuration ``q_ref``.

    e = q - q_ref,      J = I                (rad or m; exact)

An objective (``goal = False``): it shapes the answer in the freedom the
higher levels leave (default priority 2) and is never required to vanish.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from kinserve.ik.tasks.base import Task
from kinserve.kinematics.validation import as_vector

if TYPE_CHECKING:  # annotations only
    import pinocchio as pin

    from kinserve.kinematics.robot import Robot


class PostureTask(Task):
    """Joints towards ``q_ref`` (``nq`` values) with ``weight`` at ``priority`` (default level 2)."""

    goal = False

    def __init__(self, q_ref: Sequence[float] | np.ndarray, weight: float | Sequence[float] = 1.0,
                 priority: int = 2, name: str = "posture"):
        super().__init__(weight, priority, name)
        self.q_ref = q_ref
        self._I = None

    @property
    def q_ref(self) -> np.ndarray:
        """The reference configuration (a private read-only copy); assign a new one to move it (validated)."""
        return self._q_ref

    @q_ref.setter
    def q_ref(self, q_ref: Sequence[float] | np.ndarray) -> None:
        q = np.array(as_vector(q_ref, len(np.ravel(q_ref)), "q_ref"), dtype=float)
        q.flags.writeable = False
        self._q_ref = q
        self._version += 1  # the length is checked against the robot by the next bind

    def bind(self, robot: Robot) -> "PostureTask":
        """Check ``q_ref`` against ``robot`` (``nq`` finite values) and a vector ``weight`` (``nq`` entries);
        the named error otherwise."""
        robot.check_q(self._q_ref, "q_ref")
        self.check_weight_rows(robot.nq)
        if self._I is None or self._I.shape[0] != robot.nq:
            self._I = np.eye(robot.nq)
            self._I.flags.writeable = False
        return self

    def compute(self, robot: Robot, data: pin.Data, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``e = q - q_ref`` and ``J = I`` (the :class:`Task` protocol)."""
        return q - self._q_ref, self._I
