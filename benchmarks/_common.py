"""Helpers shared by the benchmarks: timing, machine description, JSON output."""

from __future__ import annotations

import json
import os
import platform
import statistics
import importlib.util
import time
from pathlib import Path
from types import ModuleType

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
    return {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(), "platform": platform.platform()}


def per_call_seconds(fn, calls: int = 20000, repeats: int = 7) -> float:
    """Median over ``repeats`` of the mean time of one call, measured over ``calls`` calls."""
    samples = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(calls):
            fn()
        samples.append((time.perf_counter() - t0) / calls)
    return statistics.median(samples)


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
