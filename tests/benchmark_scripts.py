"""The benchmark scripts of ``benchmarks/`` (not installed) loaded from their files for the tests.

They import each other by bare name, so a script is registered in ``sys.modules`` under the name it is
loaded as (its siblings find it there; dataclasses also look their module up while a class is built). No
``sys.path`` edit. ``benchmarks/_common.load_test_helper`` does the same the other way.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

#: The folder of the benchmark scripts.
BENCH = Path(__file__).resolve().parents[1] / "benchmarks"


def load_benchmark(name: str, module_name: str | None = None) -> ModuleType:
    """``benchmarks/<name>.py`` loaded from its file, registered as ``module_name`` (default ``name``, the
    name its siblings import it by) and returned."""
    module_name = name if module_name is None else module_name
    spec = importlib.util.spec_from_file_location(module_name, BENCH / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[module_name] = module
    spec.loader.exec_module(module)
    return module
