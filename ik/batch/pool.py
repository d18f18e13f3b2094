"""Persistent worker processes for :func:`ik.solve_many`, with time limits, one retry and clean termination.

Each worker is a process (``fork`` start method on Linux: it inherits the
loaded modules) with its own duplex pipe to the parent. The parent hands a
chunk to an idle worker and knows at every moment which worker holds which
chunk and since when, which ``concurrent.futures.ProcessPoolExecutor`` cannot
tell; that is what the time limits need:

* **chunk limit**: a worker that has not finished its chunk within the limit
  the runner gives for that chunk (derived from the per-target time budget,
  see :mod:`ik.batch.runners`) is *stalled*;
* **stopped worker**: a worker seen in the stopped state (``SIGSTOP``,
  ``/proc/<pid>/stat`` state ``T``) for :data:`STOPPED_GRACE` seconds is
  stalled too, without waiting for the chunk limit;
* **deadline**: the caller's overall ``timeout``.

On a stall or at the deadline every worker is killed (``SIGKILL`` also ends
a stopped process) and reaped, and :class:`WorkerTimeoutError` names the
worker, its state and its chunk; the next call starts a fresh pool. A worker
that *dies* (killed, crashed) is replaced and its chunk is run once more; a
chunk that kills two workers raises :class:`WorkerError`.

Messages on the pipes are a few dozen bytes (below ``PIPE_BUF``, written
atomically), so the parent never blocks on a worker stopped in the middle of
a message; the bulk data travels through files in ``/dev/shm``: the job
(written once per call, see :func:`ik.batch.worker.write_job`) and one result
file per chunk.

Every worker makes its BLAS single-threaded first
(:func:`ik.batch.worker.limit_blas_threads`): with the default of one
OpenBLAS thread per core, two workers on two cores ran four BLAS threads
that spin while they wait for work, and two processes were *slower* than one
(see :mod:`ik.batch.runners`).
"""

from __future__ import annotations

import atexit
import multiprocessing as mp
import os
import pickle
import signal
import threading
import time
import traceback
from collections import deque
from collections.abc import Callable, Iterable
from multiprocessing.connection import wait

from kinserve.ik.batch.worker import LoadedJobs, limit_blas_threads, worker_chunk
from kinserve.kinematics.errors import WorkerError, WorkerTimeoutError

#: Seconds a worker may stay in the stopped state before it counts as stalled.
STOPPED_GRACE = 2.0
#: Longest single wait (s) between two checks of the workers' states.
POLL = 0.5
#: Chunks a worker holds at once: the one it solves and the next, already in its pipe, so that it
#: never waits for the parent between two chunks (on a loaded machine that round trip costs
#: scheduling latency twice per chunk).
PREFETCH = 2


def _context():
    return mp.get_context("fork") if "fork" in mp.get_all_start_methods() else mp.get_context()


def _worker_main(conn) -> None:
    """Loop of a worker process: receive ``(job_id, path, start, stop)``, solve, write the result file,
    notify."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
    limit_blas_threads()
    jobs = LoadedJobs()  # the jobs this worker has read, most recent last
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):
            return
        if msg is None:
            return
        job_id, path, start, stop = msg
        try:
            out = worker_chunk(jobs, job_id, path, start, stop)
            out_path = f"{path}.{start}.out"
            with open(out_path + ".tmp", "wb") as fh:
                pickle.dump(out, fh, protocol=pickle.HIGHEST_PROTOCOL)
            os.replace(out_path + ".tmp", out_path)
            conn.send(("done", job_id, start, out_path))
        except Exception as exc:  # sent to the parent, which raises it
            text = traceback.format_exc()[-3000:]
            try:
                pickle.dumps(exc)
            except Exception:
                exc = None
            conn.send(("error", job_id, start, exc, text))


def process_state(pid: int) -> str:
    """One-letter state of a process from ``/proc/<pid>/stat`` (``R``, ``S``, ``T`` stopped, ...); ``?`` if
    unknown."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as fh:
            stat = fh.read()
        return stat[stat.rindex(b")") + 2:][:1].decode()
    except (OSError, ValueError):
        return "?"


_STATES = {"R": "running", "S": "sleeping", "D": "in uninterruptible wait", "T": "stopped (SIGSTOP?)",
           "t": "stopped by a tracer", "Z": "zombie"}


class _Worker:
    """A worker process, its pipe, and the chunks it holds (the first is the one it is solving)."""

    __slots__ = ("process", "conn", "queue", "head_since", "stopped_since")

    def __init__(self, process, conn):
        self.process = process
        self.conn = conn
        self.queue = deque()  # (start, stop, limit) of the chunks sent to it, oldest first
        self.head_since = 0.0  # when it started on queue[0] (as far as the parent can tell)
        self.stopped_since = None

    @property
    def task(self):
        """``(start, stop, since, limit)`` of the chunk it is solving, or None when idle."""
        if not self.queue:
            return None
        start, stop, limit = self.queue[0]
        return start, stop, self.head_since, limit


class WorkerPool:
    """``processes`` persistent worker processes (module docstring); one :meth:`run` at a time."""

    def __init__(self, processes: int):
        self.processes = processes
        self.lock = threading.Lock()
        self._ctx = _context()
        self.workers = [self._spawn() for _ in range(processes)]

    def _spawn(self) -> _Worker:
        parent_conn, child_conn = self._ctx.Pipe(duplex=True)
        proc = self._ctx.Process(target=_worker_main, args=(child_conn,), name="kinserve-ik-worker",
                                 daemon=True)
        proc.start()
        child_conn.close()
        return _Worker(proc, parent_conn)

    def pids(self) -> list[int]:
        """Process ids of the workers."""
        return [w.process.pid for w in self.workers]

    def alive(self) -> bool:
        """Whether every worker process is alive."""
        return all(w.process.is_alive() for w in self.workers)

    def run(self, job_id: tuple, path: str, chunks: Iterable[tuple[int, int]],
            on_done: Callable[[dict], None], chunk_limit: Callable[[int], float],
            deadline: float | None = None) -> None:
        """Solve ``chunks`` (``(start, stop)`` pairs) of the job in file ``path``; ``on_done(result)`` for
        each.

        ``chunk_limit(n)`` is the time limit (s) of a chunk of ``n`` targets;
        ``deadline`` an absolute ``time.monotonic()`` time or None. On any
        exception the pool is terminated before it propagates.
        """
        pending = deque(chunks)
        retried = set()
        try:
            while True:
                self._dispatch(job_id, path, pending, chunk_limit)
                busy = [w for w in self.workers if w.task is not None]
                if not busy:
                    return
                now = time.monotonic()
                timeout = min([POLL] + [w.task[2] + w.task[3] - now for w in busy]
                              + ([deadline - now] if deadline is not None else []))
                waited = [w.conn for w in busy] + [w.process.sentinel for w in busy]
                ready = set(wait(waited, max(0.0, timeout)))
                for w in busy:
                    if w.conn in ready or w.conn.poll():
                        self._receive(w, job_id, on_done, pending, retried)
                    elif w.process.sentinel in ready:
                        self._replace_dead(w, pending, retried)
                self._check_stalls(deadline)
        except BaseException:
            self.terminate()
            raise

    def _dispatch(self, job_id, path, pending, chunk_limit) -> None:
        """Top every worker up to :data:`PREFETCH` chunks, one round at a time (even shares)."""
        for depth in range(PREFETCH):
            for i in range(len(self.workers)):
                w = self.workers[i]
                if len(w.queue) > depth or not pending:
                    continue
                if not w.queue and not w.process.is_alive():
                    w = self.workers[i] = self._spawn()
                start, stop = pending.popleft()
                try:
                    w.conn.send((job_id, path, start, stop))
                except OSError:  # it died since the check: requeue, the sentinel reports it
                    pending.appendleft((start, stop))
                    continue
                if not w.queue:
                    w.head_since = time.monotonic()
                    w.stopped_since = None
                w.queue.append((start, stop, chunk_limit(stop - start)))

    def _receive(self, w: _Worker, job_id, on_done, pending, retried) -> None:
        try:
            msg = w.conn.recv()
        except (EOFError, OSError):
            self._replace_dead(w, pending, retried)
            return
        kind, msg_job, start = msg[:3]
        if msg_job != job_id or not w.queue or start != w.queue[0][0]:
            return  # not this run's (cannot happen: a pool is terminated when a run is abandoned)
        w.queue.popleft()
        w.head_since = time.monotonic()  # it goes on with the next chunk in its pipe, if any
        w.stopped_since = None
        if kind == "error":
            exc, text = msg[3], msg[4]
            if exc is not None:
                raise exc
            raise WorkerError(f"ik.solve_many: worker process {w.process.pid} failed on targets[{start}:]:\n"
                              f"{text}")
        with open(msg[3], "rb") as fh:
            out = pickle.load(fh)
        os.unlink(msg[3])
        on_done(out)

    def _replace_dead(self, w: _Worker, pending, retried) -> None:
        """Replace a dead worker; its current chunk is retried once, the chunks behind it go back in line."""
        start, stop, _ = w.queue[0]
        w.process.join(1.0)
        code = w.process.exitcode
        i = self.workers.index(w)
        self.workers[i] = self._spawn()
        if (start, stop) in retried:
            raise WorkerError(
                f"ik.solve_many: worker processes died twice on targets[{start}:{stop}] "
                f"(last exit code {code}; a negative code is the signal that ended it)"
            )
        retried.add((start, stop))
        for s_, e_, _ in reversed(w.queue):
            pending.appendleft((s_, e_))

    def _check_stalls(self, deadline) -> None:
        now = time.monotonic()
        for w in self.workers:
            if w.task is None:
                continue
            start, stop, t0, limit = w.task
            state = process_state(w.process.pid)
            if state in ("T", "t"):
                w.stopped_since = w.stopped_since or now
            else:
                w.stopped_since = None
            stalled = now - t0 > limit
            stopped = w.stopped_since is not None and now - w.stopped_since >= STOPPED_GRACE
            late = deadline is not None and now > deadline
            if stalled or stopped or late:
                why = ("it exceeded the chunk time limit of %.1f s" % limit if stalled
                       else "it is stopped" if stopped else "the overall timeout expired")
                raise WorkerTimeoutError(
                    f"ik.solve_many: worker process {w.process.pid} ({_STATES.get(state, state)}) has not "
                    f"finished targets[{start}:{stop}] after {now - t0:.1f} s - {why}; every worker was "
                    f"terminated (timeout= sets the overall limit, max_time= the per-target budget the chunk "
                    f"limit derives from)"
                )
        if deadline is not None and now > deadline:
            raise WorkerTimeoutError("ik.solve_many: the overall timeout expired; every worker was "
                                     "terminated")

    def terminate(self) -> None:
        """Kill and reap every worker (a stopped process dies on SIGKILL too)."""
        for w in self.workers:
            if w.process.is_alive():
                w.process.kill()
        for w in self.workers:
            w.process.join(5.0)
            w.conn.close()
        self.workers = []

    def close(self) -> None:
        """Ask idle workers to exit, then terminate whatever is left."""
        for w in self.workers:
            if w.task is None and w.process.is_alive():
                try:
                    w.conn.send(None)
                except OSError:
                    pass
        for w in self.workers:
            w.process.join(1.0)
        self.terminate()


class PoolKeeper:
    """The persistent pool of one process (at most one at a time): made on demand by :meth:`acquire`, replaced
    when a run needs another size or a worker died, stopped by :meth:`shutdown` (and at exit)."""

    def __init__(self) -> None:
        self.pool: WorkerPool | None = None
        self.lock = threading.Lock()  # guards ``pool``

    def acquire(self, processes: int, deadline: float | None = None) -> WorkerPool:
        """The pool of ``processes`` workers, locked for one run (release ``pool.lock`` after).

        A pool of another size, or one with a dead worker, is replaced. Waits for
        another thread's run to finish (until ``deadline``).
        """
        while True:
            with self.lock:
                current = self.pool
                if current is None or current.processes != processes or not current.workers:
                    if current is not None and current.lock.acquire(blocking=False):
                        current.close()
                        current.lock.release()
                    self.pool = WorkerPool(processes)
                pool = self.pool
            timeout = -1 if deadline is None else max(0.0, deadline - time.monotonic())
            if not pool.lock.acquire(timeout=timeout):
                raise WorkerTimeoutError("ik.solve_many: the overall timeout expired while another batch "
                                         "held the worker pool")
            if pool.workers:
                return pool
            pool.lock.release()  # terminated by the run that held it: make a new one

    def shutdown(self) -> None:
        """Stop the workers (a later :meth:`acquire` starts new ones)."""
        with self.lock:
            pool, self.pool = self.pool, None
        if pool is not None:
            with pool.lock:
                pool.close()


#: This process's worker pool (the workers are a resource of the process, shared by every batch).
POOL_KEEPER = PoolKeeper()


def acquire_pool(processes: int, deadline: float | None = None) -> WorkerPool:
    """:meth:`PoolKeeper.acquire` of this process's pool."""
    return POOL_KEEPER.acquire(processes, deadline)


def shutdown_pool() -> None:
    """Stop the persistent worker processes (they are started again on demand)."""
    POOL_KEEPER.shutdown()


atexit.register(shutdown_pool)


def current_pool() -> WorkerPool | None:
    """The persistent pool, if one is running (for tests and diagnostics)."""
    return POOL_KEEPER.pool
