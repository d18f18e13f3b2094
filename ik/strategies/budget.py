"""A solve's budget: seconds on the clock and/or iterations of every start together.

A request with the option ``iteration_budget`` and no ``max_time`` never reads the clock to decide its
answer (the answer depends only on the inputs and the seed); otherwise ``max_time`` (or the method's default
of :mod:`kinserve.ik.options`) bounds the wall-clock time.
"""

from __future__ import annotations

import time
from typing import NamedTuple

from kinserve.ik.options import MAX_TIME_QP
from kinserve.ik.request import SolveRequest


class Budget(NamedTuple):
    """``seconds`` (None: no clock) and ``iterations`` (None: no cap) of one stage of a solve."""

    seconds: float | None
    iterations: int | None

    def keywords(self) -> dict:
        """The solver keywords of this budget (``max_time``, ``iteration_budget``)."""
        out: dict = {"max_time": self.seconds}
        if self.iterations is not None:
            out["iteration_budget"] = self.iterations
        return out

    def share(self, fraction: float) -> Budget:
        """A stage's part of this budget."""
        seconds = None if self.seconds is None else fraction * self.seconds
        iterations = None if self.iterations is None else max(1, int(fraction * self.iterations))
        return Budget(seconds, iterations)

    def after(self, t0: float, iterations_used: int) -> Budget:
        """What is left of this budget at the present moment, ``iterations_used`` iterations after ``t0``."""
        seconds = None if self.seconds is None else max(self.seconds - (time.perf_counter() - t0), 1e-3)
        iterations = None if self.iterations is None else max(1, self.iterations - iterations_used)
        return Budget(seconds, iterations)


def request_budget(req: SolveRequest, default_seconds: float = MAX_TIME_QP) -> Budget:
    """The budget of a request: its ``max_time`` (default ``default_seconds``, none with an iteration budget
    alone) and its ``iteration_budget`` option."""
    iterations = req.options.get("iteration_budget")
    if req.max_time is not None:
        return Budget(req.max_time, iterations)
    return Budget(None if iterations is not None else default_seconds, iterations)
