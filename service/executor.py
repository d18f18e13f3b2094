"""Bounded executors for heavy requests (IK, batches, plans) and model loading.

Microsecond endpoints (``/health``, ``/fk``, ``/jacobian``, ...) run inline on
the event loop. Everything that can take milliseconds to seconds runs on a
:class:`BoundedExecutor`, never on the server's generic thread pool:

* the **solver** executor is a pool of processes, one per core by default
  (``--solver-threads``), started with the server, each with its own robot
  cache. In a thread, a solve would hold the GIL the event loop needs:
  measured on this machine, ``/health`` p50 went from 5 ms to 33 ms (p95
  20 -> 97 ms) while four ``/ik`` ran in threads. In processes the event
  loop keeps its interpreter to itself (``/health`` p95 12-16 ms while 45
  unreachable ``/ik`` run, ``bench_service.py``);
* the **loader** executor is one thread that loads a model a microsecond
  endpoint has not seen yet (milliseconds, once per robot variant).

Admission policy (bounded queue, deadline-aware):

* at most ``workers + queue`` jobs are admitted at a time (running or
  waiting); one more is refused at once with :class:`ServiceBusy`
  (HTTP 503 with ``Retry-After``);
* every job carries its request's deadline (time of arrival + the request's
  time cap), so time spent waiting counts against the cap: a job still
  waiting for a worker at its deadline (or after :data:`MIN_QUEUE_WAIT`, for
  tiny caps) is dropped and answered with :class:`ServiceBusy`, and one that
  starts gets only the time left (:attr:`Deadline.remaining`; jobs use at
  least a millisecond). ``time.monotonic`` is system-wide, so a deadline
  means the same instant in a solver process.
"""

from __future__ import annotations

import asyncio
import gc
import math
import threading
import time
from concurrent.futures import Executor
from concurrent.futures.process import BrokenProcessPool
from typing import Callable

#: Seconds any admitted job may wait for a worker, even when its own time cap is shorter.
MIN_QUEUE_WAIT = 0.05


class ServiceBusy(Exception):
    """The queue is full, a job waited past its deadline, or a worker died; retry after ``retry_after`` s."""

    def __init__(self, message: str, retry_after: int = 1):
        super().__init__(message)
        self.retry_after = int(retry_after)


class Deadline:
    """An absolute point on the (system-wide) monotonic clock by which a request must be answered."""

    __slots__ = ("at", "budget")

    def __init__(self, budget: float):
        self.budget = float(budget)
        self.at = time.monotonic() + self.budget

    def __getstate__(self):
        return (self.at, self.budget)

    def __setstate__(self, state):
        self.at, self.budget = state

    @property
    def remaining(self) -> float:
        """Seconds left (may be negative)."""
        return self.at - time.monotonic()


def _run_job(job: Callable, deadline: Deadline, work_budget: float | None, args: tuple):
    """Run ``job(deadline, *args)`` in a worker; return ``(result, seconds)``."""
    t0 = time.monotonic()
    if work_budget is not None:
        deadline = Deadline(max(min(work_budget, deadline.remaining), 1e-3))
    return job(deadline, *args), time.monotonic() - t0


class BoundedExecutor:
    """``workers`` workers of an executor built by ``factory`` and room for ``queue`` waiting jobs."""

    def __init__(self, factory: Callable[[], Executor], workers: int, queue: int, name: str = "solver"):
        if workers < 1 or queue < 0:
            raise ValueError(f"BoundedExecutor needs workers >= 1 and queue >= 0, got {workers}, {queue}")
        self.name = name
        self.workers = int(workers)
        self.capacity = int(workers) + int(queue)
        self._factory = factory
        # made for the first job: an app that never serves (an import-time ``app``) starts no executor, and
        # a process pool's queues (named semaphores) exist only while the service runs
        self._executor: Executor | None = None
        self._closed = False
        self._admitted = 0
        self._lock = threading.Lock()
        self._mean_job = 0.05  # s, running mean of job durations (for Retry-After)

    @property
    def admitted(self) -> int:
        """Jobs running or waiting now."""
        return self._admitted

    def retry_after(self) -> int:
        """Seconds a refused client should wait: the time to drain the current queue, at least 1."""
        return max(1, math.ceil(self._admitted * self._mean_job / self.workers))

    async def run(self, job: Callable, deadline: Deadline, work_budget: float | None = None, *args):
        """``job(d, *args)`` on a worker; its result (or what it raised).

        ``d`` is ``deadline``, or with ``work_budget`` the earlier of ``deadline`` and
        ``work_budget`` seconds after the job starts (an IK ``max_time`` counts from
        the start of the solve, while queueing counts against the request's cap).
        ``job`` and ``args`` must be picklable for a process pool.
        """
        with self._lock:
            if self._closed:
                raise ServiceBusy(f"the server is shutting down: its {self.name} workers are stopped")
            if self._admitted >= self.capacity:
                raise ServiceBusy(
                    f"the server is busy: {self._admitted} heavy requests running or queued "
                    f"(limit {self.capacity}); retry later", self.retry_after())
            self._admitted += 1
            if self._executor is None:
                self._executor = self._factory()
            executor = self._executor
        try:
            cf = executor.submit(_run_job, job, deadline, work_budget, args)
        except BrokenProcessPool:
            self._release(None)
            self._replace_broken()
            raise ServiceBusy(f"a {self.name} process died and was replaced; retry") from None
        except BaseException:
            self._release(None)
            raise
        cf.add_done_callback(self._on_done)
        fut = asyncio.wrap_future(cf)
        try:
            result, _ = await asyncio.wait_for(asyncio.shield(fut), max(deadline.remaining, MIN_QUEUE_WAIT))
            return result
        except asyncio.TimeoutError:  # TimeoutError on Python >= 3.11
            if cf.cancel():  # still waiting for a worker: give up on it
                raise ServiceBusy(
                    f"no {self.name} worker became free within the request's time cap ({deadline.budget:.3g} "
                    "s); the server is overloaded, retry later", self.retry_after()) from None
            result, _ = await fut  # running: the job's own budget ends by the deadline
            return result
        except BrokenProcessPool:
            self._replace_broken()
            raise ServiceBusy(f"a {self.name} process died during the request and was replaced; "
                              "retry") from None

    def _on_done(self, cf) -> None:
        duration = None
        if not cf.cancelled() and cf.exception() is None:
            duration = cf.result()[1]
        self._release(duration)

    def _release(self, duration: float | None) -> None:
        with self._lock:
            self._admitted -= 1
            if duration:
                self._mean_job += 0.1 * (duration - self._mean_job)

    def _replace_broken(self) -> None:
        with self._lock:
            old = self._executor
            if old is None or not getattr(old, "_broken", False):  # replaced already, or shut down
                return
            self._executor = None  # the next job makes a new one (never once shut down)
        old.shutdown(wait=False, cancel_futures=True)

    def shutdown(self, grace: float = 2.0) -> None:
        """Stop the workers: queued jobs are cancelled, running ones get ``grace`` s, then their processes are
        killed (:func:`stop_executor`). Later jobs are refused with :class:`ServiceBusy`."""
        with self._lock:
            self._closed = True
            executor, self._executor = self._executor, None
        if executor is not None:
            stop_executor(executor, grace)


def stop_executor(executor: Executor, grace: float) -> None:
    """Shut ``executor`` down and wait until its workers have ended: queued jobs cancelled, a running job
    given ``grace`` s before its process (of a process pool) is killed; at most about ``2 * grace`` s.

    For a process pool this also releases its queues, whose locks are named POSIX semaphores: their
    finalizers unlink them here. Left for interpreter exit, they were never unlinked when the server ends by
    a signal (uvicorn re-raises the SIGTERM it handled once it has shut down, and the process dies without
    its exit handlers), and multiprocessing's resource tracker then warned of "leaked semaphore objects".
    """
    processes = list((getattr(executor, "_processes", None) or {}).values())  # process pools only
    stopper = threading.Thread(target=executor.shutdown, kwargs={"wait": True, "cancel_futures": True},
                               name="kinserve-executor-stop", daemon=True)
    stopper.start()
    stopper.join(grace)
    if stopper.is_alive():  # a job still runs: end its process (a thread cannot be stopped)
        for p in processes:
            if p.is_alive():
                p.kill()
        stopper.join(grace)
    del processes, stopper
    gc.collect()  # the queues' semaphores, if anything still forms a reference cycle with them
