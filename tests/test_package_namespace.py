"""One import package, ``kinserve``: proven for a built wheel, for the editable (dev) install, and in the
source.

- The wheel (``pip wheel --no-deps``, offline: ``--no-build-isolation``) holds
  ``kinserve/...`` and its ``.dist-info`` only; ``top_level.txt`` is ``kinserve``.
- Installed into a temporary target folder, ``kinserve.ik`` imports from there
  (run from a folder outside the repository) and ``ik`` / ``robots`` do not resolve.
- A user's folder with its own ``kinematics.py`` / ``robots.py`` next to the
  script does not break ``from kinserve import robots`` (issue 9).
- No file of the repository edits ``sys.path`` or ``PYTHONPATH``, or imports
  a bare ``robots`` / ``ik`` / ... module.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

import kinserve

ROOT = Path(__file__).resolve().parents[1]
SUBPACKAGES = ("robots", "kinematics", "ik", "planners", "viz", "scenarios", "service")
NOT_SHIPPED = (".venv", ".git", "build", "dist", "*.egg-info", "__pycache__", "demo-out", "bench-out",
               "tests", "benchmarks", ".pytest_cache", ".hypothesis", ".schemathesis")

#: Imports ``kinserve``, prints where from, and checks that no bare subpackage name resolves.
PROBE = """
import importlib.util, json, kinserve, kinserve.ik
from kinserve import robots
bare = {name: getattr(importlib.util.find_spec(name), "origin", None) for name in %r}
print(json.dumps({"file": kinserve.__file__, "ik": kinserve.ik.__file__, "version": kinserve.__version__,
                  "nq": robots.load("planar4r").nq, "bare": bare}))
""" % (SUBPACKAGES,)


def python(code: str, cwd: Path, **env: str) -> dict:
    import json

    out = subprocess.run([sys.executable, "-c", code], cwd=cwd, env={**os.environ, **env},
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """A wheel built from a copy of the source tree (the build never writes into the repository)."""
    work = tmp_path_factory.mktemp("wheel")
    src = work / "src"
    shutil.copytree(ROOT, src, ignore=shutil.ignore_patterns(*NOT_SHIPPED))
    out = subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation",
                          "--no-index", "-w", str(work / "dist"), str(src)], capture_output=True,
                         text=True, timeout=300)
    assert out.returncode == 0, out.stdout + out.stderr
    (whl,) = (work / "dist").glob("kinserve-*.whl")
    return whl


@pytest.fixture(scope="module")
def installed(wheel, tmp_path_factory) -> Path:
    """The wheel installed (no dependencies) into a temporary ``--target`` folder."""
    target = tmp_path_factory.mktemp("target")
    out = subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-index", "--target",
                          str(target), str(wheel)], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stdout + out.stderr
    return target


def test_wheel_top_level_is_kinserve_only(wheel):
    with zipfile.ZipFile(wheel) as z:
        names = z.namelist()
        dist_info = f"kinserve-{kinserve.__version__}.dist-info"
        assert z.read(f"{dist_info}/top_level.txt").decode().split() == ["kinserve"]
        record = z.read(f"{dist_info}/RECORD").decode().splitlines()
    tops = {name.split("/", 1)[0] for name in names}
    assert tops == {"kinserve", dist_info}, tops
    assert {line.split(",", 1)[0].split("/", 1)[0] for line in record} == tops
    # every subpackage is inside kinserve/, with its data files; tests and benchmarks are not shipped
    for sub in SUBPACKAGES:
        assert f"kinserve/{sub}/__init__.py" in names, sub
    assert "kinserve/__init__.py" in names and "kinserve/py.typed" in names
    assert any(n.startswith("kinserve/robots/models/") and n.endswith(".xacro") for n in names)
    assert any(n.startswith("kinserve/scenarios/data/") and n.endswith(".json") for n in names)
    assert not any("/tests/" in n or "/benchmarks/" in n or n.endswith("conftest.py") for n in names)


def test_installed_wheel_imports_as_kinserve_from_outside_the_repo(installed, tmp_path):
    info = python(PROBE, tmp_path, PYTHONPATH=str(installed))
    assert Path(info["file"]) == installed / "kinserve" / "__init__.py"
    assert Path(info["ik"]) == installed / "kinserve" / "ik" / "__init__.py"
    assert info["version"] == kinserve.__version__ and info["nq"] == 4
    assert info["bare"] == dict.fromkeys(SUBPACKAGES), info["bare"]  # `import ik` does not resolve
    assert sorted(p.name for p in installed.iterdir()
                  if not p.name.endswith(".dist-info")) in (["kinserve"], ["bin", "kinserve"])


def user_folder(tmp_path: Path) -> Path:
    """A user's project with modules named like kinserve's subpackages, and a script using kinserve."""
    folder = tmp_path / "user_project"
    folder.mkdir()
    (folder / "kinematics.py").write_text("WHO = 'the user'\n")
    (folder / "robots.py").write_text("WHO = 'the user'\n")
    (folder / "script.py").write_text(
        "import json, kinematics, robots as user_robots\n"
        "from kinserve import robots\n"
        "from kinserve.kinematics.errors import InputError\n"
        "print(json.dumps({'user': [kinematics.WHO, user_robots.WHO], 'nq': robots.load('scara').nq,\n"
        "                  'robots': robots.__name__}))\n")
    return folder


def run_script(folder: Path, **env: str) -> dict:
    import json

    out = subprocess.run([sys.executable, "script.py"], cwd=folder, env={**os.environ, **env},
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_installed_wheel_coexists_with_a_users_kinematics_module(installed, tmp_path):
    info = run_script(user_folder(tmp_path), PYTHONPATH=str(installed))
    assert info == {"user": ["the user", "the user"], "nq": 4, "robots": "kinserve.robots"}


def test_editable_install_imports_from_any_folder(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    out = subprocess.run([sys.executable, "-c", "import kinserve, kinserve.ik; print(kinserve.__file__)"],
                         cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert Path(out.stdout.strip()) == ROOT / "__init__.py"
    info = python(PROBE, tmp_path)
    assert info["bare"] == dict.fromkeys(SUBPACKAGES), info["bare"]
    assert info["nq"] == 4


def test_editable_install_coexists_with_a_users_kinematics_module(tmp_path):
    info = run_script(user_folder(tmp_path))
    assert info == {"user": ["the user", "the user"], "nq": 4, "robots": "kinserve.robots"}


# --------------------------------------------------------------- the source tree cannot regress
BARE = "|".join(SUBPACKAGES)
FORBIDDEN = {
    "sys.path edit": re.compile(r"\bsys\.path\s*(\.\s*(insert|append|extend|remove|pop|clear)\b"
                                r"|\+?=|\[[^\]]*\]\s*=)"),
    "site.addsitedir": re.compile(r"\baddsitedir\s*\("),
    # setting it (a keyword, an item assignment, setenv); removing it from a child's environment is fine
    "PYTHONPATH set": re.compile(r"PYTHONPATH\s*=|\[\s*[\"']PYTHONPATH[\"']\s*\]\s*=|[\"']PYTHONPATH[\"']\s*:"
                                 r"|setenv\(\s*[\"']PYTHONPATH"),
    "bare import": re.compile(rf"^\s*(import\s+({BARE})\b|from\s+({BARE})(\.\w+)*\s+import\b)", re.M),
    # a dotted module name in quotes, not a file name such as "ik.json"
    "bare module string": re.compile(rf"[\"'](-m\s+)?({BARE})\."
                                     r"(?!(json|csv|png|html|npz|md|txt|urdf|srdf|xacro|py)[\"'])"
                                     r"\w+(\.\w+)*(:\w+)?[\"']"),
    "python -m bare": re.compile(rf"python3?\s+-m\s+({BARE})\b"),
}


def source_files() -> list[Path]:
    skip = {".venv", ".git", "build", "dist", "demo-out", "bench-out", "__pycache__", ".pytest_cache",
            ".hypothesis"}
    files = []
    for dirpath, dirnames, filenames in os.walk(ROOT):
        dirnames[:] = [d for d in dirnames if d not in skip and not d.endswith(".egg-info")]
        files += [Path(dirpath) / f for f in filenames if f.endswith((".py", ".toml", ".cfg", ".ini", ".md"))
                  or f == "Makefile"]
    return files


def test_the_forbidden_patterns_are_caught():
    samples = {
        "sys.path edit": ["sys.path.insert(0, ROOT)", "sys.path.append('x')", "sys.path[:0] = [r]",
                          "sys.path += [r]"],
        "PYTHONPATH set": ["env = dict(os.environ, PYTHONPATH=ROOT)", "env['PYTHONPATH'] = x",
                           "monkeypatch.setenv('PYTHONPATH', r)"],
        "bare import": ["import robots", "from ik import solve", "from kinematics.errors import InputError",
                        "    import service.cli"],
        "bare module string": ['"service.app:app"', "'scenarios.planar4r'", '"ik.batch"'],
        "python -m bare": ["python -m service.cli fk panda"],
    }
    for kind, lines in samples.items():
        for line in lines:
            assert FORBIDDEN[kind].search(line), (kind, line)
    allowed = {"PYTHONPATH set": ['env.pop("PYTHONPATH", None)'],
               "bare module string": ['"kinematics.json"', "'ik.json'"]}
    for kind, lines in allowed.items():
        for line in lines:
            assert not FORBIDDEN[kind].search(line), (kind, line)
    for fine in ["from kinserve import robots", "from . import ik", "dirs = list(sys.path)",
                 "for entry in sys.path:", '"kinserve.service.app:app"', "python -m kinserve.service.cli",
                 "from .ik import x"]:
        assert not any(p.search(fine) for p in FORBIDDEN.values()), fine


def test_no_sys_path_edits_or_bare_imports_in_the_repository():
    this = Path(__file__).resolve()
    found = []
    for path in source_files():
        if path.resolve() == this:  # the patterns' own test samples
            continue
        text = path.read_text(encoding="utf-8", errors="replace")
        for kind, pattern in FORBIDDEN.items():
            if kind in ("bare import",) and path.suffix != ".py":
                continue
            for m in pattern.finditer(text):
                line = text.count("\n", 0, m.start()) + 1
                found.append(f"{path.relative_to(ROOT)}:{line}: {kind}: {m.group(0).strip()}")
    assert not found, "\n".join(found)
