"""The ``Task`` protocol: what the IK solvers need to know about a goal or an objective.

A task maps a configuration ``q`` (``nq`` values) to an **error** ``e(q)``
(``m`` values) that the solver drives towards zero, and gives its
**Jacobian** ``J(q) = de/dq`` (``m x nv``), so that to first order

    e(q + dq) ~= e(q) + J(q) dq.

The differential IK step of one priority level minimises the weighted sum

    1/2 sum_tasks | sqrt(W) (e + J dq) |^2          (W = diag(weight))

over the joint steps ``dq`` the higher levels leave free (strict priority,
see :mod:`kinserve.ik.qp.hierarchy`), subject to every hard constraint.

Attributes every task has
-------------------------
``weight``
    A positive number or ``m`` numbers: the weight of the task's rows inside
    its priority level (the cost is ``1/2 |sqrt(w) (e + J dq)|^2``). A vector of
    another length is refused when the task is made (rows known then, e.g.
    ``FrameTask``) or bound (rows depending on the robot, e.g. ``PostureTask``).
``priority``
    An integer ``>= 1``; level 1 is the highest. A lower level moves only in
    the freedom the higher ones leave.
``goal``
    True when the task must be *met* for the solve to succeed (a frame pose,
    a centre-of-mass position); False for an *objective* that is only
    improved (posture, joint-limit centring). :func:`kinserve.ik.solve`
    reports success when every goal task is within tolerance.
``name``
    A short label used in :attr:`Result.task_errors` and in messages: a non-empty
    str, or None for the class's default (:func:`check_name`).

Methods a task implements
-------------------------
``bind(robot) -> Task``
    Validate the task against ``robot`` (frame names, vector lengths) and
    return the task to evaluate (``self`` or a bound copy). Called once per
    solve, before any iteration; raise
    :class:`kinserve.kinematics.errors.InputError` naming the argument.
    :func:`kinserve.ik.step` keeps the bound problem of the same objects from
    one call to the next and binds again only when a task's ``_version`` moved
    (assigning ``weight`` or ``priority`` does that): a task whose ``bind``
    depends on an attribute the user may change increments ``self._version``
    when it changes (see ``PostureTask.q_ref``).
``compute(robot, data, q) -> (e, J)``
    The error and Jacobian at ``q``. ``data`` is ``robot.data`` holding the
    kinematics of ``q``: ``pinocchio.computeJointJacobians`` has run (joint
    placements ``data.oMi`` and joint Jacobians ``data.J``), frame placements
    are **not** updated - call ``pinocchio.updateFramePlacement`` for the
    frames you use. Do not run other algorithms that overwrite ``data`` with
    another configuration. The outputs of a user's ``compute`` (one written
    outside kinserve) are checked on every evaluation: a pair, ``e`` of ``m``
    finite numbers, ``J`` of ``m x nv``, a vector ``weight`` of ``m`` numbers
    (:func:`checked_output`); anything else raises an error naming the task's
    class, never a NumPy error or a solve that "converges" on NaN.
``errors(e) -> (position, orientation)``
    Norms used for the success test (m, rad). The default treats the whole
    error as a position-like quantity: ``(|e|, 0)``.

Example: a centre-of-mass task (a user task, nothing in the solver changes)::

    import pinocchio as pin
    from kinserve import ik

    class CoMTask(ik.Task):
        def __init__(self, target, weight=1.0, priority=1):
            super().__init__(weight=weight, priority=priority, name="com")
            self.target = np.asarray(target, dtype=float)

        def compute(self, robot, data, q):
            # e = c(q) - c*, J = dc/dq (Pinocchio's jacobianCenterOfMass)
            J = pin.jacobianCenterOfMass(robot.model, data, q, False)
            return data.com[0] - self.target, J

    res = ik.solve(robot, tasks=[CoMTask((0.1, 0.0, 0.4)), ik.PostureTask(q_ref, priority=2)])
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from kinserve.kinematics.errors import InputError, NonFiniteError, ShapeError
from kinserve.kinematics.validation import MAX_ABS, as_positive, describe, is_bounded

if TYPE_CHECKING:  # annotations only
    import pinocchio as pin

    from kinserve.kinematics.robot import Robot


def check_weight(weight: float | Sequence[float], name: str = "weight",
                 rows: int | None = None) -> float | np.ndarray:
    """A positive finite number (float) or a 1-D array of them (validated task weight).

    Refused (:class:`InputError` naming ``name``): a number not in ``(0, 1e6]``, a vector with a NaN,
    infinite, negative or larger than 1e6 entry or without a positive one, and a vector whose length is
    not ``rows`` (the task's number of error rows) when ``rows`` is given.
    """
    if isinstance(weight, numbers.Real) and not isinstance(weight, bool):
        return as_positive(weight, name)
    try:
        if weight is None or isinstance(weight, (str, bytes, dict)):
            raise TypeError
        w = np.array(weight, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a positive number or a sequence of them, got {weight!r}") from None
    if w.ndim != 1 or w.size == 0:
        raise InputError(f"{name} must be a positive number or a 1-D sequence of them, got shape {w.shape}")
    if rows is not None and w.size != rows:
        raise ShapeError(f"{name} must be a number or {rows} numbers (one per error row of the task), "
                         f"got {w.size}")
    if not is_bounded(w):
        raise NonFiniteError(f"{name} must be finite with entries at most {MAX_ABS:g}, got {w.tolist()}")
    if np.any(w < 0.0) or not np.any(w > 0.0):
        raise InputError(f"{name} entries must be >= 0 with at least one > 0, got {w.tolist()}")
    return w


def check_name(name: object, owner: str) -> str:
    """The label of a task or constraint: ``name`` if it is a non-empty str, ``owner`` (the class name, the
    default) for None; else :class:`InputError` naming ``owner``. Labels appear in messages and in
    :attr:`Result.task_errors`: NaN or an arbitrary object would be kept and printed."""
    if name is None:
        return owner
    if isinstance(name, str) and name:
        return name
    raise InputError(f"{owner} name must be None or a non-empty str, got {describe(name)}")


#: Largest accepted priority level (levels are integers from 1 to this).
MAX_PRIORITY = 10**6


def check_priority(priority: int, name: str = "priority") -> int:
    """An integer from 1 (the highest level) to :data:`MAX_PRIORITY`; :class:`InputError` otherwise."""
    if isinstance(priority, bool) or not isinstance(priority, numbers.Integral) \
            or not 1 <= priority <= MAX_PRIORITY:
        raise InputError(f"{name} must be an integer >= 1 (1 = highest level) and at most {MAX_PRIORITY:,}, "
                         f"got {priority!r}")
    return int(priority)


class Task:
    """Base class of IK tasks (the protocol of the module docstring).

    Subclasses implement :meth:`compute` (and usually :meth:`bind`); the
    constructor validates ``weight`` and ``priority``.
    """

    #: True for a goal that must be met (success test), False for an objective.
    goal: bool = True

    #: Bumped by every change that needs a new bind (``weight``, ``priority``, a subclass's bound inputs):
    #: :func:`kinserve.ik.step` rebuilds its cached problem when a task's version moved.
    _version: int = 0

    def __init__(self, weight: float | Sequence[float] = 1.0, priority: int = 1, name: str | None = None):
        self.weight = weight
        self.priority = priority
        self.name = check_name(name, type(self).__name__)

    @property
    def weight(self) -> float | np.ndarray:
        """Weight of the task's rows in its level: a number > 0 or one per row (validated on assignment)."""
        return self._weight

    @weight.setter
    def weight(self, value: float | Sequence[float]) -> None:
        self._weight = check_weight(value, f"{type(self).__name__} weight", self.weight_rows())
        self._version += 1

    def weight_rows(self) -> int | None:
        """The number of error rows a vector ``weight`` must have, when known before :meth:`bind` (None:
        not known yet; a task whose rows depend on the robot checks its weight in :meth:`bind` with
        :meth:`check_weight_rows`)."""
        return None

    def check_weight_rows(self, rows: int) -> None:
        """:class:`ShapeError` unless the weight is a number or ``rows`` numbers (one per error row)."""
        w = self._weight
        if type(w) is not float and len(w) != rows:
            raise ShapeError(f"{type(self).__name__} weight must be a number or {rows} numbers (one per "
                             f"error row of the task), got {len(w)}")

    @property
    def priority(self) -> int:
        """Priority level, an integer ``>= 1`` (1 = highest; validated on assignment)."""
        return self._priority

    @priority.setter
    def priority(self, value: int) -> None:
        self._priority = check_priority(value, f"{type(self).__name__} priority")
        self._version += 1

    def bind(self, robot: Robot) -> "Task":
        """Validate against ``robot`` and return the task to evaluate (default: ``self``)."""
        return self

    def compute(self, robot: Robot, data: pin.Data,  # pragma: no cover - protocol
                q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(e, J)`` at ``q``: error ``(m,)`` and Jacobian ``(m, nv)`` with ``e(q + dq) ~= e + J dq``."""
        raise NotImplementedError(f"{type(self).__name__}.compute(robot, data, q) must return (e, J)")

    def errors(self, e: np.ndarray) -> tuple[float, float]:
        """``(position-like, orientation-like)`` error norms of ``e`` (success test); default ``(|e|, 0)``."""
        return math.sqrt(float(e.dot(e))), 0.0

    def __repr__(self) -> str:
        return f"{type(self).__name__}(name={self.name!r}, weight={self.weight!r}, priority={self.priority})"


def is_users_task(task: Task) -> bool:
    """Whether ``task``'s :meth:`~Task.compute` is written outside kinserve (a user's task, or a user's
    subclass overriding a kinserve task's ``compute``): its outputs are checked on every evaluation
    (:func:`checked_output`); kinserve's own tasks are not."""
    return not getattr(type(task).compute, "__module__", "").startswith("kinserve.")


def checked_output(task: Task, output: object, nv: int) -> tuple[np.ndarray, np.ndarray]:
    """``(e, J)`` of a user task's :meth:`~Task.compute` ``output`` as float arrays, after checking the
    protocol: a pair, ``e`` a vector of ``m`` numbers, ``J`` ``m x nv``, every entry finite with magnitude
    at most :data:`~kinserve.kinematics.validation.MAX_ABS`, and a vector ``weight`` of ``m`` numbers.
    :class:`InputError` (not a pair, or not numbers), :class:`ShapeError` (shapes, weight length) or
    :class:`NonFiniteError`, each naming the task's class."""
    name = type(task).__name__
    try:
        e, J = output  # type: ignore[misc]
    except (TypeError, ValueError):
        raise InputError(f"{name}.compute(robot, data, q) must return a pair (e, J), got "
                         f"{type(output).__name__}") from None
    try:
        e, J = np.asarray(e, dtype=float), np.asarray(J, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name}.compute(robot, data, q) must return numbers: an error vector e and a "
                         f"Jacobian J") from None
    if e.ndim != 1:
        raise ShapeError(f"{name}.compute: the error e must be a vector of m numbers, got shape {e.shape}")
    if J.shape != (len(e), nv):
        raise ShapeError(f"{name}.compute: the Jacobian J must be {len(e)} x {nv} (one row per error row, "
                         f"one column per joint velocity), got shape {J.shape}")
    for value, what in ((e, "error e"), (J, "Jacobian J")):
        if not is_bounded(value):
            raise NonFiniteError(f"{name}.compute: the {what} must hold finite numbers with magnitude <= "
                                 f"{MAX_ABS:g}, got {value.tolist()}")
    task.check_weight_rows(len(e))
    return e, J
