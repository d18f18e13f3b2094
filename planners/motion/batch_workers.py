"""The work of :func:`planners.motion.plan_many` and the worker processes that do it.

A :class:`MotionJob` holds everything one ``plan_many`` call needs: the robot, the validated problems,
the shared keywords of the planner and the base seed; :meth:`MotionJob.plan_chunk` plans problems
``start .. stop`` with seed ``base + index`` each, wherever it runs (this process, a worker process, a
Ray actor), so a problem's plan never depends on which worker planned it.

:class:`ChunkPool` runs the chunks on ``processes`` worker processes made for one call (``fork`` where
available: a worker inherits the robot with its collision model already built; ``spawn`` pickles the
job, and the robot rebuilds its collision model from its URDF text). Like :mod:`kinserve.ik.batch.pool`:

* each chunk has a time limit (``limit(n)`` s for ``n`` problems); a worker past it, or one seen
  stopped (``SIGSTOP``) for :data:`STOPPED_GRACE` s, or the overall ``deadline``, ends the call with
  :class:`WorkerTimeoutError` naming the worker and its chunk;
* a worker that dies is replaced and its chunk planned once more; a chunk that kills two workers
  raises :class:`WorkerError`;
* results travel through files (in ``/dev/shm`` when available), the pipes carry short messages only;
* every worker is killed and reaped when the call ends, however it ends: no process is left behind.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import pickle
import signal
import tempfile
import time
import traceback
import uuid
from collections import deque
from collections.abc import Callable, Sequence
from multiprocessing.connection import wait
from typing import TYPE_CHECKING, Any, NamedTuple

from kinserve.ik.batch.pool import process_state
from kinserve.ik.batch.worker import limit_blas_threads
from kinserve.kinematics.errors import WorkerError, WorkerTimeoutError

if TYPE_CHECKING:  # annotations only
    from kinserve.kinematics.robot import Robot

#: Seconds a worker may stay stopped before it counts as stalled.
STOPPED_GRACE = 2.0
#: Longest wait (s) between two checks of the workers.
POLL = 0.5


class MotionProblem(NamedTuple):
    """One planning problem: ``start`` (nq,), ``goal`` (a configuration, a goal set or a pose, as
    ``plan_motion`` takes it) and ``obstacles`` (a tuple of shapes)."""

    start: Any
    goal: Any
    obstacles: tuple = ()


class MotionJob:
    """Everything a worker needs to plan the problems of one ``plan_many`` call (module docstring).

    ``planner(robot, start, goal, obstacles=..., seed=..., **kwargs)`` plans one problem
    (``plan_motion``); ``kwargs`` are its shared keywords, ``seed`` the base seed.
    """

    def __init__(self, robot: Robot, problems: Sequence[MotionProblem], kwargs: dict, seed: int,
                 planner: Callable[..., Any]) -> None:
        self.robot = robot
        self.problems = tuple(problems)
        self.kwargs = dict(kwargs)
        self.seed = seed
        self.planner = planner

    def prepare(self) -> None:
        """Build what every plan reads, before any chunk is timed: the robot's collision model (with its
        compiled pre-check) when a problem has obstacles or self collision is checked (the default)."""
        if self.kwargs.get("self_collision", True) or any(p.obstacles for p in self.problems):
            self.robot.collision  # noqa: B018 - built on first read, kept by the robot

    def plan_chunk(self, start: int, stop: int) -> list:
        """The plans of problems ``start .. stop - 1``, problem ``i`` with seed ``self.seed + i``."""
        out = []
        for i in range(start, stop):
            p = self.problems[i]
            out.append(self.planner(self.robot, p.start, p.goal, obstacles=p.obstacles, seed=self.seed + i,
                                    **self.kwargs))
        return out


def _context() -> mp.context.BaseContext:
    return mp.get_context("fork") if "fork" in mp.get_all_start_methods() else mp.get_context("spawn")


def _result_folder() -> str:
    shm = "/dev/shm"
    return shm if os.path.isdir(shm) and os.access(shm, os.W_OK) else tempfile.gettempdir()


def _worker_main(conn, job: MotionJob, prefix: str) -> None:
    """Loop of a worker: receive ``(start, stop)``, plan, write the plans to a file, send its name."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
    limit_blas_threads()
    job.prepare()  # nothing left to do in a forked worker; a spawned one builds the collision model here
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):
            return
        if msg is None:
            return
        start, stop = msg
        try:
            plans = job.plan_chunk(start, stop)
            path = f"{prefix}.{start}.out"
            with open(path + ".tmp", "wb") as fh:
                pickle.dump(plans, fh, protocol=pickle.HIGHEST_PROTOCOL)
            os.replace(path + ".tmp", path)
            conn.send(("done", start, path))
        except Exception as exc:  # sent to the parent, which raises it
            text = traceback.format_exc()[-3000:]
            try:
                pickle.dumps(exc)
            except Exception:
                exc = None
            conn.send(("error", start, exc, text))


class _Worker:
    """A worker process, its pipe, and the chunk it holds: ``(start, stop, since)`` or None."""

    __slots__ = ("process", "conn", "task", "stopped_since")

    def __init__(self, process, conn) -> None:
        self.process = process
        self.conn = conn
        self.task: tuple[int, int, float] | None = None
        self.stopped_since: float | None = None


class ChunkPool:
    """``processes`` worker processes for one job (module docstring); :meth:`run` once, then
    :meth:`terminate` (also a context manager)."""

    def __init__(self, job: MotionJob, processes: int) -> None:
        self.job = job
        self.prefix = os.path.join(_result_folder(), f"kinserve-plan-many-{os.getpid()}-{uuid.uuid4().hex}")
        self._ctx = _context()
        self.workers: list[_Worker] = []
        try:
            for _ in range(processes):
                self.workers.append(self._spawn())
        except BaseException:
            self.terminate()
            raise

    def __enter__(self) -> ChunkPool:
        return self

    def __exit__(self, *exc: object) -> None:
        self.terminate()

    def _spawn(self) -> _Worker:
        parent_conn, child_conn = self._ctx.Pipe(duplex=True)
        proc = self._ctx.Process(target=_worker_main, args=(child_conn, self.job, self.prefix),
                                 name="kinserve-plan-worker", daemon=True)
        proc.start()
        child_conn.close()
        return _Worker(proc, parent_conn)

    def pids(self) -> list[int]:
        """Process ids of the current workers."""
        return [w.process.pid for w in self.workers]

    def run(self, chunks: Sequence[tuple[int, int]], on_done: Callable[[int, list], None],
            limit: Callable[[int], float], deadline: float | None = None) -> None:
        """Plan ``chunks`` (``(start, stop)`` pairs); ``on_done(start, plans)`` for each, in completion order.

        ``limit(n)``: time limit (s) of a chunk of ``n`` problems; ``deadline``: absolute
        ``time.monotonic()`` or None. The workers are terminated when this returns or raises.
        """
        pending, retried = deque(chunks), set()
        try:
            while True:
                self._dispatch(pending)
                busy = [w for w in self.workers if w.task is not None]
                if not busy:
                    return
                now = time.monotonic()
                waits = [POLL] + [w.task[2] + limit(w.task[1] - w.task[0]) - now for w in busy]
                waits += [deadline - now] if deadline is not None else []
                ready = set(wait([w.conn for w in busy] + [w.process.sentinel for w in busy],
                                 max(0.0, min(waits))))
                for w in busy:
                    if w.conn in ready or w.conn.poll():
                        self._receive(w, on_done, pending, retried)
                    elif w.process.sentinel in ready:
                        self._replace_dead(w, pending, retried)
                self._check_stalls(limit, deadline)
        finally:
            self.terminate()

    def _dispatch(self, pending: deque) -> None:
        """Hand the next chunk to every idle worker (a dead idle one is replaced first)."""
        for i, w in enumerate(self.workers):
            if w.task is not None or not pending:
                continue
            if not w.process.is_alive():
                w = self.workers[i] = self._spawn()
            start, stop = pending.popleft()
            try:
                w.conn.send((start, stop))
            except OSError:  # it died since the check: the chunk goes back, the sentinel reports the death
                pending.appendleft((start, stop))
                continue
            w.task, w.stopped_since = (start, stop, time.monotonic()), None

    def _receive(self, w: _Worker, on_done, pending: deque, retried: set) -> None:
        try:
            msg = w.conn.recv()
        except (EOFError, OSError):
            self._replace_dead(w, pending, retried)
            return
        kind, start = msg[0], msg[1]
        stop = w.task[1]
        w.task = None
        if kind == "error":
            exc, text = msg[2], msg[3]
            if exc is not None:
                raise exc
            raise WorkerError(f"plan_many: worker process {w.process.pid} failed on "
                              f"problems[{start}:{stop}]:\n{text}")
        with open(msg[2], "rb") as fh:
            plans = pickle.load(fh)
        os.unlink(msg[2])
        on_done(start, plans)

    def _replace_dead(self, w: _Worker, pending: deque, retried: set) -> None:
        """Replace a dead worker; its chunk is planned once more (a second death raises)."""
        start, stop, _ = w.task
        w.process.join(1.0)
        code = w.process.exitcode
        w.conn.close()
        self.workers[self.workers.index(w)] = self._spawn()
        if (start, stop) in retried:
            raise WorkerError(f"plan_many: worker processes died twice on problems[{start}:{stop}] (last "
                              f"exit code {code}; a negative code is the signal that ended it)")
        retried.add((start, stop))
        pending.appendleft((start, stop))

    def _check_stalls(self, limit: Callable[[int], float], deadline: float | None) -> None:
        now = time.monotonic()
        for w in self.workers:
            if w.task is None:
                continue
            start, stop, since = w.task
            state = process_state(w.process.pid)
            w.stopped_since = (w.stopped_since or now) if state in ("T", "t") else None
            late = limit(stop - start)
            stopped = w.stopped_since is not None and now - w.stopped_since >= STOPPED_GRACE
            why = ("it exceeded the chunk time limit of %.1f s" % late if now - since > late
                   else "it is stopped" if stopped
                   else "the overall timeout expired" if deadline is not None and now > deadline else None)
            if why is not None:
                raise WorkerTimeoutError(f"plan_many: worker process {w.process.pid} has not finished "
                                         f"problems[{start}:{stop}] after {now - since:.1f} s - {why}; every "
                                         f"worker was terminated")

    def terminate(self) -> None:
        """Kill and reap every worker and remove the result files left behind."""
        for w in self.workers:
            if w.process.is_alive():
                w.process.kill()
        for w in self.workers:
            w.process.join(5.0)
            w.conn.close()
        self.workers = []
        folder, base = os.path.split(self.prefix)
        for name in os.listdir(folder):
            if name.startswith(base):
                try:
                    os.unlink(os.path.join(folder, name))
                except FileNotFoundError:
                    pass
