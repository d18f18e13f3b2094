"""The heavy work of the service, run in the solver processes (:mod:`service.executor`).

Each function takes the job's :class:`Deadline` first, then plain picklable
arguments (the validated request models), and returns plain data for
:func:`service.responses.json_response`. A solver process keeps its own
bounded :class:`RobotPool`, created by :func:`init_worker`.
"""

from __future__ import annotations

import os
import time
from typing import TYPE_CHECKING

import numpy as np

from kinserve import ik
from kinserve.kinematics.errors import FrameError, InputError, KinserveError

from . import schemas as S
from .executor import Deadline
from .fields import FieldError, field
from .robot_pool import RobotPool
from .settings import ServiceSettings

if TYPE_CHECKING:
    from kinserve.planners import JointTrajectory

#: IK budget (s) of a request that names no ``max_time``.
DEFAULT_MAX_TIME = 0.5

#: Scheduling niceness added to solver processes. 0: the kernel already favours the event loop's
#: process, which sleeps between short bursts; measured, niceness 10 starved the solvers (IK budgets
#: missed) whenever other programs loaded the machine, without being needed for /health.
SOLVER_NICENESS = 0

_pool: RobotPool | None = None
_settings = ServiceSettings()


def init_worker(settings_json: str | None = None, niceness: int = SOLVER_NICENESS) -> None:
    """Set up a solver process (called by :func:`service.solver_start.start_solver` once the process
    follows its server): its settings, its robot pool, its compiled kernels and its niceness."""
    global _pool, _settings
    _settings = (ServiceSettings(**__import__("json").loads(settings_json)) if settings_json
                 else ServiceSettings())
    _pool = RobotPool(_settings.robot_cache, _settings.robot_cache_bytes)
    load_compiled_kernels()
    if niceness and hasattr(os, "nice"):
        try:
            os.nice(niceness)
        except OSError:
            pass


def pool() -> RobotPool:
    """This process's :class:`RobotPool` (built on first use with the process's settings)."""
    global _pool
    if _pool is None:
        _pool = RobotPool(_settings.robot_cache, _settings.robot_cache_bytes)
    return _pool


def load_compiled_kernels() -> None:
    """Import Numba, load the compiled IK kernels (~0.5 s from their cache) and import the planners when a
    solver process starts, before it takes a job: a job that loaded them would overrun its time cap."""
    from kinserve.ik.constraints import clearance_kernel  # noqa: F401 - loaded on import
    from kinserve.ik.lm import kernel as lm_kernel  # noqa: F401 - loaded on import
    from kinserve.kinematics import precheck_kernels  # noqa: F401 - loaded on import
    from kinserve.planners import cartesian  # noqa: F401 - the planners, before a plan's clock starts


def warm(deadline: Deadline, robot: str = "panda") -> int:
    """Load ``robot`` and its IK seed table for the tool frame (so the first request does not pay for
    them: building the table takes ~0.1-0.3 s); returns the process id."""
    from kinserve.ik.state import seed_table

    r = pool().get(robot, {})
    seed_table(r, r.tip)
    return os.getpid()


def capped_by(settings: ServiceSettings, max_time: float | None) -> float:
    """A request's IK budget: its ``max_time`` (default :data:`DEFAULT_MAX_TIME`) capped by the server."""
    return min(max_time if max_time is not None else DEFAULT_MAX_TIME, settings.max_time_cap)


def capped(max_time: float | None) -> float:
    """:func:`capped_by` with this process's settings."""
    return capped_by(_settings, max_time)


def robot_of(req: S.RobotRef):
    """The pooled robot a request names; errors as a :class:`FieldError` (404 for an unknown robot)."""
    with field("params" if req.params else "robot"):
        return pool().get(req.robot, dict(req.params))


def ik_kwargs(robot, req: S.IKOptions) -> dict:
    """The keyword arguments of ``ik.solve`` for a request's options, each checked (422 on its field)."""
    with field("q0"):
        q0 = None if req.q0 is None else robot.check_q(req.q0, "q0")
    with field("frame"):
        frame = req.frame
        if frame is not None:
            robot.frame_id(frame)
    with field("spheres"):
        spheres = [ik.Sphere(s.center, s.radius, frames=s.frames) for s in req.spheres]
    kw = dict(q0=q0, frame=frame, relax=tuple(req.relax), spheres=spheres, centring=req.centring,
              method=req.method, tol_pos=req.tol_pos, tol_rot=req.tol_rot, seed=req.seed)
    from .collision_endpoint import obstacles_of

    kw["obstacles"] = obstacles_of(req.obstacles)
    if req.self_collision:  # the robot's collision geometry (see service/collision_endpoint.py)
        with field("self_collision"):
            robot.collision_scene(kw["obstacles"], True)  # builds the model; no <collision> -> 422
        kw.update(self_collision=True, collision_margin=req.collision_margin)
    return kw


def result_out(res) -> dict:
    """An IK result as the JSON-ready dict of :class:`~kinserve.service.schemas.IKResponse`."""
    return {
        "success": bool(res.success), "q": np.asarray(res.q, dtype=float).tolist(),
        "position_error": float(res.position_error), "orientation_error": float(res.orientation_error),
        "iterations": int(res.iterations), "restarts": int(res.restarts), "elapsed": float(res.elapsed),
        "message": str(res.message), "task_errors": list(res.task_errors),
    }


def not_attempted(robot, problem: list, kwargs: dict, why: str) -> dict:
    """The answer for a batch problem the time cap left no time for: the start configuration and its
    residual (for several frame targets, the largest of their errors, as :class:`ik.Result` reports)."""
    q0 = kwargs["q0"]
    q = robot.neutral() if q0 is None else np.clip(q0, robot.lower, robot.upper)
    if isinstance(problem[0], S.FrameTarget):
        targets = [ik.Target(robot, np.asarray(t.pose, dtype=float), t.frame, tuple(t.relax), t.relax_frame)
                   for t in problem]
    else:
        targets = [ik.Target(robot, np.asarray(problem, dtype=float), kwargs["frame"], kwargs["relax"])]
    errors = np.array([t.errors_at(robot, q) for t in targets])
    pe, re = errors.max(axis=0)
    return {"success": False, "q": q.tolist(), "position_error": float(pe), "orientation_error": float(re),
            "iterations": 0, "restarts": 0, "elapsed": 0.0, "message": why, "task_errors": []}


def solve_ik(deadline: Deadline, req: S.IKRequest, max_time: float) -> dict:
    """``POST /ik``: one solve given ``max_time`` from its start (the request's capped ``max_time``),
    never past the request's ``deadline``; loading the model is not charged to the solve.

    ``target`` (one 4x4 pose of ``frame``) or ``targets`` (several frame targets, one task each).
    """
    r = robot_of(req)
    kwargs = ik_kwargs(r, req)
    if (req.target is None) == (req.targets is None):
        raise FieldError("target", InputError("give exactly one of target (a 4x4 pose) or targets (a list of "
                                              "frame targets)"))
    problem, loc = (req.target, "target") if req.target is not None else (req.targets, "targets")
    if (kwargs["obstacles"] or kwargs["spheres"]) and not req.self_collision:
        tool_frames = [t.frame for t in req.targets] if req.targets else [kwargs["frame"] or r.tip]
        # binding checks the obstacles now: one containing the fixed base is an error on its field
        with field("obstacles" if kwargs["obstacles"] else "spheres"):
            ik.ObstacleAvoidance(kwargs["spheres"] + kwargs["obstacles"], link_radius=req.link_radius,
                                 tool_frames=tool_frames).bind(r)
    if req.target is not None:
        prepare_starts(r, kwargs)
    return solve_problem(r, req, kwargs, problem, max(min(max_time, deadline.remaining), 1e-3), loc)


def solve_problem(robot, req: S.IKOptions, kwargs: dict, problem: list, budget: float, loc: str) -> dict:
    """One IK problem of a request: a 4x4 pose of ``kwargs["frame"]``, or a list of
    :class:`~service.schemas.FrameTarget` solved together (one :class:`ik.FrameTask` each, plus the
    request's centring task and obstacle constraints); errors name ``loc`` (``"target"``, ``"targets[3]"``).
    """
    if not isinstance(problem[0], S.FrameTarget):
        with field(loc):
            res = ik.solve(robot, np.asarray(problem, dtype=float), max_time=budget,
                           link_radius=req.link_radius, **kwargs)
        return result_out(res)
    if req.method not in ("auto", "qp"):
        raise FieldError("method", InputError("several targets are solved by method 'auto' or 'qp', "
                                              f"got {req.method!r}"))
    tasks = frame_tasks(robot, problem, loc)
    if req.centring:
        tasks.append(ik.CentringTask(req.centring))
    shapes = kwargs["spheres"] + kwargs["obstacles"]
    if req.self_collision:  # the robot's collision geometry, as ik.solve(self_collision=True)
        constraints = [ik.CollisionConstraint(shapes, margin=req.collision_margin)]
    else:
        constraints = [ik.ObstacleAvoidance(shapes, link_radius=req.link_radius,
                                            tool_frames=[t.frame for t in problem])] if shapes else []
    with field(loc):
        res = ik.solve(robot, tasks=tasks, constraints=constraints, q0=kwargs["q0"], method=req.method,
                       tol_pos=req.tol_pos, tol_rot=req.tol_rot, seed=req.seed, max_time=budget)
    return result_out(res)


def frame_tasks(robot, targets: list[S.FrameTarget], loc: str) -> list:
    """One bound :class:`ik.FrameTask` per frame target; errors name ``loc[i].frame`` or ``loc[i]``."""
    tasks = []
    for i, t in enumerate(targets):
        try:
            task = ik.FrameTask(t.frame, np.asarray(t.pose, dtype=float), relax=tuple(t.relax),
                                relax_frame=t.relax_frame)
            tasks.append(task.bind(robot))
        except FrameError as exc:
            raise FieldError(f"{loc}[{i}].frame", exc) from None
        except KinserveError as exc:
            raise FieldError(f"{loc}[{i}]", exc) from None
    return tasks


def prepare_starts(robot, kwargs: dict) -> None:
    """Build the IK seed table of the request's frame before the solve's clock starts.

    Like loading the model, it is a one-time cost per robot variant and process
    (0.1-0.3 s), not part of any one solve; charged to ``max_time`` it would
    make the first request for a variant fail on a short budget.
    """
    from kinserve.ik.state import seed_table

    if kwargs["method"] in ("auto", "lm", "qp"):
        seed_table(robot, kwargs["frame"] or robot.tip)


def solve_ik_batch(deadline: Deadline, req: S.IKBatchRequest) -> dict:
    """``POST /ik/batch``: the targets in order, each given ``min(max_time, time left)``, until time is up.

    The targets the time cap leaves no time for are answered as not attempted (:func:`not_attempted`).
    """
    t0 = time.perf_counter()
    r = robot_of(req)
    kwargs = ik_kwargs(r, req)
    prepare_starts(r, kwargs)
    per_target = capped(req.max_time)
    out = []
    attempted = 0
    for i, problem in enumerate(req.targets):
        left = deadline.remaining
        if left <= 1e-3:
            with field(f"targets[{i}]"):
                out.append(not_attempted(r, problem, kwargs,
                                         "not attempted: the request's time cap "
                                         f"({deadline.budget:g} s) was spent"))
            continue
        out.append(solve_problem(r, req, kwargs, problem, min(per_target, left), f"targets[{i}]"))
        attempted += 1
    return {"results": out, "success_rate": sum(o["success"] for o in out) / len(out),
            "elapsed": time.perf_counter() - t0, "attempted": attempted,
            "stop_reason": "completed" if attempted == len(out) else "time_cap"}


def trajectory_out(traj: JointTrajectory) -> dict:
    """A :class:`~kinserve.planners.JointTrajectory` as the JSON-ready dict of
    :class:`~kinserve.service.schemas.JointTrajectoryOut`."""
    return {
        "joint_names": list(traj.joint_names), "times": np.asarray(traj.times).tolist(),
        "positions": np.asarray(traj.positions).tolist(),
        "velocities": np.asarray(traj.velocities).tolist(),
        "accelerations": None if traj.accelerations is None else np.asarray(traj.accelerations).tolist(),
    }


def plan_cartesian(deadline: Deadline, req: S.CartesianPlanRequest) -> dict:
    """``POST /plan/cartesian`` within the time left, stopping at the first failure unless told not to."""
    from kinserve.planners import cartesian_to_joint

    if len(req.poses) < 2:
        raise FieldError("poses", InputError(f"poses: the interpolated mode passes through at least 2 poses, "
                                             f"got {len(req.poses)} (the line mode moves from q0)"))
    r = robot_of(req)
    with field("q0"):
        q0 = None if req.q0 is None else r.check_q(req.q0, "q0")
    with field("frame"):
        if req.frame is not None:
            r.frame_id(req.frame)
    with field("poses"):
        plan = cartesian_to_joint(
            r, [np.asarray(p, dtype=float) for p in req.poses], q0=q0, frame=req.frame, steps=req.steps,
            dt=req.dt, interpolation=req.interpolation, relax=tuple(req.relax), max_time=capped(None),
            total_time=max(deadline.remaining, 1e-3), stop_on_failure=req.stop_on_failure,
        )
    return {
        "success": bool(plan.success),
        "trajectory": trajectory_out(plan.trajectory),
        "max_position_error": float(plan.max_position_error),
        "max_orientation_error": float(plan.max_orientation_error),
        "events": [dict(e) for e in plan.events],
        "message": plan.message,
        "stop_reason": plan.stop_reason,
        "poses_attempted": int(len(plan.position_errors)),
        "total_poses": int(plan.total_poses),
    }
