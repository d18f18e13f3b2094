"""The work of :func:`ik.solve_many`, wherever it runs: a job, its chunks, and a worker process's loaded jobs.

A :class:`Job` is everything needed to solve the targets of one
``solve_many`` call: the robot, the validated ``ik.solve`` keywords, the
method options, the (validated) target poses and start configurations.
:func:`solve_chunk` solves targets ``start .. start + len(poses)`` of a job
and returns compact arrays (joint vectors, flags, errors, counters) plus the
messages - far cheaper to pickle than one ``Result`` per target.

Targets whose ``ik.solve`` strategy is plain Levenberg-Marquardt (method ``"lm"``, or ``"auto"`` without a
usable closed form, obstacles, collision, centring or history; relaxed components allowed) on a chain the
compiled kernel models are solved a whole chunk at a time in one compiled call
(:func:`kinserve.ik.lm.many.solve_lm_many`): the answers ``ik.solve`` gives one by one, without its Python
work per target. Anything else goes target by target through ``ik.solve``'s own code path
(:func:`kinserve.ik.solve.run`).

Worker processes (:mod:`ik.batch.pool`) receive a job once, as a file
written by :func:`write_job` (in ``/dev/shm`` when available), and keep the
last :data:`WORKER_JOBS` jobs loaded (:class:`LoadedJobs`, owned by the
worker's loop): the robot is rebuilt once per worker and job, never per
chunk. :func:`limit_blas_threads` runs first in every worker (see
:mod:`ik.batch.pool` for why).
"""

from __future__ import annotations

import os
import pickle
import tempfile
import uuid
from collections import OrderedDict
from typing import TYPE_CHECKING

import numpy as np

from kinserve.ik.lm.chains import compiled_chain
from kinserve.ik.lm.many import ManySettings, solve_lm_many
from kinserve.ik.plan import LM, choose_strategy
from kinserve.ik.request import SolveRequest, target_request
from kinserve.ik.solve import run
from kinserve.ik.state import ik_state, seed_table
from kinserve.ik.targets import Target

if TYPE_CHECKING:  # annotations only
    from kinserve.ik.result import Result
    from kinserve.kinematics.robot import Robot

#: Jobs a worker keeps loaded (least recently used first out).
WORKER_JOBS = 2

#: Options of ``ik.solve`` the compiled batch understands (those of method ``"lm"``).
VECTOR_OPTIONS = frozenset({"max_iter", "damping", "max_starts", "prefer_q0", "seed_table",
                            "iteration_budget"})


class Job:
    """Everything a worker needs to solve the targets of one ``solve_many`` call.

    ``kwargs`` are the validated keywords of ``ik.solve`` (``frame``,
    ``relax``, ``spheres``, ``method``, ``max_time``, ...), ``options`` its
    method-specific options; ``poses`` ``(N, 4, 4)`` and ``q0s`` ``(N, nq)``
    or None are already validated.
    """

    def __init__(self, robot: Robot, kwargs: dict, options: dict, keep_history: bool, frame: str,
                 poses: np.ndarray | None = None, q0s: np.ndarray | None = None,
                 prepared: SolveRequest | None = None) -> None:
        self.id = (os.getpid(), uuid.uuid4().int)  #: unique across processes and calls
        self.robot = robot
        self.kwargs = kwargs
        self.options = options
        self.keep_history = keep_history
        self.frame = frame
        self.poses = poses
        self.q0s = q0s
        self.ray_address = None  #: Ray cluster to join (``backend="ray"``)
        #: The request of ``ik.solve`` shared by every target (:func:`kinserve.ik.request.target_request`;
        #: each target replaces its pose and start): the caller's, or built here (warming the IK state).
        self.request = prepared if prepared is not None else target_request(robot, np.eye(4), None, **kwargs,
                                                                             options=options)
        #: Whether the chunks go through the compiled batch (module docstring).
        self.vectorised = _vectorisable(self)

    def prepared(self) -> SolveRequest:
        """The request of ``ik.solve`` shared by every target (:attr:`request`)."""
        return self.request

    def chunk(self, start: int, stop: int) -> tuple[np.ndarray, np.ndarray | None]:
        """``(poses, q0s)`` of targets ``start .. stop``."""
        return self.poses[start:stop], None if self.q0s is None else self.q0s[start:stop]


def _vectorisable(job: Job) -> bool:
    """Whether ``ik.solve`` would answer the job's targets with plain LM on a chain the compiled kernel
    models, with options the compiled batch takes."""
    if job.keep_history or not VECTOR_OPTIONS.issuperset(job.options):
        return False
    req = job.request
    return choose_strategy(req) is LM and compiled_chain(job.robot, req.target.frame_id) is not None


def _empty_out(n: int, nq: int, start: int, keep_history: bool) -> dict:
    return {
        "start": start,
        "q": np.empty((n, nq)),
        "success": np.zeros(n, dtype=bool),
        "position_error": np.empty(n),
        "orientation_error": np.empty(n),
        "iterations": np.zeros(n, dtype=np.int64),
        "restarts": np.zeros(n, dtype=np.int64),
        "elapsed": np.empty(n),
        "message": [],
        "method": [],
        "info": [],
        "history": [] if keep_history else None,
    }


def solve_chunk(job: Job, start: int, poses: np.ndarray, q0s: np.ndarray | None) -> dict:
    """Solve targets ``start .. start + len(poses)`` of ``job``; return compact arrays (module docstring)."""
    robot = job.robot
    n = len(poses)
    base = job.request
    if job.vectorised:
        return _compiled_chunk(job, start, poses, q0s)
    out = _empty_out(n, robot.nq, start, job.keep_history)
    relax, relax_frame = job.kwargs["relax"], job.kwargs["relax_frame"]
    for i in range(n):
        r = run(base._replace(target=Target(robot, poses[i], job.frame, relax, relax_frame),
                              q0=None if q0s is None else q0s[i]))
        out["q"][i] = r.q
        out["success"][i] = r.success
        out["position_error"][i] = r.position_error
        out["orientation_error"][i] = r.orientation_error
        out["iterations"][i] = r.iterations
        out["restarts"][i] = r.restarts
        out["elapsed"][i] = r.elapsed
        out["message"].append(r.message)
        out["method"].append(r.method)
        out["info"].append(r.info)
        if job.keep_history:
            out["history"].append(r.history)
    return out


def _settings(req: SolveRequest, options: dict) -> ManySettings:
    """The compiled batch's settings for the request's tolerances, budget and seed and the LM ``options``."""
    lm = {k: v for k, v in options.items() if k != "seed_table"}
    return ManySettings(tol_pos=req.tol_pos, tol_rot=req.tol_rot, max_time=req.max_time, seed=req.seed,
                        seed_table_enabled=options.get("seed_table", True), **lm)


def _compiled_chunk(job: Job, start: int, poses: np.ndarray, q0s: np.ndarray | None) -> dict:
    """:func:`solve_chunk` in one compiled call (:func:`kinserve.ik.lm.many.solve_lm_many`); a target whose
    prepared starts run out is solved by ``ik.solve``'s own path."""
    robot, base = job.robot, job.request
    relax, relax_frame = job.kwargs["relax"], job.kwargs["relax_frame"]

    def one(i: int) -> Result:
        return run(base._replace(target=Target(robot, poses[i], job.frame, relax, relax_frame),
                                 q0=None if q0s is None else q0s[i]))

    a = solve_lm_many(robot, job.frame, np.asarray(poses), None if q0s is None else np.asarray(q0s),
                      relax=relax, relax_frame=relax_frame, settings=_settings(base, job.options),
                      fallback=one)
    n = len(poses)
    # the parent fills info {"batched": True}: nothing to pickle per target
    return {"start": start, "q": a.q, "success": a.success, "position_error": a.position_error,
            "orientation_error": a.orientation_error, "iterations": a.iterations, "restarts": a.restarts,
            "elapsed": a.elapsed, "message": a.message, "method": ["lm"] * n, "info": None, "history": None}


# ------------------------------------------------------------ job files (to worker processes)
def write_job(job: Job) -> str:
    """Write the job (robot, options, targets, the robot's seed table for the frame) to a temporary file.

    The seed table travels with the job so a worker never rebuilds it. The
    file lives in ``/dev/shm`` (memory) when it is writable.
    """
    table = seed_table(job.robot, job.frame)
    data = pickle.dumps((job.id, job.robot, job.kwargs, job.options, job.keep_history, job.frame, job.poses,
                         job.q0s, table), protocol=pickle.HIGHEST_PROTOCOL)
    shm = "/dev/shm" if os.path.isdir("/dev/shm") and os.access("/dev/shm", os.W_OK) else None
    fd, path = tempfile.mkstemp(prefix="kinserve-ik-job-", suffix=".pkl", dir=shm)
    with os.fdopen(fd, "wb") as fh:
        fh.write(data)
    return path


def read_job(path: str) -> Job:
    """The :class:`Job` of a file from :func:`write_job` (installs its seed table in this process)."""
    with open(path, "rb") as fh:
        job_id, robot, kwargs, options, keep_history, frame, poses, q0s, table = pickle.load(fh)
    ik_state(robot).install_seed_table(frame, table)
    job = Job(robot, kwargs, options, keep_history, frame, poses, q0s)
    job.id = job_id
    return job


class LoadedJobs:
    """The jobs one worker process has loaded (least recently used dropped first), owned by its loop."""

    def __init__(self, size: int = WORKER_JOBS) -> None:
        self.size = size
        self.jobs: OrderedDict[tuple, Job] = OrderedDict()

    def get(self, job_id: tuple, path: str) -> Job:
        """The job ``job_id``, read from ``path`` the first time."""
        job = self.jobs.get(job_id)
        if job is None:
            job = self.jobs[job_id] = read_job(path)
            while len(self.jobs) > self.size:
                self.jobs.popitem(last=False)
        else:
            self.jobs.move_to_end(job_id)
        return job


def worker_chunk(jobs: LoadedJobs, job_id: tuple, path: str, start: int, stop: int) -> dict:
    """Solve targets ``start .. stop`` of the job ``job_id`` stored at ``path`` (``jobs`` loads it once)."""
    job = jobs.get(job_id, path)
    poses, q0s = job.chunk(start, stop)
    return solve_chunk(job, start, poses, q0s)


# ------------------------------------------------------------ process set-up
def limit_blas_threads() -> None:
    """Make this process's BLAS/OpenMP libraries single-threaded (each worker owns one core).

    ``threadpoolctl`` sets the thread count of every BLAS/OpenMP library
    already loaded (NumPy's and SciPy's OpenBLAS); the environment variables
    cover libraries loaded later.
    """
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[var] = "1"
    import scipy.linalg  # noqa: F401  - load SciPy's BLAS now so that the limit reaches it too
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)
