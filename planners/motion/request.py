"""``MotionRequest``: the validated arguments of :func:`~kinserve.planners.motion.plan.plan_motion`.

Validated once, here: every wrong argument raises :class:`InputError` /
:class:`ShapeError` (or :class:`JointLimitError`, an ``InputError``) whose message
names it and says what was expected.

Limits: the velocity limits are the URDF's (``robot.model.velocityLimit``; a joint
without one - zero, negative or not finite - gets :data:`DEFAULT_VELOCITY_LIMIT`);
the acceleration limits default to :data:`DEFAULT_ACCELERATION_FACTOR` times the
velocity limits (rad/s^2 or m/s^2: the joint reaches full speed in half a second).

Goals: one configuration ``(nq,)``, a goal set ``(n, nq)``, or a pose of ``frame`` (an
:class:`~kinserve.ik.targets.Target` in ``goal_pose``; turned into a goal set by
:mod:`.pose_goal`). What makes ``goal`` a pose (:func:`goal_kind`):

* a ``pinocchio.SE3``, or any other form :func:`kinserve.kinematics.validation.as_pose` accepts that is not
  an array of one or two dimensions, is a pose;
* a ``(4, 4)`` array is a pose - except on a robot with ``nq == 4``, where it is a goal set of four
  configurations unless ``frame=`` or ``relax=`` is given (then it is a pose);
* ``frame=`` or ``relax=`` with a configuration or a goal set is an error.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from kinserve.ik.arguments import check_max_time
from kinserve.ik.targets import Target
from kinserve.kinematics.errors import InputError, ShapeError
from kinserve.kinematics.robot import Robot, as_robot
from kinserve.kinematics.shapes import as_obstacles
from kinserve.kinematics.validation import as_flag, as_matrix, as_pose, check_limits

from .rrt_connect import SearchBudget

#: Velocity limit (rad/s or m/s) of a joint whose URDF gives none.
DEFAULT_VELOCITY_LIMIT = 1.0
#: Default acceleration limit of each joint: this factor (1/s) times its velocity limit.
DEFAULT_ACCELERATION_FACTOR = 2.0
#: Default cap on the size of a pose goal's goal set (``goal_count``).
GOAL_COUNT = 4
#: Largest ``goal_count`` accepted (each member costs up to ``STARTS_PER_GOAL`` IK solves; the HTTP
#: service caps it lower still).
MAX_GOAL_COUNT = 1000


@dataclass(frozen=True)
class MotionRequest:
    """The validated plan request: ``start`` ``(nq,)``, ``goals`` ``(n, nq)`` (``single_goal`` when ``goal``
    was one configuration; ``(0, nq)`` for a pose goal), ``obstacles`` (shapes), ``self_collision``, the
    search ``budget``, ``seed``, ``velocity_limits`` and ``acceleration_limits`` ``(nq,)``, ``simplify``,
    ``goal_pose`` (the pose goal with its frame and relaxed components, None for joint goals) and
    ``goal_count`` (cap on a pose goal's goal set, 1 to :data:`MAX_GOAL_COUNT`)."""

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
    goal_pose: Target | None = None
    goal_count: int = GOAL_COUNT


def _given(relax: Any) -> bool:
    """Whether ``relax`` names any component (None and empty sequences name none)."""
    if relax is None:
        return False
    return not (isinstance(relax, (str, tuple, list)) and len(relax) == 0)


def _shape(value: Any) -> tuple[int, ...] | None:
    """``np.shape(value)``, or None for a ragged or array-less value."""
    try:
        return np.shape(value)
    except (TypeError, ValueError):
        return None


def goal_kind(robot: Robot, goal: Any, frame: Any = None, relax: Any = ()) -> str:
    """``"pose"``, ``"configuration"`` or ``"goal set"``: how :func:`motion_request` reads ``goal`` (module
    docstring); :class:`InputError` when ``frame`` / ``relax`` come with joint goals."""
    if isinstance(goal, pin.SE3):
        return "pose"
    shape = _shape(goal)
    ndim = -1 if shape is None else len(shape)
    pose_hint = frame is not None or _given(relax)
    if ndim == 2 and shape == (4, 4) and (robot.nq != 4 or pose_hint):
        return "pose"
    if ndim not in (1, 2):
        return "pose"  # as_pose decides (a position + quaternion form, or a clear error)
    if pose_hint:
        raise InputError(f"frame= and relax= apply to a pose goal (4x4 array or pinocchio.SE3); goal is a "
                         f"{'configuration' if ndim == 1 else 'goal set'} of shape {shape}")
    return "configuration" if ndim == 1 else "goal set"


def _pose(robot: Robot, goal: Any, frame: Any, relax: Any) -> Target:
    """The pose goal as an IK :class:`Target` (frame default ``robot.tip``); errors name ``goal`` / ``frame``
    / ``relax``."""
    if frame is not None and not isinstance(frame, str):
        raise InputError(f"frame must be a frame name (str) or None, got {frame!r}")
    try:
        T = as_pose(goal, "goal")
    except ShapeError as exc:
        if not isinstance(goal, pin.SE3) and _shape(goal) == (4, 4):
            raise  # a 4x4 pose with a wrong bottom row: as_pose's own message
        raise ShapeError(f"goal must be one configuration ({robot.nq},), a goal set (n, {robot.nq}) or a "
                         f"pose (4x4 array or pinocchio.SE3); {exc}") from None
    return Target(robot, T, frame, relax)


def _goals(robot: Robot, goal: Any) -> tuple[np.ndarray, bool]:
    """``(n, nq)`` goals within the limits and whether ``goal`` was a single configuration."""
    ndim = np.ndim(goal)
    if ndim == 1:
        q = robot.check_q(goal, "goal", check_limits=True)
        return q[None, :].copy(), True
    goals = as_matrix(goal, (-1, robot.nq), "goal")
    if len(goals) == 0:
        raise ShapeError(f"goal: a goal set needs at least one configuration (n, {robot.nq}), got none")
    for i, q in enumerate(goals):
        check_limits(q, robot.lower, robot.upper, robot.joint_names, f"goal[{i}]")
    return goals.copy(), False


def _budget(max_time: Any, max_iterations: Any) -> SearchBudget:
    """The search budget: ``max_time`` None or a number of seconds in ``(0, 1e6]`` (as :func:`ik.solve`
    bounds it), ``max_iterations`` None or an integer >= 1, not both None."""
    max_time = check_max_time(max_time)
    if max_iterations is not None and (isinstance(max_iterations, bool)
                                       or not isinstance(max_iterations, numbers.Integral)
                                       or max_iterations < 1):
        raise InputError(f"max_iterations must be None or an integer >= 1, got {max_iterations!r}")
    if max_time is None and max_iterations is None:
        raise InputError("max_time and max_iterations are both None: give at least one budget")
    return SearchBudget(None if max_iterations is None else int(max_iterations), max_time)


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


def _goal_count(value: Any) -> int:
    """``goal_count`` as an int from 1 to :data:`MAX_GOAL_COUNT` (:class:`InputError` otherwise)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or not 1 <= value <= MAX_GOAL_COUNT:
        raise InputError(f"goal_count must be an integer from 1 to {MAX_GOAL_COUNT}, got {value!r}")
    return int(value)


def motion_request(robot: Robot, start: Any, goal: Any, obstacles: Any, self_collision: Any, max_time: Any,
                   seed: Any, acceleration_limits: Any, simplify: Any, max_iterations: Any, frame: Any = None,
                   relax: Any = (), goal_count: Any = GOAL_COUNT) -> MotionRequest:
    """The :class:`MotionRequest` of :func:`~kinserve.planners.motion.plan.plan_motion`'s arguments."""
    as_robot(robot)
    q0 = robot.check_q(start, "start", check_limits=True).copy()
    pose = None
    if goal_kind(robot, goal, frame, relax) == "pose":
        pose = _pose(robot, goal, frame, relax)
        goals, single = np.zeros((0, robot.nq)), False
    else:
        goals, single = _goals(robot, goal)
    v_max = velocity_limits(robot)
    return MotionRequest(q0, goals, single, as_obstacles(obstacles, "obstacles"),
                         as_flag(self_collision, "self_collision"), _budget(max_time, max_iterations),
                         _seed(seed), v_max, _accelerations(acceleration_limits, v_max),
                         as_flag(simplify, "simplify"), pose, _goal_count(goal_count))


__all__ = ["DEFAULT_ACCELERATION_FACTOR", "DEFAULT_VELOCITY_LIMIT", "GOAL_COUNT", "MAX_GOAL_COUNT",
           "MotionRequest", "goal_kind", "motion_request", "velocity_limits"]
