"""``ik.step``: one differential-IK velocity for a control loop (the role of Pink's ``solve_ik``).

At the current configuration ``q`` and control period ``dt`` (s), with the
tasks grouped by priority and every constraint's rows at ``q`` (joint
limits as ``lower - q <= dq <= upper - q``, velocity limits as
``|dq| <= v_max dt``, obstacle dampers ``g^T dq >= -xi c``), the step ``dq``
is the hierarchical least-squares step of :mod:`ik.qp.hierarchy` with the
Levenberg-Marquardt damping ``lambda = 0.01 |e_1|^2 + damping``, and the
returned velocity is ``v = dq / dt`` (rad/s or m/s). Integrating
``q + v dt`` keeps the joint limits; the obstacle rows are first order, so
the clearance may shrink by at most the fraction ``xi`` per period (to first
order) and grows when it is negative.

The bound problem (tasks and constraints validated against the robot) is
kept by the robot's IK state, per thread
(:class:`~kinserve.ik.step_problems.StepProblems`): calling ``ik.step``
again with the same task and constraint objects (targets moved with
``FrameTask.set_target``) skips the validation; an object changed in
between (a new ``weight``, ``priority``, ``q_ref``, ``v_max``) is validated
and bound again.
"""

from __future__ import annotations

import math
import numbers
from itertools import chain
from typing import TYPE_CHECKING, Any

import numpy as np

from kinserve.ik import numpy_fast
from kinserve.ik.arguments import check_backend
from kinserve.ik.problem import Problem
from kinserve.ik.qp.dense_qp import DEFAULT_BACKEND
from kinserve.ik.qp.hierarchy import hierarchical_step
from kinserve.ik.state import ik_state
from kinserve.kinematics.errors import InputError
from kinserve.kinematics.shapes import Shape
from kinserve.kinematics.validation import MAX_ABS, as_nonnegative, as_positive

if TYPE_CHECKING:  # annotations only
    from kinserve.kinematics.robot import Robot

#: Floor of the Levenberg-Marquardt damping of ``ik.step``.
STEP_DAMPING = 1e-6
#: Accepted control periods ``dt`` (s): from 1 ns (below it ``dq / dt`` loses all meaning) to 1e6 s.
MIN_DT = 1e-9
MAX_DT = MAX_ABS
_clip = numpy_fast.clip


def _problem(robot: Robot, tasks: list, constraints: list) -> Problem:
    """The bound problem of these objects: the one the robot's IK state keeps for them in this thread
    (:class:`~kinserve.ik.step_problems.StepProblems`), or a new one when none is kept or one of them
    changed since (its change counter moved)."""
    # the change counters, tasks first (0 for objects without one: shapes are immutable); one comprehension,
    # not a call per object
    versions = tuple([getattr(obj, "_version", 0) for obj in chain(tasks, constraints)])
    store = ik_state(robot).step_problems
    pb = store.find(robot, tasks, constraints, versions)
    if pb is None:
        pb = Problem(robot, tasks, constraints)
        store.keep(robot, tasks, constraints, versions, pb)
    return pb


def _check_robot_and_numbers(robot: Any, dt: Any, damping: Any) -> float:
    """``dt`` as a float; :class:`InputError` unless ``robot`` is a Robot, ``dt`` a number of seconds in
    ``[MIN_DT, MAX_DT]`` and ``damping`` a finite number in ``[0, 1e6]``."""
    if not (hasattr(robot, "model") and hasattr(robot, "check_q")):
        raise InputError(f"robot must be a kinserve.kinematics.Robot, got {type(robot).__name__}")
    if not (type(dt) is float and MIN_DT <= dt <= MAX_DT):  # (the common case in one test)
        if isinstance(dt, bool) or not isinstance(dt, numbers.Real):
            raise InputError(f"dt must be a positive number of seconds, got {dt!r}")
        dt = as_positive(dt, "dt", MAX_DT)
        if dt < MIN_DT:
            raise InputError(f"dt must be at least {MIN_DT:g} s (the control period), got {dt!r}")
    if damping is not STEP_DAMPING:
        as_nonnegative(damping, "damping")
    return dt


def _objects(value: Any, name: str, protocol: str) -> list:
    """``value`` as a list: one object with the method ``protocol`` or a sequence of them (checked later by
    :class:`~kinserve.ik.problem.Problem`); :class:`InputError` for None, text or a non-sequence."""
    if hasattr(value, protocol) or isinstance(value, Shape):  # (one task, one constraint or one obstacle)
        return [value]
    if value is None or isinstance(value, (str, bytes, dict)):
        raise InputError(f"{name} must be a sequence of ik.{'Task' if name == 'tasks' else 'Constraint'} "
                         f"objects, got {value!r}")
    try:
        return list(value)
    except TypeError:
        raise InputError(f"{name} must be a sequence of ik.{'Task' if name == 'tasks' else 'Constraint'} "
                         f"objects, got {value!r}") from None


def step(robot: Robot, tasks: Any, constraints: Any = (), q: np.ndarray | None = None, dt: float = 0.01, *,
         damping: float = STEP_DAMPING,
         backend: str = DEFAULT_BACKEND) -> np.ndarray:
    """Joint velocity ``v`` (``nv``,) for one control period ``dt`` (module docstring).

    ``q`` must lie inside the joint limits. ``damping`` (>= 0, finite) is the
    floor of the Levenberg-Marquardt damping, ``backend`` the QP solver used
    when the closed forms do not apply. Raises :class:`InputError` when an
    argument is invalid or the constraints leave no feasible velocity.

    Refused: ``tasks`` that is None, text or not a sequence of tasks; ``dt`` outside
    ``[MIN_DT, MAX_DT]`` (1e-9 s to 1e6 s), NaN or not a number; ``damping`` negative, non-finite or
    above 1e6; ``q`` missing, of the wrong length or non-finite; a ``backend`` that is not one of the
    installed QP solvers (any case).
    """
    dt = _check_robot_and_numbers(robot, dt, damping)
    if backend is not DEFAULT_BACKEND:
        backend = check_backend(backend, none_is_default=False)
    if q is None:
        raise InputError("q (the current configuration) is required")
    q = robot.check_q(q, "q")
    tasks = _objects(tasks, "tasks", "compute")
    constraints = [] if constraints is None else _objects(constraints, "constraints", "rows")
    pb = _problem(robot, tasks, constraints)
    q = _clip(q, robot.lower, robot.upper)
    levels, pe, re, _ = pb.evaluate(q)
    lb, ub, G, gl, gu = pb.box_and_rows(q, float(dt))
    dq, _ = hierarchical_step(levels, lb, ub, G, gl, gu, lam=0.01 * (pe * pe + re * re) + damping,
                              max_step=math.inf, backend=backend)
    if dq is None:
        raise InputError("the constraints leave no feasible velocity at q (QP infeasible)")
    return dq / dt
