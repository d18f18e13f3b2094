"""A/B of the IK benchmarks between an earlier revision and the working tree, in one run.

The earlier revision is exported with ``git archive`` into a temporary folder ``kinserve``; a link
``benchmarks/kinserve`` to that folder, beside its scripts, makes ``import kinserve`` find it before the
installed package (a script's own folder comes first on the import path). Each side runs its own copy of
``bench_ik``, ``bench_ik_constrained``, ``bench_collision`` and ``time_ik_step`` (the scripts as they were at
that revision), alternating ``--rounds`` times (base, head, base, head, ...) so that a slow stretch of a
shared machine falls on both. Peers come from ``bench-out/venvs`` (``make peers``) for both sides. Every
figure is the median over the rounds (the rounds' values are printed beside it); the ratio column is head /
base. Ratios to a solver measured in the same process (ik_LM, the unconstrained solve) are the robust figures:
the two sides run minutes apart.

    python benchmarks/ab_revision.py --base b69b75b [--rounds 2] [--out bench-out/ab]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: Each benchmark: its arguments (both sides) and the head-only ones (options the base did not have).
BENCHES = {
    "ik": (["benchmarks/bench_ik.py", "--n", "300", "--no-pink", "--batch-n", "2000"], ["--many-n", "1000"]),
    "cons": (["benchmarks/bench_ik_constrained.py", "--n", "150", "--no-mesh", "--step-calls", "1000"], []),
    "coll": (["benchmarks/bench_collision.py", "--n", "150", "--passes", "2", "--configs", "100",
              "--rounds", "3"], []),
    "step": (["benchmarks/time_ik_step.py", "400"], []),
}
#: ``--no-peers``: the options (both sides have them) that leave the peers' solvers out of each benchmark
#: whose rows are kinserve against kinserve; RTB's ``ik_LM`` in ``bench_ik`` stays (rows are ratios to it).
NO_PEERS = {"ik": ["--no-placo"], "cons": ["--no-pink", "--no-placo"], "coll": ["--no-pink", "--no-roboplan"],
            "step": []}
_A = "A: 3 spheres r 5 cm at 0.3/0.5/0.7 of shoulder->target"
_B = "B: 2 cubes 8 cm at 0.35/0.65 of shoulder->target"
#: The table: label, benchmark, path into its JSON, target.
ROWS = [
    ("same-start ik.solve median / ik_LM same start", "ik",
     ("per_solve", "auto (same start)", "median_vs_ik_LM_same_start"), "≤ 1.0"),
    ("same-start ik.solve median (ms)", "ik", ("per_solve", "auto (same start)", "median_ms"), ""),
    ("ik.solve (auto) median / ik_LM", "ik", ("per_solve", "auto", "median_vs_ik_LM"), "≤ 1.0"),
    ("ik.solve (auto) median (ms)", "ik", ("per_solve", "auto", "median_ms"), ""),
    ("solve_many, 1 process (targets/s)", "ik", ("solve_many", "one_process_targets_per_s"), ""),
    ("ik.solve one by one (targets/s)", "ik", ("solve_many", "ours_one_by_one_per_s"), ""),
    ("3 spheres: median / unconstrained", "cons", ("workloads", _A, "per_solver", "kinserve",
                                                   "median_vs_unconstrained"), "≤ 3"),
    ("3 spheres: p95 / unconstrained median", "cons", ("workloads", _A, "per_solver", "kinserve",
                                                       "p95_vs_unconstrained_median"), "≤ 10"),
    ("3 spheres: success % (witness-feasible)", "cons", ("workloads", _A, "per_solver", "kinserve",
                                                         "success_pct"), "≥ 99"),
    ("3 spheres: median (ms)", "cons", ("workloads", _A, "per_solver", "kinserve", "median_ms"), ""),
    ("3 spheres: unconstrained median (ms)", "cons", ("workloads", _A, "per_solver", "kinserve unconstrained",
                                                      "median_ms"), ""),
    ("2 cubes: median / unconstrained", "cons", ("workloads", _B, "per_solver", "kinserve",
                                                 "median_vs_unconstrained"), ""),
    ("2 cubes: median (ms)", "cons", ("workloads", _B, "per_solver", "kinserve", "median_ms"), ""),
    ("2 cubes: unconstrained median (ms)", "cons", ("workloads", _B, "per_solver", "kinserve unconstrained",
                                                    "median_ms"), ""),
    ("open scene: median / unconstrained", "coll", ("workloads", "open scene", "per_solver", "kinserve",
                                                    "median_vs_unconstrained"), "≤ 1.5"),
    ("open scene: median (ms)", "coll", ("workloads", "open scene", "per_solver", "kinserve", "median_ms"),
     ""),
    ("open scene: unconstrained median (ms)", "coll",
     ("workloads", "open scene", "per_solver", "kinserve unconstrained", "median_ms"), ""),
    ("open scene: success %", "coll", ("workloads", "open scene", "per_solver", "kinserve", "success_pct"),
     "100"),
    ("obstacle in the way: median / unconstrained", "coll",
     ("workloads", "obstacle in the way", "per_solver", "kinserve", "median_vs_unconstrained"), "≤ 5"),
    ("obstacle in the way: median (ms)", "coll",
     ("workloads", "obstacle in the way", "per_solver", "kinserve", "median_ms"), ""),
    ("obstacle in the way: unconstrained median (ms)", "coll",
     ("workloads", "obstacle in the way", "per_solver", "kinserve unconstrained", "median_ms"), ""),
    ("obstacle in the way: success %", "coll",
     ("workloads", "obstacle in the way", "per_solver", "kinserve", "success_pct"), "≥ 99"),
    ("ik.step, two levels (µs CPU)", "step", ("two levels (posture priority 2) us",), "≤ 100"),
    ("ik.step, bench_ik_constrained's step (µs CPU)", "step",
     ("bench_ik_constrained step (two levels, no velocity limits) us",), "≤ 100"),
    ("ik.step, one level (µs CPU)", "step", ("one level (posture priority 1) us",), ""),
]


def export(base: str, into: Path) -> Path:
    """The tree of revision ``base`` as ``into/kinserve`` (its benchmarks included), with the link
    ``benchmarks/kinserve`` to itself: its scripts import that tree."""
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", base, "--prefix=kinserve/"], check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    tree = into / "kinserve"
    (tree / "benchmarks" / "kinserve").symlink_to(tree, target_is_directory=True)
    return tree


def command(name: str, side: str, target: Path, no_peers: bool = False) -> list[str]:
    """The command line of benchmark ``name`` (:data:`BENCHES`) for one side, writing ``target`` (the step
    timing writes its own file); ``no_peers``: with :data:`NO_PEERS`' options."""
    args, head_only = BENCHES[name]
    extra = (head_only if side == "head" else []) + (NO_PEERS[name] if no_peers else [])
    return [sys.executable, *args, *extra] + ([] if name == "step" else ["--out", str(target)])


def run_side(side: str, tree: Path, round_: int, out: Path,
             benches: tuple[str, ...] = tuple(BENCHES), no_peers: bool = False) -> None:
    """The benchmarks ``benches`` (names of :data:`BENCHES`) of one side (the scripts of ``tree``), each one's
    JSON in ``out/<side>_<round>_<bench>.json`` (``no_peers``: :func:`command`)."""
    env = dict(os.environ, KINSERVE_BENCH_VENVS=str(ROOT / "bench-out" / "venvs"))
    for name in benches:
        target = out / f"{side}_{round_}_{name}.json"
        cmd = command(name, side, target, no_peers)
        with open(out / f"{side}_{round_}_{name}.txt", "w") as log:
            subprocess.run(cmd, cwd=tree, env=env, stdout=log, stderr=subprocess.STDOUT, check=False)
        if name == "step":  # (time_ik_step writes its own file)
            written = tree / "bench-out" / "ik_step_time.json"
            if written.exists():
                target.write_text(written.read_text())


def _get(d: object, path: tuple) -> object:
    for k in path:
        if not isinstance(d, dict) or k not in d:
            return None
        d = d[k]
    return d


def _values(out: Path, side: str, bench: str, path: tuple) -> list[float]:
    vals = []
    for f in sorted(out.glob(f"{side}_*_{bench}.json")):
        v = _get(json.loads(f.read_text()), path)
        if isinstance(v, (int, float)):
            vals.append(float(v))
    return vals


def _fmt(x: float | None) -> str:
    return "—" if x is None else (f"{x:,.0f}" if abs(x) >= 1000 else f"{x:.3g}")


def table(out: Path, base: str) -> str:
    """The A/B table (Markdown) of the JSON files in ``out``."""
    lines = [f"| figure | target | {base} | head | head / {base} |", "|---|---|---|---|---|"]
    for label, bench, path, target in ROWS:
        b, h = _values(out, "base", bench, path), _values(out, "head", bench, path)
        mb = statistics.median(b) if b else None
        mh = statistics.median(h) if h else None
        ratio = "—" if not mb or mh is None else f"{mh / mb:.2f}"
        lines.append(f"| {label} | {target} | {_fmt(mb)} ({', '.join(map(_fmt, b))}) | "
                     f"{_fmt(mh)} ({', '.join(map(_fmt, h))}) | {ratio} |")
    many = _values(out, "head", "ik", ("solve_many", "one_process_targets_per_s"))
    loop = _values(out, "head", "ik", ("solve_many", "ours_one_by_one_per_s"))
    if many and loop:
        lines.append("")
        lines.append(f"solve_many per process / a loop of ik.solve (head): "
                     f"{statistics.median(many) / statistics.median(loop):.2f} [target ≥ 2]")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--base", required=True, help="the earlier revision (a commit or tag)")
    ap.add_argument("--rounds", type=int, default=2, help="alternating rounds (default 2)")
    ap.add_argument("--out", default=str(ROOT / "bench-out" / "ab"), help="folder of the JSON files")
    ap.add_argument("--table-only", action="store_true", help="print the table of an earlier run")
    ap.add_argument("--benches", default=",".join(BENCHES),
                    help=f"comma-separated benchmarks to run (default: all of {', '.join(BENCHES)}); the "
                         "table also reads the files earlier runs left in --out")
    ap.add_argument("--no-peers", action="store_true",
                    help="leave the peers' solvers out (their solves between kinserve's change its caches); "
                         "RTB's ik_LM stays")
    args = ap.parse_args()
    benches = tuple(b for b in args.benches.split(",") if b)
    unknown = [b for b in benches if b not in BENCHES]
    if unknown:
        ap.error(f"unknown benchmark(s) {', '.join(unknown)}; expected some of {', '.join(BENCHES)}")
    out = Path(args.out).resolve()  # (the base's scripts run in its own tree)
    if not args.table_only:
        out.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory() as tmp:
            tree = export(args.base, Path(tmp))
            for r in range(1, args.rounds + 1):
                run_side("base", tree, r, out, benches, args.no_peers)
                run_side("head", ROOT, r, out, benches, args.no_peers)
                print(f"round {r}/{args.rounds} done", flush=True)
    print(table(out, args.base))


if __name__ == "__main__":
    main()
