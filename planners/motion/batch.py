"""``plan_many``: many motion-planning problems at once, on every core (or on Ray actors).

Design (that of :func:`kinserve.ik.solve_many`):

* Every problem is checked **once, in the calling process**, before any work starts: a problem is
  ``(start, goal)`` or ``(start, goal, obstacles)``; errors name the problem's index. The robot's
  collision model is built here too, before any worker starts (a forked worker inherits it).
* Problems are cut into chunks (:func:`motion_chunks`) and planned by
  :meth:`~.batch_workers.MotionJob.plan_chunk`: in this process (``processes=1``), on worker processes
  made for the call (``backend="local"``, :class:`~.batch_workers.ChunkPool`), or on Ray actors
  (``backend="ray"``). Problem ``i`` is planned with seed ``seed + i`` wherever it runs, so the plans
  are those of ``plan_motion`` one by one, in order, for any number of processes.
* Every chunk of ``n`` problems has the time limit ``CHUNK_FACTOR * n * budget + CHUNK_SLACK`` (s),
  ``budget`` being ``max_time`` (the plan's wall-clock budget); ``timeout=`` bounds the whole call. A Ray
  actor's start (its process, imports, the job's set-up) is timed apart, and its first chunk's limit counts
  from when it is ready (:mod:`kinserve.ik.batch.ray_actors`).
  A stalled worker raises :class:`~kinserve.kinematics.errors.WorkerTimeoutError`, a killed one is
  replaced and its chunk retried once; no worker outlives the call.
"""

from __future__ import annotations

import inspect
import math
import os
import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from kinserve.ik.arguments import check_max_time
from kinserve.ik.batch.ray_actors import BatchLabels, run_on_new_actors
from kinserve.ik.batch.ray_backend import ensure_ray, refuse_unused_address
from kinserve.ik.batch.runners import CHUNK_FACTOR, CHUNK_SLACK
from kinserve.kinematics.errors import InputError, WorkerTimeoutError
from kinserve.kinematics.robot import as_robot
from kinserve.kinematics.shapes import as_obstacles
from kinserve.kinematics.validation import as_choice, as_positive

from .batch_workers import ChunkPool, MotionJob, MotionProblem

if TYPE_CHECKING:  # annotations only
    from kinserve.kinematics.robot import Robot

__all__ = ["plan_many", "MotionProblem", "motion_chunks", "BACKENDS"]

#: Execution backends of :func:`plan_many`.
BACKENDS = ("local", "ray")
#: Budget (s) a chunk limit assumes per problem when ``max_time`` is None (iteration budgets only).
UNTIMED_BUDGET = 10.0
#: Largest ``processes`` accepted; on this machine no more workers than its cores are started anyway.
MAX_PROCESSES = 1024
#: The arguments of the planner that ``plan_many`` sets itself (not shared keywords).
_PER_PROBLEM = ("robot", "start", "goal", "obstacles", "seed")


def _cpu_count() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - non-Linux
        return os.cpu_count() or 1


def _goal(robot: Robot, goal: Any, label: str) -> Any:
    """A configuration goal validated as ``(nq,)``; a goal set ``(k, nq)`` row by row; a pose (4x4)
    or any other form passed on as it is (the planner checks it)."""
    try:
        arr = np.asarray(goal, dtype=float)
    except (TypeError, ValueError):
        return goal
    if arr.ndim == 1:
        return robot.check_q(arr, label)
    if arr.ndim == 2 and arr.shape[1] == robot.nq and arr.shape != (4, 4):
        return np.array([robot.check_q(row, f"{label}[{k}]") for k, row in enumerate(arr)])
    return goal


def checked_problems(robot: Robot, problems: Any) -> list[MotionProblem]:
    """The problems as :class:`MotionProblem` records, each checked (:class:`InputError` naming
    ``problems[i]``): start ``(nq,)`` finite, goal (see :func:`_goal`), obstacles a sequence of shapes."""
    if isinstance(problems, (str, bytes, dict)) or not hasattr(problems, "__iter__"):
        raise InputError(f"problems must be a sequence of (start, goal) or (start, goal, obstacles), got "
                         f"{type(problems).__name__}")
    out = []
    for i, p in enumerate(problems):
        label = f"problems[{i}]"
        if isinstance(p, (str, bytes, dict)) or not isinstance(p, Sequence) or len(p) not in (2, 3):
            raise InputError(f"{label} must be (start, goal) or (start, goal, obstacles), got {p!r:.200}")
        start = robot.check_q(p[0], f"{label}.start")
        goal = _goal(robot, p[1], f"{label}.goal")
        obstacles = as_obstacles(p[2], f"{label}.obstacles") if len(p) == 3 else ()
        out.append(MotionProblem(start, goal, obstacles))
    return out


def motion_chunks(n: int, processes: int, chunksize: int | None = None) -> list[tuple[int, int]]:
    """``(start, stop)`` of each chunk: by default about 4 chunks per process (even shares when plan
    times differ), at least one problem each."""
    if chunksize is None:
        chunksize = max(1, math.ceil(n / (4 * processes)))
    return [(s, min(n, s + chunksize)) for s in range(0, n, chunksize)]


def _check_count(value: Any, name: str, maximum: int | None = None) -> None:
    if value is not None and (isinstance(value, bool) or not isinstance(value, int) or value < 1
                              or (maximum is not None and value > maximum)):
        bound = "a positive integer" if maximum is None else f"an integer from 1 to {maximum}"
        raise InputError(f"{name} must be {bound} or None, got {value!r}")


def _plan_motion() -> Callable[..., Any]:
    from .plan import plan_motion

    return plan_motion


def _checked_planner(planner: Any, plan_kwargs: dict) -> Callable[..., Any]:
    """The planner (``plan_motion`` for None), after checking it is callable and takes every shared keyword
    (:class:`InputError` naming the unknown ones; a planner with ``**kwargs`` takes any)."""
    if planner is None:
        planner = _plan_motion()
    elif not callable(planner):
        raise InputError(f"planner must be a function planning one problem (default plan_motion), got "
                         f"{planner!r:.80}")
    try:
        params = inspect.signature(planner).parameters
    except (TypeError, ValueError):  # a builtin without a signature: nothing to check
        return planner
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()):
        return planner
    named = [k for k, p in params.items() if p.kind in (inspect.Parameter.POSITIONAL_OR_KEYWORD,
                                                       inspect.Parameter.KEYWORD_ONLY)]
    accepted = [k for k in named if k not in _PER_PROBLEM]
    unknown = sorted(k for k in plan_kwargs if k not in accepted)
    if unknown:
        name = getattr(planner, "__name__", "the planner")
        raise InputError(f"plan_many: unknown keyword(s) {', '.join(unknown)} for {name}; accepted: "
                         f"{', '.join(accepted)}")
    return planner


def check_shared_values(robot: Robot, problem: MotionProblem, plan_kwargs: dict) -> None:
    """Check the values of ``plan_motion``'s shared keywords in the caller, before any worker starts: the
    request ``plan_motion`` would build for ``problem``'s goal with them (from the robot's middle
    configuration: the start of each problem is checked on its own). Its :class:`InputError` names the
    keyword; the message says it is a shared one."""
    from .request import motion_request

    given = {k: p.default for k, p in inspect.signature(_plan_motion()).parameters.items()
             if p.default is not inspect.Parameter.empty}
    given.update(plan_kwargs)
    try:
        motion_request(robot, robot.middle(), problem.goal, (), given["self_collision"], given["max_time"],
                       None, given["acceleration_limits"], given["simplify"], given["max_iterations"],
                       given["frame"], given["relax"], given["goal_count"])
    except InputError as exc:
        raise type(exc)(f"plan_many (shared keywords of plan_motion): {exc}") from None


def worker_count(processes: int | None, n: int, local: bool = True) -> int:
    """Workers to start for ``n`` problems: ``processes`` (default: every available core), at most one per
    problem and, for workers on this machine (``local``), at most its cores."""
    wanted = _cpu_count() if processes is None else processes
    if local:
        wanted = min(wanted, _cpu_count())
    return max(1, min(wanted, n))


def _seed(seed: Any) -> int:
    if seed is None:
        return 0
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"seed must be a non-negative integer or None, got {seed!r}")
    return int(seed)


def _chunk_limit(kwargs: dict) -> Callable[[int], float]:
    max_time = kwargs.get("max_time", 1.0)
    budget = UNTIMED_BUDGET if max_time is None else check_max_time(max_time)
    return lambda n: CHUNK_FACTOR * n * budget + CHUNK_SLACK


def plan_many(robot: Robot, problems: Any, processes: int | None = None, backend: str = "local", *,
              seed: int | None = None, chunksize: int | None = None, timeout: float | None = None,
              ray_address: str | None = None, planner: Callable[..., Any] | None = None,
              **plan_kwargs: Any) -> list:
    """``plan_motion`` for every problem of ``problems``; returns the ``MotionPlan`` list in order.

    Parameters
    ----------
    problems:
        A sequence of ``(start, goal)`` or ``(start, goal, obstacles)``: ``start`` ``(nq,)``, ``goal`` as
        ``plan_motion`` takes it, ``obstacles`` a sequence of shapes (default: none).
    processes:
        Worker processes (default: every available core, at most one per problem); ``1`` plans in this
        process. At most :data:`MAX_PROCESSES`; no more workers than this machine's cores are started
        (except Ray actors on a cluster joined by ``ray_address``).
    backend:
        ``"local"`` (worker processes of this machine) or ``"ray"`` (Ray actors; ``ray_address`` joins a
        running cluster, else a local Ray with ``processes`` CPUs is started and left running).
    seed:
        Base seed: problem ``i`` is planned with seed ``seed + i`` (None: 0), so every plan is
        deterministic and independent of the number of processes.
    chunksize:
        Problems per chunk (default: :func:`motion_chunks`).
    timeout:
        Overall limit (s); when it expires, or a worker stalls, :class:`WorkerTimeoutError` is raised
        and every worker is terminated.
    planner:
        The function planning one problem, ``planner(robot, start, goal, obstacles=, seed=, **kw)``
        (default ``plan_motion``).
    plan_kwargs:
        The keywords of ``plan_motion`` shared by every problem (``max_time``, ``max_iterations``,
        ``self_collision``, ``simplify``, ``acceleration_limits``, ...).

    Refused before any work starts (:class:`InputError` naming the argument): ``robot`` not a
    :class:`~kinserve.kinematics.Robot`; a ``backend`` other than ``"local"`` or ``"ray"``;
    ``processes`` not an integer from 1 to :data:`MAX_PROCESSES`; ``chunksize`` not a positive integer;
    ``planner`` not callable; a shared keyword the planner does not take (and, for ``plan_motion``, a shared
    keyword's value it would refuse: :func:`check_shared_values`); a malformed problem.
    """
    robot = as_robot(robot)
    backend = as_choice(backend, "backend", BACKENDS)
    refuse_unused_address(ray_address, backend)
    _check_count(processes, "processes", MAX_PROCESSES)
    _check_count(chunksize, "chunksize")
    deadline = None if timeout is None else time.monotonic() + as_positive(timeout, "timeout")
    if "obstacles" in plan_kwargs:
        raise InputError("plan_many: obstacles belong to each problem, (start, goal, obstacles), not to "
                         "the shared keywords")
    planner = _checked_planner(planner, plan_kwargs)
    job = MotionJob(robot, checked_problems(robot, problems), plan_kwargs, _seed(seed), planner)
    n = len(job.problems)
    if n == 0:
        return []
    if planner is _plan_motion():
        check_shared_values(robot, job.problems[0], plan_kwargs)
    job.prepare()  # here, once, whatever the backend: a forked worker inherits the collision model
    processes = worker_count(processes, n, local=backend == "local" or ray_address is None)
    chunks = motion_chunks(n, processes, chunksize)
    plans: list = [None] * n

    def on_done(start: int, chunk_plans: list) -> None:
        plans[start:start + len(chunk_plans)] = chunk_plans

    if backend == "ray":
        run_ray(job, chunks, processes, on_done, _chunk_limit(plan_kwargs), deadline, ray_address)
    elif processes == 1:
        run_here(job, chunks, on_done, deadline)
    else:
        with ChunkPool(job, processes) as pool:
            pool.run(chunks, on_done, _chunk_limit(plan_kwargs), deadline)
    return plans


def run_here(job: MotionJob, chunks: Sequence[tuple[int, int]], on_done: Callable[[int, list], None],
             deadline: float | None) -> None:
    """Plan the chunks in this process, one after the other (the deadline is checked between chunks)."""
    for start, stop in chunks:
        if deadline is not None and time.monotonic() > deadline:
            raise WorkerTimeoutError(f"plan_many: the overall timeout expired before "
                                     f"problems[{start}:{stop}]")
        on_done(start, job.plan_chunk(start, stop))


class _RayPlanner:
    """Body of a Ray actor: holds the job (robot, problems, keywords) received once and prepared
    (:meth:`~.batch_workers.MotionJob.prepare`), plans chunks."""

    def __init__(self, job: MotionJob) -> None:
        from kinserve.ik.batch.worker import limit_blas_threads

        limit_blas_threads()
        self.job = job
        job.prepare()

    def ready(self) -> bool:
        """Answers once ``__init__`` has run (:func:`~kinserve.ik.batch.ray_actors.run_on_actors` times the
        start)."""
        return True

    def plan(self, start: int, stop: int) -> list:
        return self.job.plan_chunk(start, stop)


def run_ray(job: MotionJob, chunks: Sequence[tuple[int, int]], processes: int,
            on_done: Callable[[int, list], None], limit: Callable[[int], float], deadline: float | None,
            address: str | None = None) -> None:
    """Plan the chunks on ``processes`` Ray actors (each receives the job once and prepares it); the
    time limits of the local pool, the actors' start timed apart (:mod:`kinserve.ik.batch.ray_actors`),
    every actor killed at the end."""
    ray = ensure_ray(address, processes)
    run_on_new_actors(ray, _RayPlanner, (ray.put(job),), processes, chunks,
                      lambda actor, start, stop: actor.plan.remote(start, stop), on_done, limit, deadline,
                      BatchLabels("plan_many:", "problems"))
