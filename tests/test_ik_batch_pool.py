"""kinserve.ik.batch.pool: a stalled (SIGSTOPped) worker raises a clear error in time and leaves no process;
a killed worker is replaced and its chunk retried once; BLAS is single-threaded in the workers.

The limits under test are the pool's own (a worker's chunk limit counts from when the chunk is handed out,
the worker's start-up included: the real CHUNK_SLACK of 10 s is kept); the checks are "not before the
limit" and "within a grace (HANG_GRACE) after it": only a missing limit takes that long, not a busy machine.
Polling for a state the pool reaches in milliseconds waits up to a minute.
"""

import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from kinserve import ik, robots
from kinserve.ik.batch import pool as batch_pool
from kinserve.ik.batch import runners as batch_runners
from kinserve.kinematics.errors import WorkerError, WorkerTimeoutError

HANG_GRACE = 10.0  # s after a limit by which the pool must have raised


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda", geometry=False)


@pytest.fixture
def slow_batch(panda):
    """200 unreachable targets solved one by one (yaw relaxed): each spends its whole 0.05 s budget."""
    poses = np.repeat(np.eye(4)[None], 200, axis=0)
    poses[:, :3, 3] = (3.0, 0.0, 0.5)
    return dict(robot=panda, targets=poses, relax=("yaw",), max_time=0.05, chunksize=10, processes=2,
                progress=False)


@pytest.fixture(autouse=True)
def no_process_left():
    yield
    pool = batch_pool.current_pool()
    pids = pool.pids() if pool is not None else []
    batch_pool.shutdown_pool()
    for pid in pids:  # anything still there is a leak: report it, and clean up
        assert not _exists(pid), f"worker {pid} left behind"


def _exists(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split(") ")[1][0] != "Z"
    except FileNotFoundError:
        return False


def _run_in_thread(kwargs):
    box = {}

    def target():
        t0 = time.monotonic()
        try:
            box["results"] = ik.solve_many(**kwargs)
        except BaseException as exc:
            box["error"] = exc
        box["elapsed"] = time.monotonic() - t0

    t = threading.Thread(target=target)
    t.start()
    return t, box


def _busy_worker(timeout=60.0, avoid=()):
    """(pid, (start, stop)) of a worker holding a chunk, once the run has started."""
    t_end = time.monotonic() + timeout
    while time.monotonic() < t_end:
        pool = batch_pool.current_pool()
        if pool is not None:
            for w in list(pool.workers):
                task = w.task
                if task is not None and w.process.pid not in avoid:
                    return w.process.pid, task[:2]
        time.sleep(0.01)
    raise AssertionError("no worker picked up a chunk")


def _release(pids):
    for pid in pids:
        try:
            os.kill(pid, signal.SIGCONT)
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass


def test_stopped_worker_raises_a_clear_error_and_is_reaped(slow_batch):
    thread, box = _run_in_thread(slow_batch)
    pid, (start, stop) = _busy_worker()
    pids = batch_pool.current_pool().pids()
    t_stop = time.monotonic()
    os.kill(pid, signal.SIGSTOP)
    try:
        thread.join(batch_pool.STOPPED_GRACE + HANG_GRACE)
        assert not thread.is_alive()
        detected = time.monotonic() - t_stop
    finally:
        _release([pid])
    err = box.get("error")
    assert isinstance(err, WorkerTimeoutError), box
    msg = str(err)
    assert f"worker process {pid}" in msg and "stopped" in msg and "targets[" in msg and "terminated" in msg
    assert batch_pool.STOPPED_GRACE <= detected < batch_pool.STOPPED_GRACE + HANG_GRACE
    assert not any(_exists(p) for p in pids)  # every worker killed and reaped, the stopped one too
    # the next batch gets a fresh pool
    again = ik.solve_many(slow_batch["robot"], slow_batch["targets"][:4], relax=("yaw",), max_time=0.01,
                          processes=2, progress=False)
    assert len(again) == 4 and not any(r.success for r in again)


def test_chunk_limit_and_overall_timeout(slow_batch, monkeypatch):
    monkeypatch.setattr(batch_pool, "STOPPED_GRACE", float("inf"))  # only the time limits can catch it now
    assert batch_runners.CHUNK_SLACK == 10.0  # chunk limit 3 * 10 * 0.05 + 10 = 11.5 s: room for a start-up
    thread, box = _run_in_thread(slow_batch)
    pid, _ = _busy_worker()
    os.kill(pid, signal.SIGSTOP)
    try:
        thread.join(11.5 + HANG_GRACE)
        assert not thread.is_alive()
    finally:
        _release([pid])
    assert isinstance(box.get("error"), WorkerTimeoutError)
    assert "chunk time limit of 11.5 s" in str(box["error"]) and f"worker process {pid}" in str(box["error"])
    assert not _exists(pid)

    # the caller's timeout= bounds the whole call (chunk limits are far away here)
    monkeypatch.setattr(batch_runners, "CHUNK_SLACK", 100.0)
    thread, box = _run_in_thread({**slow_batch, "timeout": 1.5})
    pid, _ = _busy_worker()
    os.kill(pid, signal.SIGSTOP)
    try:
        thread.join(1.5 + HANG_GRACE)
    finally:
        _release([pid])
    assert isinstance(box.get("error"), WorkerTimeoutError) and "overall timeout" in str(box["error"])
    assert 1.5 <= box["elapsed"] < 1.5 + HANG_GRACE


def test_killed_worker_is_retried_once(slow_batch):
    thread, box = _run_in_thread({**slow_batch, "targets": slow_batch["targets"][:60]})
    pid, chunk = _busy_worker()
    t_end = time.monotonic() + 60.0  # the parent may still be in the middle of handing them out
    while time.monotonic() < t_end and [len(w.queue) for w in batch_pool.current_pool().workers] != [2, 2]:
        time.sleep(0.002)
    # the next chunk too
    assert [len(w.queue) for w in batch_pool.current_pool().workers] == [batch_pool.PREFETCH] * 2
    os.kill(pid, signal.SIGKILL)  # the chunk it was solving is retried, the one behind it goes back in line
    thread.join(30)
    assert "error" not in box, box.get("error")
    res = box["results"]
    assert len(res) == 60 and all(r is not None and not r.success and r.position_error > 1.0 for r in res)


def test_a_chunk_that_kills_two_workers_raises(slow_batch):
    thread, box = _run_in_thread(slow_batch)
    pid, chunk = _busy_worker()
    os.kill(pid, signal.SIGKILL)
    # the chunk goes to the replacement worker first: kill that one on the same chunk
    t_end = time.monotonic() + 60.0
    second = None
    while second is None and time.monotonic() < t_end:
        pool = batch_pool.current_pool()
        for w in list(pool.workers if pool else []):
            task = w.task
            if task is not None and task[:2] == chunk and w.process.pid != pid:
                second = w.process.pid
        time.sleep(0.005)
    assert second is not None
    os.kill(second, signal.SIGKILL)
    thread.join(30)
    err = box.get("error")
    assert isinstance(err, WorkerError) and not isinstance(err, WorkerTimeoutError)
    assert f"targets[{chunk[0]}:{chunk[1]}]" in str(err) and "died twice" in str(err) and "-9" in str(err)


def test_workers_run_single_threaded_blas():
    code = (
        "import numpy, scipy.linalg\n"
        "from threadpoolctl import threadpool_info\n"
        "from kinserve.ik.batch.worker import limit_blas_threads\n"
        "before = max(i['num_threads'] for i in threadpool_info())\n"
        "limit_blas_threads()\n"
        "info = threadpool_info()\n"
        "print(before, len(info), max(i['num_threads'] for i in info))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={**os.environ, "OPENBLAS_NUM_THREADS": "2"}).stdout.split()
    before, libraries, after = map(int, out)
    assert before == 2 and libraries >= 1 and after == 1
