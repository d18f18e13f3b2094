"""``solve_many``: many IK targets at once, on every core.

Design
------
* Every argument and every target is validated **once, in the calling
  process** (errors name the offending target index), before any work starts.
* Targets are cut into chunks and solved by a pool of worker processes. The
  pool is **persistent**: created on first use (``fork`` start method on
  Linux) and reused by later calls with the same number of processes, so a
  batch does not pay process start-up again.
* A call is a *job*: the robot (pickled kinematic model), the solve options
  and the seed table of :mod:`ik.seeds`, serialised once in the parent into
  a temporary file (in ``/dev/shm`` when available); chunks carry only the
  job id and the file name. A worker loads a job the first time it sees its
  id and keeps it (a few jobs, least recently used first out): the robot is
  rebuilt **once per worker and job, never per target**.
* Plain pose targets (method ``"lm"``, or ``"auto"`` on a robot without a
  finite closed form; no relaxation, spheres, centring or history) are
  solved a whole chunk at a time by the stacked Levenberg-Marquardt of
  :mod:`ik.batch_lm` (one NumPy iteration for all the chunk's targets; a
  few large chunks); anything else goes target by target through
  ``ik.solve``'s own code path. The stacked answers are valid solutions within
  the same tolerances, not necessarily the very configurations ``ik.solve``
  returns one by one.
* A worker solves a whole chunk and sends back compact arrays (joint
  vectors, flags, errors, counters) plus the messages - far cheaper to pickle
  than one ``Result`` per target. The parent rebuilds the ``Result`` list in
  the original order. Histories are dropped unless ``keep_history=True``.
* A ``tqdm`` progress bar (on stderr) follows the completed chunks of long
  batches.
* Execution backends live in :data:`BACKENDS` (``"processes"``, ``"serial"``,
  ``"ray"`` through :mod:`ik.ray_backend`); each is one function
  ``runner(job, chunks, processes, on_done)``.
"""

from __future__ import annotations

import atexit
import itertools
import math
import multiprocessing as mp
import os
import pickle
import tempfile
import threading
from collections import OrderedDict
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool

import numpy as np

from kinserve.kinematics.errors import InputError

from .analytic import closed_form_solver
from .batch_lm import BatchChain, solve_batch
from .result import Result
from .seeds import install_table, seed_table
from .solve import prepare, solve_prepared
from .targets import Target

#: Batches at least this long show a progress bar by default.
PROGRESS_THRESHOLD = 500

#: Jobs a worker keeps unpickled.
WORKER_JOBS = 4

#: Options of ``solve`` the stacked LM understands.
VECTOR_OPTIONS = frozenset({"max_iter", "damping"})
#: Largest chunk for the stacked LM (rows solved together).
VECTOR_CHUNK = 1000

_job_ids = itertools.count()


def _cpu_count() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - non-Linux
        return os.cpu_count() or 1


class _Job:
    """Everything a worker needs to solve targets of one ``solve_many`` call."""

    def __init__(self, robot, kwargs: dict, options: dict, keep_history: bool, frame: str):
        self.id = (os.getpid(), next(_job_ids))
        self.robot = robot
        self.kwargs = kwargs
        self.options = options
        self.keep_history = keep_history
        self.frame = frame
        self._prepared = None
        self._vectorised = None
        self.ray_address = None

    def payload_file(self) -> str:
        """Write the job (robot, options, the robot's seed table for the frame) to a temporary file."""
        table = seed_table(self.robot, self.frame)
        data = pickle.dumps((self.robot, self.kwargs, self.options, self.keep_history, self.frame, table),
                            protocol=pickle.HIGHEST_PROTOCOL)
        shm = "/dev/shm" if os.path.isdir("/dev/shm") and os.access("/dev/shm", os.W_OK) else None
        fd, path = tempfile.mkstemp(prefix="kinserve-ik-job-", suffix=".pkl", dir=shm)
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        return path

    def prepared(self):
        if self._prepared is None:
            self._prepared = prepare(self.robot, np.eye(4), None, **self.kwargs)
        return self._prepared

    def vectorised(self) -> bool:
        """Whether the targets can go through the stacked LM of :mod:`ik.batch_lm` (module docstring)."""
        if self._vectorised is None:
            self._vectorised = _vectorisable(self)
        return self._vectorised


def _solve_chunk(robot, common: dict, options: dict, keep_history: bool, start: int, poses, q0s):
    """Solve one chunk for a runner that holds ``(robot, common, options, keep_history)`` (e.g. a Ray actor).

    ``common`` is the dict :func:`solve_many` hands to every runner
    (``"kwargs"``: the validated ``ik.solve`` keywords, ``"frame"``, ...). The
    job is rebuilt once per ``common`` object and robot, not per chunk.
    """
    key = (id(robot), id(common))
    job = _compat_jobs.get(key)
    if job is None:
        job = _compat_jobs[key] = _Job(robot, common["kwargs"], options, keep_history, common["frame"])
        while len(_compat_jobs) > WORKER_JOBS:
            _compat_jobs.popitem(last=False)
    return _solve_job_chunk(job, start, poses, q0s)


_compat_jobs: OrderedDict = OrderedDict()


def _solve_job_chunk(job: _Job, start: int, poses, q0s):
    """Solve targets ``start .. start + len(poses)``; return compact arrays (see the module docstring)."""
    robot = job.robot
    n = len(poses)
    out = {
        "start": start,
        "q": np.empty((n, robot.nq)),
        "success": np.zeros(n, dtype=bool),
        "position_error": np.empty(n),
        "orientation_error": np.empty(n),
        "iterations": np.zeros(n, dtype=np.int64),
        "restarts": np.zeros(n, dtype=np.int64),
        "elapsed": np.empty(n),
        "message": [],
        "method": [],
        "info": [],
        "history": [] if job.keep_history else None,
    }
    base = job.prepared()
    relax, relax_frame = job.kwargs["relax"], job.kwargs["relax_frame"]
    if job.vectorised():
        b = solve_batch(robot, job.frame, np.asarray(poses), None if q0s is None else np.asarray(q0s),
                        tol_pos=base["tol_pos"], tol_rot=base["tol_rot"], seed=base["seed"],
                        max_time=base["max_time"], **job.options)
        for key in ("q", "success", "position_error", "orientation_error", "iterations", "restarts", "elapsed"):
            out[key][:] = b[key]
        out["message"] = b["message"]
        out["method"] = ["lm"] * n
        out["info"] = [{"batched": True} for _ in range(n)]
        return out
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


def _vectorisable(job) -> bool:
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


# ----------------------------------------------------------------- worker side
_worker_jobs: OrderedDict = OrderedDict()


def _worker_chunk(job_id, path: str, start, poses, q0s):
    job = _worker_jobs.get(job_id)
    if job is None:
        with open(path, "rb") as fh:
            robot, kwargs, options, keep_history, frame, table = pickle.load(fh)
        install_table(robot, frame, table)
        job = _Job(robot, kwargs, options, keep_history, frame)
        _worker_jobs[job_id] = job
        while len(_worker_jobs) > WORKER_JOBS:
            _worker_jobs.popitem(last=False)
    else:
        _worker_jobs.move_to_end(job_id)
    return _solve_job_chunk(job, start, poses, q0s)


# ----------------------------------------------------------------- parent side
_pool = None
_pool_size = 0
_pool_lock = threading.Lock()


def _get_pool(processes: int) -> ProcessPoolExecutor:
    global _pool, _pool_size
    with _pool_lock:
        if _pool is None or _pool_size != processes:
            if _pool is not None:
                _pool.shutdown(wait=False, cancel_futures=True)
            ctx = mp.get_context("fork") if "fork" in mp.get_all_start_methods() else mp.get_context()
            _pool = ProcessPoolExecutor(max_workers=processes, mp_context=ctx)
            _pool_size = processes
        return _pool


def shutdown_pool() -> None:
    """Stop the persistent worker processes (they are started again on demand)."""
    global _pool
    with _pool_lock:
        if _pool is not None:
            _pool.shutdown(wait=True, cancel_futures=True)
            _pool = None


atexit.register(shutdown_pool)


def _run_serial(job, chunks, processes, on_done):
    for start, poses, q0s in chunks:
        on_done(_solve_job_chunk(job, start, poses, q0s))


def _run_processes(job, chunks, processes, on_done):
    path = job.payload_file()
    try:
        for attempt in range(2):
            pool = _get_pool(processes)
            try:
                futures = [pool.submit(_worker_chunk, job.id, path, s, p, q) for s, p, q in chunks]
                for fut in as_completed(futures):
                    on_done(fut.result())
                return
            except BrokenProcessPool:
                shutdown_pool()  # a worker died (e.g. killed): start a fresh pool once
                if attempt:
                    raise
    finally:
        os.unlink(path)


def _run_ray(job, chunks, processes, on_done):
    """Ray actors (:mod:`ik.ray_backend`, ``ray_address=`` to join a cluster)."""
    from .ray_backend import run_ray

    common = {"prepared": job.prepared(), "frame": job.frame, "relax": job.kwargs["relax"],
              "relax_frame": job.kwargs["relax_frame"], "kwargs": job.kwargs}
    run_ray(job.robot, chunks, common, job.options, job.keep_history, processes, on_done, address=job.ray_address)


#: Execution backends: ``name -> runner(job, chunks, processes, on_done)``.
BACKENDS = {"processes": _run_processes, "serial": _run_serial, "ray": _run_ray}


def _as_poses(targets) -> list:
    if isinstance(targets, np.ndarray):
        if targets.ndim == 2 and targets.shape == (4, 4):
            raise InputError("targets must be a sequence of poses (N, 4, 4); got a single 4x4 pose - use ik.solve")
        if targets.ndim != 3:
            raise InputError(f"targets must have shape (N, 4, 4), got shape {targets.shape}")
        return list(targets)
    try:
        return list(targets)
    except TypeError:
        raise InputError(f"targets must be a sequence of 4x4 poses, got {type(targets).__name__}") from None


def solve_many(
    robot,
    targets,
    q0=None,
    *,
    processes: int | None = None,
    chunksize: int | None = None,
    progress: bool | None = None,
    backend: str = "processes",
    ray_address: str | None = None,
    keep_history: bool = False,
    qp_backend: str = "osqp",
    frame: str | None = None,
    relax=(),
    relax_frame: str = "world",
    spheres=(),
    centring=0.0,
    method: str = "auto",
    tol_pos: float = 1e-4,
    tol_rot: float = 1e-3,
    max_time: float | None = None,
    seed: int | None = None,
    **options,
) -> list[Result]:
    """Solve ``ik.solve`` for every pose of ``targets``; returns the results in order.

    Parameters
    ----------
    targets:
        ``(N, 4, 4)`` array or sequence of poses (``pinocchio.SE3`` accepted).
    q0:
        None, one configuration for every target, or ``(N, nq)`` configurations.
    processes:
        Worker processes (default: every available core). ``1`` solves in
        this process.
    chunksize:
        Targets per task (default: about 8 tasks per worker).
    progress:
        Show a tqdm bar (default: for batches of at least 500 targets).
    backend:
        Execution backend, ``"processes"`` (default; a persistent pool, see
        the module docstring), ``"serial"`` or ``"ray"`` (:mod:`ik.ray_backend`;
        ``ray_address`` joins a running cluster). Not to be confused with
        ``qp_backend``, the QP solver of method ``"qp"`` (``ik.solve``'s ``backend``).
    keep_history:
        Return each ``Result.history`` (costs pickling time); by default ``history`` is None.
    The remaining keywords are those of :func:`ik.solve`, shared by every target.
    """
    if backend not in BACKENDS:
        raise InputError(f"backend must be one of {sorted(BACKENDS)}, got {backend!r}")
    poses = _as_poses(targets)
    n = len(poses)
    if n == 0:
        return []
    kwargs = dict(frame=frame, relax=relax, relax_frame=relax_frame, spheres=spheres, centring=centring,
                  method=method, backend=qp_backend, tol_pos=tol_pos, tol_rot=tol_rot, max_time=max_time, seed=seed)
    # validate the shared arguments once, and every target (fast path, ~4 us each)
    prepared = prepare(robot, poses[0], None, **kwargs)
    frame = kwargs["frame"] = prepared["target"].frame
    checked = np.empty((n, 4, 4))
    for i, pose in enumerate(poses):
        try:
            checked[i] = Target(robot, pose, frame, relax, relax_frame).T
        except InputError as exc:
            raise type(exc)(f"targets[{i}]: {exc}") from None
    q0s = None
    if q0 is not None:
        arr = np.asarray(q0, dtype=float) if not isinstance(q0, np.ndarray) else q0
        if arr.ndim == 1:
            q0s = np.repeat(robot.check_q(arr, "q0")[None, :], n, axis=0)
        else:
            if arr.shape != (n, robot.nq):
                raise InputError(f"q0 must have shape ({robot.nq},) or ({n}, {robot.nq}), got shape {arr.shape}")
            q0s = np.array([robot.check_q(arr[i], f"q0[{i}]") for i in range(n)])
        if prepared["spheres"] is not None:
            for i in range(n):
                c = prepared["spheres"].clearances_at(q0s[i])
                if c.size and c.min() < 0:
                    raise InputError(f"q0[{i}]: a sphere already contains the start configuration: "
                                     f"{prepared['spheres'].describe_violation(c)}")
    if options:  # reject bad options now rather than in a worker
        solve_prepared(robot, {**prepared, "target": Target(robot, checked[0], frame, relax, relax_frame),
                               "q0": None if q0s is None else q0s[0]}, **options)
    if processes is None:
        processes = _cpu_count()
    if isinstance(processes, bool) or not isinstance(processes, int) or processes < 1:
        raise InputError(f"processes must be a positive integer or None, got {processes!r}")
    processes = min(processes, n)
    job = _Job(robot, kwargs, options, keep_history, frame)
    if chunksize is None:
        if job.vectorised():  # stacked LM: few large chunks (2 per process)
            chunksize = min(VECTOR_CHUNK, max(64, math.ceil(n / (2 * processes))))
        else:
            chunksize = max(1, math.ceil(n / (processes * 8)))
    if isinstance(chunksize, bool) or not isinstance(chunksize, int) or chunksize < 1:
        raise InputError(f"chunksize must be a positive integer or None, got {chunksize!r}")
    chunks = [(s, checked[s:s + chunksize], None if q0s is None else q0s[s:s + chunksize]) for s in range(0, n, chunksize)]
    runner = BACKENDS[backend]
    if processes == 1 and backend == "processes":
        runner = _run_serial
    if runner is _run_serial:
        job.robot = robot.copy()
    job.ray_address = ray_address

    results: list = [None] * n
    bar = None
    if progress is None:
        progress = n >= PROGRESS_THRESHOLD
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=n, desc="kinserve.ik.solve_many", unit="target", leave=False)

    def on_done(res):
        s = res["start"]
        for i in range(len(res["message"])):
            results[s + i] = Result(
                q=res["q"][i], success=bool(res["success"][i]), position_error=float(res["position_error"][i]),
                orientation_error=float(res["orientation_error"][i]), iterations=int(res["iterations"][i]),
                restarts=int(res["restarts"][i]), elapsed=float(res["elapsed"][i]), message=res["message"][i],
                history=res["history"][i] if res["history"] is not None else None, method=res["method"][i],
                frame=frame, info=res["info"][i],
            )
        if bar is not None:
            bar.update(len(res["message"]))

    try:
        runner(job, chunks, processes, on_done)
    finally:
        if bar is not None:
            bar.close()
    return results
