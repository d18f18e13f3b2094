"""A pose goal turned into a goal set: several collision-free IK solutions of the pose on different branches.

:func:`pose_goal_set` runs kinserve's collision-aware IK (:func:`kinserve.ik.solve` with the request's
``obstacles`` and ``self_collision``, every iterate and answer checked on the robot's collision model
with a margin of :data:`IK_MARGIN`) from a sequence of starts:

1. the plan's start (the seed table's samples next, when that start does not converge);
2. configurations drawn uniformly inside the joint limits by a generator seeded with the plan's seed
   (each solve's own restarts seeded from it too; the seed table off, so each start finds its own branch).

A solution joins the set when the IK converged (``tol_pos`` 1e-4 m, ``tol_rot`` 1e-3 rad on the kept
components), it lies more than :data:`GOAL_SEPARATION` (rad, Euclidean joint-space distance) from every
member so far - on another branch of the pose's solutions - and the planner accepts it as a path's end
(``admit``: free, at least the clearance floor from every checked pair). The search stops at
``goal_count`` members, after ``STARTS_PER_GOAL * goal_count`` starts, or - when the request has a
``max_time`` - once that time is spent (checked before each start; one solve is bounded by its iteration
budget, so the overrun is at most one solve). A set left empty by the clock says so in its ``reason``.

Each solve has an iteration budget of :data:`IK_ITERATIONS` and no clock: with ``max_time=None`` the
goal set depends only on the inputs and the seed (with ``seed=None`` the starts are drawn from fresh
entropy, as the search's samples are); with ``max_time`` a loaded machine may try fewer starts. The
one-time IK set-up of the frame and scene is :func:`warm_pose_goal`, done before any clock starts.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from kinserve import ik
from kinserve.kinematics.robot import Robot

from .request import MotionRequest

#: Smallest Euclidean joint-space distance (rad) between two members of a pose goal's goal set.
GOAL_SEPARATION = 0.5
#: Starts tried per member wanted: at most ``STARTS_PER_GOAL * goal_count`` IK solves.
STARTS_PER_GOAL = 2
#: Iteration budget of one IK solve (all of its restarts together).
IK_ITERATIONS = 100
#: Clearance (m) the IK keeps from obstacles and between checked pairs: twice the planner's floor
#: (:data:`~.clearance.CLEARANCE_FLOOR`), so its answers clear the planner's check.
IK_MARGIN = 2e-4
#: Entropy added to the plan's seed for the IK's starts (a stream apart from the search's samples).
_STREAM = 0x905E

#: ``admit(q, name) -> (reason or None, clearance)``: why ``q`` cannot end a path (None when it can).
Admit = Callable[[np.ndarray, str], tuple[str | None, Any]]


@dataclass
class GoalSet:
    """The goal set of a pose goal.

    ``goals`` ``(n, nq)`` (``n <= goal_count``; ``(0, nq)`` when none) with the planner's ``clearances``
    of each; ``starts``: IK solves run; ``iterations``: their iterations; ``elapsed``: their wall time
    (s); ``reason``: why the set is empty (``""`` otherwise).
    """

    goals: np.ndarray
    clearances: list = field(default_factory=list)
    starts: int = 0
    iterations: int = 0
    elapsed: float = 0.0
    reason: str = ""


def _ik_options(request: MotionRequest) -> dict:
    """The collision keywords of every solve: the request's scene, the margin when there is one."""
    scene = request.self_collision or len(request.obstacles) > 0
    return {"obstacles": request.obstacles, "self_collision": request.self_collision,
            "collision_margin": IK_MARGIN if scene else 0.0}


def warm_pose_goal(robot: Robot, request: MotionRequest) -> None:
    """The IK's one-time set-up for the request's frame and scene (:func:`kinserve.ik.warm`)."""
    options = _ik_options(request)
    ik.warm(robot, request.goal_pose.frame, self_collision=options["self_collision"],
            obstacles=options["obstacles"], collision_margin=options["collision_margin"])


def _solve(robot: Robot, request: MotionRequest, q0: np.ndarray, first: bool, seed: int) -> ik.Result:
    return ik.solve(robot, request.goal_pose, q0=q0, max_time=None, seed=seed, iteration_budget=IK_ITERATIONS,
                    prefer_q0=True, seed_table=first, **_ik_options(request))


def _separated(q: np.ndarray, members: list[np.ndarray]) -> bool:
    return all(float(np.linalg.norm(q - m)) > GOAL_SEPARATION for m in members)


def _failure_reason(starts: int, best: tuple[float, float] | None, last: str,
                    max_time: float | None = None) -> str:
    residual = "none" if best is None else f"{best[0]:.3g} m / {best[1]:.3g} rad"
    if max_time is not None:
        return (f"no collision-free IK solution of the goal pose found before the time budget max_time = "
                f"{max_time:g} s was spent ({starts} starts tried; best residual {residual}; last reason: "
                f"{last or 'none'})")
    return (f"no collision-free IK solution reaches the goal pose ({starts} starts tried; best residual "
            f"{residual}; last reason: {last or 'none'})")


def pose_goal_set(robot: Robot, request: MotionRequest, admit: Admit) -> GoalSet:
    """Up to ``request.goal_count`` collision-free IK solutions of ``request.goal_pose``, pairwise more than
    :data:`GOAL_SEPARATION` apart, each accepted by ``admit``, found within ``request.budget.max_time``
    when it is set (module docstring)."""
    rng = np.random.default_rng(None if request.seed is None else [request.seed, _STREAM])
    members: list[np.ndarray] = []
    clearances: list = []
    best, last, iterations, starts = None, "", 0, 0
    max_time = request.budget.max_time
    t0 = time.perf_counter()
    timed_out = False
    for k in range(STARTS_PER_GOAL * request.goal_count):
        if len(members) == request.goal_count:
            break
        if max_time is not None and time.perf_counter() - t0 >= max_time:
            timed_out = True
            break
        q0 = request.start if k == 0 else robot.lower + (robot.upper - robot.lower) * rng.random(robot.nq)
        res = _solve(robot, request, q0, k == 0, int(rng.integers(2**31)))
        starts, iterations = starts + 1, iterations + res.iterations
        if best is None or res.position_error < best[0]:
            best = (res.position_error, res.orientation_error)
        if not res.success:
            last = res.message
            continue
        if not _separated(res.q, members):
            continue
        reason, c = admit(res.q, f"IK solution from start {k}")
        if reason is not None:
            last = reason
            continue
        members.append(res.q.copy())
        clearances.append(c)
    goals = np.array(members).reshape(len(members), robot.nq)
    reason = "" if members else _failure_reason(starts, best, last, max_time if timed_out else None)
    return GoalSet(goals, clearances, starts, iterations, time.perf_counter() - t0, reason)


__all__ = ["GOAL_SEPARATION", "IK_ITERATIONS", "IK_MARGIN", "STARTS_PER_GOAL", "GoalSet", "pose_goal_set",
           "warm_pose_goal"]
