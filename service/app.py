"""The HTTP kinematics service (FastAPI), in the spirit of MoveIt's compute_fk / compute_ik.

Endpoints: ``GET /`` (a redirect to ``/docs``), ``GET /health``, ``GET /robots``, ``GET /robots/{name}``,
``POST /fk``, ``POST /jacobian``, ``POST /ik``, ``POST /ik/batch``,
``POST /plan/cartesian``, ``POST /plan/motion`` (:mod:`.motion_jobs`), ``POST /collision``
(:mod:`.collision_endpoint`). Poses are 4x4 row-major lists;
joint vectors are lists of ``nq`` numbers (rad / m).

Errors are JSON ``{"detail": [{"loc": [...], "msg": ..., "type": ...}]}``:
422 for a malformed or invalid field (schema violations, wrong lengths,
non-orthonormal rotations, unknown frames or relax names, models whose
parameters are out of bounds), 404 for an unknown robot, 413 for a body over
the size limit, 408 for a body that does not arrive in time, 503 (with
``Retry-After``) when the solver queue is full. Failing to reach a target is
a 200 with ``success: false``. Every number in an answer is finite.

Where work runs (see :mod:`service.executor`): the microsecond endpoints
(health, catalogue, FK, Jacobian) compute inline on the event loop; IK,
batches and plans run in the solver processes (:mod:`service.jobs`). A
request waits there at most the request time cap; an ``/ik`` solve then gets
its ``max_time`` (capped by ``--max-time-cap``), so does a ``/plan/motion`` plan
(default 1 s), and ``/ik/batch`` and ``/plan/cartesian`` end within the request time cap counted from their
arrival, queueing included. Every process has its own bounded robot cache
(:class:`RobotPool`).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import multiprocessing
import os
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

import numpy as np
from fastapi import FastAPI, Path, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import RedirectResponse
from fastapi_offline import FastAPIOffline

from kinserve.kinematics.errors import KinserveError

from . import cartesian_line, jobs, motion_jobs
from . import motion_schemas as M
from . import schemas as S
from .executor import BoundedExecutor, Deadline, ServiceBusy
from .fields import FieldError, field
from .limits import BodyLimitMiddleware
from .offline_docs import add_redoc
from .responses import error_body, json_response, json_safe
from .robot_pool import RobotPool
from .settings import ServiceSettings
from .solver_start import start_solver

log = logging.getLogger("kinserve.service")

DEFAULT_MAX_TIME = jobs.DEFAULT_MAX_TIME
MAX_TIME_CAP = ServiceSettings.max_time_cap
BATCH_TIME_CAP = ServiceSettings.request_time_cap

_ERRORS = {404: {"model": S.ErrorResponse}, 422: {"model": S.ErrorResponse}}
#: Two entries of ``GET /robots``'s answer, its documented example.
CATALOGUE_EXAMPLE = {
    "panda": "Franka Emika Panda 7-DOF arm (fingers locked; flange panda_link8, tool panda_hand)",
    "planar4r": "S1 planar 4R arm, joints about z, links l1..l4 = 1.0/0.8/0.6/0.4 m [params: l1, l2, l3, l4, "
                "limit, radius]",
}
_HEAVY_ERRORS = {**_ERRORS, 503: {"model": S.ErrorResponse}}
#: The Swagger UI page (``GET /`` redirects there).
DOCS_URL = "/docs"
ROBOT_NAME = Path(description="a built-in robot name (GET /robots)", openapi_examples={
    "planar4r": {"summary": "the planar 4R arm of scenario S1", "value": "planar4r"},
    "panda": {"summary": "the Franka Emika Panda", "value": "panda"}})

__all__ = ["create_app", "app", "FieldError", "field"]


def solver_executor(settings: ServiceSettings) -> BoundedExecutor:
    """``settings.threads`` solver processes (spawned: no fork of a running event loop) and their queue.

    Each process follows the server process that made the pool (:func:`service.solver_start.start_solver`,
    before it imports the solvers): it ends when the server does, even when the server dies while the
    process is still starting.
    """
    def factory():
        return ProcessPoolExecutor(max_workers=settings.threads,
                                   mp_context=multiprocessing.get_context("spawn"),
                                   initializer=start_solver, initargs=(os.getpid(), settings.to_env()))

    return BoundedExecutor(factory, settings.threads, settings.queue, name="solver")


async def warm_solvers(solvers: BoundedExecutor, count: int) -> None:
    """Start ``count`` solver processes at once, each loading the most used robot (:func:`jobs.warm`)."""
    results = await asyncio.gather(*(solvers.run(jobs.warm, Deadline(60.0)) for _ in range(count)),
                                   return_exceptions=True)
    for r in results:
        if isinstance(r, BaseException):
            log.warning("a solver process failed to warm up: %s: %s", type(r).__name__, r)


def loader_executor(settings: ServiceSettings) -> BoundedExecutor:
    """One thread loading models for the inline endpoints."""
    return BoundedExecutor(lambda: ThreadPoolExecutor(1, thread_name_prefix="kinserve-loader"), 1,
                           settings.queue, name="loader")


def create_app(settings: ServiceSettings | None = None, *, max_time_cap: float | None = None) -> FastAPI:
    """The service with ``settings`` (``max_time_cap`` overrides that one field, for convenience)."""
    settings = settings or ServiceSettings()
    if max_time_cap is not None:
        settings = ServiceSettings(**{**settings.__dict__, "max_time_cap": float(max_time_cap)})
    pool = RobotPool(settings.robot_cache, settings.robot_cache_bytes)
    solvers = solver_executor(settings)
    loader = loader_executor(settings)

    @contextlib.asynccontextmanager
    async def lifespan(app: FastAPI):
        # start every solver process now (spawning one takes ~1 s) with the most used model loaded; the
        # server answers meanwhile (heavy requests queue behind the warm-up)
        warming = asyncio.ensure_future(warm_solvers(solvers, settings.threads))
        try:
            yield
        finally:
            warming.cancel()
            solvers.shutdown()  # returns once the solver processes have ended and their queues are released
            loader.shutdown()

    # /docs (Swagger UI) and /redoc load their JS/CSS from the fastapi-offline package, served here under
    # /static-offline-docs, not from a CDN: the pages work without internet. No schema validator badge either.
    app = FastAPIOffline(
        title="kinserve",
        version="0.1.0",
        description="Forward kinematics, Jacobians, constrained inverse kinematics and Cartesian plans over "
                    "HTTP.",
        docs_url=DOCS_URL,
        swagger_ui_parameters={"validatorUrl": None},
        lifespan=lifespan,
        redoc_url=None,  # (add_redoc: the same page without its one request to a CDN)
    )
    add_redoc(app)
    from .collision_endpoint import router as collision_router

    app.include_router(collision_router)
    app.add_middleware(BodyLimitMiddleware, max_body=settings.max_body, body_timeout=settings.body_timeout)
    app.state.pool, app.state.solvers, app.state.settings = pool, solvers, settings

    # ------------------------------------------------------------------ errors
    @app.exception_handler(RequestValidationError)
    async def _validation_error(request: Request, exc: RequestValidationError):
        # The default handler echoes the offending input, which cannot be JSON-encoded when it is NaN/inf.
        detail = [
            {"loc": json_safe(list(e.get("loc", ()))), "msg": str(e.get("msg", "")),
             "type": str(e.get("type", ""))}
            for e in exc.errors()
        ]
        return json_response({"detail": detail}, 422)

    @app.exception_handler(FieldError)
    async def _field_error(request: Request, exc: FieldError):
        return json_response(error_body(["body", exc.field], str(exc.error),
                                        type(exc.error).__name__), exc.status)

    @app.exception_handler(KinserveError)
    async def _kinserve_error(request: Request, exc: KinserveError):
        return json_response(error_body(["body"], str(exc), type(exc).__name__), 422)

    @app.exception_handler(ServiceBusy)
    async def _busy(request: Request, exc: ServiceBusy):
        return json_response(error_body([], str(exc), "ServiceBusy"), 503,
                             headers={"Retry-After": str(exc.retry_after)})

    @app.exception_handler(ArithmeticError)
    @app.exception_handler(np.linalg.LinAlgError)
    async def _numerical(request: Request, exc: Exception):
        log.warning("numerical failure answered as 422: %s: %s", type(exc).__name__, exc)
        return json_response(error_body(["body"], "the computation failed numerically "
                                                  f"({type(exc).__name__}: {exc}); "
                                        "the model or inputs are degenerate", "NumericalError"), 422)

    # ------------------------------------------------------------------ helpers
    async def robot_here(name: str, params: dict, field_name: str):
        """The event-loop thread's Robot; a first-time load runs on the loader thread."""
        with field(field_name):
            robot = pool.cached(name, params)
            if robot is None:
                pool.check_name(name)
                await loader.run(lambda d: pool.get(name, params), Deadline(settings.request_time_cap))
                robot = pool.get(name, params)  # this thread's copy (loads inline only if evicted meanwhile)
        return robot

    async def heavy(req: S.RobotRef, job, budget: float, *args):
        """Answer ``job(deadline, req, *args)`` run in a solver process; an unknown robot is a 404 before
        queueing. ``budget`` bounds the whole request from now, queueing included."""
        with field("robot"):
            pool.check_name(req.robot)
        return json_response(await solvers.run(job, Deadline(budget), None, req, *args))

    # --------------------------------------------------------- inline endpoints
    @app.get("/", include_in_schema=False)
    async def root(request: Request) -> RedirectResponse:
        return RedirectResponse(request.scope.get("root_path", "") + DOCS_URL)  # 307

    @app.get("/health", response_model=S.HealthResponse, summary="Is the service up")
    async def health():
        """Answered on the event loop, even while every solver process is busy: `status` is always `ok`;
        `robots_loaded` counts the robot variants loaded in this process, `solver_jobs` the heavy requests
        (IK, batches, plans) running or waiting for a solver process."""
        return json_response({"status": "ok", "robots_loaded": len(pool), "solver_jobs": solvers.admitted})

    @app.get("/robots", response_model=dict[str, str], summary="The built-in robots",
             responses={200: {"content": {"application/json": {"example": CATALOGUE_EXAMPLE}}}})
    async def list_robots():
        """Every robot name the service serves, with a one-line description; a parametric robot lists the
        names of its model parameters (`params` of a request, e.g. `{"l1": 1.2}` for planar4r). Only these
        names are served: a path or URDF from the network is not read."""
        return json_response(pool.catalogue)

    @app.get("/robots/{name}", response_model=S.RobotInfo, responses={404: {"model": S.ErrorResponse}},
             summary="One robot's joints, limits, tool frame and frames")
    async def robot_info(name: str = ROBOT_NAME):
        """The joint names and limits (rad for revolute joints, m for prismatic ones), the default tool frame
        (`tip`, used when a request names no `frame`), the task axes (the components of x y z roll pitch yaw
        the robot can control; IK relaxes the others) and every frame name. An unknown name is a 404 whose
        message lists the known ones."""
        r = await robot_here(name, {}, "robot")
        return json_response({
            "name": name, "description": r.description, "nq": r.nq, "joint_names": r.joint_names,
            "lower": r.lower, "upper": r.upper, "tip": r.tip, "task_axes": list(r.task_axes),
            "frames": r.frame_names,
        })

    @app.post("/fk", response_model=S.FKResponse, responses=_ERRORS, summary="Forward kinematics of a frame")
    async def fk(req: S.FKRequest):
        """The pose of `frame` (default the robot's tool frame, `tip`) at the joint values `q` (nq numbers,
        rad / m): a homogeneous 4x4 matrix in the world frame, row major, translation in metres. Answered on
        the event loop in microseconds. Errors: 422 naming `q` (wrong length, a non-finite or huge number),
        `frame` (unknown) or `params`; 404 for an unknown robot."""
        r = await robot_here(req.robot, req.params, "params" if req.params else "robot")
        with field("q"):
            q = r.check_q(req.q, "q")
        with field("frame"):
            if req.frame is not None:
                r.frame_id(req.frame)
        return json_response({"robot": req.robot, "frame": req.frame or r.tip, "pose": r.fk(q, req.frame)})

    @app.post("/jacobian", response_model=S.JacobianResponse, responses=_ERRORS,
              summary="Jacobian, singular values and manipulability of a frame")
    async def jacobian(req: S.JacobianRequest):
        """The 6 x nq Jacobian of `frame` (default the tool frame) at `q`: rows [v; w] = [vx, vy, vz, wx, wy,
        wz], the frame's linear (m/s) and angular (rad/s) velocity per unit joint velocity. `reference`:
        `world` (default, the geometric Jacobian: origin velocity and angular velocity in world axes,
        Pinocchio's LOCAL_WORLD_ALIGNED), `local` (the same twist in the frame's axes) or `spatial` (the
        spatial twist, Pinocchio's WORLD). Also the singular values of the world Jacobian's rows of the
        robot's task axes, largest first, and their product, the manipulability (0 at a singularity).
        Errors as `POST /fk`."""
        r = await robot_here(req.robot, req.params, "params" if req.params else "robot")
        with field("q"):
            q = r.check_q(req.q, "q")
        with field("frame"):
            if req.frame is not None:
                r.frame_id(req.frame)
        J = r.jacobian(q, req.frame, reference=req.reference)
        sv = r.singular_values(q, req.frame)
        return json_response({
            "robot": req.robot, "frame": req.frame or r.tip, "reference": req.reference, "jacobian": J,
            "singular_values": sv, "manipulability": float(np.prod(sv)),
        })

    # ------------------------------------------------------ solver endpoints
    @app.post("/ik", response_model=S.IKResponse, responses=_HEAVY_ERRORS,
              summary="Inverse kinematics: joint values placing frames at poses")
    async def solve_ik(req: S.IKRequest):
        """Joint values placing `frame` (default the tool frame) at `target`, or several frames at once
        (`targets`, one task each, solved together), as `ik.solve` does in Python. A pose is a 4x4 matrix (row
        major, m), `{"position": [x, y, z], "quaternion": [qx, qy, qz, qw]}` (unit quaternion, scalar last:
        Pinocchio's and ROS's order) or `{"position", "rpy"}` (rad). `relax` frees components (x y z roll
        pitch yaw, world axes); `obstacles`, `spheres` and `self_collision` keep the robot clear; `centring`
        pulls the free joints to mid-range; `seed` makes the restarts reproducible.

        Time: the solve gets `max_time` (see the field: a default, capped by the server's
        `--max-time-cap`); the request waits for a solver process at most the request time cap, and a full
        queue is a 503 with `Retry-After`. A target not reached is a 200 with `success: false`, the closest
        `q` found, its residuals (m, rad) and the reason in `message`. Invalid input is a 422 naming the
        field; an unknown robot a 404."""
        return await heavy(req, jobs.solve_ik, settings.request_time_cap,
                           jobs.capped_by(settings, req.max_time))

    @app.post("/ik/batch", response_model=S.IKBatchResponse, responses=_HEAVY_ERRORS,
              summary="Inverse kinematics of many independent targets")
    async def solve_ik_batch(req: S.IKBatchRequest):
        """Up to 1000 independent problems with the options of `POST /ik`: each item of `targets` is a pose
        of `frame` (the pose forms of `/ik`) or a list of frame targets solved together. The targets are
        solved in order, each within `max_time`, and the whole request ends within the server's request time
        cap (`--request-time-cap`, queueing included): targets left without time are answered
        `success: false` ("not attempted") and `stop_reason` is `time_cap`. One answer per target, in
        order, and `success_rate` over all of them; a target not reached is a result, never an error."""
        return await heavy(req, jobs.solve_ik_batch, settings.request_time_cap)

    @app.post("/plan/cartesian", response_model=S.CartesianPlanResponse, responses=_HEAVY_ERRORS,
              summary="Joint trajectory through Cartesian poses")
    async def plan_cartesian(req: S.CartesianPlanRequest):
        """A joint trajectory moving `frame` through `poses` (the pose forms of `/ik`). Interpolated mode
        (default): `steps` poses per segment (`interpolation`: decoupled or screw), each solved by IK from
        the one before, `dt` seconds apart. Line mode, chosen by giving any of `jump_threshold`, `obstacles`,
        `self_collision`, `max_step`, `max_rotation_step`: from `q0` (required) the frame moves on straight
        lines to each pose in turn, at rest at each pose, checked for joint jumps, limits, singularities and
        collisions. The plan ends within `max_time` (default and upper bound: the server's request time
        cap). A plan that stops early is a 200 with `success: false` and the reason in `stop_reason`
        (`ik_failed`, `time_cap`, `joint_limit`, `joint_jump`, `singularity`, `collision`) and `message`;
        the trajectory holds what was reached."""
        budget = (settings.request_time_cap if req.max_time is None
                  else min(req.max_time, settings.request_time_cap))
        job = cartesian_line.move_through if cartesian_line.wants_line(req) else jobs.plan_cartesian
        return await heavy(req, job, budget)

    @app.post("/plan/motion", response_model=M.MotionPlanResponse, responses=_HEAVY_ERRORS,
              summary="Collision-free joint-space motion plan")
    async def plan_motion(req: M.MotionPlanRequest):
        """A collision-free motion from `start` to `goal`, as `planners.plan_motion` in Python: RRT-Connect
        in joint space, every path segment certified collision free as a continuous motion, shortcut
        (`simplify`) and time-parameterised within the joint velocity and `acceleration_limits`, at rest at
        both ends. The goal is a configuration, a goal set (reach any one) or a pose of `frame` (turned into
        up to `goal_count` collision-free IK solutions). `obstacles` (the `/ik` shapes) and `attached`
        objects carried by a frame are kept clear, and the robot's own link pairs with `self_collision`.
        Budget: `max_time` (s; default 1 s, capped by `--max-time-cap`) and `max_iterations`; with a `seed`
        and a `max_iterations` reached before `max_time` runs out, the answer depends only on the request. A
        start or goal in collision or no path within the budget is a 200 with `success: false` and the
        reason in `message`."""
        return await heavy(req, motion_jobs.plan_motion, settings.request_time_cap,
                           motion_jobs.plan_time(req.max_time, settings.max_time_cap))

    return app


#: The ASGI application, for ``uvicorn kinserve.service.app:app`` (``kinserve serve --workers N`` passes its
#: settings to the worker processes through the environment, see :mod:`service.settings`).
app = create_app(ServiceSettings.from_env())
