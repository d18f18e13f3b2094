"""The work of :func:`ik.solve_many`, wherever it runs: a job, its chunks, and a worker process's job cache.

A :class:`Job` is everything needed to solve the targets of one
``solve_many`` call: the robot, the validated ``ik.solve`` keywords, the
method options, the (validated) target poses and start configurations.
:func:`solve_chunk` solves targets ``start .. start + len(poses)`` of a job
and returns compact arrays (joint vectors, flags, errors, counters) plus the
messages - far cheaper to pickle than one ``Result`` per target.

Plain pose targets (method ``"lm"``, or ``"auto"`` on a robot without a
finite closed form; no relaxation, spheres, centring or history) are solved
a whole chunk at a time by the stacked Levenberg-Marquardt of
:mod:`ik.batch.batch_lm`; anything else goes target by target through
``ik.solve``'s own code path (:func:`ik.solve.solve_prepared`).

Worker processes (:mod:`ik.batch.pool`) receive a job once, as a file
written by :func:`write_job` (in ``/dev/shm`` when available), and keep the
last :data:`WORKER_JOBS` jobs loaded: the robot is rebuilt once per worker
and job, never per chunk. :func:`limit_blas_threads` runs first in every
worker (see :mod:`ik.batch.pool` for why).
"""

from __future__ import annotations

import itertools
import os
import pickle
import tempfile
from collections import OrderedDict
from typing import TYPE_CHECKING

import numpy as np

from kinserve.ik.closed_form import closed_form_solver
from kinserve.ik.batch.batch_lm import BatchChain, solve_batch
from kinserve.ik.starts.seed_table import install_table, seed_table
from kinserve.ik.solve import prepare, solve_prepared
from kinserve.ik.targets import Target

if TYPE_CHECKING:  # annotations only
    from kinserve.kinematics.robot import Robot

#: Jobs a worker keeps loaded (least recently used first out).
WORKER_JOBS = 2

#: Options of ``ik.solve`` the stacked LM understands.
VECTOR_OPTIONS = frozenset({"max_iter", "damping"})

_job_ids = itertools.count()


class Job:
    """Everything a worker needs to solve the targets of one ``solve_many`` call.

    ``kwargs`` are the validated keywords of ``ik.solve`` (``frame``,
    ``relax``, ``spheres``, ``method``, ``max_time``, ...), ``options`` its
    method-specific options; ``poses`` ``(N, 4, 4)`` and ``q0s`` ``(N, nq)``
    or None are already validated.
    """

    def __init__(self, robot: Robot, kwargs: dict, options: dict, keep_history: bool, frame: str,
                 poses: np.ndarray | None = None, q0s: np.ndarray | None = None,
                 prepared: dict | None = None) -> None:
        self.id = (os.getpid(), next(_job_ids))
        self.robot = robot
        self.kwargs = kwargs
        self.options = options
        self.keep_history = keep_history
        self.frame = frame
        self.poses = poses
        self.q0s = q0s
        self.ray_address = None  #: Ray cluster to join (``backend="ray"``)
        self._prepared = prepared  # from the caller's own prepare(**kwargs), if it has one
        self._vectorised = None

    def prepared(self) -> dict:
        """The checked arguments of ``ik.solve`` shared by every target (:func:`ik.solve.prepare`)."""
        if self._prepared is None:
            self._prepared = prepare(self.robot, np.eye(4), None, **self.kwargs)
        return self._prepared

    def vectorised(self) -> bool:
        """Whether the targets go through the stacked LM of :mod:`ik.batch.batch_lm` (module docstring)."""
        if self._vectorised is None:
            self._vectorised = _vectorisable(self)
        return self._vectorised

    def chunk(self, start: int, stop: int) -> tuple[np.ndarray, np.ndarray | None]:
        """``(poses, q0s)`` of targets ``start .. stop``."""
        return self.poses[start:stop], None if self.q0s is None else self.q0s[start:stop]


def _vectorisable(job: Job) -> bool:
    p = job.prepared()
    if job.keep_history or p["spheres"] is not None or p["weights"] is not None or job.kwargs["relax"]:
        return False
    if set(job.options) - VECTOR_OPTIONS:
        return False
    if p["method"] == "auto":
        solver = closed_form_solver(job.robot, job.frame)
        if solver is not None and solver.finite:
            return False  # "auto" answers with the closed form
    elif p["method"] != "lm":
        return False
    try:
        BatchChain(job.robot, job.frame)
    except ValueError:
        return False
    return True


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
    base = job.prepared()
    if job.vectorised():
        b = solve_batch(robot, job.frame, np.asarray(poses), None if q0s is None else np.asarray(q0s),
                        tol_pos=base["tol_pos"], tol_rot=base["tol_rot"], seed=base["seed"],
                        max_time=base["max_time"], **job.options)
        b["start"] = start
        b["method"] = ["lm"] * n
        b["info"] = None  # the parent fills {"batched": True}: nothing to pickle per target
        b["history"] = None
        return b
    out = _empty_out(n, robot.nq, start, job.keep_history)
    relax, relax_frame = job.kwargs["relax"], job.kwargs["relax_frame"]
    for i in range(n):
        p = dict(base)
        p["target"] = Target(robot, poses[i], job.frame, relax, relax_frame)
        p["q0"] = None if q0s is None else q0s[i]
        r = solve_prepared(robot, p, **job.options)
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


# ------------------------------------------------------------ job files (to worker processes)
def write_job(job: Job) -> str:
    """Write the job (robot, options, targets, the robot's seed table for the frame) to a temporary file.

    The seed table travels with the job so a worker never rebuilds it. The
    file lives in ``/dev/shm`` (memory) when it is writable.
    """
    table = seed_table(job.robot, job.frame)
    data = pickle.dumps((job.id, job.robot, job.kwargs, job.options, job.keep_history, job.frame, job.poses, job.q0s,
                         table), protocol=pickle.HIGHEST_PROTOCOL)
    shm = "/dev/shm" if os.path.isdir("/dev/shm") and os.access("/dev/shm", os.W_OK) else None
    fd, path = tempfile.mkstemp(prefix="kinserve-ik-job-", suffix=".pkl", dir=shm)
    with os.fdopen(fd, "wb") as fh:
        fh.write(data)
    return path


def read_job(path: str) -> Job:
    """The :class:`Job` of a file from :func:`write_job` (installs its seed table in this process)."""
    with open(path, "rb") as fh:
        job_id, robot, kwargs, options, keep_history, frame, poses, q0s, table = pickle.load(fh)
    install_table(robot, frame, table)
    job = Job(robot, kwargs, options, keep_history, frame, poses, q0s)
    job.id = job_id
    return job


_worker_jobs: OrderedDict = OrderedDict()


def worker_chunk(job_id: tuple[int, int], path: str, start: int, stop: int) -> dict:
    """Solve targets ``start .. stop`` of the job ``job_id`` stored at ``path`` (loaded once per process)."""
    job = _worker_jobs.get(job_id)
    if job is None:
        job = _worker_jobs[job_id] = read_job(path)
        while len(_worker_jobs) > WORKER_JOBS:
            _worker_jobs.popitem(last=False)
    else:
        _worker_jobs.move_to_end(job_id)
    poses, q0s = job.chunk(start, stop)
    return solve_chunk(job, start, poses, q0s)


# ------------------------------------------------------------ actors holding a robot (Ray)
_actor_jobs: OrderedDict = OrderedDict()


def actor_chunk(robot: Robot, common: dict, options: dict, keep_history: bool, start: int, poses: np.ndarray,
                q0s: np.ndarray | None) -> dict:
    """Solve one chunk for a runner that holds ``(robot, common, options, keep_history)`` (a Ray actor).

    ``common`` carries ``"kwargs"`` (the validated ``ik.solve`` keywords) and
    ``"frame"``; the job is rebuilt once per ``common`` object and robot, not per chunk.
    """
    key = (id(robot), id(common))
    job = _actor_jobs.get(key)
    if job is None:
        job = _actor_jobs[key] = Job(robot, common["kwargs"], options, keep_history, common["frame"])
        while len(_actor_jobs) > WORKER_JOBS:
            _actor_jobs.popitem(last=False)
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
