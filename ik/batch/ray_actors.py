"""Chunks of a batch on Ray actors, each actor's start timed apart from its chunks.

A Ray actor is a new process: it imports kinserve, receives the job once and builds its state in its
``__init__`` (the robot's IK tables, its collision model, the compiled kernels loaded from the disk
cache). On a busy machine that can take longer than a chunk's work, so :func:`run_on_actors` keeps the
two apart:

* each actor is asked ``ready()`` as soon as it is made (the answer comes once its ``__init__`` has
  run) and has :data:`ACTOR_START_LIMIT` seconds, counted from then, to give it;
* its first chunk is handed over at once (Ray runs an actor's calls in order, so the chunk waits behind
  ``ready()``), but that chunk's limit ``chunk_limit(n)`` (s, ``n`` items) counts from the moment the
  actor is seen ready; a later chunk's counts from when it is handed over;
* ``deadline`` (an absolute ``time.monotonic()`` time, or None) bounds the whole run, start included.

An actor late to start or late on a chunk, or the deadline passed, raises :class:`WorkerTimeoutError`
naming the chunk; an actor that died, or whose ``__init__`` or chunk raised something other than a
:class:`~kinserve.kinematics.errors.KinserveError`, raises :class:`WorkerError` with Ray's reason. The
caller kills the actors (in a ``finally``; :func:`run_on_new_actors` makes and kills them), so none
outlives the run.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable, Iterable, Sequence
from types import ModuleType
from typing import Any, NamedTuple

from kinserve.kinematics.errors import KinserveError, WorkerError, WorkerTimeoutError

#: Seconds an actor may take from being made to answering ``ready()`` (process start, imports, the job's
#: set-up). Generous: it only stops a run whose actors cannot start at all (``deadline`` bounds a run).
ACTOR_START_LIMIT = 300.0
#: Longest wait (s) between two checks of the running chunks.
POLL = 0.5


class ActorChunk(NamedTuple):
    """A chunk on an actor: items ``start .. stop - 1``, and since when (``time.monotonic()``) its limit
    counts - None while the actor is starting."""

    actor: Any
    start: int
    stop: int
    since: float | None


class BatchLabels(NamedTuple):
    """How messages name the batch: the ``prefix`` they begin with (the caller and a colon) and the
    batch's ``items`` (``"targets"``)."""

    prefix: str
    items: str


def run_on_new_actors(ray: ModuleType, body: type, args: Sequence[Any], processes: int,
                      chunks: Sequence[tuple[int, int]], submit: Callable[[Any, int, int], Any],
                      on_done: Callable[[int, Any], None], chunk_limit: Callable[[int], float],
                      deadline: float | None, labels: BatchLabels) -> None:
    """:func:`run_on_actors` on new actors of class ``body`` (one CPU each, made with ``args``): as many as
    ``processes``, the cluster's CPUs and the chunks allow (at least one), every one killed when the run
    ends, however it ends."""
    actor_class = ray.remote(num_cpus=1)(body)
    cpus = int(ray.available_resources().get("CPU", processes)) or 1
    actors = [actor_class.remote(*args) for _ in range(max(1, min(processes, cpus, len(chunks))))]
    try:
        run_on_actors(ray, actors, chunks, submit, on_done, chunk_limit, deadline, labels)
    finally:
        for actor in actors:
            ray.kill(actor)


def run_on_actors(ray: ModuleType, actors: Sequence[Any], chunks: Iterable[tuple[int, int]],
                  submit: Callable[[Any, int, int], Any], on_done: Callable[[int, Any], None],
                  chunk_limit: Callable[[int], float], deadline: float | None, labels: BatchLabels,
                  start_limit: float = ACTOR_START_LIMIT) -> None:
    """Hand ``chunks`` (``(start, stop)`` pairs) to the ``actors`` (each has a ``ready()`` method), one at a
    time each, the next to whichever finishes; ``submit(actor, start, stop)`` makes the call and returns
    its result reference, ``on_done(start, result)`` takes each result. Time limits and errors: module
    docstring."""
    queue = deque(chunks)
    made = time.monotonic()
    starting = {actor.ready.remote(): actor for actor in actors}
    running: dict[Any, ActorChunk] = {}  # result reference -> its chunk

    def hand(actor: Any, since: float | None) -> None:
        start, stop = queue.popleft()
        running[submit(actor, start, stop)] = ActorChunk(actor, start, stop, since)

    for actor in actors:
        if queue:
            hand(actor, None)
    while running:
        done, _ = ray.wait([*starting, *running], num_returns=1, timeout=POLL)
        if not done:
            check_lateness(running.values(), time.monotonic(), made, chunk_limit, start_limit, deadline,
                           labels)
            continue
        ref = done[0]
        if ref in starting:
            actor = starting.pop(ref)
            _result(ray, ref, labels, None)
            now = time.monotonic()
            for key, chunk in running.items():
                if chunk.actor is actor and chunk.since is None:
                    running[key] = chunk._replace(since=now)
            continue
        chunk = running.pop(ref)
        on_done(chunk.start, _result(ray, ref, labels, chunk))
        if queue:
            hand(chunk.actor, time.monotonic())


def check_lateness(running: Iterable[ActorChunk], now: float, made: float,
                   chunk_limit: Callable[[int], float], start_limit: float, deadline: float | None,
                   labels: BatchLabels) -> None:
    """:class:`WorkerTimeoutError` when a chunk's actor has been starting for more than ``start_limit`` s
    (since ``made``), a started chunk has run for more than ``chunk_limit(n)`` s, or ``deadline`` has
    passed (all ``time.monotonic()`` times)."""
    for chunk in running:
        starting = chunk.since is None
        elapsed = now - (made if starting else chunk.since)
        limit = start_limit if starting else chunk_limit(chunk.stop - chunk.start)
        late = elapsed > limit
        if late or (deadline is not None and now > deadline):
            why = f"{'start' if starting else 'chunk'} limit {limit:.1f} s" if late else "overall timeout"
            span = f"{labels.items}[{chunk.start}:{chunk.stop}]"
            state = f"has not started after {elapsed:.1f} s ({why}), so {span} never ran" if starting \
                else f"has not finished {span} after {elapsed:.1f} s ({why})"
            raise WorkerTimeoutError(f"{labels.prefix} a Ray actor {state}; every actor was killed")


def _result(ray: ModuleType, ref: Any, labels: BatchLabels, chunk: ActorChunk | None) -> Any:
    """``ray.get(ref)``; a kinserve error raised on the actor as it is (Ray's wrapper, an instance of the
    error's class carrying Ray's traceback as its text, is unwrapped to the error itself), any other failure
    (the actor died, its set-up or chunk raised) as :class:`WorkerError` naming the chunk (None: the actor's
    set-up)."""
    try:
        return ray.get(ref)
    except KinserveError as exc:
        cause = getattr(exc, "cause", None)
        if isinstance(cause, KinserveError):
            raise cause from None
        raise
    except ray.exceptions.RayError as exc:
        what = "its set-up" if chunk is None else f"{labels.items}[{chunk.start}:{chunk.stop}]"
        reason = str(exc).strip().splitlines()
        raise WorkerError(f"{labels.prefix} a Ray actor failed on {what}: "
                          f"{reason[-1] if reason else type(exc).__name__}; every actor was killed") from None


__all__ = ["ACTOR_START_LIMIT", "ActorChunk", "BatchLabels", "check_lateness", "run_on_actors",
           "run_on_new_actors"]
