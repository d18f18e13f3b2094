"""The HTTP kinematics service (FastAPI), in the spirit of MoveIt's compute_fk / compute_ik.

Endpoints: ``GET /health``, ``GET /robots``, ``GET /robots/{name}``,
``POST /fk``, ``POST /jacobian``, ``POST /ik``, ``POST /ik/batch``,
``POST /plan/cartesian``. Poses are 4x4 row-major lists; joint vectors are
lists of ``nq`` numbers (rad / m).

Errors are JSON ``{"detail": [{"loc": [...], "msg": ..., "type": ...}]}``:
422 for a malformed or invalid field (schema violations, wrong lengths,
non-orthonormal rotations, unknown frames or relax names, models whose
parameters are out of bounds), 404 for an unknown robot, 413 for a body over
the size limit, 408 for a body that does not arrive in time, 503 (with
``Retry-After``) when the solver queue is full. Failing to reach a target is
a 200 with ``success: false``. Every number in an answer is finite.

Where work runs (see :mod:`service.executor`): the microsecond endpoints
(health, catalogue, FK, Jacobian) compute inline on the event loop; IK,
batches, plans and first-time model loads run on the bounded solver
executor: a request waits there at most the request time cap, an ``/ik``
solve then gets its ``max_time`` (capped by ``--max-time-cap``), and
``/ik/batch`` and ``/plan/cartesian`` end within the request time cap counted
from their arrival, queueing included. Each thread has its own ``Robot`` copy (:class:`RobotPool`).
"""

from __future__ import annotations

import contextlib
import logging
import time

import numpy as np
from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError

from kinserve import ik
from kinserve.kinematics.errors import FrameError, KinserveError, UnknownRobotError

from . import schemas as S
from .executor import Deadline, ServiceBusy, SolverExecutor
from .limits import BodyLimitMiddleware
from .responses import error_body, json_response, json_safe
from .robot_pool import RobotPool
from .settings import ServiceSettings

log = logging.getLogger("kinserve.service")

#: IK budget (s) of a request that names no ``max_time``.
DEFAULT_MAX_TIME = 0.5
MAX_TIME_CAP = ServiceSettings.max_time_cap
BATCH_TIME_CAP = ServiceSettings.request_time_cap

_ERRORS = {404: {"model": S.ErrorResponse}, 422: {"model": S.ErrorResponse}}
_HEAVY_ERRORS = {**_ERRORS, 503: {"model": S.ErrorResponse}}


class FieldError(Exception):
    """A library error tagged with the request field it concerns."""

    def __init__(self, field: str, error: Exception, status: int = 422):
        super().__init__(str(error))
        self.field, self.error, self.status = field, error, status


@contextlib.contextmanager
def field(name: str):
    """Attribute any :class:`KinserveError` raised inside to request field ``name``.

    An error that names its own argument (``exc.argument``, e.g. ``spheres`` or
    ``q0`` from :func:`ik.solve`) is attributed to that field instead; an
    unknown frame to ``frame`` (or to ``spheres`` when raised for a sphere).
    """
    try:
        yield
    except UnknownRobotError as exc:
        raise FieldError("robot", exc, 404) from exc
    except KinserveError as exc:
        arg = exc.argument
        if arg is None or arg == "target":
            arg = "frame" if isinstance(exc, FrameError) and name != "spheres" else name
        raise FieldError(arg, exc) from exc


def result_out(res) -> dict:
    return {
        "success": bool(res.success), "q": np.asarray(res.q, dtype=float).tolist(),
        "position_error": float(res.position_error), "orientation_error": float(res.orientation_error),
        "iterations": int(res.iterations), "restarts": int(res.restarts), "elapsed": float(res.elapsed),
        "message": str(res.message),
    }


def not_attempted(robot, target, frame: str | None, relax, q0, why: str) -> dict:
    """The answer for a batch target the time cap left no time for: the start configuration, its residual."""
    q = robot.neutral() if q0 is None else np.clip(q0, robot.lower, robot.upper)
    pe, re = ik.Target(robot, target, frame, relax).errors_at(robot, q)
    return {"success": False, "q": q.tolist(), "position_error": float(pe), "orientation_error": float(re),
            "iterations": 0, "restarts": 0, "elapsed": 0.0, "message": why}


def create_app(settings: ServiceSettings | None = None, *, max_time_cap: float | None = None) -> FastAPI:
    """The service with ``settings`` (``max_time_cap`` overrides that one field, for convenience)."""
    settings = settings or ServiceSettings()
    if max_time_cap is not None:
        settings = ServiceSettings(**{**settings.__dict__, "max_time_cap": float(max_time_cap)})
    app = FastAPI(
        title="kinserve",
        version="0.1.0",
        description="Forward kinematics, Jacobians, constrained inverse kinematics and Cartesian plans over HTTP.",
    )
    app.add_middleware(BodyLimitMiddleware, max_body=settings.max_body, body_timeout=settings.body_timeout)
    pool = RobotPool(settings.robot_cache, settings.robot_cache_bytes)
    solvers = SolverExecutor(settings.threads, settings.queue)
    app.state.pool, app.state.solvers, app.state.settings = pool, solvers, settings

    # ------------------------------------------------------------------ errors
    @app.exception_handler(RequestValidationError)
    async def _validation_error(request: Request, exc: RequestValidationError):
        # The default handler echoes the offending input, which cannot be JSON-encoded when it is NaN/inf.
        detail = [
            {"loc": json_safe(list(e.get("loc", ()))), "msg": str(e.get("msg", "")), "type": str(e.get("type", ""))}
            for e in exc.errors()
        ]
        return json_response({"detail": detail}, 422)

    @app.exception_handler(FieldError)
    async def _field_error(request: Request, exc: FieldError):
        return json_response(error_body(["body", exc.field], str(exc.error), type(exc.error).__name__), exc.status)

    @app.exception_handler(KinserveError)
    async def _kinserve_error(request: Request, exc: KinserveError):
        return json_response(error_body(["body"], str(exc), type(exc).__name__), 422)

    @app.exception_handler(ServiceBusy)
    async def _busy(request: Request, exc: ServiceBusy):
        return json_response(error_body([], str(exc), "ServiceBusy"), 503, headers={"Retry-After": str(exc.retry_after)})

    @app.exception_handler(ArithmeticError)
    @app.exception_handler(np.linalg.LinAlgError)
    async def _numerical(request: Request, exc: Exception):
        log.warning("numerical failure answered as 422: %s: %s", type(exc).__name__, exc)
        return json_response(error_body(["body"], f"the computation failed numerically ({type(exc).__name__}: {exc}); "
                                        "the model or inputs are degenerate", "NumericalError"), 422)

    # ------------------------------------------------------------------ helpers
    def capped(max_time: float | None) -> float:
        return min(max_time if max_time is not None else DEFAULT_MAX_TIME, settings.max_time_cap)

    async def robot_here(name: str, params: dict, field_name: str):
        """The event-loop thread's Robot; a first-time load runs on the solver executor."""
        with field(field_name):
            robot = pool.cached(name, params)
            if robot is None:
                pool.check_name(name)
                await solvers.run(lambda d: pool.get(name, params), Deadline(settings.request_time_cap))
                robot = pool.get(name, params)  # this thread's copy (loads inline only if evicted meanwhile)
        return robot

    async def heavy(req: S.RobotRef, job, budget: float, work_budget: float | None = None):
        """Answer ``job(deadline)`` run on the solver executor; an unknown robot is a 404 before queueing.

        ``budget`` bounds the whole request from now (queueing included); ``work_budget``
        the job itself from its start (see :meth:`SolverExecutor.run`).
        """
        with field("robot"):
            pool.check_name(req.robot)
        return json_response(await solvers.run(job, Deadline(budget), work_budget))

    def robot_of(req: S.RobotRef):
        """This (solver) thread's Robot for the request."""
        with field("params" if req.params else "robot"):
            return pool.get(req.robot, dict(req.params))

    def ik_kwargs(robot, req: S.IKOptions) -> dict:
        with field("q0"):
            q0 = None if req.q0 is None else robot.check_q(req.q0, "q0")
        with field("frame"):
            frame = req.frame
            if frame is not None:
                robot.frame_id(frame)
        with field("spheres"):
            spheres = [ik.Sphere(s.center, s.radius, frames=s.frames) for s in req.spheres]
        return dict(
            q0=q0, frame=frame, relax=tuple(req.relax), spheres=spheres, centring=req.centring,
            method=req.method, tol_pos=req.tol_pos, tol_rot=req.tol_rot, seed=req.seed,
        )

    # --------------------------------------------------------- inline endpoints
    @app.get("/health")
    async def health():
        return json_response({"status": "ok", "robots_loaded": len(pool), "solver_jobs": solvers.admitted})

    @app.get("/robots", response_model=dict[str, str])
    async def list_robots():
        return json_response(pool.catalogue)

    @app.get("/robots/{name}", response_model=S.RobotInfo, responses={404: {"model": S.ErrorResponse}})
    async def robot_info(name: str):
        r = await robot_here(name, {}, "robot")
        return json_response({
            "name": name, "description": r.description, "nq": r.nq, "joint_names": r.joint_names,
            "lower": r.lower.tolist(), "upper": r.upper.tolist(), "tip": r.tip, "task_axes": list(r.task_axes),
            "frames": r.frame_names,
        })

    @app.post("/fk", response_model=S.FKResponse, responses=_ERRORS)
    async def fk(req: S.FKRequest):
        r = await robot_here(req.robot, req.params, "params" if req.params else "robot")
        with field("q"):
            q = r.check_q(req.q, "q")
        with field("frame"):
            fid = r.frame_id(req.frame) if req.frame is not None else None
        T = r.fk(q, req.frame if fid is not None else None)
        return json_response({"robot": req.robot, "frame": req.frame or r.tip, "pose": T.tolist()})

    @app.post("/jacobian", response_model=S.JacobianResponse, responses=_ERRORS)
    async def jacobian(req: S.JacobianRequest):
        r = await robot_here(req.robot, req.params, "params" if req.params else "robot")
        with field("q"):
            q = r.check_q(req.q, "q")
        with field("frame"):
            if req.frame is not None:
                r.frame_id(req.frame)
        J = r.jacobian(q, req.frame, reference=req.reference)
        sv = r.singular_values(q, req.frame)
        return json_response({
            "robot": req.robot, "frame": req.frame or r.tip, "reference": req.reference, "jacobian": J.tolist(),
            "singular_values": sv.tolist(), "manipulability": float(np.prod(sv)),
        })

    # ---------------------------------------------------- solver-pool endpoints
    @app.post("/ik", response_model=S.IKResponse, responses=_HEAVY_ERRORS)
    async def solve_ik(req: S.IKRequest):
        def job(deadline: Deadline) -> dict:
            r = robot_of(req)
            kwargs = ik_kwargs(r, req)
            with field("target"):
                res = ik.solve(r, np.asarray(req.target, dtype=float), max_time=max(deadline.remaining, 1e-3), **kwargs)
            return result_out(res)

        return await heavy(req, job, settings.request_time_cap, work_budget=capped(req.max_time))

    @app.post("/ik/batch", response_model=S.IKBatchResponse, responses=_HEAVY_ERRORS)
    async def solve_ik_batch(req: S.IKBatchRequest):
        def job(deadline: Deadline) -> dict:
            t0 = time.perf_counter()
            r = robot_of(req)
            kwargs = ik_kwargs(r, req)
            per_target = capped(req.max_time)
            out = []
            attempted = 0
            for i, target in enumerate(req.targets):
                T = np.asarray(target, dtype=float)
                left = deadline.remaining
                with field(f"targets[{i}]"):
                    if left <= 1e-3:
                        out.append(not_attempted(r, T, kwargs["frame"], kwargs["relax"], kwargs["q0"],
                                                 f"not attempted: the request's time cap ({deadline.budget:g} s) was spent"))
                        continue
                    res = ik.solve(r, T, max_time=min(per_target, left), **kwargs)
                attempted += 1
                out.append(result_out(res))
            rate = sum(o["success"] for o in out) / len(out)
            return {"results": out, "success_rate": rate, "elapsed": time.perf_counter() - t0, "attempted": attempted,
                    "stop_reason": "completed" if attempted == len(out) else "time_cap"}

        return await heavy(req, job, settings.request_time_cap)

    @app.post("/plan/cartesian", response_model=S.CartesianPlanResponse, responses=_HEAVY_ERRORS)
    async def plan_cartesian(req: S.CartesianPlanRequest):
        from kinserve.planners import cartesian_to_joint

        def job(deadline: Deadline) -> dict:
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
            traj = plan.trajectory
            return {
                "success": bool(plan.success),
                "trajectory": {
                    "joint_names": list(traj.joint_names), "times": np.asarray(traj.times).tolist(),
                    "positions": np.asarray(traj.positions).tolist(), "velocities": np.asarray(traj.velocities).tolist(),
                    "accelerations": None if traj.accelerations is None else np.asarray(traj.accelerations).tolist(),
                },
                "max_position_error": float(plan.max_position_error),
                "max_orientation_error": float(plan.max_orientation_error),
                "events": [dict(e) for e in plan.events],
                "message": plan.message,
                "stop_reason": plan.stop_reason,
                "poses_attempted": int(len(plan.position_errors)),
                "total_poses": int(plan.total_poses),
            }

        budget = settings.request_time_cap if req.max_time is None else min(req.max_time, settings.request_time_cap)
        return await heavy(req, job, budget)

    return app


#: The ASGI application, for ``uvicorn kinserve.service.app:app`` (``kinserve serve --workers N`` passes its
#: settings to the worker processes through the environment, see :mod:`service.settings`).
app = create_app(ServiceSettings.from_env())
