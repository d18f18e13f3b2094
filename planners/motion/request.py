"""``MotionRequest``: the validated arguments of :func:`~kinserve.planners.motion.plan.plan_motion`.

Validated once, here: every wrong argument raises :class:`InputError` /
:class:`ShapeError` (or :class:`JointLimitError`, an ``InputError``) whose message
names it and says what was expected.

Limits: the velocity limits are the URDF's (``robot.model.velocityLimit``; a joint
without one - zero, negative or not finite - gets :data:`DEFAULT_VELOCITY_LIMIT`);
the acceleration limits default to :data:`DEFAULT_ACCELERATION_FACTOR` times the
velocity limits (rad/s^2 or m/s^2: the joint reaches full speed in half a second).
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass
from typing import Any

import numpy as np

from kinserve.kinematics.collision_queries import as_obstacles
from kinserve.kinematics.errors import InputError, ShapeError
from kinserve.kinematics.robot import Robot
from kinserve.kinematics.validation import as_matrix, check_limits

from .rrt_connect import SearchBudget

#: Velocity limit (rad/s or m/s) of a joint whose URDF gives none.
DEFAULT_VELOCITY_LIMIT = 1.0
#: Default acceleration limit of each joint: this factor (1/s) times its velocity limit.
DEFAULT_ACCELERATION_FACTOR = 2.0


@dataclass(frozen=True)
class MotionRequest:
    """The validated plan request: ``start`` ``(nq,)``, ``goals`` ``(n, nq)`` (``single_goal`` when ``goal``
    was one configuration), ``obstacles`` (shapes), ``self_collision``, the search ``budget``, ``seed``,
    ``velocity_limits`` and ``acceleration_limits`` ``(nq,)``, ``simplify``."""

    start: np.ndarray
    goals: np.ndarray
    single_goal: bool
    obstacles: tuple
    self_collision: bool
    budget: SearchBudget
    seed: int | None
    velocity_limits: np.ndarray
    acceleration_limits: np.ndarray
    simplify: bool


def _flag(value: Any, name: str) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise InputError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def _goals(robot: Robot, goal: Any) -> tuple[np.ndarray, bool]:
    """``(n, nq)`` goals within the limits and whether ``goal`` was a single configuration."""
    try:
        ndim = np.ndim(goal)
    except (TypeError, ValueError):
        ndim = -1
    if ndim == 1:
        q = robot.check_q(goal, "goal", check_limits=True)
        return q[None, :].copy(), True
    if ndim != 2:
        raise ShapeError(f"goal must be one configuration ({robot.nq},) or a goal set (n, {robot.nq}), "
                         f"got {type(goal).__name__} of {ndim} dimensions")
    goals = as_matrix(goal, (-1, robot.nq), "goal")
    if len(goals) == 0:
        raise ShapeError(f"goal: a goal set needs at least one configuration (n, {robot.nq}), got none")
    for i, q in enumerate(goals):
        check_limits(q, robot.lower, robot.upper, robot.joint_names, f"goal[{i}]")
    return goals.copy(), False


def _budget(max_time: Any, max_iterations: Any) -> SearchBudget:
    if max_time is not None and (isinstance(max_time, bool) or not isinstance(max_time, numbers.Real)
                                 or not np.isfinite(max_time) or max_time <= 0):
        raise InputError(f"max_time must be None or a finite number of seconds > 0, got {max_time!r}")
    if max_iterations is not None and (isinstance(max_iterations, bool)
                                       or not isinstance(max_iterations, numbers.Integral)
                                       or max_iterations < 1):
        raise InputError(f"max_iterations must be None or an integer >= 1, got {max_iterations!r}")
    if max_time is None and max_iterations is None:
        raise InputError("max_time and max_iterations are both None: give at least one budget")
    return SearchBudget(None if max_iterations is None else int(max_iterations),
                        None if max_time is None else float(max_time))


def _seed(seed: Any) -> int | None:
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0):
        raise InputError(f"seed must be None or an integer >= 0, got {seed!r}")
    return None if seed is None else int(seed)


def velocity_limits(robot: Robot) -> np.ndarray:
    """``(nq,)`` velocity limits (module docstring)."""
    v = np.array(robot.model.velocityLimit, dtype=float)
    return np.where(np.isfinite(v) & (v > 0.0), v, DEFAULT_VELOCITY_LIMIT)


def _accelerations(value: Any, v_max: np.ndarray) -> np.ndarray:
    if value is None:
        return DEFAULT_ACCELERATION_FACTOR * v_max
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        value = np.full(len(v_max), float(value))
    a = as_matrix(value, (len(v_max),), "acceleration_limits")
    if np.any(a <= 0.0):
        raise InputError(f"acceleration_limits must be > 0 for every joint, got {a.tolist()}")
    return a.copy()


def motion_request(robot: Robot, start: Any, goal: Any, obstacles: Any, self_collision: Any, max_time: Any,
                   seed: Any, acceleration_limits: Any, simplify: Any, max_iterations: Any) -> MotionRequest:
    """The :class:`MotionRequest` of :func:`~kinserve.planners.motion.plan.plan_motion`'s arguments."""
    if not isinstance(robot, Robot):
        raise InputError(f"robot must be a kinserve Robot (robots.load(...)), got {type(robot).__name__}")
    q0 = robot.check_q(start, "start", check_limits=True).copy()
    goals, single = _goals(robot, goal)
    v_max = velocity_limits(robot)
    return MotionRequest(q0, goals, single, as_obstacles(obstacles, "obstacles"),
                         _flag(self_collision, "self_collision"), _budget(max_time, max_iterations),
                         _seed(seed), v_max, _accelerations(acceleration_limits, v_max),
                         _flag(simplify, "simplify"))


__all__ = ["DEFAULT_ACCELERATION_FACTOR", "DEFAULT_VELOCITY_LIMIT", "MotionRequest", "motion_request",
           "velocity_limits"]
