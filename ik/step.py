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
cached on the call's objects: calling ``ik.step`` again with the same task
and constraint objects (targets moved with ``FrameTask.set_target``) skips
the validation; an object changed in between (a new ``weight``,
``priority``, ``q_ref``, ``v_max``) is validated and bound again.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from kinserve.kinematics.errors import InputError

from kinserve.ik import numpy_fast
from kinserve.ik.qp.dense_qp import DEFAULT_BACKEND
from kinserve.ik.qp.hierarchy import hierarchical_step
from kinserve.ik.problem import Problem
from kinserve.ik.qp.backends import available_backends

#: Floor of the Levenberg-Marquardt damping of ``ik.step``.
STEP_DAMPING = 1e-6
_clip = numpy_fast.clip
_cache: dict = {}

if TYPE_CHECKING:  # annotations only
    from kinserve.kinematics.robot import Robot


def _version(obj: Any) -> int:
    """The change counter of a task or constraint (0 for objects without one: shapes are immutable)."""
    return getattr(obj, "_version", 0)


def _problem(robot, tasks, constraints) -> Problem:
    """The bound problem of these objects, cached by their ids and rebuilt when one of them changed.

    The cache entry holds the robot, tasks and constraints themselves, so none
    of them can be collected while it exists and no other object can reuse
    their ids: equal keys mean the very same objects. Each entry also keeps
    the objects' change counters (``_version``: bumped by a new ``weight``,
    ``priority``, ``PostureTask.q_ref``, ``VelocityLimits.v_max``, ...), so an
    object changed since the entry was made is bound (and validated) again.
    A target moved with ``FrameTask.set_target`` needs no new bind.
    """
    key = (id(robot), id(robot.data), *map(id, tasks), None, *map(id, constraints))
    versions = (*map(_version, tasks), *map(_version, constraints))
    entry = _cache.get(key)
    if entry is not None and entry[2] == versions:
        return entry[1]
    pb = Problem(robot, tasks, constraints)
    if len(_cache) > 64:
        _cache.clear()
    _cache[key] = ((robot, robot.data, list(tasks), list(constraints)), pb, versions)
    return pb


def _check_backend(backend: Any) -> str:
    """A QP backend name installed on this machine (:func:`kinserve.ik.qp.backends.available_backends`)."""
    if isinstance(backend, str) and backend.lower() in available_backends():
        return backend.lower()
    raise InputError(f"backend must be one of the installed QP solvers {available_backends()}, got {backend!r}")


def step(robot: Robot, tasks: Any, constraints: Any = (), q: np.ndarray | None = None, dt: float = 0.01, *,
         damping: float = STEP_DAMPING,
         backend: str = DEFAULT_BACKEND) -> np.ndarray:
    """Joint velocity ``v`` (``nv``,) for one control period ``dt`` (module docstring).

    ``q`` must lie inside the joint limits. ``damping`` (>= 0, finite) is the
    floor of the Levenberg-Marquardt damping, ``backend`` the QP solver used
    when the closed forms do not apply. Raises :class:`InputError` when an
    argument is invalid or the constraints leave no feasible velocity.
    """
    if not (hasattr(robot, "model") and hasattr(robot, "check_q")):
        raise InputError(f"robot must be a kinserve.kinematics.Robot, got {type(robot).__name__}")
    if type(dt) is not float and (isinstance(dt, bool) or not isinstance(dt, (int, float))):
        raise InputError(f"dt must be a positive number of seconds, got {dt!r}")
    if not 0.0 < dt < math.inf:  # NaN fails too
        raise InputError(f"dt must be a positive number of seconds, got {dt!r}")
    if damping is not STEP_DAMPING and (isinstance(damping, bool) or not isinstance(damping, (int, float))
                                        or not 0.0 <= damping < math.inf):
        raise InputError(f"damping must be a finite number >= 0, got {damping!r}")
    if backend is not DEFAULT_BACKEND:
        backend = _check_backend(backend)
    if q is None:
        raise InputError("q (the current configuration) is required")
    q = robot.check_q(q, "q")
    tasks = list(tasks) if not hasattr(tasks, "compute") else [tasks]
    constraints = [] if constraints is None else (list(constraints) if not hasattr(constraints, "rows") else [constraints])
    pb = _problem(robot, tasks, constraints)
    q = _clip(q, robot.lower, robot.upper)
    levels, pe, re, _ = pb.evaluate(q)
    lb, ub, G, l, u = pb.box_and_rows(q, float(dt))
    dq, _ = hierarchical_step(levels, lb, ub, G, l, u, lam=0.01 * (pe * pe + re * re) + damping, max_step=math.inf,
                              backend=backend)
    if dq is None:
        raise InputError("the constraints leave no feasible velocity at q (QP infeasible)")
    return dq / dt
