"""ab_revision.py: the export of an earlier revision and the A/B table (medians over rounds, head / base)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from benchmark_scripts import load_benchmark


def _ab():
    return load_benchmark("ab_revision")


def _write(folder: Path, side: str, r: int, bench: str, data: dict) -> None:
    (folder / f"{side}_{r}_{bench}.json").write_text(json.dumps(data))


def test_the_table_gives_medians_over_rounds_and_their_ratio(tmp_path):
    ab = _ab()
    same = ("per_solve", "auto (same start)", "median_vs_ik_LM_same_start")
    for r, (b, h) in enumerate([(0.8, 0.9), (1.0, 1.3), (0.9, 1.0)], start=1):
        for side, value, many, loop in (("base", b, 100.0, 10.0), ("head", h, 300.0 * r, 100.0)):
            _write(tmp_path, side, r, "ik", {
                "per_solve": {"auto (same start)": {"median_vs_ik_LM_same_start": value}},
                "solve_many": {"one_process_targets_per_s": many, "ours_one_by_one_per_s": loop}})
    assert ab._values(tmp_path, "base", "ik", same) == [0.8, 1.0, 0.9]
    text = ab.table(tmp_path, "abc123")
    row = next(line for line in text.splitlines() if line.startswith("| same-start ik.solve median / ik_LM"))
    cells = [c.strip() for c in row.split("|")[1:-1]]
    assert cells[2].startswith("0.9 (0.8, 1, 0.9)") and cells[3].startswith("1 (0.9, 1.3, 1)")
    assert cells[4] == f"{1.0 / 0.9:.2f}"
    missing = next(line for line in text.splitlines() if line.startswith("| open scene: median"))
    assert "— ()" in missing  # no such file: a dash, not an error
    assert "solve_many per process / a loop of ik.solve (head): 6.00" in text


def test_the_base_revision_is_exported_as_a_kinserve_folder(tmp_path):
    ab = _ab()
    root = Path(__file__).resolve().parents[1]
    if subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True).returncode:
        pytest.skip("not a git checkout")
    tree = ab.export("HEAD", tmp_path)
    assert tree == tmp_path / "kinserve"
    assert (tree / "benchmarks" / "bench_ik.py").is_file() and (tree / "ik" / "solve.py").is_file()
    # a script of the exported tree imports the exported kinserve, not the installed one
    (tree / "benchmarks" / "where.py").write_text("import kinserve\nprint(kinserve.__file__)\n")
    out = subprocess.run([sys.executable, str(tree / "benchmarks" / "where.py")], capture_output=True,
                         text=True, timeout=60, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert Path(out.stdout.strip()).resolve() == (tree / "__init__.py").resolve()


def test_no_peers_adds_only_options_both_sides_accept(tmp_path):
    """``--no-peers`` adds each benchmark's peer switches, on both sides, and the scripts of both sides (the
    head's, and b69b75b's read from git) declare every one of them."""
    ab = _ab()
    target = tmp_path / "x.json"
    for name in ab.BENCHES:
        plain, quiet = ab.command(name, "base", target), ab.command(name, "base", target, no_peers=True)
        assert [a for a in quiet if a not in plain] == ab.NO_PEERS[name]
        head = ab.command(name, "head", target, no_peers=True)
        assert set(ab.NO_PEERS[name]) <= set(head) and set(ab.BENCHES[name][1]) <= set(head)
    root = Path(__file__).resolve().parents[1]
    for name, options in ab.NO_PEERS.items():
        script = ab.BENCHES[name][0][0]
        shown = subprocess.run(["git", "-C", str(root), "show", f"b69b75b:{script}"], capture_output=True,
                               text=True)
        if shown.returncode:
            pytest.skip("b69b75b is not in this checkout")
        own = (root / script).read_text()
        for option in options:
            assert f'"{option}"' in shown.stdout and f'"{option}"' in own, (script, option)
