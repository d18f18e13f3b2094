"""A fake clock for tests of time limits: it advances by a fixed step at every reading, so a time limit ends
after a fixed number of readings - on any machine, however busy.

:func:`stepping_clock` installs one :class:`SteppingClock` as ``time.perf_counter`` and ``time.monotonic``
and in place of every kinserve module attribute bound to either of them (``_now = time.perf_counter``);
everything is restored on exit. Only code that reads the clock through these names sees it (``asyncio``'s
event loop keeps its own reference: do not run an event loop under it).
"""

from __future__ import annotations

import contextlib
import sys
import time
from collections.abc import Iterator

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


@contextlib.contextmanager
def stepping_clock(step: float = 1e-3) -> Iterator[SteppingClock]:
    """A :class:`SteppingClock` of ``step`` seconds in place of the real clocks while the block runs."""
    clock = SteppingClock(step)
    patched = [(time, "perf_counter", time.perf_counter), (time, "monotonic", time.monotonic)]
    for name, module in list(sys.modules.items()):
        if name.startswith("kinserve") and module is not None:
            patched += [(module, attr, value) for attr, value in list(vars(module).items())
                        if any(value is real for real in REAL_CLOCKS)]
    for owner, attr, _ in patched:
        setattr(owner, attr, clock)
    try:
        yield clock
    finally:
        for owner, attr, value in patched:
            setattr(owner, attr, value)
