"""Execution backends of :func:`ik.solve_many`: where the chunks of a job are solved, and within what time.

Each backend is one function ``runner(job, chunks, processes, on_done, limits)``
in :data:`BACKENDS`; ``chunks`` are ``(start, stop)`` index pairs into
``job.poses``, ``on_done`` takes the compact result of one chunk
(:func:`ik.batch.worker.solve_chunk`), ``limits`` is a :class:`TimeLimits`.

* ``"processes"``: the persistent local pool of :mod:`ik.batch.pool`;
* ``"serial"``: this process, chunk after chunk;
* ``"ray"``: Ray actors (:mod:`ik.batch.ray_backend`, ``ray_address=`` joins a cluster).

Time limits
-----------
Every solve is bounded by its time budget ``max_time`` (default
:data:`DEFAULT_BUDGET` per method), so a chunk of ``n`` targets needs at most
about ``n * max_time``; the limit of a chunk is

    limit(n) = FACTOR * n * max_time + SLACK       (s)

(``FACTOR`` = :data:`CHUNK_FACTOR` covers the overshoot of a budget by its
last iteration and a loaded machine, ``SLACK`` = :data:`CHUNK_SLACK` the
worker's start and the loading of the job). A worker still on its chunk
after the limit is stalled: the pool is terminated and
:class:`kinserve.kinematics.errors.WorkerTimeoutError` names the worker and
the chunk. ``timeout=`` bounds the whole call as well. The serial backend
cannot interrupt a chunk: it checks the overall timeout between chunks.

Two processes against one
-------------------------

* Every worker makes its BLAS and OpenMP libraries single-threaded
  (:func:`ik.batch.worker.limit_blas_threads`): with one OpenBLAS thread per
  core in every process, workers would run more BLAS threads than there are
  cores, and idle OpenBLAS threads spin. The caller's process is left as the
  user configured it.
* The parent's serial work is done on whole arrays: the targets are validated
  all at once, the ``Result`` list is rebuilt from each chunk's arrays.
* Each worker holds its next chunk already (:data:`ik.batch.pool.PREFETCH`),
  so it never waits for the parent between two chunks.
* A few large chunks (2 per process, at most
  :data:`ik.batch.solve_many.VECTOR_CHUNK` targets) and dynamic dispatch keep
  the workers even.

A session's processes share the CPU with the machine's other sessions (the
kernel's autogroup scheduling): ``benchmarks/bench_ik.py`` records what two
plain CPU-bound processes get next to the ``solve_many`` ratio.
"""

from __future__ import annotations

import glob
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from kinserve.ik.batch.pool import acquire_pool, current_pool
from kinserve.ik.batch.ray_backend import run_ray_chunks
from kinserve.ik.batch.worker import Job, solve_chunk, write_job
from kinserve.kinematics.errors import WorkerTimeoutError

#: Time budget (s) of one solve per method when ``max_time`` is not given (the solvers' defaults).
DEFAULT_BUDGET = {"lm": 0.1, "qp": 0.5, "auto": 0.5, "analytic": 0.1}
#: Budget (s) assumed for the classical methods (bounded by their iteration cap, not by time).
CLASSICAL_BUDGET = 1.0
#: Chunk limit = CHUNK_FACTOR * targets * budget + CHUNK_SLACK (module docstring).
CHUNK_FACTOR = 3.0
CHUNK_SLACK = 10.0


@dataclass(frozen=True)
class TimeLimits:
    """Per-chunk limits and the overall deadline of one ``solve_many`` call (module docstring)."""

    budget: float  #: time budget of one target (s)
    deadline: float | None  #: absolute ``time.monotonic()`` of the overall timeout, or None
    factor: float
    slack: float

    @classmethod
    def for_job(cls, job: Job, timeout: float | None) -> "TimeLimits":
        """The limits of ``job`` with the module's current ``CHUNK_FACTOR`` / ``CHUNK_SLACK``."""
        p = job.prepared()
        budget = p.max_time if p.max_time is not None else DEFAULT_BUDGET.get(p.method, CLASSICAL_BUDGET)
        deadline = None if timeout is None else time.monotonic() + timeout
        return cls(budget, deadline, CHUNK_FACTOR, CHUNK_SLACK)

    def chunk(self, n: int) -> float:
        """Time limit (s) of a chunk of ``n`` targets."""
        return self.factor * n * self.budget + self.slack


def run_serial(job: Job, chunks: Sequence[tuple[int, int]], processes: int, on_done: Callable[[dict], None],
               limits: TimeLimits) -> None:
    """Solve the chunks in this process, one after the other (the overall timeout is checked between
    chunks)."""
    for start, stop in chunks:
        if limits.deadline is not None and time.monotonic() > limits.deadline:
            raise WorkerTimeoutError(f"ik.solve_many: the overall timeout expired before "
                                     f"targets[{start}:{stop}]")
        poses, q0s = job.chunk(start, stop)
        on_done(solve_chunk(job, start, poses, q0s))


def run_processes(job: Job, chunks: Sequence[tuple[int, int]], processes: int,
                  on_done: Callable[[dict], None], limits: TimeLimits) -> None:
    """Solve the chunks on the persistent local pool (:mod:`ik.batch.pool`)."""
    path = write_job(job)
    pool = None
    try:
        pool = acquire_pool(processes, limits.deadline)
        pool.run(job.id, path, chunks, on_done, limits.chunk, limits.deadline)
    finally:
        if pool is not None:
            pool.lock.release()
            if current_pool() is not pool and pool.workers:
                pool.close()  # replaced by a pool of another size while this run held it
        for leftover in [path] + glob.glob(path + ".*"):
            try:
                os.unlink(leftover)
            except FileNotFoundError:
                pass


def run_ray(job: Job, chunks: Sequence[tuple[int, int]], processes: int, on_done: Callable[[dict], None],
            limits: TimeLimits) -> None:
    """Solve the chunks on Ray actors (:mod:`ik.batch.ray_backend`)."""
    common = {"frame": job.frame, "kwargs": job.kwargs}
    run_ray_chunks(job.robot, chunks, job.chunk, common, job.options, job.keep_history, processes, on_done,
                   limits.chunk, address=job.ray_address, deadline=limits.deadline)


#: Execution backends: ``name -> runner(job, chunks, processes, on_done, limits)``.
BACKENDS = {"processes": run_processes, "serial": run_serial, "ray": run_ray}
