"""Ray execution backend of :func:`ik.solve_many` (``backend="ray"``).

The batch is cut into the same chunks as the local backends. One Ray actor
per worker receives the robot **once** (Ray pickles a ``Robot`` as its
kinematic model, without meshes) together with the solve options, builds
its :class:`ik.batch.worker.Job` once, then solves whole chunks
(:func:`ik.batch.worker.solve_chunk`) and returns the same compact arrays
as a local worker, so results are identical, target for target, to the
``"processes"`` backend for the same seed.

Time limits are those of the local pool (:mod:`ik.batch.runners`), with the
actor's start timed apart (:mod:`ik.batch.ray_actors`): an actor not started
after :data:`~ik.batch.ray_actors.ACTOR_START_LIMIT` seconds, or still on its
chunk ``chunk_limit(n)`` seconds after it began, or the overall ``deadline``,
kills every actor and raises
:class:`kinserve.kinematics.errors.WorkerTimeoutError`.

``ray.init(address=...)`` joins an existing cluster when an address is
given (``ray_address="auto"`` or ``"ray://host:10001"``); otherwise a local
Ray with ``processes`` CPUs is started and left running for later batches
(``ray.shutdown()`` stops it). Install with ``pip install kinserve[ray]``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from types import ModuleType
from typing import TYPE_CHECKING

from kinserve.ik.batch.ray_actors import BatchLabels, run_on_new_actors
from kinserve.ik.batch.worker import Job, limit_blas_threads, solve_chunk
from kinserve.kinematics.errors import InputError

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

    def ready(self) -> bool:
        """Answers once ``__init__`` has run (:func:`~ik.batch.ray_actors.run_on_actors` times the start)."""
        return True

    def solve(self, start, poses, q0s):
        return solve_chunk(self.job, start, poses, q0s)


def run_ray_chunks(robot: Robot, chunks: Sequence[tuple[int, int]],
                   chunk_data: Callable[[int, int], tuple[np.ndarray, np.ndarray | None]], common: dict,
                   options: dict, keep_history: bool, processes: int, on_done: Callable[[dict], None],
                   chunk_limit: Callable[[int], float], address: str | None = None,
                   deadline: float | None = None) -> None:
    """Solve ``chunks`` (``(start, stop)`` target indices; ``chunk_data(start, stop)`` gives their
    ``(poses, q0s)``) on ``processes`` actors; ``on_done(result)`` for each. The actors' start and each
    chunk are timed apart (:mod:`ik.batch.ray_actors`)."""
    ray = ensure_ray(address, processes)
    run_on_new_actors(ray, _ChunkSolver, (ray.put(robot), common, options, keep_history), processes, chunks,
                      lambda actor, start, stop: actor.solve.remote(start, *chunk_data(start, stop)),
                      lambda _, result: on_done(result), chunk_limit, deadline,
                      BatchLabels("ik.solve_many:", "targets"))
