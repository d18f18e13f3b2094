"""Typed public signatures: every public function and method of robots, kinematics, planners and ik
annotates its parameters and its return type; py.typed ships (see the wheel test).

Public: names not starting with ``_`` (plus ``__init__`` and ``__call__``), in public classes.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("robots", "kinematics", "planners", "ik")  # every public signature of these is annotated


def unannotated(path: Path) -> list[str]:
    """``"Class.method: x, return"`` for every public signature of ``path`` missing an annotation."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    missing = []

    def visit(node: ast.AST, prefix: str, in_class: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.ClassDef) and not child.name.startswith("_"):
                visit(child, f"{prefix}{child.name}.", True)
            elif isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                if child.name.startswith("_") and child.name not in ("__init__", "__call__"):
                    continue
                a = child.args
                params = [*a.posonlyargs, *a.args, *a.kwonlyargs]
                if in_class and params and params[0].arg in ("self", "cls") and not any(
                        isinstance(d, ast.Name) and d.id == "staticmethod" for d in child.decorator_list):
                    params = params[1:]
                params += [p for p in (a.vararg, a.kwarg) if p is not None]
                bad = [p.arg for p in params if p.annotation is None]
                if child.returns is None and child.name != "__init__":  # PEP 484: __init__ returns None
                    bad.append("return")
                if bad:
                    missing.append(f"{prefix}{child.name}: {', '.join(bad)}")

    visit(tree, "", False)
    return missing


def modules() -> list[str]:
    return sorted(str(p.relative_to(ROOT)) for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py"))


def test_the_checker_sees_missing_annotations(tmp_path):
    f = tmp_path / "m.py"
    f.write_text("def f(a, b: int) -> int: ...\nclass C:\n    def g(self, x: int): ...\n    def _h(self, y): "
                 "...\ndef _private(z): ...\ndef k(*args, **kw) -> None: "
                 "...\nclass D:\n    def __init__(self, n): ...\n")
    assert unannotated(f) == ["f: a", "C.g: return", "k: args, kw", "D.__init__: n"]


@pytest.mark.parametrize("module", modules())
def test_public_signatures_are_annotated(module):
    assert unannotated(ROOT / module) == []
