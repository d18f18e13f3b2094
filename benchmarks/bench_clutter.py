"""The collision check in clutter: MotionBenchMaker's 700 Panda scenes, kinserve beside roboplan.

    .venv/bin/python benchmarks/bench_clutter.py --dataset ../shared/datasets/motion-bench-maker \\
        --out bench-out/clutter.json [--per-set 3] [--configs 200] [--all]

Scenes: the MotionBenchMaker problems (Chamzas et al., RA-L 2022) as VAMP ships them (7 sets x 100
scenes of about a dozen boxes and cylinders; the archive is unpacked at run time into
``bench-out/motion-bench-maker/`` by ``bench_motion.unpack``), with the dataset's own Panda (its meshes
and SRDF; ``bench_motion.load_robot``). Each scene is read from its YAML with
``planners.motion.scene_yaml.read_planning_scene`` (not timed). Configurations: uniform in the joint
limits, ``numpy.random.default_rng(scene number)``; the same for every checker.

Measured per scene (the checker that goes first alternates from scene to scene):

(a) **first check in a new scene**: ``robot.in_collision(q0, shapes)`` on shapes just read - the scene
    built from the shapes, then its first check, as a planner pays it when it meets a new scene
    (scenes whose obstacles have the shapes of an earlier scene's, poses aside, reuse that scene's
    geometry layout, as they would in a planning process); also the second call on the same shapes;
(b) **per configuration**: each of ``--configs`` configurations timed alone (``perf_counter``) through
    ``robot.in_collision(q, shapes)`` (the front door: validation of ``q``, the scene lookup) and
    through the scene's own ``CollisionScene.in_collision(q)``;
(c) **roboplan 0.7.0** (``bench-out/venvs/roboplan``, ``_clutter_peer_roboplan.py``): its ``Scene`` of
    the same URDF + SRDF (coal on the meshes, not their hulls), the obstacles added (``first``: scene
    update plus the first ``hasCollisions``), then ``hasCollisions(q)`` on the same configurations,
    timed inside the worker the same way. Its verdicts are compared with kinserve's: kinserve checks
    the meshes' convex hulls, which contain the meshes, so it may report a collision roboplan does not.

(d) with roboplan in the run, each checker's **first check in a pass of its own** over the same scenes and
    configurations, as a planning process alone on the machine meets new scenes: roboplan's worker runs
    the scenes one after the other (``pass`` requests of :data:`PASS_CHUNK` scenes: no request between
    two scenes of a chunk, so its process does not wait on the benchmark's), each scene's obstacles set
    plus its first ``hasCollisions``, then its configurations; once the worker has ended, kinserve's
    (the scene layouts forgotten first, so that it builds the same ones; each scene measured as in (a)
    and (b), only its first check reported). The first-check target reads this pass: in the alternating
    run, the checker that goes second in a scene meets it right after waiting for the other checker's
    process, and that wait slows the next check of either checker, whatever it builds (docs/benchmarks.md
    has the measurements).

Reported: median and p95 of the first check (µs) - over every scene, and apart for the scenes where the
checker went first (its own previous scene's checks came just before) and those where it went second (the
other checker's process ran just before, and its code and data fill the caches; docs/benchmarks.md has the
figures), each checker's in the pass of its own (d), and by the path the first configuration's check took (the
spheres decide: one compiled call; the hulls decide the pairs the spheres leave: a second one; coal checks the
pairs both leave; asked after the timings) - median and p95 per configuration (µs) over all the configurations
checked, the share in collision, the ratios kinserve / roboplan measured in this run, and the targets (median
<= 5 µs per configuration, <= 50 µs for the first check; VAMP's 1.8 µs per configuration on the project's
machine type is the reference). Defaults: 3 scenes per set x 200 configurations; ``--all``: every scene x 1000
configurations, and the run's table is written into the ``clutter`` section of docs/benchmarks.md (``--docs``;
``render_tables.render_clutter``). Also the host's memory latency (:mod:`memory_latency`: one dependent
load in an 8 MiB ring, in the L3 the host's guests share, and in a 256 MiB one, in memory) just before and
after kinserve's pass of its own, in the JSON's ``machine`` section: the first check waits mostly on memory,
so its figure moves with the host's state, which the warm per-configuration figures do not show.
"""

from __future__ import annotations

import argparse
import os
import time
from dataclasses import dataclass
from pathlib import Path

import memory_latency
import numpy as np
from _motion_peers import MotionPeer
from bench_motion import SETS, SHARED_DATASET, load_robot, model_files, unpack
from render_tables import first_check_for_target, host_latency, render_clutter, write_section

from kinserve.kinematics.precheck_verdicts import COLLIDING, FREE, UNDECIDED
from kinserve.planners.motion.scene_yaml import read_planning_scene

from _common import machine, write_json
from _peers import PeerError

ROOT = Path(__file__).resolve().parents[1]
#: Targets (µs) and the reference figure of VAMP on the project's machine type.
TARGETS = {"per_configuration_median_us": 5.0, "first_check_median_us": 50.0,
           "vamp_per_configuration_us": 1.8}
CHECKERS = ("kinserve", "roboplan")
#: Scenes per ``pass`` request of roboplan's pass of its own (d): its worker waits on the benchmark's process
#: before the first scene of each chunk only.
PASS_CHUNK = 25
#: The paths a kinserve check takes on a configuration: the sphere pre-check certifies it free or finds it in
#: collision for certain (one compiled call); the hulls' distances decide the pairs the spheres leave (a
#: second compiled call, :mod:`kinserve.kinematics.hull_verdict`); coal checks the pairs both leave.
PRECHECK_VERDICTS = ("spheres: free", "spheres: collision", "hulls", "coal")


@dataclass(frozen=True)
class SceneFile:
    """One MotionBenchMaker scene: its set, number in the set (1..100), YAML file and run-wide seed."""

    set: str
    index: int
    path: Path
    seed: int


@dataclass
class SceneTimes:
    """What one checker measured on one scene (s); ``collision``: its verdict per configuration."""

    first_s: float
    second_s: float | None
    per_q_s: np.ndarray
    collision: np.ndarray
    per_q_scene_s: np.ndarray | None = None
    scene_s: float | None = None
    #: Whether the other checker's turn came just before this scene (its worker process ran right before
    #: this checker read the scene: caches hold the other process's code and data).
    after_peer: bool = False
    #: kinserve: the path its check of the first configuration took (:data:`PRECHECK_VERDICTS`; asked after
    #: the timings).
    first_verdict: str | None = None


class ClutterPeer(MotionPeer):
    """roboplan's collision check in its own venv (``_clutter_peer_roboplan.py``; the protocol and the stderr
    log of :class:`_motion_peers.MotionPeer`)."""

    def __init__(self, peer: str = "roboplan", timeout: float = 120.0) -> None:
        super().__init__(peer, timeout, script="_clutter_peer_roboplan.py", log_prefix="clutter")


def start_roboplan(dataset: Path) -> ClutterPeer | None:
    """The roboplan worker with the dataset's Panda, or None after printing why it is skipped."""
    urdf, srdf, package = model_files(dataset)
    try:
        worker = ClutterPeer()
    except (PeerError, OSError, ValueError) as exc:
        print(f"SKIP roboplan: {str(exc).strip().splitlines()[0] if str(exc).strip() else exc!r}", flush=True)
        return None
    try:
        worker.call({"cmd": "setup", "urdf": urdf.read_text(), "package_paths": [str(package)],
                     "srdf": srdf.read_text(), "joints": [f"panda_joint{i}" for i in range(1, 8)]})
    except Exception as exc:  # noqa: BLE001 - any failure of a peer skips it, never the benchmark
        print(f"SKIP roboplan: setup failed: {exc}", flush=True)
        worker.close()
        return None
    print(f"roboplan: {worker.version}", flush=True)
    return worker


# --------------------------------------------------------------------------- workload
def scene_files(problems: Path, sets=SETS, per_set: int | None = None) -> list[SceneFile]:
    """Scenes ``1..per_set`` (all 100 when None) of each set, interleaved set by set (scene 1 of every set,
    then scene 2, ...) so that a subset covers every set."""
    by_set = []
    for name in sets:
        files = sorted((problems / f"{name}_panda").glob("scene*.yaml"))
        by_set.append([(name, int(f.stem[5:]), f) for f in files[:per_set]])
    out: list[SceneFile] = []
    for k in range(max(len(s) for s in by_set)):
        for files in by_set:
            if k < len(files):
                out.append(SceneFile(*files[k], seed=len(out)))
    return out


def configurations(robot, n: int, seed: int) -> np.ndarray:
    """``n`` configurations uniform in the robot's joint limits, float ``(n, nq)``."""
    rng = np.random.default_rng(seed)
    return rng.uniform(robot.lower, robot.upper, size=(n, robot.nq))


def time_kinserve(robot, path: Path, qs: np.ndarray) -> SceneTimes:
    """(a) and (b) for kinserve on one scene (see the module docstring)."""
    shapes = tuple(read_planning_scene(path))
    clock = time.perf_counter
    q0 = qs[0]
    t0 = clock()
    robot.in_collision(q0, shapes)
    t1 = clock()
    robot.in_collision(q0, shapes)
    t2 = clock()
    in_collision = robot.in_collision
    per_q, hits = np.empty(len(qs)), np.empty(len(qs), dtype=bool)
    for k, q in enumerate(qs):
        s = clock()
        hit = in_collision(q, shapes)
        per_q[k] = clock() - s
        hits[k] = hit
    scene = robot.collision_scene(shapes)
    scene_check = scene.in_collision
    per_q_scene = np.empty(len(qs))
    for k, q in enumerate(qs):
        s = clock()
        scene_check(q)
        per_q_scene[k] = clock() - s
    return SceneTimes(t1 - t0, t2 - t1, per_q, hits, per_q_scene,
                      first_verdict=precheck_verdict(scene, q0))


def time_alone(robot, scenes: list[SceneFile], n_configs: int) -> list[float]:
    """(d): kinserve's first check (s) in each of ``scenes``, in a pass of its own (see the module
    docstring): the layouts forgotten, one untimed pass on the first scene, then :func:`time_kinserve` on
    each scene (its first check is the one reported; its configurations are checked after it)."""
    robot.collision.forget_scenes()
    time_kinserve(robot, scenes[0].path, configurations(robot, 10, 10**6))
    return [time_kinserve(robot, scene.path, configurations(robot, n_configs, scene.seed)).first_s
            for scene in scenes]


def time_alone_roboplan(worker: ClutterPeer, robot, scenes: list[SceneFile], n_configs: int
                        ) -> list[float] | None:
    """(d): roboplan's first check (s) in each of ``scenes``, in a pass of its own (``pass`` requests of
    :data:`PASS_CHUNK` scenes, the configurations of :func:`configurations` as for kinserve); None once the
    worker has failed."""
    out: list[float] = []
    for start in range(0, len(scenes), PASS_CHUNK):
        chunk = [{"obstacles": [shape.to_dict() for shape in read_planning_scene(scene.path)],
                  "qs": configurations(robot, n_configs, scene.seed).tolist()}
                 for scene in scenes[start:start + PASS_CHUNK]]
        answer = worker.try_call({"cmd": "pass", "scenes": chunk})
        if answer is None:
            return None
        out += answer["first_s"]
    return out


def precheck_verdict(scene, q: np.ndarray) -> str:
    """The :data:`PRECHECK_VERDICTS` entry of the path the scene's check takes at ``q`` (``coal`` when the
    scene has no pre-check)."""
    pre = scene.precheck()
    if pre is None:
        return PRECHECK_VERDICTS[3]
    verdict = pre.classify(pre.floats, pre.ints, q, pre.tolerance)
    if verdict == FREE or verdict == COLLIDING:
        return PRECHECK_VERDICTS[0 if verdict == FREE else 1]
    if verdict > UNDECIDED and pre.hull_verdict is not None:
        verdict = pre.hull_verdict(pre.floats, pre.ints, *pre.hull_arguments, q, verdict, pre.tolerance)
        if verdict == FREE or verdict == COLLIDING:
            return PRECHECK_VERDICTS[2]
    return PRECHECK_VERDICTS[3]


def time_roboplan(worker: ClutterPeer, path: Path, qs: np.ndarray) -> SceneTimes | None:
    """(c): roboplan on one scene, timed inside its worker; None once the worker has failed."""
    shapes = [s.to_dict() for s in read_planning_scene(path)]
    first = worker.try_call({"cmd": "first", "obstacles": shapes, "q": qs[0].tolist()})
    if first is None:
        return None
    second = worker.try_call({"cmd": "checks", "qs": [qs[0].tolist()]})
    checks = worker.try_call({"cmd": "checks", "qs": qs.tolist()})
    if second is None or checks is None:
        return None
    return SceneTimes(first["scene_s"] + first["check_s"], second["times_s"][0],
                      np.asarray(checks["times_s"]), np.asarray(checks["collision"], dtype=bool),
                      scene_s=first["scene_s"])


def run_scenes(robot, worker, scenes: list[SceneFile], n_configs: int) -> dict[str, list[SceneTimes]]:
    """Every checker on every scene; the one that goes first alternates."""
    out: dict[str, list[SceneTimes]] = {"kinserve": []}
    if worker is not None:
        out["roboplan"] = []
    warm = configurations(robot, 10, 10**6)  # one untimed pass each on the first scene
    time_kinserve(robot, scenes[0].path, warm)
    if worker is not None:
        time_roboplan(worker, scenes[0].path, warm)
    t0 = time.perf_counter()
    for k, scene in enumerate(scenes):
        qs = configurations(robot, n_configs, scene.seed)
        order = list(out) if k % 2 == 0 else list(out)[::-1]
        for turn, name in enumerate(order):
            times = time_kinserve(robot, scene.path, qs) if name == "kinserve" \
                else time_roboplan(worker, scene.path, qs)
            if times is None:  # the peer failed: its rows stop here
                out.pop(name)
                continue
            times.after_peer = turn > 0  # second in this scene: right after the other checker's turn
            out[name].append(times)
        if (k + 1) % 20 == 0 or k + 1 == len(scenes):
            print(f"  {k + 1}/{len(scenes)} scenes ({time.perf_counter() - t0:.0f} s)", flush=True)
    return out


# --------------------------------------------------------------------------- figures
def _us(values) -> dict:
    v = np.asarray(values, dtype=float) * 1e6
    return {"median_us": float(np.median(v)), "p95_us": float(np.percentile(v, 95)),
            "mean_us": float(v.mean())}


def figures(rows: list[SceneTimes]) -> dict:
    """First / second check and per-configuration statistics (µs) of one checker over its scenes."""
    out = {"scenes": len(rows), "configurations": int(sum(len(r.per_q_s) for r in rows)),
           "first_check": _us([r.first_s for r in rows]),
           "second_check": _us([r.second_s for r in rows]),
           "per_configuration": _us(np.concatenate([r.per_q_s for r in rows])),
           "per_configuration_scene_medians": _us([np.median(r.per_q_s) for r in rows]),
           "in_collision_share": float(np.mean(np.concatenate([r.collision for r in rows])))}
    for key, after in (("first_check_after_own_turn", False), ("first_check_after_peer_turn", True)):
        chosen = [r.first_s for r in rows if r.after_peer is after]
        if chosen and len(chosen) < len(rows):
            out[key] = {**_us(chosen), "scenes": len(chosen)}
    if rows and all(r.first_verdict is not None for r in rows):
        out["first_check_by_precheck"] = {
            v: {**_us([r.first_s for r in rows if r.first_verdict == v]),
                "scenes": sum(r.first_verdict == v for r in rows)}
            for v in PRECHECK_VERDICTS if any(r.first_verdict == v for r in rows)}
    if rows and rows[0].per_q_scene_s is not None:
        out["per_configuration_scene_call"] = _us(np.concatenate([r.per_q_scene_s for r in rows]))
    if rows and rows[0].scene_s is not None:
        out["scene_update"] = _us([r.scene_s for r in rows])
    return out


def agreement(results: dict[str, list[SceneTimes]]) -> dict | None:
    """How kinserve's verdicts compare with roboplan's on the same configurations (None without roboplan)."""
    if "roboplan" not in results:
        return None
    k = np.concatenate([r.collision for r in results["kinserve"]])
    r = np.concatenate([r.collision for r in results["roboplan"]])
    return {"configurations": len(k), "same": int((k == r).sum()),
            "kinserve_only_collision": int((k & ~r).sum()), "roboplan_only_collision": int((~k & r).sum())}


def ratios(summary: dict) -> dict:
    """kinserve / roboplan of the medians measured in this run."""
    if "roboplan" not in summary:
        return {}
    k, r = summary["kinserve"], summary["roboplan"]
    peer_per_q = r["per_configuration"]["median_us"]
    alone = {"first_check_alone_median": k["first_check_alone"]["median_us"]
             / r["first_check_alone"]["median_us"]} \
        if "first_check_alone" in k and "first_check_alone" in r else {}
    return {"first_check_median": k["first_check"]["median_us"] / r["first_check"]["median_us"], **alone,
            "per_configuration_median": k["per_configuration"]["median_us"] / peer_per_q,
            "per_configuration_scene_call_median":
                k["per_configuration_scene_call"]["median_us"] / peer_per_q}


def targets_met(summary: dict) -> dict:
    k = summary["kinserve"]
    first = first_check_for_target(k)[1]
    return {f"median per configuration <= {TARGETS['per_configuration_median_us']:g} us":
            k["per_configuration"]["median_us"] <= TARGETS["per_configuration_median_us"],
            f"median first check in a new scene, in a pass of its own <= "
            f"{TARGETS['first_check_median_us']:g} us":
            first["median_us"] <= TARGETS["first_check_median_us"]}


def print_table(summary: dict, agree: dict | None, ratio: dict, met: dict) -> None:
    print(f"\n{'checker':<22} {'scenes':>6} {'configs':>8} {'first us':>17} {'second us':>10} "
          f"{'per q us':>17} {'colliding':>9}")
    for name, f in summary.items():
        first, per_q = f["first_check"], f["per_configuration"]
        print(f"{name:<22} {f['scenes']:>6} {f['configurations']:>8} "
              f"{first['median_us']:>8.1f}/{first['p95_us']:<8.1f} {f['second_check']['median_us']:>10.1f} "
              f"{per_q['median_us']:>8.2f}/{per_q['p95_us']:<8.2f} {f['in_collision_share']:>9.1%}")
        if "per_configuration_scene_call" in f:
            s = f["per_configuration_scene_call"]
            print(f"{'  (scene.in_collision)':<22} {'':>6} {'':>8} {'':>17} {'':>10} "
                  f"{s['median_us']:>8.2f}/{s['p95_us']:<8.2f}")
    print("  (median/p95; first = scene built from the shapes + its first check; per q = one configuration)")
    for name, f in summary.items():
        if "first_check_alone" in f:
            alone = f["first_check_alone"]
            print(f"  {name} first check in a pass of its own: "
                  f"{alone['median_us']:.1f}/{alone['p95_us']:.1f} us")
        if "first_check_after_peer_turn" in f:
            own, peer = f["first_check_after_own_turn"], f["first_check_after_peer_turn"]
            print(f"  {name} first check after its own previous scene: {own['median_us']:.1f}/"
                  f"{own['p95_us']:.1f} us ({own['scenes']} scenes); right after the other checker's turn: "
                  f"{peer['median_us']:.1f}/{peer['p95_us']:.1f} us ({peer['scenes']} scenes)")
        if "first_check_by_precheck" in f:
            print(f"  {name} first check by the pre-check's verdict on it: " + "; ".join(
                f"{v} {g['median_us']:.1f}/{g['p95_us']:.1f} us ({g['scenes']} scenes)"
                for v, g in f["first_check_by_precheck"].items()))
    for key, value in ratio.items():
        print(f"  kinserve / roboplan, {key}: {value:.2f}")
    if agree:
        print(f"  verdicts: {agree['same']}/{agree['configurations']} equal; collision for kinserve only "
              f"(hulls contain the meshes): {agree['kinserve_only_collision']}, for roboplan only: "
              f"{agree['roboplan_only_collision']}")
    print(f"  reference: VAMP {TARGETS['vamp_per_configuration_us']:g} us per configuration")
    for key, value in met.items():
        print(f"  target {key}: {'met' if value else 'NOT met'}")


def print_host(host: dict) -> None:
    """The host's memory latency (:mod:`memory_latency`) before and after kinserve's pass of its own
    (``render_tables.host_latency``)."""
    for when, figures in host_latency(host):
        print(f"  host {when} pass: dependent load {figures}")


# --------------------------------------------------------------------------- run
def run(dataset: Path, per_set: int | None, n_configs: int, checkers=CHECKERS,
        work: Path = ROOT / "bench-out" / "motion-bench-maker") -> dict:
    """The whole benchmark; returns the JSON document."""
    problems = unpack(dataset, work)
    robot = load_robot(dataset)
    scenes = scene_files(problems, SETS, per_set)
    print(f"{len(scenes)} scenes x {n_configs} configurations; checkers: {', '.join(checkers)}", flush=True)
    worker = start_roboplan(dataset) if "roboplan" in checkers else None
    peer_alone = None
    try:
        results = run_scenes(robot, worker, scenes, n_configs)
        if "roboplan" in results:
            print("roboplan's first checks in a pass of its own", flush=True)
            peer_alone = time_alone_roboplan(worker, robot, scenes, n_configs)
    finally:
        if worker is not None:
            worker.close()
    summary = {name: figures(rows) for name, rows in results.items()}
    if peer_alone is not None and "roboplan" in summary:
        summary["roboplan"]["first_check_alone"] = _us(peer_alone)
    host = {"memory_latency_ns_before_pass": memory_latency.probe()}
    if worker is not None and "kinserve" in summary:
        print("kinserve's first checks in a pass of its own", flush=True)
        summary["kinserve"]["first_check_alone"] = _us(time_alone(robot, scenes, n_configs))
    host["memory_latency_ns_after_pass"] = memory_latency.probe()
    agree, ratio = agreement(results), ratios(summary)
    met = targets_met(summary)
    print_table(summary, agree, ratio, met)
    print_host(host)
    per_scene = [{"set": s.set, "index": s.index,
                  **{name: {"first_us": rows[k].first_s * 1e6,
                            "per_configuration_median_us": float(np.median(rows[k].per_q_s)) * 1e6,
                            "in_collision": int(rows[k].collision.sum()),
                            **({"first_verdict": rows[k].first_verdict} if rows[k].first_verdict else {})}
                     for name, rows in results.items() if k < len(rows)}}
                 for k, s in enumerate(scenes)]
    return {"machine": {**machine(), "load_average": list(os.getloadavg()), **host},
            "workload": {"dataset": str(dataset), "scenes": len(scenes), "per_set": per_set,
                         "configurations_per_scene": n_configs, "checkers": list(results),
                         "peer_version": None if worker is None else worker.version},
            "summary": summary, "ratios_kinserve_over_roboplan": ratio, "verdicts": agree,
            "targets": TARGETS, "targets_met": met, "scenes": per_scene}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dataset", type=Path, default=SHARED_DATASET,
                    help="folder with panda/problems.tar.bz2, panda.urdf, panda.srdf, meshes/ (default "
                         "$KINSERVE_MBM_DATASET, else ../shared/datasets/motion-bench-maker)")
    ap.add_argument("--out", default="bench-out/clutter.json", help="JSON output")
    ap.add_argument("--per-set", type=int, default=3, help="scenes per set (default 3: 21 scenes)")
    ap.add_argument("--configs", type=int, default=200, help="configurations per scene (default 200)")
    ap.add_argument("--all", action="store_true", help="all 700 scenes x 1000 configurations")
    ap.add_argument("--checkers", default=",".join(CHECKERS), help="comma-separated: kinserve,roboplan")
    ap.add_argument("--docs", default=str(ROOT / "docs" / "benchmarks.md"),
                    help="page whose generated clutter section a full run (--all) rewrites ('' : none)")
    args = ap.parse_args()
    per_set, n_configs = (None, 1000) if args.all else (args.per_set, args.configs)
    doc = run(args.dataset, per_set, n_configs, tuple(args.checkers.split(",")))
    write_json(args.out, doc)
    if args.all and args.docs:
        write_section(Path(args.docs), "clutter", render_clutter(doc))
        print(f"wrote the clutter section of {args.docs}")


if __name__ == "__main__":
    main()
