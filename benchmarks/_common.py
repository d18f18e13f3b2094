"""Helpers shared by the benchmarks: timing, machine description, JSON output."""

from __future__ import annotations

import importlib.util
import json
import math
import os
import platform
import statistics
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

TESTS_DIR = Path(__file__).resolve().parents[1] / "tests"


def machine() -> dict:
    """What the figures were measured on."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(),
            "platform": platform.platform(), "date": time.strftime("%Y-%m-%d", time.gmtime())}


def per_call_seconds(fn, calls: int = 20000, repeats: int = 7) -> float:
    """Median over ``repeats`` of the mean time of one call, measured over ``calls`` calls."""
    samples = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(calls):
            fn()
        samples.append((time.perf_counter() - t0) / calls)
    return statistics.median(samples)


def cpu_per_call_seconds(fn: Callable[[], Any], calls: int, repeats: int = 5) -> float:
    """Smallest over ``repeats`` of the mean CPU time (``time.process_time``) of one call over ``calls``
    calls.

    CPU time, not wall time: on a shared machine the neighbours' time slices do not count.
    """
    best = math.inf
    for _ in range(repeats):
        c0 = time.process_time()
        for _ in range(calls):
            fn()
        best = min(best, (time.process_time() - c0) / calls)
    return best


def interleaved(solvers: dict, n: int, block: int, label: str = "") -> Iterator[tuple[str, Callable, int]]:
    """``(name, solver, item)`` for every solver and every item ``0..n-1``, in the benchmarks' fair order.

    Items go in blocks of ``block``; within a block each solver runs all its items, and the solver that
    goes first rotates from block to block, so no solver always meets the warm (or the noisy) machine
    first. A progress line is printed after each block.
    """
    names = list(solvers)
    t_all = time.perf_counter()
    for b, lo in enumerate(range(0, n, block)):
        hi = min(lo + block, n)
        for name in names[b % len(names):] + names[: b % len(names)]:
            for i in range(lo, hi):
                yield name, solvers[name], i
        prefix = f"[{label}] " if label else ""
        print(f"  {prefix}{hi}/{n} targets ({time.perf_counter() - t_all:.1f} s)", flush=True)


def timed(fn: Callable, *args: Any) -> tuple[Any, float, float | None]:
    """``(answer, wall s, CPU s)`` of one ``fn(*args)``.

    A peer worker (or a solver with untimed setup) reports its own measurement as ``fn.inner_time`` /
    ``fn.inner_cpu``; it replaces ours, which would count the pipe to the worker.
    """
    t0, c0 = time.perf_counter(), time.process_time()
    q = fn(*args)
    dt, dc = time.perf_counter() - t0, time.process_time() - c0
    inner = getattr(fn, "inner_time", None)
    if inner is None:
        return q, dt, dc
    return q, inner, getattr(fn, "inner_cpu", None)


def write_json(path: str | None, payload: dict) -> None:
    if path:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        Path(path).write_text(json.dumps(payload, indent=2))
        print(f"wrote {path}")


def load_test_helper(name: str) -> ModuleType:
    """A helper module of ``tests/`` (e.g. the reference lattice graph), loaded from its file.

    The benchmarks share these references with the tests without putting ``tests/`` on ``sys.path``.
    """
    spec = importlib.util.spec_from_file_location(f"_kinserve_test_helper_{name}", TESTS_DIR / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
