"""``plan_motion``: a collision-free joint-space motion from a start to a goal, a goal set or a pose, timed.

The steps, each its own module: validate the request (:mod:`.request`); set up
outside any clock the robot's collision scene with the obstacles, the reach table
of its pairs (:mod:`.reach`), the edge certifier (:mod:`.edges`), toppra and, for a
pose goal, the IK; check the start; turn a pose goal into a goal set of collision-free
IK solutions (:mod:`.pose_goal`); check the goals; search with bidirectional RRT-Connect (:mod:`.rrt_connect`,
budget: ``max_iterations`` and / or ``max_time``); simplify (:mod:`.shortcut`); time
the path with toppra (:mod:`.timing`). Every segment of ``path`` and the
trajectory's geometric path are certified collision free as continuous motions.

An answer depends only on the inputs and ``seed`` when the budget is
``max_iterations`` alone (``max_time=None``); with ``max_time`` the search stops
on the clock, so a loaded machine may find a different path or none. A pose goal's
IK solves run on iteration budgets; with ``max_time`` the goal-set search also stops
once that time is spent (with ``max_time=None`` the goal set never depends on the clock).
"""

from __future__ import annotations

import time
from collections.abc import Iterable
from typing import Any, NamedTuple

import numpy as np
import pinocchio as pin

from kinserve.kinematics.robot import Robot
from kinserve.kinematics.shapes import Shape
from kinserve.kinematics.types import ArrayLike

from .blended_path import corner_directions, distinct_points
from .clearance import CLEARANCE_FLOOR, Clearance, ClearanceOracle
from .edges import EdgeCertifier
from .pose_goal import pose_goal_set, warm_pose_goal
from .reach import pair_reach
from .request import GOAL_COUNT, MotionRequest, motion_request
from .result import MotionPlan
from .rrt_connect import SearchBudget, rrt_connect
from .shortcut import CertifiedPath, path_length, simplify_path
from .timing import TimedPath, load_toppra, time_parameterize


def _pairs_text(pairs: list[tuple[str, str]]) -> str:
    return ", ".join(f"{a} with {b}" for a, b in pairs)


def _blocked_reason(robot: Robot, request: MotionRequest, certifier: EdgeCertifier, q: np.ndarray,
                    name: str) -> tuple[str | None, Clearance | None]:
    """Why configuration ``q`` (called ``name``) cannot be a path's end (None when it can) and its
    clearance."""
    if certifier.in_collision(q):
        pairs = robot.collisions(q, request.obstacles, self_collision=request.self_collision)
        return f"{name} is in collision: {_pairs_text(pairs) or 'a checked pair'}", None
    c = certifier.clearance(q)
    k = certifier.closest_violation(c)
    if k >= 0:
        a, b = certifier.oracle.scene.pair_names[k]
        return (f"{name} is closer than the clearance floor {CLEARANCE_FLOOR:g} m to a collision: "
                f"{a} with {b} at {c.distance[k]:.3g} m"), c
    return None, c


def _goal_reasons(robot: Robot, request: MotionRequest, certifier: EdgeCertifier):
    """``(indices of the usable goals, their clearances, reasons of the others)``."""
    usable, clearances, reasons = [], [], []
    for i, q in enumerate(request.goals):
        name = "goal" if request.single_goal else f"goal[{i}]"
        reason, c = _blocked_reason(robot, request, certifier, q, name)
        if reason is None:
            usable.append(i)
            clearances.append(c)
        else:
            reasons.append(reason)
    return usable, clearances, reasons


class _Goals(NamedTuple):
    """The goals the search aims at: ``goals`` ``(n, nq)``, the indices of the ``usable`` ones with their
    ``clearances``, why none is usable (``failure``, None when some are) and the IK's ``stats``."""

    goals: np.ndarray
    usable: list[int]
    clearances: list[Clearance]
    failure: str | None
    stats: dict


def _resolve_goals(robot: Robot, request: MotionRequest, certifier: EdgeCertifier) -> _Goals:
    """The request's goals checked (:func:`_goal_reasons`), or a pose goal's goal set (:mod:`.pose_goal`)."""
    if request.goal_pose is None:
        usable, clearances, reasons = _goal_reasons(robot, request, certifier)
        failure = None if usable else "; ".join(reasons[:3]) + ("; ..." if len(reasons) > 3 else "")
        return _Goals(request.goals, usable, clearances, failure, {})
    found = pose_goal_set(robot, request,
                          lambda q, name: _blocked_reason(robot, request, certifier, q, name))
    stats = {"ik_time": found.elapsed, "ik_starts": found.starts, "ik_iterations": found.iterations,
             "goal_set_size": len(found.goals)}
    return _Goals(found.goals, list(range(len(found.goals))), found.clearances, found.reason or None, stats)


def _search_budget(request: MotionRequest, ik_time: float) -> SearchBudget:
    """The search's budget: ``max_time`` less the time the pose goal's IK took (``max_iterations`` as is)."""
    budget = request.budget
    if budget.max_time is None or ik_time == 0.0:
        return budget
    return SearchBudget(budget.max_iterations, max(budget.max_time - ik_time, 0.0))


def _timed(toppra, path: CertifiedPath, certifier: EdgeCertifier, request: MotionRequest,
           joint_names: list[str]) -> TimedPath:
    """The trajectory of ``path``: its distinct waypoints, the certified room of each corner along both of
    its directions (:meth:`~.edges.EdgeCertifier.room`), then :func:`~.timing.time_parameterize`."""
    keep = distinct_points(path.points)
    points, clear = path.points[keep], [path.clearances[k] for k in keep]
    room = np.zeros(len(points))
    if len(points) > 2:
        e_in, e_out = corner_directions(points)
        room[1:-1] = [min(certifier.room(c, a), certifier.room(c, b))
                      for c, a, b in zip(clear[1:-1], e_in, e_out)]
    return time_parameterize(toppra, points, room, request.velocity_limits, request.acceleration_limits,
                             joint_names)


def _failure(request: MotionRequest, message: str, stats: dict,
             goals: np.ndarray | None = None) -> MotionPlan:
    empty = np.zeros((0, len(request.start)))
    goals = request.goals if goals is None else goals
    return MotionPlan(False, message, empty, empty.copy(), None, -1, stats, goals.copy())


def _stats(certifier: EdgeCertifier, **values: Any) -> dict:
    oracle = certifier.oracle
    out = {"plan_time": 0.0, "simplify_time": 0.0, "parameterize_time": 0.0, "ik_time": 0.0, "ik_starts": 0,
           "ik_iterations": 0, "nodes": 0, "iterations": 0, "length_before": 0.0, "length_after": 0.0,
           "timing": "none"}
    out.update(values, checks=oracle.checks, distance_checks=oracle.distance_checks,
               pair_distances=oracle.pair_distances)
    return out


def plan_motion(robot: Robot, start: ArrayLike, goal: ArrayLike | pin.SE3, *,
                obstacles: Shape | list | tuple = (), self_collision: bool = True,
                max_time: float | None = 1.0, seed: int | None = None,
                acceleration_limits: float | ArrayLike | None = None,
                simplify: bool = True, max_iterations: int | None = None, frame: str | None = None,
                relax: str | Iterable[str] | None = (), goal_count: int = GOAL_COUNT) -> MotionPlan:
    """A certified collision-free motion of ``robot`` from ``start`` to ``goal``, timed.

    ``goal``: one configuration ``(nq,)``, a goal set (list / ``(n, nq)`` array; reach any one:
    ``goal_index`` says which), or a pose of ``frame`` (default ``robot.tip``) in the world: a 4x4 array or
    a ``pinocchio.SE3``, with the components named in ``relax`` left free (``x y z roll pitch yaw``, as in
    :func:`kinserve.ik.solve`). On a robot with ``nq == 4`` a ``(4, 4)`` array is a goal set of four
    configurations unless ``frame=`` or ``relax=`` is given (or pass a ``pinocchio.SE3``). A pose becomes a
    goal set of up to ``goal_count`` collision-free IK solutions on different branches
    (:mod:`~kinserve.planners.motion.pose_goal`); the plan reaches one of them (``goals``, ``goal_index``).
    ``obstacles``: shapes of :mod:`kinserve.kinematics.shapes` (``ik.Box``, ``ik.Sphere``, ``ik.Cylinder``,
    ...); ``self_collision``: check the robot's self pairs too. ``max_time`` (s) and ``max_iterations``
    (RRT-Connect samples) bound the search (at least one; with ``max_iterations`` alone the result depends
    only on the inputs and ``seed``); the pose goal's IK runs on iteration budgets and stops once
    ``max_time`` is spent, its time (``stats["ik_time"]``) is taken from ``max_time`` before the search
    starts. ``goal_count``: an integer from 1 to
    :data:`~kinserve.planners.motion.request.MAX_GOAL_COUNT`. ``acceleration_limits``: per
    joint or one value (rad/s^2; default: 2 x the URDF velocity limits). ``simplify``: shortcut the path.

    A start or goal in collision (the message names the pairs), closer than the clearance floor to one, a
    pose that no collision-free configuration reaches, or no path within the budget: a :class:`MotionPlan`
    with ``success=False`` and the reason. Invalid arguments raise :class:`InputError` /
    :class:`ShapeError` naming the argument.
    """
    request = motion_request(robot, start, goal, obstacles, self_collision, max_time, seed,
                             acceleration_limits, simplify, max_iterations, frame, relax, goal_count)
    scene = robot.collision_scene(request.obstacles, request.self_collision)
    certifier = EdgeCertifier(ClearanceOracle(scene), pair_reach(robot.model, scene))
    toppra = load_toppra()
    if request.goal_pose is not None:
        warm_pose_goal(robot, request)
    rng = np.random.default_rng(request.seed)
    reason, c_start = _blocked_reason(robot, request, certifier, request.start, "start")
    if reason is not None:
        return _failure(request, reason, _stats(certifier))
    goals = _resolve_goals(robot, request, certifier)
    if goals.failure is not None:
        return _failure(request, goals.failure, _stats(certifier, **goals.stats), goals.goals)
    t0 = time.perf_counter()
    found = rrt_connect(c_start, goals.clearances, robot.lower, robot.upper, certifier, rng,
                        _search_budget(request, goals.stats.get("ik_time", 0.0)))
    t1 = time.perf_counter()
    searched = dict(plan_time=t1 - t0, nodes=found.nodes, iterations=found.iterations, **goals.stats)
    if found.goal < 0:
        return _failure(request, f"no path found within the budget ({found.iterations} iterations, "
                        f"{t1 - t0:.3g} s)", _stats(certifier, **searched), goals.goals)
    raw = CertifiedPath(found.path, found.clearances)
    path = simplify_path(raw, certifier, rng) if request.simplify else raw
    t2 = time.perf_counter()
    timed = _timed(toppra, path, certifier, request, robot.joint_names)
    t3 = time.perf_counter()
    stats = _stats(certifier, **searched, simplify_time=t2 - t1, parameterize_time=t3 - t2,
                   length_before=path_length(raw.points), length_after=path_length(path.points),
                   timing=timed.method)
    message = f"path found ({len(path.points)} waypoints), timed by {timed.method}"
    return MotionPlan(True, message, path.points.copy(), raw.points.copy(), timed.trajectory,
                      goals.usable[found.goal], stats, goals.goals.copy())


__all__ = ["plan_motion"]
