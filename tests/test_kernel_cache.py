"""The compiled kernels' on-disk cache: one key over every kernel source (kinserve.kinematics.kernel_cache).

Numba keys a cached function on its own file only, so a kernel inlining a primitive of another file would
keep stale machine code after the primitive changed. The test builds a primitive and a kernel in two files
of its own, in fresh processes: the second run loads the kernel from the cache, and after the primitive's
file changes the third run recompiles and returns the new value.
"""

from __future__ import annotations

import ast
import json
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from kinserve.kinematics import kernel_cache

ROOT = Path(kernel_cache.__file__).resolve().parents[1]

RUNNER = textwrap.dedent("""
    import json, sys
    from kinserve.kinematics.kernel_cache import kernel_set_locator
    kernel_set_locator([sys.argv[1] + "/prim_mod.py", sys.argv[1] + "/kern_mod.py"])
    import kern_mod
    value = kern_mod.kernel(1.0)
    stats = kern_mod.kernel.stats
    print(json.dumps({"value": value, "hits": sum(stats.cache_hits.values()),
                      "misses": sum(stats.cache_misses.values())}))
""")

PRIMITIVE = textwrap.dedent("""
    from kinserve.kinematics.kernel_cache import inline

    @inline
    def scale(x):
        return {factor} * x
""")

KERNEL = textwrap.dedent("""
    from kinserve.kinematics.kernel_cache import jit
    from prim_mod import scale

    @jit
    def kernel(x):
        return scale(x) + 1.0
""")


def _run(folder: Path) -> dict:
    # run in ``folder``: ``python -c`` imports the two modules from its working directory
    out = subprocess.run([sys.executable, "-c", RUNNER, str(folder)], capture_output=True, text=True,
                         timeout=300, check=True, cwd=folder)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_a_changed_primitive_recompiles_the_kernel_that_inlines_it(tmp_path):
    (tmp_path / "prim_mod.py").write_text(PRIMITIVE.format(factor="2.0"))
    (tmp_path / "kern_mod.py").write_text(KERNEL)
    first = _run(tmp_path)
    assert first["value"] == 3.0 and first["misses"] == 1
    second = _run(tmp_path)
    assert second["value"] == 3.0 and second["hits"] == 1, second  # the cache serves an unchanged set
    (tmp_path / "prim_mod.py").write_text(PRIMITIVE.format(factor="3.0"))  # only the primitive's file
    third = _run(tmp_path)
    assert third["value"] == 4.0 and third["hits"] == 0, third  # recompiled, not the stale code


_DECORATORS = ("jit", "inline", "leaf", "compiled", "_jit", "_inline", "_leaf")


def _compiled_modules() -> list[str]:
    """The modules of kinserve that decorate functions with Numba (directly or through kernel_cache)."""
    found = []
    for path in sorted(ROOT.rglob("*.py")):
        rel = path.relative_to(ROOT)
        if rel.parts[0] in ("tests", "benchmarks", "bench-out", "demo-out") or ".venv" in rel.parts:
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and any(
                    "njit" in ast.unparse(d) or ast.unparse(d).split("(")[0] in _DECORATORS
                    for d in node.decorator_list):
                found.append(str(path))
                break
    return found


def _kinserve_imports(path: str) -> set[str]:
    """The files of kinserve's modules that the module at ``path`` imports names from (``kernel_cache``, the
    locator itself, aside): constants and functions the compiled code may bake in."""
    tree = ast.parse(Path(path).read_text(encoding="utf-8"))
    package = Path(path).parent.relative_to(ROOT).parts
    out = set()
    for node in ast.walk(tree):
        if not isinstance(node, ast.ImportFrom) or node.module is None and not node.level:
            continue
        if node.level:
            parts = [*package[:len(package) - node.level + 1], *(node.module or "").split(".")]
        elif node.module.startswith("kinserve."):
            parts = node.module.split(".")[1:]
        else:
            continue
        target = ROOT.joinpath(*[p for p in parts if p])
        for alias in node.names:  # ``from package import module`` reads the module, not the package
            module = target / f"{alias.name}.py"
            found = module if module.exists() else next(
                (c for c in (target.with_suffix(".py"), target / "__init__.py") if c.exists()), None)
            if found is not None and found.name != "kernel_cache.py":
                out.add(str(found))
    return out


def test_every_module_with_compiled_code_and_what_it_reads_shares_the_kernel_key():
    """KERNEL_FILES = the modules with compiled code plus the kinserve modules they import names from (a
    constant of another file is baked into the machine code: changing it must recompile too)."""
    modules = _compiled_modules()
    assert len(modules) >= 5, modules
    read = set().union(*map(_kinserve_imports, modules))
    assert str(ROOT / "kinematics/obstacle_table.py") in read  # the parser finds what the kernels read
    expected = set(modules) | read
    assert set(kernel_cache.KERNEL_FILES) == expected, (sorted(expected), kernel_cache.KERNEL_FILES)
    assert all(Path(f).exists() for f in kernel_cache.KERNEL_FILES)


def test_each_compiled_primitive_is_written_once():
    """Rodrigues' formula and the tree's forward kinematics live in kernel_primitives only."""
    signature = "c + v * ax * ax, v * ax * ay - s * az"  # the first row of Rot(a, q)
    tree_step = "out[9 + i] = P[9 + i] + p0 * g[9]"
    holders = {s: [f for f in kernel_cache.KERNEL_FILES if s in Path(f).read_text()]
               for s in (signature, tree_step)}
    assert holders == {s: [str(ROOT / "kinematics/kernel_primitives.py")] for s in holders}, holders


def test_the_signatures_array_types_are_defined_once():
    """The read-only array types of every kernel's signature are kernel_cache's (F1, F2, I1, ...): no kernel
    file spells one out again."""
    spelled = [f for f in kernel_cache.KERNEL_FILES if "readonly=True" in Path(f).read_text()]
    assert spelled == [], spelled
    assert "readonly=True" in Path(kernel_cache.__file__).read_text()
    assert kernel_cache.F2_ANY.layout == "A" and kernel_cache.F1.layout == "C" and kernel_cache.I2.ndim == 2


def test_compile_all_imports_every_kernel_file_as_its_module():
    """``compile_all`` (what ``make test`` runs before the suite) imports the module of every kernel file:
    the names it returns are those modules, loaded from exactly those files."""
    names = kernel_cache.compile_all()
    assert len(names) == len(kernel_cache.KERNEL_FILES)
    for name, path in zip(names, kernel_cache.KERNEL_FILES):
        assert name.startswith("kinserve.") and Path(sys.modules[name].__file__).resolve() == Path(path)


LEAF_RUNNER = textwrap.dedent("""
    import json, re
    import numpy as np
    import leaf_mod  # (from the working directory: the test's folder)
    X, pairs = np.arange(8.0).reshape(4, 2), np.array([3, 1, 2, 0])

    def counts(dispatcher):  # calls of the reference-count functions in the function's own machine code
        text = next(iter(dispatcher.inspect_llvm().values()))
        return len(re.findall(r"call .*@NRT_(?:incref|decref)\\(", text))

    answers = []
    for margin in (leaf_mod.margin_leaf, leaf_mod.margin_jit):
        W = np.zeros((4, 2))
        answers.append([margin(X, W, pairs), W.tolist(), counts(margin)])
    try:
        leaf_mod.allocating(X[0])
        refused = ""
    except Exception as exc:  # Numba's typing error: no NRT, no allocation
        refused = type(exc).__name__
    print(json.dumps({"leaf": answers[0], "jit": answers[1], "refused": refused}))
""")

#: The pattern of the pre-check's certificate: a loop over pairs calling a compiled function and an inlined
#: helper that takes a row view, with an early return; once as a leaf, once as jit.
LEAF_BODY = """
    m = 1.0
    for p in range(pairs.shape[0]):
        _touch(X, W, pairs[p])
        m = min(m, _row_sum(W, pairs[p]))
        if m < -10.0:
            return -1.0 - p
    return m
"""
LEAF_MODULE = textwrap.dedent("""
    import numpy as np
    from kinserve.kinematics.kernel_cache import inline, jit, leaf

    @jit
    def _touch(X, W, i):
        W[i, 0] = X[i, 0] + W[i, 1]

    @inline
    def _row_sum(X, i):
        row = X[i]
        return row[0] + row[1]

    @leaf
    def margin_leaf(X, W, pairs):{body}
    @jit
    def margin_jit(X, W, pairs):{body}
    @leaf
    def allocating(x):
        return np.empty(x.shape[0]).sum()
""").format(body=textwrap.indent(LEAF_BODY, "    "))


def test_a_leaf_counts_no_references_and_refuses_to_allocate(tmp_path):
    """``leaf`` (the pre-check's hot helpers): the same answers and writes as ``jit``, without the calls of
    Numba's reference counting that ``jit`` leaves in a function of this shape (the certificate's: a loop
    calling a compiled function, a row view, an early return; their absence is what the decorator is for),
    and Numba refuses to compile a leaf that allocates. A fresh cache folder: the machine code is compiled in
    the process, so it can be inspected."""
    (tmp_path / "leaf_mod.py").write_text(LEAF_MODULE)
    out = subprocess.run([sys.executable, "-c", LEAF_RUNNER], capture_output=True, text=True, timeout=300,
                         check=True, cwd=tmp_path)
    got = json.loads(out.stdout.strip().splitlines()[-1])
    X = np.arange(8.0).reshape(4, 2)
    W = np.zeros((4, 2))
    for i in (3, 1, 2, 0):  # the same loop in NumPy
        W[i, 0] = X[i, 0] + W[i, 1]
    expected = min(1.0, *(W[i].sum() for i in (3, 1, 2, 0)))
    assert got["leaf"][:2] == got["jit"][:2] == [expected, W.tolist()], got
    assert got["jit"][2] > 0 and got["leaf"][2] == 0, got
    assert got["refused"], got  # the allocating leaf did not compile


def test_an_entry_point_is_the_kernels_machine_code_without_dispatch_or_the_kernel_itself():
    """``entry_point`` gives the compiled function of a one-signature kernel, not its dispatcher, with the
    dispatcher's answers; a compiled result without an entry point (a Numba that no longer offers it) gives
    the dispatcher back, and a kernel of several signatures is refused."""
    from types import SimpleNamespace

    from kinserve import robots
    from kinserve.kinematics import precheck_kernels as pk
    from kinserve.kinematics.shapes import Box

    robot = robots.load("panda")
    pose = np.eye(4)
    pose[:3, 3] = (0.45, 0.0, 0.45)
    pre = robot.collision_scene((Box(pose, (0.3, 0.6, 0.05)),)).precheck()
    certify = kernel_cache.entry_point(pk.certify_configuration)
    assert certify is not pk.certify_configuration and not hasattr(certify, "overloads")
    Q = robot.random_q(np.random.default_rng(4), 200)
    answers = [certify(pre.floats, pre.ints, q, pre.tolerance) for q in Q]
    assert answers == [pk.certify_configuration(pre.floats, pre.ints, q, pre.tolerance) for q in Q]
    assert any(answers) and not all(answers)
    fake = SimpleNamespace(overloads={"signature": SimpleNamespace()})
    assert kernel_cache.entry_point(fake) is fake
    with pytest.raises(RuntimeError, match="2 compiled signatures"):
        kernel_cache.entry_point(SimpleNamespace(overloads={"a": SimpleNamespace(), "b": SimpleNamespace()}))
