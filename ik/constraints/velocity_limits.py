"""``VelocityLimits(v_max)``: ``|v_i| <= v_max_i`` for the differential step of :func:`kinserve.ik.step`.

With the control period ``dt`` (s) the step ``dq = v dt`` is boxed by
``-v_max dt <= dq <= v_max dt`` (rad or m). :func:`kinserve.ik.solve`
iterates without time (``dt=None``): the limits do not apply there.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from kinserve.ik.constraints.base import Constraint
from kinserve.kinematics.errors import InputError, ShapeError
from kinserve.kinematics.validation import as_numbers

if TYPE_CHECKING:  # annotations only
    import pinocchio as pin

    from kinserve.kinematics.robot import Robot


class VelocityLimits(Constraint):
    """Joint speed limits ``v_max`` (rad/s or m/s): one positive number for every joint or one per joint.

    Refused (here and on assignment to :attr:`v_max`): bools, text and other non-numbers, and other
    shapes (:class:`ShapeError`); NaN, infinities and magnitudes above 1e6 (:class:`NonFiniteError`);
    zero or negative limits (:class:`InputError`). A vector of another length than ``nv`` is refused
    when the constraint is bound to a robot.
    """

    def __init__(self, v_max: float | Sequence[float]) -> None:
        super().__init__(name="velocity limits")
        self.v_max = v_max

    @property
    def v_max(self) -> np.ndarray:
        """The limits (a 0-D array for one number, else one per joint), read-only.

        Validated on assignment; the solvers re-bind after a change.
        """
        return self._v_max

    @v_max.setter
    def v_max(self, v_max: float | Sequence[float]) -> None:
        v = as_numbers(v_max, "v_max")  # (no bools, text; finite, |x| <= 1e6)
        if v.ndim > 1 or v.size == 0:
            raise ShapeError("v_max must be a number or a 1-D sequence of numbers (one per joint), got "
                             f"shape {v.shape}")
        if np.any(v <= 0.0):
            raise InputError(f"v_max must be positive, got {v.tolist()}")
        v = np.array(v, dtype=float)  # (a copy: the caller's array stays writeable and unchanged)
        v.flags.writeable = False  # change the limits by assignment (validated, and the solvers re-bind)
        self._v_max = v
        self._v = None
        self._box = None  # (dt, lower, upper) of the last call, read-only
        self._version += 1

    def bind(self, robot: Robot) -> "VelocityLimits":
        """Check ``v_max`` against ``robot`` (one number or ``nv``) and expand it to one limit per joint."""
        if self.v_max.ndim == 0:
            self._v = np.full(robot.model.nv, float(self.v_max))
        elif self.v_max.shape != (robot.model.nv,):
            raise InputError(f"v_max must be one number or {robot.model.nv} numbers (one per joint), "
                             f"got {self.v_max.size}")
        else:
            self._v = self.v_max
        self._box = None
        return self

    def rows(self, robot: Robot, data: pin.Data, q: np.ndarray,
             dt: float | None = None) -> tuple[np.ndarray | None, np.ndarray, np.ndarray]:
        """The box ``-v_max dt <= dq <= v_max dt`` (``G=None``); unbounded when ``dt`` is None."""
        if dt is None:
            return None, np.full(q.shape[0], -np.inf), np.full(q.shape[0], np.inf)
        cached = self._box
        if cached is None or cached[0] != dt:  # one control period after another: the same box
            hi = self._v * dt
            lo = -hi
            lo.flags.writeable = hi.flags.writeable = False
            cached = self._box = (dt, lo, hi)
        return None, cached[1], cached[2]
