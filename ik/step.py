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
from itertools import chain
from typing import TYPE_CHECKING, Any

import numpy as np

from kinserve.ik import numpy_fast
from kinserve.ik.problem import Problem
from kinserve.ik.qp.backends import available_backends
from kinserve.ik.qp.dense_qp import DEFAULT_BACKEND
from kinserve.ik.qp.hierarchy import hierarchical_step
from kinserve.ik.state import ik_state
from kinserve.kinematics.errors import InputError

if TYPE_CHECKING:  # annotations only
    from kinserve.kinematics.robot import Robot

#: Floor of the Levenberg-Marquardt damping of ``ik.step``.
STEP_DAMPING = 1e-6
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


def _check_backend(backend: Any) -> str:
    """A QP backend name installed on this machine (:func:`kinserve.ik.qp.backends.available_backends`)."""
    if isinstance(backend, str) and backend.lower() in available_backends():
        return backend.lower()
    raise InputError(f"backend must be one of the installed QP solvers {available_backends()}, "
                     f"got {backend!r}")


def _check_robot_and_numbers(robot: Any, dt: Any, damping: Any) -> None:
    """:class:`InputError` unless ``robot`` is a Robot, ``dt`` a positive finite number of seconds and
    ``damping`` a finite number >= 0."""
    if not (hasattr(robot, "model") and hasattr(robot, "check_q")):
        raise InputError(f"robot must be a kinserve.kinematics.Robot, got {type(robot).__name__}")
    if type(dt) is not float and (isinstance(dt, bool) or not isinstance(dt, (int, float))):
        raise InputError(f"dt must be a positive number of seconds, got {dt!r}")
    if not 0.0 < dt < math.inf:  # NaN fails too
        raise InputError(f"dt must be a positive number of seconds, got {dt!r}")
    if damping is not STEP_DAMPING and (isinstance(damping, bool) or not isinstance(damping, (int, float))
                                        or not 0.0 <= damping < math.inf):
        raise InputError(f"damping must be a finite number >= 0, got {damping!r}")


def step(robot: Robot, tasks: Any, constraints: Any = (), q: np.ndarray | None = None, dt: float = 0.01, *,
         damping: float = STEP_DAMPING,
         backend: str = DEFAULT_BACKEND) -> np.ndarray:
    """Joint velocity ``v`` (``nv``,) for one control period ``dt`` (module docstring).

    ``q`` must lie inside the joint limits. ``damping`` (>= 0, finite) is the
    floor of the Levenberg-Marquardt damping, ``backend`` the QP solver used
    when the closed forms do not apply. Raises :class:`InputError` when an
    argument is invalid or the constraints leave no feasible velocity.
    """
    _check_robot_and_numbers(robot, dt, damping)
    if backend is not DEFAULT_BACKEND:
        backend = _check_backend(backend)
    if q is None:
        raise InputError("q (the current configuration) is required")
    q = robot.check_q(q, "q")
    tasks = list(tasks) if not hasattr(tasks, "compute") else [tasks]
    if constraints is None:
        constraints = []
    else:
        constraints = list(constraints) if not hasattr(constraints, "rows") else [constraints]
    pb = _problem(robot, tasks, constraints)
    q = _clip(q, robot.lower, robot.upper)
    levels, pe, re, _ = pb.evaluate(q)
    lb, ub, G, gl, gu = pb.box_and_rows(q, float(dt))
    dq, _ = hierarchical_step(levels, lb, ub, G, gl, gu, lam=0.01 * (pe * pe + re * re) + damping,
                              max_step=math.inf, backend=backend)
    if dq is None:
        raise InputError("the constraints leave no feasible velocity at q (QP infeasible)")
    return dq / dt
