"""``solve_many``: many IK targets at once, on every core.

Design
------
* Every argument and every target is validated **once, in the calling
  process**, before any work starts (errors name the offending target
  index): the targets and start configurations vectorised
  (:func:`checked_poses`), the method options directly
  (:func:`ik.options.check_options`, no trial solve).
* Targets are cut into chunks (:func:`chunk_bounds`) and solved by an
  execution backend of :mod:`ik.batch.runners`: a persistent pool of worker
  processes (:mod:`ik.batch.pool`; default), this process (``"serial"``), or
  Ray actors (:mod:`ik.batch.ray_backend`). The work of a chunk, wherever it runs,
  is :mod:`ik.batch.worker`: targets ``ik.solve`` would answer with plain
  Levenberg-Marquardt go through one compiled call per chunk
  (:mod:`ik.lm.many`), with the answers ``ik.solve`` gives them one by one;
  anything else goes target by target through ``ik.solve``'s own code path.
* A worker sends back compact arrays per chunk; this process rebuilds the
  ``Result`` list in the original order. Histories are dropped unless
  ``keep_history=True``.
* Every chunk has a time limit derived from the per-target budget, and
  ``timeout=`` bounds the whole call: a stalled worker (e.g. stopped by
  ``SIGSTOP``) raises :class:`kinserve.kinematics.errors.WorkerTimeoutError`
  naming the worker and its chunk, and the pool is terminated; a killed
  worker is replaced and its chunk retried once (:mod:`ik.batch.pool`).
* A ``tqdm`` progress bar (on stderr) follows the completed chunks of long
  batches.
"""

from __future__ import annotations

import math
import os
import sys
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from kinserve.ik.batch.pool import shutdown_pool
from kinserve.ik.batch.ray_backend import refuse_unused_address
from kinserve.ik.batch.runners import BACKENDS, TimeLimits, run_serial
from kinserve.ik.batch.worker import Job
from kinserve.ik.request import target_request
from kinserve.ik.result import Result
from kinserve.ik.targets import Target
from kinserve.kinematics.errors import InputError, ShapeError
from kinserve.kinematics.validation import (
    MAX_ABS,
    ROTATION_TOL,
    as_choice,
    as_flag,
    as_numbers,
    as_positive,
    describe,
)

if TYPE_CHECKING:  # annotations only
    from kinserve.kinematics.robot import Robot
    from kinserve.kinematics.types import MatrixLike, VectorLike

__all__ = ["solve_many", "shutdown_pool", "checked_poses", "chunk_bounds", "BACKENDS"]

#: Batches at least this long show a progress bar by default.
PROGRESS_THRESHOLD = 500
#: Largest chunk of the compiled batch (targets solved in one call).
VECTOR_CHUNK = 1000
#: Largest ``processes`` accepted; no more workers than this machine's cores are started on it anyway.
MAX_PROCESSES = 1024
#: Largest ``chunksize`` accepted (a chunk is never longer than the batch).
MAX_CHUNKSIZE = 10**7


def _cpu_count() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - non-Linux
        return os.cpu_count() or 1


def _as_array(targets) -> np.ndarray | None:
    """``(N, 4, 4)`` float64 view/copy of an array or a list of poses, or None when it is not a clean
    numeric stack."""
    if isinstance(targets, np.ndarray):
        if targets.ndim == 2 and targets.shape == (4, 4):
            raise InputError("targets must be a sequence of poses (N, 4, 4); got a single 4x4 pose "
                             "(solve one pose with ik.solve)")
        if targets.ndim != 3:
            raise InputError(f"targets must have shape (N, 4, 4), got shape {targets.shape}")
        if targets.shape[1:] == (4, 4) and targets.dtype.kind in "fiu":
            return np.asarray(targets, dtype=np.float64)
        return None
    try:
        arr = np.asarray(targets, dtype=np.float64)
    except (TypeError, ValueError):
        return None
    return arr if arr.ndim == 3 and arr.shape[1:] == (4, 4) else None


def _well_formed(T: np.ndarray) -> np.ndarray:
    """Mask of the poses that pass every check of ``ik.targets.Target`` (vectorised, slightly stricter).

    Bottom row exactly ``[0 0 0 1]``, finite, ``|p_i| <= MAX_ABS``,
    ``|R^T R - I| <= tol`` entrywise and ``|det R - 1| <= tol``; the
    tolerance is 0.999 of ``ROTATION_TOL``, so a pose this test rejects on
    rounding alone is decided by ``Target`` itself.
    """
    tol = 0.999 * ROTATION_TOL
    R = T[:, :3, :3]
    ok = (T[:, 3, :] == (0.0, 0.0, 0.0, 1.0)).all(axis=1)
    ok &= np.isfinite(R).all(axis=(1, 2)) & (np.abs(T[:, :3, 3]) <= MAX_ABS).all(axis=1)
    with np.errstate(invalid="ignore", over="ignore"):
        G = np.einsum("nki,nkj->nij", R, R) - np.eye(3)
        ok &= (np.abs(G) <= tol).all(axis=(1, 2))
        ok &= np.abs(np.linalg.det(np.where(np.isfinite(R), R, 0.0)) - 1.0) <= tol
    return ok


def checked_poses(robot: Robot, targets: Any, frame: str, relax: str | Iterable[str] | None = (),
                  relax_frame: str = "world") -> np.ndarray:
    """Validated ``(N, 4, 4)`` float64 copy of ``targets`` (array, sequence of 4x4 or ``pinocchio.SE3``).

    Checked all at once (:func:`_well_formed`); a pose that fails is checked
    again by :class:`ik.targets.Target`, whose error is raised with the
    target's index (``targets[i]: ...``).
    """
    if not isinstance(targets, np.ndarray):
        if isinstance(targets, (str, bytes, dict)) or not hasattr(targets, "__iter__"):
            raise InputError(f"targets must be a sequence of 4x4 poses, got {type(targets).__name__}")
        # (this also consumes an iterator once)
        targets = [t.homogeneous if isinstance(t, pin.SE3) else t for t in targets]
    arr = _as_array(targets)
    if arr is None:  # ragged / non-numeric: one by one, for the message
        out = np.empty((len(targets), 4, 4))
        for i, pose in enumerate(targets):
            out[i] = _one_pose(robot, i, pose, frame, relax, relax_frame)
        return out
    out = np.array(arr, dtype=np.float64)
    if len(out):
        for i in np.flatnonzero(~_well_formed(out)):
            out[i] = _one_pose(robot, i, arr[i], frame, relax, relax_frame)
    return out


def _one_pose(robot, i, pose, frame, relax, relax_frame) -> np.ndarray:
    try:
        return Target(robot, pose, frame, relax, relax_frame).T
    except InputError as exc:
        raise type(exc)(f"targets[{i}]: {exc}") from None


def _checked_q0s(robot, q0, n: int) -> np.ndarray | None:
    """``(n, nq)`` start configurations from None, one configuration, or ``(n, nq)`` (each validated).

    :class:`ShapeError` for anything that is not numbers (text, bools, None inside, ragged lists) or of
    another shape; :class:`NonFiniteError` naming the row and joint (a float array) or the entries."""
    if q0 is None:
        return None
    forms = f"None, one configuration ({robot.nq} numbers) or one per target (shape ({n}, {robot.nq}))"
    arr = q0
    if not (type(q0) is np.ndarray and q0.dtype == np.float64):  # (a float array: rows named below)
        try:
            arr = as_numbers(q0, "q0")
        except ShapeError:
            raise ShapeError(f"q0 must be {forms}, got {describe(q0)}") from None
    if arr.ndim == 1:
        return np.repeat(robot.check_q(arr, "q0")[None, :], n, axis=0)
    if arr.shape != (n, robot.nq):
        raise ShapeError(f"q0 must be {forms}, got shape {arr.shape}")
    arr = np.array(arr, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        bad = ~(np.isfinite(arr).all(axis=1) & (np.abs(arr) <= MAX_ABS).all(axis=1))
    for i in np.flatnonzero(bad):
        robot.check_q(arr[i], f"q0[{i}]")  # raises, naming the row and the joint
    return arr


def _check_count(value: Any, name: str, maximum: int) -> int | None:
    """None, or ``value`` as an int in ``[1, maximum]``; else :class:`InputError` naming ``name``."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 1 <= value <= maximum:
        raise InputError(f"{name} must be an integer from 1 to {maximum} or None, got {value!r}")
    return int(value)


def worker_count(processes: int | None, n: int, local: bool = True) -> int:
    """Workers to start for ``n`` targets: ``processes`` (default: every available core), at most one per
    target and, for workers on this machine (``local``), at most its cores (:func:`_cpu_count`)."""
    wanted = _cpu_count() if processes is None else processes
    if local:
        wanted = min(wanted, _cpu_count())
    return max(1, min(wanted, n))


def _check_timeout(timeout) -> float | None:
    """None (no overall limit) or a positive finite number of seconds."""
    return None if timeout is None else as_positive(timeout, "timeout")


def chunk_bounds(n: int, processes: int, chunksize: int | None, vectorised: bool) -> list[tuple[int, int]]:
    """``(start, stop)`` of each chunk: by default 2 chunks per process of at most
    :data:`VECTOR_CHUNK` targets for the compiled batch, about 8 per process otherwise."""
    if chunksize is None:
        if vectorised:
            chunksize = min(VECTOR_CHUNK, max(64, math.ceil(n / (2 * processes))))
        else:
            chunksize = max(1, math.ceil(n / (processes * 8)))
    return [(s, min(n, s + chunksize)) for s in range(0, n, chunksize)]


def solve_many(
    robot: Robot,
    targets: Any,
    q0: VectorLike | MatrixLike | None = None,
    *,
    processes: int | None = None,
    chunksize: int | None = None,
    progress: bool | None = None,
    backend: str = "processes",
    ray_address: str | None = None,
    keep_history: bool = False,
    timeout: float | None = None,
    qp_backend: str = "osqp",
    frame: str | None = None,
    relax: str | Iterable[str] | None = (),
    relax_frame: str = "world",
    spheres: Any = (),
    obstacles: Any = (),
    link_radius: float = 0.0,
    self_collision: bool = False,
    collision_margin: float = 0.0,
    centring: float | VectorLike = 0.0,
    method: str = "auto",
    tol_pos: float = 1e-4,
    tol_rot: float = 1e-3,
    max_time: float | None = None,
    seed: int | None = None,
    **options: Any,
) -> list[Result]:
    """Solve ``ik.solve`` for every pose of ``targets``; returns the results in order.

    Parameters
    ----------
    targets:
        ``(N, 4, 4)`` array or sequence of poses (``pinocchio.SE3`` accepted).
    q0:
        None, one configuration for every target, or ``(N, nq)`` configurations: finite numbers with
        ``|x| <= 1e6`` (:class:`ShapeError` for text, bools or another shape, :class:`NonFiniteError`).
    processes:
        Worker processes (default: every available core), an integer from 1 to
        :data:`MAX_PROCESSES` (1024); larger values, 0, negatives and non-integers are refused
        (:class:`InputError`). No more workers than targets are started, nor, on this machine (the
        ``"processes"`` backend, or ``"ray"`` without ``ray_address``), more than its cores
        (``os.sched_getaffinity`` / ``os.cpu_count()``). ``1`` solves in this process.
    chunksize:
        Targets per chunk (default: see :func:`chunk_bounds`), an integer from 1 to
        :data:`MAX_CHUNKSIZE` or None.
    progress:
        Show a tqdm bar (default: for batches of at least 500 targets when stderr is a terminal).
    backend:
        Execution backend, ``"processes"`` (default; a persistent pool, see
        :mod:`ik.batch.pool`), ``"serial"`` or ``"ray"`` (:mod:`ik.batch.ray_backend`;
        ``ray_address`` joins a running cluster). Not to be confused with
        ``qp_backend``, the QP solver of method ``"qp"`` (``ik.solve``'s ``backend``).
    keep_history:
        Return each ``Result.history`` (costs pickling time); by default ``history`` is None.
    timeout:
        Overall limit in seconds (None: none beyond the per-chunk limits of
        :mod:`ik.batch.runners`). When it expires, or a worker stalls,
        :class:`~kinserve.kinematics.errors.WorkerTimeoutError` is raised and
        the workers are terminated.
    The remaining keywords are those of :func:`ik.solve`, shared by every target, validated as ``ik.solve``
    validates them (e.g. ``tol_pos``, ``tol_rot`` and ``max_time`` finite and at most 1e6) once, before any
    worker starts.
    """
    backend = as_choice(backend, "backend (the execution backend; qp_backend names the QP solver)",
                        tuple(BACKENDS))
    refuse_unused_address(ray_address, backend)
    processes = _check_count(processes, "processes", MAX_PROCESSES)
    chunksize = _check_count(chunksize, "chunksize", MAX_CHUNKSIZE)
    timeout = _check_timeout(timeout)
    keep_history = as_flag(keep_history, "keep_history")
    progress = None if progress is None else as_flag(progress, "progress (or None)")
    kwargs = dict(frame=frame, relax=relax, relax_frame=relax_frame, spheres=spheres, obstacles=obstacles,
                  link_radius=link_radius, centring=centring, method=method, backend=qp_backend,
                  tol_pos=tol_pos, tol_rot=tol_rot, max_time=max_time, seed=seed,
                  self_collision=self_collision, collision_margin=collision_margin)
    job = _job(robot, targets, q0, kwargs, options, keep_history)
    if job is None:
        return []
    n = len(job.poses)
    processes = worker_count(processes, n, local=backend != "ray" or ray_address is None)
    job.ray_address = ray_address
    chunks = chunk_bounds(n, processes, chunksize, job.vectorised)
    runner = run_serial if processes == 1 and backend == "processes" else BACKENDS[backend]
    results: list = [None] * n
    bar = _progress_bar(n, progress)
    try:
        runner(job, chunks, processes, _collector(results, job.frame, bar), TimeLimits.for_job(job, timeout))
    finally:
        if bar is not None:
            bar.close()
    return results


def _job(robot: Robot, targets: Any, q0: Any, kwargs: dict, options: dict, keep_history: bool) -> Job | None:
    """The validated :class:`Job` of a call (one request shared by every target), or None without targets.

    A start inside an obstacle is not an error (as in ``ik.solve``): the solver moves out or starts elsewhere.
    """
    prepared = target_request(robot, np.eye(4), None, **kwargs, options=options)
    frame = kwargs["frame"] = prepared.target.frame
    poses = checked_poses(robot, targets, frame, kwargs["relax"], kwargs["relax_frame"])
    if len(poses) == 0:
        return None
    q0s = _checked_q0s(robot, q0, len(poses))
    return Job(robot, kwargs, options, keep_history, frame, poses, q0s, prepared=prepared)


def _progress_bar(n: int, progress: bool | None) -> Any:
    """A tqdm bar on stderr: with ``progress=True``, or by default for large calls on a terminal."""
    if progress is None:
        progress = n >= PROGRESS_THRESHOLD and sys.stderr.isatty()
    if not progress:
        return None
    from tqdm import tqdm

    return tqdm(total=n, desc="kinserve.ik.solve_many", unit="target", leave=False)


def _collector(results: list, frame: str, bar: Any) -> Callable[[dict], None]:
    """``on_done(chunk)``: the chunk's compact arrays as :class:`Result` objects in ``results``."""

    def on_done(res: dict) -> None:
        s = res["start"]
        m = len(res["message"])
        info = res["info"] if res["info"] is not None else [{"batched": True} for _ in range(m)]
        hist = res["history"] if res["history"] is not None else [None] * m
        results[s:s + m] = [  # positional: the fields of Result in order (half the cost of keywords)
            Result(q, ok, pe, re, it, rs, el, msg, h, meth, frame, inf)
            for q, ok, pe, re, it, rs, el, msg, h, meth, inf in zip(
                list(res["q"]), res["success"].tolist(), res["position_error"].tolist(),
                res["orientation_error"].tolist(), res["iterations"].tolist(), res["restarts"].tolist(),
                res["elapsed"].tolist(), res["message"], hist, res["method"], info)
        ]
        if bar is not None:
            bar.update(m)

    return on_done
