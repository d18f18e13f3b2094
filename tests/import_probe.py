"""Which modules a fresh interpreter has imported after running a piece of code (for the tests that keep light
entry points light: the command line, the error classes, a solver process before it follows its server)."""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path


def imported_after(code: str, modules: Sequence[str], cwd: str | Path | None = None) -> tuple[list[str], str]:
    """Those of ``modules`` that ``sys.modules`` holds once ``code`` has run in a new interpreter, and what
    ``code`` printed; an AssertionError with the interpreter's stderr when ``code`` fails."""
    probe = (f"{code}\nimport json as _json, sys as _sys\n"
             f"print(_json.dumps([m for m in {list(modules)!r} if m in _sys.modules]))\n")
    run = subprocess.run([sys.executable, "-c", probe], cwd=cwd, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    printed, _, last = run.stdout.rstrip("\n").rpartition("\n")
    return json.loads(last), printed
