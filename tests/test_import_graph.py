"""Every kinserve module imports, and the import graph of kinserve's modules has no cycle.

The graph is read from the source with ``ast``: an edge ``a -> b`` for every
``import`` / ``from ... import`` in module ``a`` (at any depth, function-level
imports included: a lazy import that dodges a circle at load time is still
a circle) that names kinserve module ``b``. ``from pkg import name`` points
at the submodule ``pkg.name`` when there is one, else at ``pkg``.
"""

import ast
import importlib
from pathlib import Path

import kinserve

ROOT = Path(kinserve.__file__).resolve().parent
SKIP = {"tests", "benchmarks", "build", "dist"}


def kinserve_modules() -> dict[str, tuple[Path, bool]]:
    """``{dotted name: (file, is package)}`` of every module of the installed kinserve tree."""
    mods = {}
    files = [ROOT / "__init__.py"] + [
        f for d in sorted(ROOT.iterdir())
        if d.is_dir() and d.name not in SKIP and (d / "__init__.py").exists() for f in d.rglob("*.py")
    ]
    for path in files:
        rel = path.relative_to(ROOT)
        if rel.parts[0] in SKIP or any(p.startswith(".") or p.endswith(".egg-info") for p in rel.parts):
            continue
        parts = list(rel.with_suffix("").parts)
        is_pkg = parts[-1] == "__init__"
        if is_pkg:
            parts = parts[:-1]
        if any(not (ROOT.joinpath(*parts[:k]) / "__init__.py").exists() for k in range(1, len(parts))):
            continue  # a folder that is not a package (data, scripts)
        mods[".".join(["kinserve", *parts])] = (path, is_pkg)
    return mods


def _targets(name: str, is_pkg: bool, node, mods) -> list[str]:
    if isinstance(node, ast.Import):
        names = [a.name for a in node.names]
    else:
        if node.level:
            base = name.split(".") if is_pkg else name.split(".")[:-1]
            base = base[: len(base) - (node.level - 1)]
            pkg = ".".join(base + ([node.module] if node.module else []))
        else:
            pkg = node.module or ""
        names = [f"{pkg}.{a.name}" if f"{pkg}.{a.name}" in mods else pkg for a in node.names]
    out = []
    for t in names:
        while t not in mods and "." in t:
            t = t.rsplit(".", 1)[0]
        if t in mods and t != name:
            out.append(t)
    return out


def _type_checking_only(tree: ast.AST) -> set[int]:
    """ids of the import nodes under ``if TYPE_CHECKING:`` (never executed, so no runtime edge)."""
    skip = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skip.update(id(n) for stmt in node.body for n in ast.walk(stmt))
    return skip


def import_graph(mods, type_only: bool = False) -> dict[str, set[str]]:
    """``{module: modules it imports}``; with ``type_only`` the imports under ``if TYPE_CHECKING:`` count
    too."""
    graph = {}
    for name, (path, is_pkg) in mods.items():
        edges = set()
        tree = ast.parse(path.read_text(), str(path))
        typing_only = set() if type_only else _type_checking_only(tree)
        for node in ast.walk(tree):
            if isinstance(node, (ast.Import, ast.ImportFrom)) and id(node) not in typing_only:
                edges.update(_targets(name, is_pkg, node, mods))
        graph[name] = edges
    return graph


def find_cycle(graph) -> list[str] | None:
    """One cycle ``[a, b, ..., a]`` of ``graph`` (depth-first search), or None."""
    state, stack = {}, []

    def visit(v):
        state[v] = "open"
        stack.append(v)
        for w in sorted(graph[v]):
            if state.get(w) == "open":
                return stack[stack.index(w):] + [w]
            if w not in state:
                found = visit(w)
                if found:
                    return found
        stack.pop()
        state[v] = "done"
        return None

    for v in sorted(graph):
        if v not in state:
            found = visit(v)
            if found:
                return found
    return None


def test_the_cycle_finder_finds_cycles():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": set()}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set(), "c": {"a", "b"}}) is None
    mods = {"kinserve.ik": (None, True), "kinserve.ik.batch.solve_many": (None, False),
            "kinserve.ik.batch.ray_backend": (None, False)}
    lazy = ast.parse("def f():\n    from .solve_many import run\n").body[0].body[0]
    assert _targets("kinserve.ik.batch.ray_backend", False, lazy, mods) == ["kinserve.ik.batch.solve_many"]


def test_every_module_imports_and_no_import_cycle():
    mods = kinserve_modules()
    assert {"kinserve.ik.batch.solve_many", "kinserve.ik.batch.ray_backend", "kinserve.kinematics.robot",
            "kinserve.service.app"} <= set(mods)
    for name in sorted(mods):
        importlib.import_module(name)
    graph = import_graph(mods)
    assert "kinserve.ik.batch.worker" in graph["kinserve.ik.batch.ray_backend"]
    assert find_cycle(graph) is None, " -> ".join(find_cycle(graph))


def _source_modules(tmp_path, sources: dict[str, str]) -> dict[str, tuple]:
    """Modules ``{dotted name: (file, False)}`` of a package ``pkg`` written from ``sources`` into
    ``tmp_path``."""
    (tmp_path / "pkg").mkdir()
    (tmp_path / "pkg" / "__init__.py").write_text("")
    mods = {"pkg": (tmp_path / "pkg" / "__init__.py", True)}
    for name, text in sources.items():
        path = tmp_path / "pkg" / f"{name}.py"
        path.write_text(text)
        mods[f"pkg.{name}"] = (path, False)
    return mods


def test_type_only_and_function_level_imports_are_edges(tmp_path):
    """A circle closed by an import under ``if TYPE_CHECKING:`` or inside a function is found when type-only
    imports count; an import under TYPE_CHECKING alone is no runtime edge."""
    mods = _source_modules(tmp_path, {
        "low": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .high import High\n",
        "high": "from .low import Low\n",
        "lazy": "def f():\n    from .user import g\n",
        "user": "from . import lazy\n",
    })
    assert import_graph(mods)["pkg.low"] == set()
    assert import_graph(mods, type_only=True)["pkg.low"] == {"pkg.high"}
    assert find_cycle(import_graph(mods, type_only=True)) in (["pkg.high", "pkg.low", "pkg.high"],
                                                                 ["pkg.lazy", "pkg.user", "pkg.lazy"])
    assert find_cycle(import_graph(mods)) == ["pkg.lazy", "pkg.user", "pkg.lazy"]


def test_kinematics_imports_one_way_even_through_type_only_imports():
    """kinserve.kinematics has no import circle, counting the imports under ``if TYPE_CHECKING:`` and those
    inside functions: the collision core is layered one way (sphere cover <- robot spheres <- pre-check <-
    layout <- scene <- model)."""
    mods = {name: entry for name, entry in kinserve_modules().items()
            if name == "kinserve.kinematics" or name.startswith("kinserve.kinematics.")}
    graph = import_graph(mods, type_only=True)
    assert {"kinserve.kinematics.collision_model", "kinserve.kinematics.collision_layout",
            "kinserve.kinematics.collision_scene", "kinserve.kinematics.sphere_cover"} <= set(graph)
    assert "kinserve.kinematics.collision_layout" in graph["kinserve.kinematics.collision_model"]
    cycle = find_cycle(graph)
    assert cycle is None, " -> ".join(cycle)
