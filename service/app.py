"""The HTTP kinematics service (FastAPI), in the spirit of MoveIt's compute_fk / compute_ik.

Endpoints: ``GET /health``, ``GET /robots``, ``GET /robots/{name}``,
``POST /fk``, ``POST /jacobian``, ``POST /ik``, ``POST /ik/batch``,
``POST /plan/cartesian``, ``POST /collision`` (:mod:`.collision_endpoint`). Poses are 4x4 row-major lists; joint vectors are
lists of ``nq`` numbers (rad / m).

Errors are JSON ``{"detail": [{"loc": [...], "msg": ..., "type": ...}]}``:
422 for a malformed or invalid field (schema violations, wrong lengths,
non-orthonormal rotations, unknown frames or relax names), 404 for an
unknown robot. Failing to reach a target is a 200 with ``success: false``.
Solver time is capped server-side (``max_time_cap``).

Sync endpoints run in the server's thread pool; each thread has its own
``Robot`` copy (``RobotPool``).
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import time

import numpy as np
from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse

from kinserve import ik
from kinserve import robots
from kinserve.kinematics.errors import FrameError, InputError, KinserveError, UnknownRobotError
from kinserve.kinematics.shapes import as_shape

from . import schemas as S
from .robot_pool import RobotPool

log = logging.getLogger("kinserve.service")

DEFAULT_MAX_TIME = 0.5
MAX_TIME_CAP = 5.0
BATCH_TIME_CAP = 60.0


class FieldError(Exception):
    """A library error tagged with the request field it concerns."""

    def __init__(self, field: str, error: Exception, status: int = 422):
        super().__init__(str(error))
        self.field, self.error, self.status = field, error, status


@contextlib.contextmanager
def field(name: str):
    """Attribute any :class:`KinserveError` raised inside to request field ``name``."""
    try:
        yield
    except UnknownRobotError as exc:
        raise FieldError("robot", exc, 404) from exc
    except FrameError as exc:
        raise FieldError("frame" if name != "spheres" else name, exc) from exc
    except KinserveError as exc:
        raise FieldError(name, exc) from exc


def error_body(loc: list, msg: str, kind: str) -> dict:
    return {"detail": [{"loc": loc, "msg": msg, "type": kind}]}


def json_safe(value):
    """``value`` with NaN/inf floats as strings and unknown objects as ``str``: always JSON-encodable."""
    if isinstance(value, float):
        return value if math.isfinite(value) else repr(value)
    if isinstance(value, (str, int, bool)) or value is None:
        return value
    if isinstance(value, dict):
        return {str(k): json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    return str(value)


def create_app(max_time_cap: float = MAX_TIME_CAP) -> FastAPI:
    app = FastAPI(
        title="kinserve",
        version="0.1.0",
        description="Forward kinematics, Jacobians, constrained inverse kinematics and Cartesian plans over HTTP.",
    )
    pool = RobotPool()
    app.state.pool = pool
    from .collision_endpoint import router as collision_router

    app.include_router(collision_router)

    @app.exception_handler(RequestValidationError)
    async def _validation_error(request: Request, exc: RequestValidationError):
        # The default handler echoes the offending input, which cannot be JSON-encoded when it is NaN/inf.
        detail = [
            {"loc": json_safe(list(e.get("loc", ()))), "msg": str(e.get("msg", "")), "type": str(e.get("type", ""))}
            for e in exc.errors()
        ]
        return JSONResponse({"detail": detail}, status_code=422)

    @app.exception_handler(FieldError)
    async def _field_error(request: Request, exc: FieldError):
        return JSONResponse(error_body(["body", exc.field], str(exc.error), type(exc.error).__name__), status_code=exc.status)

    @app.exception_handler(KinserveError)
    async def _kinserve_error(request: Request, exc: KinserveError):
        return JSONResponse(error_body(["body"], str(exc), type(exc).__name__), status_code=422)

    def robot_of(req: S.RobotRef):
        with field("params" if req.params else "robot"):
            return pool.get(req.robot, dict(req.params))

    def capped(max_time: float | None) -> float:
        return min(max_time if max_time is not None else DEFAULT_MAX_TIME, max_time_cap)

    def ik_kwargs(robot, req: S.IKOptions) -> dict:
        with field("q0"):
            q0 = None if req.q0 is None else robot.check_q(req.q0, "q0")
        with field("frame"):
            frame = req.frame
            if frame is not None:
                robot.frame_id(frame)
        with field("spheres"):
            spheres = [ik.Sphere(s.center, s.radius, frames=s.frames) for s in req.spheres]
        kw = dict(
            q0=q0, frame=frame, relax=tuple(req.relax), spheres=spheres, centring=req.centring,
            method=req.method, tol_pos=req.tol_pos, tol_rot=req.tol_rot, seed=req.seed,
        )
        if req.self_collision or req.obstacles:  # collision options (see service/collision_endpoint.py)
            from .collision_endpoint import obstacles_of

            obstacles = obstacles_of(req.obstacles)
            with field("self_collision" if req.self_collision else "obstacles"):
                robot.collision_scene(obstacles, req.self_collision)  # builds the model; ModelError -> 422
            kw.update(self_collision=req.self_collision, obstacles=obstacles, collision_margin=req.collision_margin)
        return kw

    def result_out(res) -> dict:
        return {
            "success": bool(res.success), "q": np.asarray(res.q, dtype=float).tolist(),
            "position_error": float(res.position_error), "orientation_error": float(res.orientation_error),
            "iterations": int(res.iterations), "restarts": int(res.restarts), "elapsed": float(res.elapsed),
            "message": str(res.message),
        }

    @app.get("/health")
    def health() -> dict:
        return {"status": "ok", "robots_loaded": len(pool._base)}

    @app.get("/robots")
    def list_robots() -> dict[str, str]:
        return robots.available()

    @app.get("/robots/{name}", response_model=S.RobotInfo, responses={404: {"model": S.ErrorResponse}})
    def robot_info(name: str):
        with field("robot"):
            r = pool.get(name)
        return S.RobotInfo(
            name=name, description=r.description, nq=r.nq, joint_names=r.joint_names, lower=r.lower.tolist(),
            upper=r.upper.tolist(), tip=r.tip, task_axes=list(r.task_axes), frames=r.frame_names,
        )

    @app.post("/fk", response_model=S.FKResponse, responses={404: {"model": S.ErrorResponse}, 422: {"model": S.ErrorResponse}})
    def fk(req: S.FKRequest):
        r = robot_of(req)
        with field("q"):
            q = r.check_q(req.q, "q")
        with field("frame"):
            T = r.fk(q, req.frame)
        return S.FKResponse(robot=req.robot, frame=req.frame or r.tip, pose=T.tolist())

    @app.post("/jacobian", response_model=S.JacobianResponse, responses={404: {"model": S.ErrorResponse}, 422: {"model": S.ErrorResponse}})
    def jacobian(req: S.JacobianRequest):
        r = robot_of(req)
        with field("q"):
            q = r.check_q(req.q, "q")
        with field("frame"):
            J = r.jacobian(q, req.frame, reference=req.reference)
            sv = r.singular_values(q, req.frame)
        return S.JacobianResponse(
            robot=req.robot, frame=req.frame or r.tip, reference=req.reference, jacobian=J.tolist(),
            singular_values=sv.tolist(), manipulability=float(np.prod(sv)),
        )

    @app.post("/ik", response_model=S.IKResponse, responses={404: {"model": S.ErrorResponse}, 422: {"model": S.ErrorResponse}})
    def solve_ik(req: S.IKRequest):
        r = robot_of(req)
        kwargs = ik_kwargs(r, req)
        if (req.target is None) == (req.targets is None):
            raise FieldError("target", InputError("give exactly one of target (a 4x4 pose) or targets (a list of frame targets)"))
        obstacles = []
        for i, spec in enumerate(req.obstacles):
            with field(f"obstacles[{i}]"):
                obstacles.append(as_shape(spec.model_dump(exclude_none=True), f"obstacles[{i}]"))
        tasks = []
        if req.targets is not None:
            if req.method not in ("auto", "qp"):
                raise FieldError("method", InputError(f"several targets are solved by method 'auto' or 'qp', got {req.method!r}"))
            for i, t in enumerate(req.targets):
                try:
                    task = ik.FrameTask(t.frame, np.asarray(t.pose, dtype=float), relax=tuple(t.relax), relax_frame=t.relax_frame)
                    tasks.append(task.bind(r))
                except FrameError as exc:
                    raise FieldError(f"targets[{i}].frame", exc) from exc
                except KinserveError as exc:
                    raise FieldError(f"targets[{i}]", exc) from exc
        tool_frames = [t.frame for t in req.targets] if req.targets else [kwargs["frame"] or r.tip]
        if obstacles or kwargs["spheres"]:
            with field("obstacles" if obstacles else "spheres"):  # an obstacle containing the fixed base is a bad request
                ik.ObstacleAvoidance(kwargs["spheres"] + obstacles, link_radius=req.link_radius, tool_frames=tool_frames).bind(r)
        if req.target is not None:
            with field("target"):
                res = ik.solve(r, np.asarray(req.target, dtype=float), max_time=capped(req.max_time),
                               obstacles=obstacles, link_radius=req.link_radius, **kwargs)
            return result_out(res)
        if req.centring:
            tasks.append(ik.CentringTask(req.centring))
        constraints = [ik.ObstacleAvoidance(kwargs["spheres"] + obstacles, link_radius=req.link_radius, tool_frames=tool_frames)]
        with field("targets"):
            res = ik.solve(r, tasks=tasks, constraints=constraints, q0=kwargs["q0"], method=req.method,
                           tol_pos=req.tol_pos, tol_rot=req.tol_rot, seed=req.seed, max_time=capped(req.max_time))
        out = result_out(res)
        out["task_errors"] = res.task_errors
        return out

    @app.post("/ik/batch", response_model=S.IKBatchResponse, responses={404: {"model": S.ErrorResponse}, 422: {"model": S.ErrorResponse}})
    def solve_ik_batch(req: S.IKBatchRequest):
        r = robot_of(req)
        kwargs = ik_kwargs(r, req)
        per_target = capped(req.max_time)
        t0 = time.perf_counter()
        out = []
        for i, target in enumerate(req.targets):
            budget = min(per_target, max(BATCH_TIME_CAP - (time.perf_counter() - t0), 1e-3))
            with field(f"targets[{i}]"):
                res = ik.solve(r, np.asarray(target, dtype=float), max_time=budget, **kwargs)
            out.append(result_out(res))
        rate = sum(o["success"] for o in out) / len(out)
        return {"results": out, "success_rate": rate, "elapsed": time.perf_counter() - t0}

    @app.post("/plan/cartesian", response_model=S.CartesianPlanResponse, responses={404: {"model": S.ErrorResponse}, 422: {"model": S.ErrorResponse}})
    def plan_cartesian(req: S.CartesianPlanRequest):
        from kinserve.planners import cartesian_to_joint

        r = robot_of(req)
        with field("q0"):
            q0 = None if req.q0 is None else r.check_q(req.q0, "q0")
        with field("poses"):
            plan = cartesian_to_joint(
                r, [np.asarray(p, dtype=float) for p in req.poses], q0=q0, frame=req.frame, steps=req.steps,
                dt=req.dt, interpolation=req.interpolation, relax=tuple(req.relax), max_time=capped(None),
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
        }

    return app


#: The ASGI application, for ``uvicorn service.app:app`` (``kinserve serve --workers N`` passes the cap
#: to its worker processes through ``KINSERVE_MAX_TIME_CAP``).
app = create_app(max_time_cap=float(os.environ.get("KINSERVE_MAX_TIME_CAP", MAX_TIME_CAP)))
