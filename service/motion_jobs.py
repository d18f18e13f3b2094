"""``POST /plan/motion`` in a solver process: :func:`kinserve.planners.plan_motion` on the pooled robot.

Carried objects are attached to a copy of the pooled robot made for the request
(``robot.copy().attach(...)``): the pooled robot is shared by every request of
the process and never carries anything. Each request field is checked on its
own, so an error answer names it (``start``, ``goal``, ``frame``,
``obstacles[k]``, ``attached[i]``, ``acceleration_limits``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from kinserve.kinematics.errors import FrameError, KinserveError, ShapeError
from kinserve.kinematics.robot import Robot

from . import motion_schemas as M
from .collision_endpoint import obstacles_of
from .executor import Deadline
from .fields import FieldError, field
from .jobs import robot_of, trajectory_out

if TYPE_CHECKING:
    from kinserve.planners import MotionPlan

#: Plan budget (s) of a request that names no ``max_time`` (``plan_motion``'s default), before the cap.
DEFAULT_PLAN_TIME = 1.0


def plan_time(max_time: float | None, cap: float) -> float:
    """A request's plan budget: its ``max_time`` (default :data:`DEFAULT_PLAN_TIME`) capped by ``cap`` (s)."""
    return min(DEFAULT_PLAN_TIME if max_time is None else max_time, cap)


def carrying(robot: Robot, specs: list[M.AttachedSpec]) -> Robot:
    """``robot`` itself when nothing is carried, else a copy of it carrying ``specs`` (errors name
    ``attached[i]`` or ``attached[i].frame``)."""
    if not specs:
        return robot
    robot = robot.copy()
    for i, spec in enumerate(specs):
        try:
            robot.attach(spec.name, spec.shape.model_dump(exclude_none=True), spec.frame, spec.pose_in_frame,
                         spec.touch_links)
        except FrameError as exc:
            raise FieldError(f"attached[{i}].frame", exc) from None
        except KinserveError as exc:
            raise FieldError(f"attached[{i}]", exc) from None
    return robot


def goal_of(goal: list | M.PositionQuaternion | M.PositionRPY) -> np.ndarray | pin.SE3:
    """The ``goal`` argument of ``plan_motion``: a pose object as a ``pinocchio.SE3`` (always a pose), a list
    as an array (``plan_motion`` reads a 4x4 as a pose or a goal set by its own rule)."""
    if isinstance(goal, (M.PositionQuaternion, M.PositionRPY)):
        return pin.SE3(np.asarray(goal.matrix(), dtype=float))
    if goal and isinstance(goal[0], list) and len({len(q) for q in goal}) != 1:
        raise FieldError("goal", ShapeError(f"goal: the configurations of a goal set must have one length, "
                                            f"got lengths {sorted({len(q) for q in goal})}"))
    return np.asarray(goal, dtype=float)


def accelerations_of(robot: Robot, value: float | list[float] | None) -> float | np.ndarray | None:
    """``acceleration_limits``: None, one value, or one per joint (a 422 on the field for another length)."""
    if value is None or isinstance(value, float):
        return value
    if len(value) != robot.nq:
        raise FieldError("acceleration_limits", ShapeError(
            f"acceleration_limits must be one number or {robot.nq} (one per joint), got {len(value)}"))
    return np.asarray(value, dtype=float)


def plan_out(plan: MotionPlan, nq: int) -> dict:
    """A :class:`~kinserve.planners.MotionPlan` as the JSON-ready dict of
    :class:`~service.motion_schemas.MotionPlanResponse` (a trajectory over the sample limit left out)."""
    message = str(plan.message)
    traj = plan.trajectory
    if traj is not None and len(traj.times) > M.MAX_TRAJECTORY_POINTS:
        message += (f"; the trajectory ({len(traj.times)} samples) is left out: over the answer's limit of "
                    f"{M.MAX_TRAJECTORY_POINTS} (raise acceleration_limits for a shorter motion)")
        traj = None
    stats = {str(k): v if isinstance(v, str) else float(v) if isinstance(v, (float, np.floating)) else int(v)
             for k, v in plan.stats.items() if v is not None}
    goals = np.zeros((0, nq)) if plan.goals is None else plan.goals
    return {"success": bool(plan.success), "message": message, "path": np.asarray(plan.path).tolist(),
            "trajectory": None if traj is None else trajectory_out(traj), "goal_index": int(plan.goal_index),
            "goals": np.asarray(goals).tolist(), "stats": stats}


def plan_motion(deadline: Deadline, req: M.MotionPlanRequest, max_time: float) -> dict:
    """``POST /plan/motion``: the plan given ``max_time`` (the request's capped ``max_time``), never past the
    request's ``deadline``; loading the model and the collision set-up are not charged to it."""
    from kinserve.planners import plan_motion as plan

    robot = carrying(robot_of(req), req.attached)
    with field("robot"):
        robot.collision  # noqa: B018 - builds the collision model; no <collision> elements -> 422 on "robot"
    with field("start"):
        start = robot.check_q(req.start, "start", check_limits=True)
    goal = goal_of(req.goal)
    obstacles = obstacles_of(req.obstacles)
    accelerations = accelerations_of(robot, req.acceleration_limits)
    with field("goal"):
        result = plan(robot, start, goal, obstacles=obstacles, self_collision=req.self_collision,
                      max_time=max(min(max_time, deadline.remaining), 1e-3), seed=req.seed,
                      acceleration_limits=accelerations, simplify=req.simplify,
                      max_iterations=req.max_iterations, frame=req.frame, relax=tuple(req.relax),
                      goal_count=req.goal_count)
    return plan_out(result, robot.nq)


__all__ = ["DEFAULT_PLAN_TIME", "accelerations_of", "carrying", "goal_of", "plan_motion", "plan_out",
           "plan_time"]
