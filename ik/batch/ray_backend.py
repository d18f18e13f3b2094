"""Ray execution backend of :func:`ik.solve_many` (``backend="ray"``).

The batch is cut into the same chunks as the local backends. One Ray actor
per worker receives the robot **once** (Ray pickles a ``Robot`` as its
kinematic model, without meshes) together with the solve options, builds
its :class:`ik.batch.worker.Job` once, then solves whole chunks
(:func:`ik.batch.worker.solve_chunk`) and returns the same compact arrays
as a local worker, so results are identical, target for target, to the
``"processes"`` backend for the same seed.

Time limits are those of the local pool (:mod:`ik.batch.runners`): an actor
still on its chunk after ``chunk_limit(n)`` seconds, or the overall
``deadline``, kills every actor and raises
:class:`kinserve.kinematics.errors.WorkerTimeoutError`.

``ray.init(address=...)`` joins an existing cluster when an address is
given (``ray_address="auto"`` or ``"ray://host:10001"``); otherwise a local
Ray with ``processes`` CPUs is started and left running for later batches
(``ray.shutdown()`` stops it). Install with ``pip install kinserve[ray]``.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Sequence
from types import ModuleType
from typing import TYPE_CHECKING, Any, NamedTuple

from kinserve.ik.batch.worker import Job, limit_blas_threads, solve_chunk
from kinserve.kinematics.errors import InputError, WorkerTimeoutError

if TYPE_CHECKING:  # annotations only
    import numpy as np

    from kinserve.kinematics.robot import Robot


def _ray():
    try:
        import ray
    except ImportError:  # pragma: no cover - depends on the installation
        raise InputError("backend='ray' needs Ray: pip install 'kinserve[ray]'") from None
    return ray


def ensure_ray(address: str | None = None, num_cpus: int | None = None) -> ModuleType:
    """Connect to Ray (``address``) or start a local instance with ``num_cpus`` CPUs; return the module."""
    ray = _ray()
    if not ray.is_initialized():
        kwargs = {"include_dashboard": False, "log_to_driver": False, "ignore_reinit_error": True}
        if address:
            ray.init(address=address, **kwargs)
        else:
            ray.init(num_cpus=num_cpus, **kwargs)
    return ray


class _ChunkSolver:
    """Body of the Ray actor: holds the job (robot, keywords, options) built once, solves its chunks."""

    def __init__(self, robot, common, options, keep_history):
        limit_blas_threads()
        # the request built here warms the robot's IK state (seed table, compiled chains) once per actor
        self.job = Job(robot, common["kwargs"], options, keep_history, common["frame"])

    def solve(self, start, poses, q0s):
        return solve_chunk(self.job, start, poses, q0s)


def run_ray_chunks(robot: Robot, chunks: Sequence[tuple[int, np.ndarray, np.ndarray | None]], common: dict,
                   options: dict, keep_history: bool, processes: int, on_done: Callable[[dict], None],
                   address: str | None = None, chunk_limit: Callable[[int], float] | None = None,
                   deadline: float | None = None) -> None:
    """Solve ``chunks`` (``(start, poses, q0s)``) on ``processes`` actors; ``on_done(result)`` for each."""
    ray = ensure_ray(address, processes)
    actor_class = ray.remote(num_cpus=1)(_ChunkSolver)
    workers = max(1, min(processes, int(ray.available_resources().get("CPU", processes)) or 1, len(chunks)))
    robot_ref = ray.put(robot)
    actors = [actor_class.remote(robot_ref, common, options, keep_history) for _ in range(workers)]
    try:
        _solve_on(ray, actors, list(chunks), on_done, chunk_limit, deadline)
    finally:
        for actor in actors:
            ray.kill(actor)


class _Running(NamedTuple):
    """A chunk on an actor: the actor, the chunk's first target index and size, when it was submitted
    (``time.monotonic()``)."""

    actor: Any
    start: int
    n: int
    t0: float


def _solve_on(ray: ModuleType, actors: list, queue: list, on_done: Callable[[dict], None],
              chunk_limit: Callable[[int], float] | None, deadline: float | None) -> None:
    """Hand the chunks of ``queue`` to the ``actors`` (one at a time each, the next to whichever finishes)
    and ``on_done`` each result; :class:`WorkerTimeoutError` when a chunk or the batch runs late."""
    pending: dict[Any, _Running] = {}  # result reference -> the chunk it belongs to

    def submit(actor):
        start, poses, q0s = queue.pop(0)
        pending[actor.solve.remote(start, poses, q0s)] = _Running(actor, start, len(poses), time.monotonic())

    for actor in actors:
        if queue:
            submit(actor)
    while pending:
        done, _ = ray.wait(list(pending), num_returns=1, timeout=0.5)
        if not done:
            _check_lateness(pending.values(), time.monotonic(), chunk_limit, deadline)
            continue
        ref = done[0]
        actor = pending.pop(ref).actor
        on_done(ray.get(ref))
        if queue:
            submit(actor)


def _check_lateness(running: Iterable[_Running], now: float, chunk_limit: Callable[[int], float] | None,
                    deadline: float | None) -> None:
    """:class:`WorkerTimeoutError` when a running chunk has taken longer than ``chunk_limit(n)`` seconds or
    the batch's ``deadline`` (``time.monotonic()`` time) has passed."""
    for _, start, n, t0 in running:
        limit = chunk_limit(n) if chunk_limit is not None else None
        if (limit is not None and now - t0 > limit) or (deadline is not None and now > deadline):
            late = limit and now - t0 > limit
            why = "chunk limit %.1f s" % limit if late else "overall timeout"
            raise WorkerTimeoutError(
                f"ik.solve_many: a Ray actor has not finished targets[{start}:{start + n}] after "
                f"{now - t0:.1f} s ({why}); every actor was killed"
            )
