"""Render the benchmark tables (Markdown) of docs/benchmarks.md from the JSON files ``make bench`` writes.

    .venv/bin/python benchmarks/render_tables.py bench-out [--out bench-out/tables.md] \
        [--docs docs/benchmarks.md]

Reads ``ik.json`` (bench_ik.py), ``ik_constrained.json`` (bench_ik_constrained.py),
``collision.json`` (bench_collision.py), ``motion.json`` and ``motion_pose.json`` (bench_motion.py, the
second with ``--pose-goals``) and ``clutter.json`` (bench_clutter.py) when present and prints one section
per file: the per-solver table (success, median / p95 / mean, ratios) with the issue's targets in brackets
and whether the run met them. "CPU" columns are ``time.process_time`` around each solve (the worker's own,
for peers in their venvs): on a shared machine a long solve is preempted, so wall times of long
solves swell while short ones do not - read the CPU ratios alongside. Any other JSON file in
the folder is listed with its numeric figures flattened (``a.b.c = value``), so
nothing measured is left out. Missing files are skipped with a note. The numbers
are copied, never recomputed: the page shows what the run wrote. ``--docs`` writes each file's table into
its own generated section of the page (``<!-- ik:begin ... -->`` .. ``<!-- ik:end -->``, and ``other`` for
the flattened files); a file the folder lacks leaves its section as it was, with the date of its own run.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path


def _ms(v) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "–"
    return f"{v:.3f} ms" if v < 10 else f"{v:.1f} ms"


def _pct(v) -> str:
    return "–" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.1f} %"


def _x(v) -> str:
    return "–" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.2f}×"


def _machine(d: dict) -> str:
    m = d.get("machine", {})
    date = f", measured {m['date']}" if m.get("date") else ""
    return f"_{m.get('cpu', '?')}, {m.get('cores', '?')} cores, Python {m.get('python', '?')}{date}_"


def _targets(d: dict) -> list[str]:
    t = d.get("targets_met") or {}
    if not t:
        return []
    return ["", "Targets: " + ", ".join(f"`{k}` {'met' if v else '**not met**'}" for k, v in t.items())]


def render_ik(d: dict) -> list[str]:
    w = d["workload"]
    out = [f"### IK (bench_ik.py): Panda `{w['frame']}`, {w['n']} targets, seed {w['seed']}", "",
           _machine(d), "",
           "| solver | success | median | p95 | mean | median / ik_LM | median / ik_LM same start |",
           "|---|---|---|---|---|---|---|"]
    for k, s in d["per_solve"].items():
        out.append(f"| {k} | {_pct(s['success_pct'])} | {_ms(s['median_ms'])} | {_ms(s['p95_ms'])} | "
                   f"{_ms(s['mean_ms'])} | {_x(s.get('median_vs_ik_LM'))} | "
                   f"{_x(s.get('median_vs_ik_LM_same_start'))} |")
    sm = d.get("solve_many")
    if sm:
        out += ["", f"solve_many on {sm['processes']} processes: {sm['targets_per_s']:,.0f} targets/s "
                    f"({_x(sm['ratio_vs_ik_LM'])} ik_LM one by one; machine delivers "
                    f"{sm['machine_parallel_scaling_2_processes']:.2f}× on 2 processes)"]
    ss = d.get("same_start")
    if ss:
        out += ["", "Same start = the start kinserve picks first (a table sample for "
                    f"{ss['table_start_pct']:.0f} % of the targets); PlaCo: {ss['placo']}."]
    return out + _targets(d)


def render_ik_constrained(d: dict) -> list[str]:
    w = d["workload"]
    out = [f"### IK with obstacles (bench_ik_constrained.py): Panda `{w['frame']}`, {w['n']} targets, "
           f"budget {w['budget_s']} s with restarts", "", _machine(d), ""]
    for note in d.get("notes", []):
        out.append(f"- {note}")
    for name, r in d["workloads"].items():
        out += ["", f"**{name}**: figures over the {r['witness_feasible']} witness-feasible targets of "
                    f"{r['n']} (success over all targets in the third column)", "",
                "| solver | success [≥ 99 %] | all targets | mesh-clear | median | p95 | mean | median / "
                "unconstrained [≤ 3×] | p95 / unconstrained [≤ 10×] | p95 / unconstrained p95 | median CPU | "
                "CPU / unconstrained |",
                "|---|---|---|---|---|---|---|---|---|---|---|---|"]
        for k, s in r["per_solver"].items():
            out.append(f"| {k} | {_pct(s['success_pct'])} | {_pct(s.get('success_all_targets_pct'))} "
                       f"| {_pct(s.get('mesh_clear_pct'))} | {_ms(s['median_ms'])} | {_ms(s['p95_ms'])} "
                       f"| {_ms(s['mean_ms'])} | {_x(s['median_vs_unconstrained'])} "
                       f"| {_x(s.get('p95_vs_unconstrained_median'))} | {_x(s['p95_vs_unconstrained_p95'])} "
                       f"| {_ms(s.get('median_cpu_ms'))} | {_x(s.get('median_cpu_vs_unconstrained'))} |")
    steps = d.get("step_us") or {}
    if steps:
        out += ["", "| one control step | µs |", "|---|---|"]
        out += [f"| {k} | {v:.1f} |" for k, v in steps.items()]
    return out + _targets(d)


def render_collision(d: dict) -> list[str]:
    w = d["workload"]
    passes = w.get("passes", 1)
    out = [f"### Collision-aware IK (bench_collision.py): {w['robot']}, table + wall, "
           f"budget {w['budget_s']} s",
           "", _machine(d), "", f"Starts in collision: {w['starts_in_collision_pct']:.1f} %."
           + (f" {passes} passes over the targets: a target's time is the median of its passes (success over "
              "every answer); the last column is the first pass alone." if passes > 1 else "")]
    for name, r in d["workloads"].items():
        extra = (f", from {r['collision_free_draws']} collision-free draws"
                 if "collision_free_draws" in r else "")
        out += ["", f"**{name}** ({r['n']} targets{extra})", "",
                "| solver | success | median | p95 | mean | median / unconstrained | p95 / unconstrained p95 "
                "| median CPU | CPU / unconstrained | pass 1: median / unconstrained |",
                "|---|---|---|---|---|---|---|---|---|---|"]
        for k, s in r["per_solver"].items():
            out.append(f"| {k} | {_pct(s['success_pct'])} | {_ms(s.get('median_ms'))} | "
                       f"{_ms(s.get('p95_ms'))} | {_ms(s.get('mean_ms'))} | "
                       f"{_x(s.get('median_vs_unconstrained'))} | {_x(s.get('p95_vs_unconstrained_p95'))} | "
                       f"{_ms(s.get('median_cpu_ms'))} | {_x(s.get('median_cpu_vs_unconstrained'))} "
                       f"| {_x(s.get('median_vs_unconstrained_first_pass'))} |")
    checks = d.get("collision_check_us") or {}
    if checks:
        out += ["", "| collision check (self + scene) | µs per call | CPU µs per call |", "|---|---|---|"]
        for k, v in checks.items():
            if not k.endswith((": pairs", ": CPU")):
                cpu = checks.get(f"{k}: CPU")
                out.append(f"| {k} | {v:.1f} | {'–' if cpu is None else f'{cpu:.1f}'} |")
    return out + _targets(d)


def _solved(f: dict) -> str:
    """``"within/n"``, with ``" (+k late)"`` when k paths came back after the budget."""
    within = f.get("within_budget", f["solved"])
    late = f["solved"] - within
    return f"{within}/{f['n']}" + (f" (+{late} late)" if late else "")


def _set_rows(d: dict, row) -> list[str]:
    """The rows of a motion table: ``row(label, planner, figures)`` overall, then per set."""
    rows = [row("**all**", name, f) for name, f in d["overall"].items()]
    return rows + [row(label, name, f) for label, per_planner in d["per_set"].items()
                   for name, f in per_planner.items()]


def _motion_row(label: str, name: str, f: dict) -> str:
    def pair(key: str) -> str:
        return f"{_ms(f.get(key + '_median_ms'))} / {_ms(f.get(key + '_p95_ms'))}"

    length = "–" if f.get("length_median") is None else f"{f['length_median']:.2f}"
    duration = "–" if f.get("duration_median_s") is None else f"{f['duration_median_s']:.2f} s"
    solved = _solved(f)
    return (f"| {label} | {name} | {solved} | {pair('plan')} | {pair('simplify')} | "
            f"{pair('total')} | {length} | {f['invalid']}/{f['checked']} | {duration} | "
            f"{_ms(f.get('toppra_median_ms'))} |")


def render_motion(d: dict) -> list[str]:
    """The MotionBenchMaker table of bench_motion.py: per set and overall, every planner of the run."""
    w = d["workload"]
    check = w.get("dense_check", {})
    out = [f"### Motion planning (bench_motion.py): MotionBenchMaker Panda, {w['problems']} problems, "
           f"{w['max_time_s']} s per problem", "", _machine(d), "",
           f"Peers: {', '.join(f'{k}: {v}' for k, v in w.get('peer_versions', {}).items()) or 'none'}. "
           f"Solved = a path returned with plan + simplify within the budget (+ late: returned after it). "
           f"Times are each planner's own, around its plan and simplify calls; total = plan + simplify; "
           f"median / p95 over every returned path. Invalid = returned paths that the dense check "
           f"(Pinocchio + coal on the dataset's meshes, steps <= {check.get('step_rad', 5e-4) * 1e3:g} mrad "
           f"per joint) rejects, of those checked. Targets (kinserve): >= 699/700 solved, 0 invalid, median "
           f"total <= 10 ms (roboplan 39 ms on this machine type), cage median total <= 25 ms, median length "
           f"<= roboplan's; stretch <= 3.3 ms (VAMP 0.33 ms).", "",
           "| set | planner | solved | plan median / p95 | simplify median / p95 | total median / p95 | "
           "length (rad) | invalid | trajectory | TOPP-RA |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    return out + _set_rows(d, _motion_row) + _targets(d)


def _pose_row(label: str, name: str, f: dict) -> str:
    solved = _solved(f)
    goals = "pose" if "ik_median_ms" in f else "joint"
    ik = f"{_ms(f.get('ik_median_ms'))} / {_ms(f.get('ik_p95_ms'))}" if goals == "pose" else "–"
    missed = f"{f['pose_missed']}/{f['solved']}" if "pose_missed" in f else "–"
    sizes = "–" if f.get("goal_set_median") is None else f"{f['goal_set_median']:g}"
    return (f"| {label} | {goals} ({name}) | {solved} | {_ms(f.get('total_median_ms'))} / "
            f"{_ms(f.get('total_p95_ms'))} | {ik} | {_ms(f.get('plan_median_ms'))} | "
            f"{_ms(f.get('simplify_median_ms'))} | {sizes} | {f['invalid']}/{f['checked']} | {missed} |")


def _load(d: dict) -> str:
    """A sentence on the machine's load average at the end of the run ("" when the JSON has none)."""
    load = d.get("machine", {}).get("load_average")
    if not load:
        return ""
    return (f" The machine was shared with other jobs: load average {', '.join(f'{x:.1f}' for x in load)} "
            f"(1, 5, 15 min) at the end of the run, on {d['machine'].get('cores', '?')} cores.")


def render_motion_pose(d: dict) -> list[str]:
    """bench_motion.py --pose-goals: kinserve on the joint goals and on the goal poses, per set, overall."""
    w = d["workload"]
    out = [f"### Motion planning to pose goals (bench_motion.py --pose-goals): MotionBenchMaker Panda, "
           f"{w['problems']} problems, {w['max_time_s']} s per problem", "", _machine(d), "",
           "The same problems twice in one run, problem after problem: the joint goal, and the pose of the "
           "robot's tip at that goal configuration (FK), which `plan_motion` turns into a goal set of up to "
           "4 collision-free IK solutions more than 0.5 rad apart. Solved = a path returned with IK + plan + "
           "simplify within the budget (+ late: after it); total = IK + plan + simplify, median / p95 over "
           "every returned path; IK = the pose goal's IK time, median / p95 over every problem. Goal set = "
           "median size. Invalid = returned paths the dense check rejects; pose missed = returned paths "
           "whose last waypoint is more than 1e-4 m / 1e-3 rad off the pose." + _load(d), "",
           "| set | goals | solved | total median / p95 | IK median / p95 | plan median | simplify median | "
           "goal set | invalid | pose missed |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    return out + _set_rows(d, _pose_row)


def _us(v) -> str:
    return "–" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.1f} µs"


def _clutter_row(label: str, f: dict, per_q: str = "per_configuration") -> str:
    first, second, q = f.get("first_check"), f.get("second_check"), f[per_q]
    head = "– | –" if first is None else \
        f"{_us(first['median_us'])} / {_us(first['p95_us'])} | {_us(second['median_us'])}"
    return (f"| {label} | {f['scenes']} | {f['configurations']} | {head} | {_us(q['median_us'])} / "
            f"{_us(q['p95_us'])} | {_us(q['mean_us'])} | {_pct(100 * f['in_collision_share'])} |")


def first_check_for_target(figures_of_checker: dict) -> tuple[str, dict]:
    """The first-check figures the clutter target reads, and their name: the pass of its own (bench_clutter's
    (d)) when the run has one, else the run's first checks (a run of kinserve alone is a pass of its own)."""
    if "first_check_alone" in figures_of_checker:
        return "first_check_alone", figures_of_checker["first_check_alone"]
    return "first_check", figures_of_checker["first_check"]


def host_latency(machine: dict) -> list[tuple[str, str]]:
    """``(when, figures)`` for each memory probe in bench_clutter's ``machine`` section
    (``memory_latency.probe`` just ``"before"`` and ``"after"`` kinserve's pass of its own; none for a run
    without it), ``figures`` as ``"8MiB 21 ns, 256MiB 149 ns"``."""
    return [(when, ", ".join(f"{name} {ns:.0f} ns" for name, ns in machine[key].items()))
            for when, key in (("before", "memory_latency_ns_before_pass"),
                              ("after", "memory_latency_ns_after_pass")) if key in machine]


def _host_latency(m: dict) -> list[str]:
    """The host's memory latency around kinserve's pass of its own (:func:`host_latency`), or nothing for a
    run without it."""
    when = host_latency(m)
    if not when:
        return []
    return ["", "The host's memory at that moment, one dependent load in a ring of cache lines "
                "(`memory_latency.py`: an 8 MiB ring sits in the L3 the host's guests share, a 256 MiB one "
                "in memory; the cold first check waits mostly on memory, so its figure follows these): "
                + "; ".join(f"{label} kinserve's pass of its own, {figures}" for label, figures in when)
                + "."]


def render_clutter(d: dict) -> list[str]:
    """bench_clutter.py: the first check in a new scene and the check per configuration, kinserve beside
    roboplan on MotionBenchMaker's Panda scenes, with the ratios, the verdicts compared and the targets."""
    w, summary = d["workload"], d["summary"]
    out = [f"### Collision check in clutter (bench_clutter.py): MotionBenchMaker Panda, {w['scenes']} scenes "
           f"x {w['configurations_per_scene']} configurations", "", _machine(d), "",
           "Each scene's obstacles (about a dozen boxes and cylinders) read from its YAML, then: the "
           "first check in the new scene (`robot.in_collision(q0, shapes)`: the scene built from the shapes "
           "plus its first check; roboplan: adding the obstacles to its scene plus its first "
           "`hasCollisions`), the second check, and every configuration (uniform in the joint limits) timed "
           "alone through the front door `robot.in_collision(q, shapes)` and through the scene's own "
           "`in_collision(q)`; roboplan's `hasCollisions(q)` timed inside its worker, in the same run, the "
           "checker that goes first alternating from scene to scene. kinserve checks the meshes' convex "
           "hulls (exact on that model: the sphere pre-check and then the hulls' compiled distances decide "
           "only what they can certify, coal the rest); roboplan checks the meshes."
           + _load(d), "",
           "| checker | scenes | configurations | first check median / p95 | second check median | "
           "per configuration median / p95 | mean | in collision |",
           "|---|---|---|---|---|---|---|---|"]
    for name, f in summary.items():
        out.append(_clutter_row(f"{name} (robot.in_collision)" if name == "kinserve" else name, f))
        if "per_configuration_scene_call" in f:
            out.append(_clutter_row("kinserve (scene.in_collision)", {**f, "first_check": None},
                                    "per_configuration_scene_call"))
    split = [(name, f) for name, f in summary.items() if "first_check_after_peer_turn" in f]
    if split:
        out += ["", "First check by what ran just before it (the checker that goes first alternates: a "
                    "checker going first follows its own previous scene, one going second follows the other "
                    "checker's process), median / p95:", ""]
        for name, f in split:
            own, peer = f["first_check_after_own_turn"], f["first_check_after_peer_turn"]
            out.append(f"- {name}: after its own previous scene {_us(own['median_us'])} / "
                       f"{_us(own['p95_us'])} ({own['scenes']} scenes); right after the other checker's turn "
                       f"{_us(peer['median_us'])} / {_us(peer['p95_us'])} ({peer['scenes']} scenes)")
    alone = [(name, f["first_check_alone"]) for name, f in summary.items() if "first_check_alone" in f]
    if alone:
        out += ["", "First check in a pass of its own over the same scenes and configurations, as a planning "
                    "process alone meets new scenes (the figure of the target; median / p95): roboplan's "
                    "worker runs the scenes back to back, then, once it has ended, kinserve (its scene "
                    "layouts forgotten first); each scene's configurations are checked after its first "
                    "check:", ""]
        out += [f"- {name}: {_us(f['median_us'])} / {_us(f['p95_us'])}" for name, f in alone]
    out += _host_latency(d.get("machine", {}))
    by_verdict = summary.get("kinserve", {}).get("first_check_by_precheck")
    if by_verdict:
        out += ["", "kinserve's first check by the path its check of that configuration took (spheres: "
                    "the sphere pre-check decides, one compiled call; hulls: the hulls' distances decide "
                    "the pairs the spheres leave, a second compiled call; coal: coal checks the pairs both "
                    "leave), median / p95: " + "; ".join(
                        f"{v} {_us(g['median_us'])} / {_us(g['p95_us'])} ({g['scenes']} scenes)"
                        for v, g in by_verdict.items())]
    ratio, agree = d.get("ratios_kinserve_over_roboplan") or {}, d.get("verdicts")
    if ratio:
        out += ["", "kinserve / roboplan (medians of this run): " + ", ".join(
            f"{key.replace('_', ' ')} {_x(value)}" for key, value in ratio.items())]
    if agree:
        out += ["", f"Verdicts: {agree['same']}/{agree['configurations']} equal; in collision for kinserve "
                    f"only (the hulls contain the meshes): {agree['kinserve_only_collision']}, for roboplan "
                    f"only: {agree['roboplan_only_collision']}."]
    t, k, met = d.get("targets", {}), summary.get("kinserve", {}), list((d.get("targets_met") or {}).values())
    if k:
        verdicts = [" (met)" if ok else " (**not met**)" for ok in met] if len(met) == 2 else ["", ""]
        per_q = k["per_configuration"]["median_us"]
        name, first_figures = first_check_for_target(k)
        own_pass, first = name == "first_check_alone", first_figures["median_us"]
        out += ["", f"Targets: median per configuration {_us(per_q)} "
                    f"[<= {t.get('per_configuration_median_us', 5):g} µs]{verdicts[0]}, first check in a new "
                    f"scene{', in a pass of its own' if own_pass else ''} {_us(first)} "
                    f"[<= {t.get('first_check_median_us', 50):g} µs]{verdicts[1]}; "
                    f"VAMP's {t.get('vamp_per_configuration_us', 1.8):g} µs per configuration on this "
                    "machine type is the reference."]
    return out


def write_section(path: Path, name: str, lines: list[str]) -> None:
    """Replace the ``<!-- name:begin -->`` .. ``<!-- name:end -->`` section of a Markdown file by ``lines``
    (appended when the file or the section does not exist yet)."""
    begin, end = f"<!-- {name}:begin (generated by benchmarks/render_tables.py) -->", f"<!-- {name}:end -->"
    block = "\n".join([begin, *lines, end])
    fresh = "# Benchmarks\n\nGenerated from the benchmarks' JSON files.\n"
    text = path.read_text() if path.exists() else fresh
    head, found, rest = text.partition(begin)
    if found:
        _, closed, tail = rest.partition(end)
        text = head + block + (tail if closed else "\n")
    else:
        text = text.rstrip("\n") + "\n\n" + block + "\n"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)


def _flatten(prefix: str, v, out: list[str]) -> None:
    if isinstance(v, dict):
        for k, x in v.items():
            _flatten(f"{prefix}.{k}" if prefix else str(k), x, out)
    elif isinstance(v, (int, float)) and not isinstance(v, bool):
        out.append(f"- `{prefix}` = {v:.6g}")
    elif isinstance(v, bool):
        out.append(f"- `{prefix}` = {'yes' if v else 'no'}")


RENDERERS = {"ik.json": render_ik, "ik_constrained.json": render_ik_constrained,
             "collision.json": render_collision, "motion.json": render_motion,
             "motion_pose.json": render_motion_pose, "clutter.json": render_clutter}


def render(folder: Path) -> str:
    lines: list[str] = []
    for name, fn in RENDERERS.items():
        path = folder / name
        if not path.exists():
            lines += [f"<!-- {name}: not found in {folder} (run its benchmark) -->", ""]
            continue
        lines += fn(json.loads(path.read_text())) + [""]
    for path in sorted(folder.glob("*.json")):
        if path.name in RENDERERS:
            continue
        lines += render_flat(path) + [""]
    return "\n".join(lines)


def render_flat(path: Path) -> list[str]:
    """A JSON file without a renderer of its own: its machine line and its numeric figures, flattened."""
    d = json.loads(path.read_text())
    flat: list[str] = []
    _flatten("", {k: v for k, v in d.items() if k != "machine"}, flat)
    machine = [_machine(d), ""] if "machine" in d else []
    return [f"### {path.stem}", "", *machine, *flat]


def write_docs(folder: Path, page: Path) -> None:
    """Write each benchmark JSON file of ``folder`` into its generated section of ``page`` (see the module
    docstring); the sections of files that ``folder`` lacks stay as they were."""
    for name, fn in RENDERERS.items():
        if (folder / name).exists():
            write_section(page, Path(name).stem, fn(json.loads((folder / name).read_text())))
    others = [p for p in sorted(folder.glob("*.json")) if p.name not in RENDERERS]
    if others:
        write_section(page, "other", [line for p in others for line in [*render_flat(p), ""]][:-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("folder", nargs="?", default="bench-out", help="where the benchmark JSON files are")
    ap.add_argument("--out", help="also write the Markdown to this file")
    ap.add_argument("--docs", help="also write the tables into their generated sections of this page "
                                   "(docs/benchmarks.md)")
    args = ap.parse_args()
    text = render(Path(args.folder))
    print(text)
    if args.out:
        Path(args.out).write_text(text)
    if args.docs:
        write_docs(Path(args.folder), Path(args.docs))


if __name__ == "__main__":
    main()
