"""``solve_many``: many IK targets at once, on every core.

Design
------
* Every argument and every target is validated **once, in the calling
  process** (errors name the offending target index), before any work starts.
* Targets are cut into chunks. A pool of worker processes (``fork`` start
  method on Linux) is created with an initializer that gives each worker its
  **own** copy of the robot - once per worker, never per target - and the
  solve options; the seed table of :mod:`ik.seeds` is built in the parent
  first, so the workers inherit it.
* A worker solves a whole chunk and sends back compact arrays (joint
  vectors, flags, errors, counters) plus the messages - far cheaper to pickle
  than one ``Result`` object per target. The parent rebuilds the ``Result``
  list in the original order. Histories are dropped unless
  ``keep_history=True`` (they are then pickled per target).
* A ``tqdm`` progress bar (on stderr) follows the completed chunks of long
  batches.
* Execution backends are looked up in :data:`BACKENDS` (``"processes"``,
  ``"serial"``); another backend (e.g. a Ray cluster) is one more function
  with the same signature.
"""

from __future__ import annotations

import math
import multiprocessing as mp
import os
from concurrent.futures import ProcessPoolExecutor, as_completed

import numpy as np

from kinematics.errors import InputError

from .result import Result
from .seeds import seed_table
from .solve import prepare, solve_prepared
from .targets import Target

#: Batches at least this long show a progress bar by default.
PROGRESS_THRESHOLD = 500

_FIELDS = ("q", "success", "position_error", "orientation_error", "iterations", "restarts", "elapsed")

# state of a worker process (set by _init_worker)
_worker = {}


def _cpu_count() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - non-Linux
        return os.cpu_count() or 1


def _solve_chunk(robot, common: dict, options: dict, keep_history: bool, start: int, poses, q0s):
    """Solve targets ``start .. start + len(poses)``; return compact arrays (see the module docstring)."""
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
        "history": [] if keep_history else None,
    }
    frame = common["frame"]
    relaxed = common["relax"]
    relax_frame = common["relax_frame"]
    for i in range(n):
        p = dict(common["prepared"])
        p["target"] = Target(robot, poses[i], frame, relaxed, relax_frame)
        p["q0"] = None if q0s is None else q0s[i]
        r = solve_prepared(robot, p, **options)
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
        if keep_history:
            out["history"].append(r.history)
    return out


def _init_worker(robot, common, options, keep_history):
    _worker["robot"] = robot.copy()
    _worker["args"] = (common, options, keep_history)


def _worker_chunk(start, poses, q0s):
    common, options, keep_history = _worker["args"]
    return _solve_chunk(_worker["robot"], common, options, keep_history, start, poses, q0s)


def _run_serial(robot, chunks, common, options, keep_history, processes, on_done):
    r = robot.copy()
    for start, poses, q0s in chunks:
        res = _solve_chunk(r, common, options, keep_history, start, poses, q0s)
        on_done(res)


def _run_processes(robot, chunks, common, options, keep_history, processes, on_done):
    ctx = mp.get_context("fork") if "fork" in mp.get_all_start_methods() else mp.get_context()
    with ProcessPoolExecutor(max_workers=processes, mp_context=ctx, initializer=_init_worker,
                             initargs=(robot, common, options, keep_history)) as pool:
        futures = [pool.submit(_worker_chunk, start, poses, q0s) for start, poses, q0s in chunks]
        for fut in as_completed(futures):
            on_done(fut.result())


#: Execution backends: ``name -> runner(robot, chunks, common, options, keep_history, processes, on_done)``.
BACKENDS = {"processes": _run_processes, "serial": _run_serial}


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
        Execution backend, ``"processes"`` (default) or ``"serial"`` (see
        :data:`BACKENDS`). Not to be confused with ``qp_backend``, the QP
        solver of method ``"qp"`` (``ik.solve``'s ``backend``).
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
    # validate the shared arguments once, and every target (fast path, ~4 us each)
    prepared = prepare(robot, poses[0], None, frame=frame, relax=relax, relax_frame=relax_frame, spheres=spheres,
                       centring=centring, method=method, backend=qp_backend, tol_pos=tol_pos, tol_rot=tol_rot,
                       max_time=max_time, seed=seed)
    frame = prepared["target"].frame
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
            one = robot.check_q(arr, "q0")
            q0s = np.repeat(one[None, :], n, axis=0)
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
    prepared.pop("target")
    prepared.pop("q0")
    common = {"prepared": prepared, "frame": frame, "relax": relax, "relax_frame": relax_frame}
    # reject bad options now rather than in a worker
    if options:
        solve_prepared(robot, {**prepared, "target": Target(robot, checked[0], frame, relax, relax_frame),
                               "q0": None if q0s is None else q0s[0]}, **options)

    if processes is None:
        processes = _cpu_count()
    if isinstance(processes, bool) or not isinstance(processes, int) or processes < 1:
        raise InputError(f"processes must be a positive integer or None, got {processes!r}")
    processes = min(processes, n)
    if chunksize is None:
        chunksize = max(1, math.ceil(n / (processes * 8)))
    if isinstance(chunksize, bool) or not isinstance(chunksize, int) or chunksize < 1:
        raise InputError(f"chunksize must be a positive integer or None, got {chunksize!r}")
    chunks = [(s, checked[s:s + chunksize], None if q0s is None else q0s[s:s + chunksize]) for s in range(0, n, chunksize)]
    runner = BACKENDS[backend]
    if processes == 1 and backend == "processes":
        runner = _run_serial
    seed_table(robot, frame)  # built once here; forked workers inherit it

    results: list = [None] * n
    bar = None
    if progress is None:
        progress = n >= PROGRESS_THRESHOLD
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=n, desc="ik.solve_many", unit="target", leave=False)

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
        runner(robot, chunks, common, options, keep_history, processes, on_done)
    finally:
        if bar is not None:
            bar.close()
    return results
