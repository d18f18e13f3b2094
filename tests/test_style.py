"""The style contract (``[tool.ruff]`` in pyproject.toml) holds for the whole repository, and it has teeth.

- ``ruff check .`` from the repository root (what ``make lint`` runs) reports nothing.
- The configuration catches planted violations: an unused import (F401), a line over 110 characters
  (E501), unsorted imports (I001), an undocumented public function (D103), a function with 16 branches
  in ``ik/`` (C901) - so the repository check cannot pass because ruff checks nothing.
- Every top-level folder is checked (none excluded by mistake); ``.venv``, ``bench-out``, ``demo-out``
  are not.
- A clean file passes, docstrings are not required in ``tests/``, and ``make test`` runs ``make lint``.
"""

from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.skipif(importlib.util.find_spec("ruff") is None,
                                reason="ruff is not installed (pip install -e '.[test]')")

CLEAN = '''"""A module that follows the contract."""

import math

from kinserve.kinematics.errors import InputError


def hypotenuse(a: float, b: float) -> float:
    """Length of the hypotenuse of a right triangle with legs ``a`` and ``b`` (same unit)."""
    if a < 0 or b < 0:
        raise InputError(f"a, b: expected non-negative lengths, got {a}, {b}")
    return math.hypot(a, b)
'''

#: One ``if`` per branch: McCabe complexity 1 + 15 = 16, one over the limit of 15.
BRANCHY = '"""Planted."""\n\n\ndef choose(x: int) -> int:\n    """Planted."""\n' + "".join(
    f"    if x == {k}:\n        return {k}\n" for k in range(15)) + "    return -1\n"


def ruff(*args: str, stdin: str | None = None) -> subprocess.CompletedProcess:
    """``ruff check`` run from the repository root (so it reads the repository's pyproject.toml)."""
    return subprocess.run([sys.executable, "-m", "ruff", "check", "--no-cache", "--output-format", "concise",
                           *args], cwd=ROOT, input=stdin, capture_output=True, text=True, timeout=120)


def codes(out: subprocess.CompletedProcess) -> set[str]:
    """The rule codes reported in ruff's concise output (``path:line:col: CODE message``)."""
    return set(re.findall(r":\d+:\d+: ([A-Z]+[0-9]+) ", out.stdout))


def check_as(path: str, source: str) -> subprocess.CompletedProcess:
    """Lint ``source`` as if it were the repository file ``path`` (nothing is written into the tree)."""
    return ruff("--stdin-filename", path, "-", stdin=source)


def test_the_repository_has_no_violations():
    out = ruff(".")
    hint = "ruff check . found violations (`ruff check --fix` sorts imports; wrap long lines by hand)"
    assert out.returncode == 0, f"{hint}:\n{out.stdout}{out.stderr}"


def test_every_folder_is_checked_and_the_generated_ones_are_not():
    out = ruff("--show-files", ".")
    assert out.returncode == 0, out.stderr
    files = [Path(line).relative_to(ROOT) for line in out.stdout.splitlines() if line.endswith(".py")]
    folders = {f.parts[0] for f in files if len(f.parts) > 1}
    expected = {"robots", "kinematics", "ik", "planners", "viz", "scenarios", "service", "benchmarks",
                "tests"}
    assert expected <= folders, expected - folders
    assert Path("__init__.py") in files and Path("tests/test_style.py") in files
    assert not folders & {".venv", "bench-out", "demo-out"}


def test_a_planted_file_is_caught(tmp_path):
    planted = tmp_path / "planted.py"
    long_line = "    return " + " + ".join(["value"] * 30) + "\n"
    assert len(long_line) > 111
    planted.write_text('"""Planted."""\n\nimport os\n\n\ndef total(value: int) -> int:\n    """Planted."""\n'
                       + long_line, encoding="utf-8")
    out = ruff("--config", str(ROOT / "pyproject.toml"), str(planted))
    assert out.returncode == 1, out.stdout + out.stderr
    assert {"F401", "E501"} <= codes(out), out.stdout
    assert "planted.py:3:8: F401" in out.stdout and "planted.py:8:111: E501" in out.stdout


def test_a_clean_file_passes_and_each_planted_violation_is_caught():
    clean = check_as("planners/planted.py", CLEAN)
    assert clean.returncode == 0, clean.stdout
    unsorted = CLEAN.replace("import math\n\nfrom kinserve.kinematics.errors import InputError\n",
                             "from kinserve.kinematics.errors import InputError\nimport math\n")
    undocumented = CLEAN.replace('    """Length of the hypotenuse', '    # """Length of the hypotenuse')
    for source, code in ((unsorted, "I001"), (undocumented, "D103"), (CLEAN + "x = 1 \n", "W291")):
        out = check_as("planners/planted.py", source)
        assert out.returncode == 1 and code in codes(out), (code, out.stdout)


def test_complexity_is_limited_in_ik_and_docstrings_are_not_required_in_tests():
    out = check_as("ik/planted.py", BRANCHY)
    assert out.returncode == 1 and codes(out) == {"C901"}, out.stdout
    assert "(16 > 15)" in out.stdout
    fewer = BRANCHY.replace("    if x == 14:\n        return 14\n", "")
    assert check_as("ik/planted.py", fewer).returncode == 0
    test_module = "import math\n\n\ndef test_hypot():\n    assert math.hypot(3, 4) == 5\n"
    assert check_as("tests/test_planted.py", test_module).returncode == 0
    assert "D103" in codes(check_as("ik/planted.py", test_module))


def test_make_test_runs_the_lint_first():
    makefile = (ROOT / "Makefile").read_text(encoding="utf-8")
    (test_rule,) = re.findall(r"^test:(.*)$", makefile, flags=re.M)
    assert "lint" in test_rule.split()
    (lint_recipe,) = re.findall(r"^lint:.*\n\t(.*)$", makefile, flags=re.M)
    assert lint_recipe.strip() == "$(PY) -m ruff check ."
