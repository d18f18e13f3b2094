"""service.executor: admission, deadlines and release of the bounded executors (in-process, threads)."""

from __future__ import annotations

import asyncio
import pickle
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import pytest

from kinserve.kinematics.errors import InputError
from kinserve.service.executor import MIN_QUEUE_WAIT, BoundedExecutor, Deadline, ServiceBusy
from kinserve.service.fields import FieldError


def gated(gate: threading.Event):
    def job(deadline):
        gate.wait(5)
        return deadline.remaining
    return job


def test_a_full_queue_refuses_at_once_and_slots_come_back():
    async def main():
        ex = BoundedExecutor(lambda: ThreadPoolExecutor(1), workers=1, queue=1)
        gate = threading.Event()
        running = [asyncio.ensure_future(ex.run(gated(gate), Deadline(5))) for _ in range(2)]
        await asyncio.sleep(0.05)
        assert ex.admitted == 2
        t0 = time.perf_counter()
        with pytest.raises(ServiceBusy) as info:
            await ex.run(gated(gate), Deadline(5))
        assert time.perf_counter() - t0 < 0.05 and info.value.retry_after >= 1
        gate.set()
        await asyncio.gather(*running)
        await asyncio.sleep(0.01)
        assert ex.admitted == 0
        assert await ex.run(lambda d: 42, Deadline(1)) == 42
        ex.shutdown()

    asyncio.run(main())


def test_a_job_still_queued_at_its_deadline_is_dropped():
    async def main():
        ex = BoundedExecutor(lambda: ThreadPoolExecutor(1), workers=1, queue=4)
        gate = threading.Event()
        blocker = asyncio.ensure_future(ex.run(gated(gate), Deadline(5)))
        await asyncio.sleep(0.02)
        ran = []
        t0 = time.perf_counter()
        with pytest.raises(ServiceBusy, match="time cap"):
            await ex.run(lambda d: ran.append(1), Deadline(0.3))
        waited = time.perf_counter() - t0
        assert 0.3 <= waited < 0.3 * 1.1 + 0.05
        gate.set()
        await blocker
        await asyncio.sleep(0.05)
        assert not ran and ex.admitted == 0  # cancelled before it started, its slot released
        # a tiny cap still gets MIN_QUEUE_WAIT to reach a free worker
        assert await ex.run(lambda d: "ran", Deadline(1e-6)) == "ran"
        assert MIN_QUEUE_WAIT > 0
        ex.shutdown()

    asyncio.run(main())


def test_work_budget_counts_from_the_start_and_never_passes_the_deadline():
    async def main():
        ex = BoundedExecutor(lambda: ThreadPoolExecutor(1), workers=1, queue=1)
        left = await ex.run(lambda d: d.remaining, Deadline(10), 0.5)
        assert 0.4 < left <= 0.5
        left = await ex.run(lambda d: d.remaining, Deadline(0.2), 5.0)
        assert left <= 0.2
        with pytest.raises(ZeroDivisionError):  # a job's exception reaches the caller
            await ex.run(lambda d: 1 / 0, Deadline(1))
        await asyncio.sleep(0.01)
        assert ex.admitted == 0
        ex.shutdown()

    asyncio.run(main())


def test_errors_and_deadlines_cross_process_boundaries():
    err = pickle.loads(pickle.dumps(FieldError("spheres", InputError("bad sphere"), 422)))
    assert (err.field, str(err.error), err.status) == ("spheres", "bad sphere", 422)
    d = Deadline(3)
    d2 = pickle.loads(pickle.dumps(d))
    assert d2.at == d.at and d2.budget == 3
