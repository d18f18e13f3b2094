"""``CentringTask``: pull the joints towards the middle of their ranges (joint-limit centring).

With ``m = (lower + upper) / 2``, ``r = upper - lower`` and per-joint weights
``w_i >= 0`` (``weights``: one number or ``nq``), the objective
``h = 1/2 sum_i w_i ((q_i - m_i) / r_i)^2`` is the task

    e_i = sqrt(w_i) (q_i - m_i) / r_i,      J = diag(sqrt(w_i) / r_i)

(:mod:`kinserve.ik.tasks.centring_weights`). An objective at priority 2 by default: only
the relative weights matter under strict priority.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from kinserve.ik.tasks.base import Task
from kinserve.ik.tasks.centring_weights import centring_weights
from kinserve.kinematics.errors import InputError

if TYPE_CHECKING:  # annotations only
    import pinocchio as pin

    from kinserve.kinematics.robot import Robot


class CentringTask(Task):
    """Joint-limit centring with per-joint ``weights`` at ``priority`` (default level 2)."""

    goal = False

    def __init__(self, weights: float | Sequence[float] = 1.0, priority: int = 2,
                 weight: float | Sequence[float] = 1.0, name: str = "centring"):
        super().__init__(weight, priority, name)
        self.weights = weights

    @property
    def weights(self) -> float | Sequence[float]:
        """The per-joint centring weights as given (validated against the robot by :meth:`bind`)."""
        return self._weights

    @weights.setter
    def weights(self, weights: float | Sequence[float]) -> None:
        self._weights = weights
        self._model = None  # bind again
        self._version += 1

    @classmethod
    def bound(cls, robot: Robot, scaled: np.ndarray, priority: int = 2) -> "CentringTask":
        """A task already bound to ``robot`` with the scaled weights ``w_i / r_i^2`` of
        :func:`~kinserve.ik.tasks.centring_weights.centring_weights` (validated: no second pass)."""
        task = cls(1.0, priority=priority)
        task._sqrt_w = np.sqrt(scaled)
        task._J = np.diag(task._sqrt_w)
        task._mid = robot.middle()
        task._model = robot.model
        return task

    def bind(self, robot: Robot) -> "CentringTask":
        """Scale the weights by ``1 / r_i^2`` for ``robot``; :class:`InputError` if none is positive or a
        vector ``weight`` (the task's, not the per-joint ``weights``) has not ``nq`` entries."""
        self.check_weight_rows(robot.nq)
        if self._model is not robot.model:
            w = centring_weights(robot, self.weights)
            if w is None:
                raise InputError("CentringTask weights must have at least one positive entry, "
                                 f"got {self.weights!r}")
            self._sqrt_w = np.sqrt(w)
            self._J = np.diag(self._sqrt_w)
            self._mid = robot.middle()
            self._model = robot.model
        return self

    def compute(self, robot: Robot, data: pin.Data, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(e, J)`` of the module docstring at ``q`` (the :class:`Task` protocol)."""
        return self._sqrt_w * (q - self._mid), self._J
