"""Typed public signatures: every public function and method of robots, kinematics and planners, and
of the ik modules in :data:`TYPED_IK`, annotates its parameters and its return type; py.typed ships
(see the wheel test).

Public: names not starting with ``_`` (plus ``__init__`` and ``__call__``), in public classes.
ik is being reshaped (tasks, constraints, solvers, batch); its modules join :data:`TYPED_IK` once
annotated, and the list may only grow.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("robots", "kinematics", "planners", "ik")  # every public signature of these is annotated
TYPED_IK = ("ik/analytic/planar.py", "ik/chooser.py", "ik/reachability.py", "ik/result.py", "ik/targets.py",
            # the IK model (issue 10)
            "ik/tasks/__init__.py", "ik/tasks/base.py", "ik/tasks/frame_task.py", "ik/tasks/posture_task.py",
            "ik/tasks/centring_task.py", "ik/constraints/__init__.py", "ik/constraints/base.py",
            "ik/constraints/joint_limits.py", "ik/constraints/velocity_limits.py", "ik/constraints/obstacles.py",
            "ik/constraints/link_capsules.py", "ik/constraints/segment_distance.py", "ik/problem.py", "ik/hierarchy.py",
            "ik/dense_qp.py", "ik/task_solver.py", "ik/multistart.py", "ik/step.py", "ik/qp_solver.py",
            # collision (issue 11)
            "ik/constraints/collision.py", "ik/collision_solve.py",
            # the front door, solvers, seeds and batch solving
            "ik/solve.py", "ik/centring.py", "ik/seeds.py", "ik/analytic/__init__.py", "ik/analytic/youbot.py",
            "ik/batch.py", "ik/batch_lm.py", "ik/ray_backend.py", "ik/qp_backends.py", "ik/lm_solver.py",
            "ik/classical.py", "ik/batch_worker.py", "ik/batch_pool.py", "ik/batch_runners.py",
            "ik/__init__.py", "ik/options.py")


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
    f.write_text("def f(a, b: int) -> int: ...\nclass C:\n    def g(self, x: int): ...\n    def _h(self, y): ...\n"
                 "def _private(z): ...\ndef k(*args, **kw) -> None: ...\nclass D:\n    def __init__(self, n): ...\n")
    assert unannotated(f) == ["f: a", "C.g: return", "k: args, kw", "D.__init__: n"]


@pytest.mark.parametrize("module", [*modules(), *TYPED_IK])
def test_public_signatures_are_annotated(module):
    assert unannotated(ROOT / module) == []
