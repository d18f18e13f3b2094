"""The bounded executor for heavy requests (IK, batches, plans, model loading).

Microsecond endpoints (``/health``, ``/fk``, ``/jacobian``, ...) run inline on
the event loop. Everything that can take milliseconds to seconds runs here,
on ``threads`` solver threads (default: one per core), never on the server's
generic thread pool - so heavy work can never starve ``/health``.

Admission policy (bounded queue, deadline-aware):

* at most ``threads + queue`` jobs are admitted at a time (running or
  waiting); one more is refused at once with :class:`ServiceBusy`
  (HTTP 503 with ``Retry-After``);
* every job carries its request's deadline (time of arrival + the request's
  time cap), so time spent waiting counts against the cap: a job still
  waiting for a thread at its deadline (or after :data:`MIN_QUEUE_WAIT`, for
  tiny caps) is dropped and answered with :class:`ServiceBusy`, and one that
  starts gets only the time left (:attr:`Deadline.remaining`; the jobs use
  at least a millisecond).
"""

from __future__ import annotations

import asyncio
import math
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from typing import Callable, TypeVar

T = TypeVar("T")

#: Seconds any admitted job may wait for a thread, even when its own time cap is shorter.
MIN_QUEUE_WAIT = 0.05


class ServiceBusy(Exception):
    """The solver queue is full, or a job waited past its deadline; retry after ``retry_after`` s."""

    def __init__(self, message: str, retry_after: int = 1):
        super().__init__(message)
        self.retry_after = int(retry_after)


class Deadline:
    """An absolute point on the monotonic clock by which a request must be answered."""

    __slots__ = ("at", "budget")

    def __init__(self, budget: float):
        self.budget = float(budget)
        self.at = time.monotonic() + self.budget

    @property
    def remaining(self) -> float:
        """Seconds left (may be negative)."""
        return self.at - time.monotonic()

    @property
    def expired(self) -> bool:
        return time.monotonic() >= self.at


class SolverExecutor:
    """``threads`` solver threads and room for ``queue`` waiting jobs (module docstring)."""

    def __init__(self, threads: int, queue: int):
        if threads < 1 or queue < 0:
            raise ValueError(f"SolverExecutor needs threads >= 1 and queue >= 0, got {threads}, {queue}")
        self.threads = int(threads)
        self.capacity = int(threads) + int(queue)
        self._pool = ThreadPoolExecutor(max_workers=self.threads, thread_name_prefix="kinserve-solver")
        self._admitted = 0
        self._lock = threading.Lock()
        self._mean_job = 0.05  # s, running mean of job durations (for Retry-After)

    @property
    def admitted(self) -> int:
        """Jobs running or waiting now."""
        return self._admitted

    def retry_after(self) -> int:
        """Seconds a refused client should wait: the time to drain the current queue, at least 1."""
        return max(1, math.ceil(self._admitted * self._mean_job / self.threads))

    async def run(self, job: Callable[[Deadline], T], deadline: Deadline, work_budget: float | None = None) -> T:
        """Run ``job(d)`` on a solver thread and return its result (raises what it raises).

        ``d`` is ``deadline``, or with ``work_budget`` the earlier of ``deadline`` and
        ``work_budget`` seconds after the job starts (an IK ``max_time`` counts from
        the start of the solve, while queueing counts against the request's cap).
        """
        with self._lock:
            if self._admitted >= self.capacity:
                raise ServiceBusy(
                    f"the server is busy: {self._admitted} heavy requests running or queued "
                    f"(limit {self.capacity}); retry later", self.retry_after())
            self._admitted += 1
        try:
            cf = self._pool.submit(self._call, job, deadline, work_budget)
        except BaseException:
            self._release(0.0)
            raise
        cf.add_done_callback(self._on_cancelled)
        fut = asyncio.wrap_future(cf)
        try:
            return await asyncio.wait_for(asyncio.shield(fut), max(deadline.remaining, MIN_QUEUE_WAIT))
        except asyncio.TimeoutError:  # TimeoutError on Python >= 3.11
            if cf.cancel():  # still waiting for a thread: give up on it
                raise ServiceBusy(
                    f"no solver thread became free within the request's time cap ({deadline.budget:.3g} s); "
                    "the server is overloaded, retry later", self.retry_after()) from None
            return await fut  # running: the job's own budget ends by the deadline

    def _call(self, job, deadline: Deadline, work_budget: float | None):
        t0 = time.monotonic()
        try:
            if work_budget is not None:
                deadline = Deadline(max(min(work_budget, deadline.remaining), 1e-3))
            return job(deadline)
        finally:
            self._release(time.monotonic() - t0)

    def _on_cancelled(self, cf) -> None:
        if cf.cancelled():  # never ran, so _call never released its slot
            self._release(0.0)

    def _release(self, duration: float) -> None:
        with self._lock:
            self._admitted -= 1
            if duration > 0:
                self._mean_job += 0.1 * (duration - self._mean_job)

    def shutdown(self) -> None:
        self._pool.shutdown(wait=False, cancel_futures=True)
