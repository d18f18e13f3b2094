"""Clocks for tests of time limits that no machine load can sway.

* :func:`stepping_clock`: a fake clock that advances by a fixed step at every reading, so a time limit ends
  after a fixed number of readings - on any machine, however busy;
* :func:`cpu_clock`: the calling thread's CPU time (``time.thread_time``) as the clock, so a time limit
  counts the work done, not the time other programs hold the cores.

Both install their clock as ``time.perf_counter`` and ``time.monotonic`` and in place of every kinserve
module attribute bound to either (``_now = time.perf_counter``), and restore everything on exit (a kinserve
module imported inside the block and holding the replacement gets the real ``perf_counter`` back). Only code
that reads the clock through these names sees it: ``asyncio``'s event loop reads ``time.monotonic``, so do
not run one under them.
"""

from __future__ import annotations

import contextlib
import sys
import time
from collections.abc import Callable, Iterator

REAL_CLOCKS = (time.perf_counter, time.monotonic)


class SteppingClock:
    """Seconds that advance by ``step`` at each call; ``readings`` counts the calls."""

    def __init__(self, step: float) -> None:
        self.step = float(step)
        self.now = 0.0
        self.readings = 0

    def __call__(self) -> float:
        self.readings += 1
        self.now += self.step
        return self.now


def _kinserve_modules() -> list:
    return [m for name, m in list(sys.modules.items()) if name.startswith("kinserve") and m is not None]


@contextlib.contextmanager
def clock_replaced(clock: Callable[[], float]) -> Iterator[Callable[[], float]]:
    """``clock`` in place of the real clocks while the block runs (see the module docstring)."""
    patched = [(time, "perf_counter", time.perf_counter), (time, "monotonic", time.monotonic)]
    for module in _kinserve_modules():
        patched += [(module, attr, value) for attr, value in list(vars(module).items())
                    if any(value is real for real in REAL_CLOCKS)]
    for owner, attr, _ in patched:
        setattr(owner, attr, clock)
    try:
        yield clock
    finally:
        for owner, attr, value in patched:
            setattr(owner, attr, value)
        for module in _kinserve_modules():  # imported inside the block, holding the replacement
            for attr, value in list(vars(module).items()):
                if value is clock:
                    setattr(module, attr, REAL_CLOCKS[0])


@contextlib.contextmanager
def stepping_clock(step: float = 1e-3) -> Iterator[SteppingClock]:
    """A :class:`SteppingClock` of ``step`` seconds in place of the real clocks while the block runs."""
    with clock_replaced(SteppingClock(step)) as clock:
        yield clock


@contextlib.contextmanager
def cpu_clock() -> Iterator[Callable[[], float]]:
    """The calling thread's CPU seconds (``time.thread_time``) in place of the real clocks."""
    with clock_replaced(time.thread_time) as clock:
        yield clock
