"""MotionBenchMaker's 700 Panda problems: kinserve's plan_motion beside roboplan and OMPL, in one run.

    .venv/bin/python benchmarks/bench_motion.py --dataset ../shared/datasets/motion-bench-maker \\
        --out bench-out/motion.json [--sets cage,box] [--n 10]
    .venv/bin/python benchmarks/bench_motion.py --pose-goals --planners kinserve   # + pose goals

The dataset: the MotionBenchMaker problems (Chamzas et al., RA-L 2022) as VAMP ships them
(``KavrakiLab/vamp``, ``resources/panda/``: ``problems.tar.bz2``, ``panda.urdf``, ``panda.srdf``,
``meshes/``), 7 sets x 100 problems, each a MoveIt planning scene of boxes and cylinders, a start and a
joint goal. The archive is unpacked at run time into ``bench-out/motion-bench-maker/`` (never committed).
Every planner gets the dataset's own Panda model and 1 s per problem (seed = the problem's number):

* kinserve ``plan_motion`` (certified RRT-Connect, shortcuts, TOPP-RA), in this process;
* roboplan 0.7.0 (``bench-out/venvs/roboplan``): RRT-Connect, ``max_connection_distance=1.0``, then
  ``PathShortcutter``;
* OMPL 2.0.1 (``bench-out/venvs/ompl``): ``RRTConnect`` + ``PathSimplifier``, kinserve's collision
  check as its validity checker.

Reported per set and overall: problems solved within the budget; median and p95 of the plan, simplify
and total (plan + simplify) times, measured by each planner around its own calls; path length (joint
space, rad); the returned paths that an independent dense check (Pinocchio + coal on the dataset's
meshes, no joint moving more than 0.5 mrad between checks; ``_motion_check.py``) finds invalid; for
kinserve also the trajectory duration and the TOPP-RA time. The issue's targets are printed beside the
figures.

``--pose-goals`` adds the pose-goal variant, ``kinserve-pose``: the same problems with the goal given as
the pose of the robot's tip (``robot.tip``) at the problem's goal configuration (FK), which
``plan_motion`` turns into a goal set of collision-free IK solutions; peers keep their joint goals. Its
total counts the IK too (IK + plan + simplify, against the same budget), its IK time is reported, and
``pose missed`` counts returned paths whose last waypoint is off the pose (> 1e-4 m or 1e-3 rad). The run
writes ``bench-out/motion_pose.json`` (unless ``--out``) and, after a full run, the ``motion_pose``
section of docs/benchmarks.md - the joint-goal table with the peers (``motion``) is left as it is.
"""

from __future__ import annotations

import argparse
import math
import os
import tarfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin
from _motion_check import DENSE_STEP, DenseChecker
from _motion_peers import start_motion_peer
from render_tables import render_motion, render_motion_pose, write_section

from kinserve import robots
from kinserve.planners.motion import plan_motion
from kinserve.planners.motion.scene_yaml import joint_vector, read_motion_request, read_planning_scene

from _common import machine, write_json

ROOT = Path(__file__).resolve().parents[1]
SETS = ("table_pick", "table_under_pick", "box", "bookshelf_small", "bookshelf_tall", "bookshelf_thin",
        "cage")
PLANNERS = ("kinserve", "roboplan", "ompl")
#: The pose-goal variant's name among the planners (``--pose-goals``).
POSE = "kinserve-pose"
#: A pose-goal path ends on the pose when its last waypoint is within these (m, rad).
POSE_TOL = (1e-4, 1e-3)
#: The issue's targets (ms / counts); the stretch is VAMP's figure times ten.
TARGETS = {"solved_of_700": 699, "median_total_ms": 10.0, "cage_median_total_ms": 25.0,
           "stretch_median_total_ms": 3.3}


@dataclass(frozen=True)
class Problem:
    """One MotionBenchMaker problem: its set, number in the set (1..100), start, goal and obstacles."""

    set: str
    index: int
    seed: int
    start: np.ndarray
    goal: np.ndarray
    obstacles: tuple


@dataclass
class Outcome:
    """One planner's answer to one problem (times in s, length in rad; ``ik_s``: a pose goal's IK)."""

    success: bool
    path: np.ndarray
    plan_s: float
    simplify_s: float
    message: str = ""
    duration_s: float | None = None
    toppra_s: float | None = None
    invalid: bool | None = None
    extra: dict = field(default_factory=dict)
    ik_s: float = 0.0

    @property
    def total_s(self) -> float:
        return self.ik_s + self.plan_s + self.simplify_s

    @property
    def length(self) -> float:
        p = np.asarray(self.path, dtype=float)
        return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum()) if len(p) > 1 else 0.0


# --------------------------------------------------------------------------- dataset
#: The dataset: ``$KINSERVE_MBM_DATASET`` (as the tests read it, ``tests/shared_data.py``), else the folder
#: beside the repository, ../shared/datasets/motion-bench-maker
SHARED_DATASET = Path(os.environ.get("KINSERVE_MBM_DATASET", Path(__file__).resolve().parents[2] / "shared"
                                     / "datasets" / "motion-bench-maker"))

def unpack(dataset: Path, work: Path) -> Path:
    """The ``problems/`` folder of the dataset's archive, unpacked into ``work`` (once)."""
    archive = dataset / "panda" / "problems.tar.bz2"
    if not archive.is_file():
        raise SystemExit(f"no {archive}: --dataset must be the folder of VAMP's resources/panda/ copy "
                         f"(with panda/problems.tar.bz2)")
    out = work / "problems"
    stamp = work / ".unpacked"
    if not stamp.exists() or stamp.read_text() != str(archive.stat().st_mtime_ns):
        work.mkdir(parents=True, exist_ok=True)
        with tarfile.open(archive, "r:bz2") as tar:
            tar.extractall(work, filter="data")
        stamp.write_text(str(archive.stat().st_mtime_ns))
    return out


def model_files(dataset: Path) -> tuple[Path, Path, Path]:
    """``(urdf, srdf, package folder)`` of the dataset's Panda."""
    panda = dataset / "panda"
    return panda / "panda.urdf", panda / "panda.srdf", panda


def load_robot(dataset: Path) -> robots.Robot:
    """The dataset's Panda with its meshes and SRDF, its collision model built."""
    urdf, srdf, package = model_files(dataset)
    robot = robots.load(urdf, package_dirs=[package], srdf=srdf, geometry=False)
    robot.collision  # built before any timed call  # noqa: B018
    return robot


def load_problems(problems: Path, robot, sets=SETS, n: int | None = None) -> list[Problem]:
    """Problems ``1..n`` (default all 100) of each set, with seed = the problem's number in the run."""
    out = []
    for name in sets:
        folder = problems / f"{name}_panda"
        count = len(list(folder.glob("request*.yaml")))
        for i in range(1, (count if n is None else min(n, count)) + 1):
            req = read_motion_request(folder / f"request{i:04d}.yaml")
            obstacles = tuple(read_planning_scene(folder / f"scene{i:04d}.yaml"))
            out.append(Problem(name, i, len(out), joint_vector(robot, req.start, "start"),
                               joint_vector(robot, req.goal, "goal"), obstacles))
    return out


# --------------------------------------------------------------------------- planners
def pose_error(robot, q: np.ndarray, T: np.ndarray) -> tuple[float, float]:
    """(position (m), orientation (rad)) error of ``robot.tip`` at ``q`` from the pose ``T``."""
    F = robot.fk(q)
    rotation = pin.log3(T[:3, :3] @ F[:3, :3].T)
    return float(np.linalg.norm(F[:3, 3] - T[:3, 3])), float(np.linalg.norm(rotation))


def run_kinserve(robot, problem: Problem, max_time: float | None, max_iterations: int | None = None,
                 pose: bool = False) -> Outcome:
    """``plan_motion`` on one problem; the times are its own stats (``max_iterations``: for tests, whose
    answers may not depend on the machine's speed). ``pose``: the goal is the pose of ``robot.tip`` at the
    problem's goal configuration (its end's pose error in ``extra["pose_error"]``)."""
    goal = robot.fk(problem.goal) if pose else problem.goal
    plan = plan_motion(robot, problem.start, goal, obstacles=problem.obstacles, max_time=max_time,
                       seed=problem.seed, max_iterations=max_iterations)
    s = plan.stats
    duration = plan.trajectory.duration if plan.trajectory is not None else None
    extra = {"raw_waypoints": len(plan.raw_path), "checks": s.get("checks")}
    if pose:
        extra.update(goal_set=len(plan.goals), ik_starts=s.get("ik_starts"))
        if plan.success:
            extra["pose_error"] = pose_error(robot, plan.path[-1], goal)
    return Outcome(bool(plan.success), np.asarray(plan.path), float(s.get("plan_time", 0.0)),
                   float(s.get("simplify_time", 0.0)), plan.message, duration,
                   float(s.get("parameterize_time", 0.0)) if plan.success else None,
                   extra=extra, ik_s=float(s.get("ik_time", 0.0)))


def run_peer(worker, problem: Problem, max_time: float) -> Outcome:
    """One problem on a peer worker: its scene, then its plan (a failed worker: a failure)."""
    shapes = [o.to_dict() for o in problem.obstacles]
    answer = worker.try_call({"cmd": "scene", "obstacles": shapes})
    if answer is not None:
        answer = worker.try_call({"cmd": "plan", "start": problem.start.tolist(),
                                  "goal": problem.goal.tolist(), "seed": problem.seed, "max_time": max_time,
                                  "max_connection_distance": 1.0})
    if answer is None:
        return Outcome(False, np.zeros((0, len(problem.start))), max_time, 0.0, "worker failed")
    path = np.asarray(answer["path"], dtype=float).reshape(-1, len(problem.start))
    return Outcome(bool(answer["success"]), path, float(answer["plan_time"]), float(answer["simplify_time"]),
                   str(answer.get("message", "")),
                   extra={k: answer[k] for k in ("raw_waypoints", "checks") if k in answer})


def peer_setup(peer: str, dataset: Path, seed: int) -> dict:
    urdf, srdf, package = model_files(dataset)
    if peer == "ompl":
        return {"urdf": str(urdf), "package_dir": str(package), "srdf": str(srdf), "seed": seed}
    joints = [f"panda_joint{i}" for i in range(1, 8)]
    return {"urdf": urdf.read_text(), "package_paths": [str(package)], "srdf": srdf.read_text(),
            "joints": joints}


def start_planners(robot, dataset: Path, names) -> dict:
    """``name -> plan(problem, max_time) -> Outcome`` of every planner that runs (peers may be skipped)."""
    planners = {}
    for name in names:
        if name == "kinserve":
            planners[name] = lambda p, t: run_kinserve(robot, p, t)
            continue
        if name == POSE:
            planners[name] = lambda p, t: run_kinserve(robot, p, t, pose=True)
            continue
        worker = start_motion_peer(name, peer_setup(name, dataset, 0))
        if worker is not None:
            planners[name] = (lambda w: lambda p, t: run_peer(w, p, t))(worker)
            planners[name].worker = worker
    return planners


def run_problems(planners: dict, problems: list[Problem], max_time: float) -> dict[str, list[Outcome]]:
    """Every planner on every problem, problem after problem; the planner that goes first rotates."""
    names = list(planners)
    for name in names:  # one untimed warm-up each on the first problem
        planners[name](problems[0], max_time)
    outcomes: dict[str, list[Outcome]] = {name: [] for name in names}
    t0 = time.perf_counter()
    for k, problem in enumerate(problems):
        for name in names[k % len(names):] + names[:k % len(names)]:
            outcomes[name].append(planners[name](problem, max_time))
        if (k + 1) % 25 == 0 or k + 1 == len(problems):
            print(f"  {k + 1}/{len(problems)} problems ({time.perf_counter() - t0:.0f} s)", flush=True)
    return outcomes


def dense_check(dataset: Path, problems: list[Problem], outcomes: dict[str, list[Outcome]],
                step: float = DENSE_STEP) -> dict:
    """Mark every returned path's ``invalid`` by the dense check; also counts starts/goals it rejects."""
    urdf, srdf, package = model_files(dataset)
    checker = DenseChecker(urdf, package, srdf, step)
    bad_ends, samples = 0, 0
    for k, problem in enumerate(problems):
        checker.set_obstacles([o.to_dict() for o in problem.obstacles])
        bad_ends += int(checker.in_collision(problem.start) or checker.in_collision(problem.goal))
        for results in outcomes.values():
            out = results[k]
            if out.success and len(out.path):
                out.invalid = checker.first_invalid(out.path) is not None
                samples += checker.samples(out.path)
    return {"step_rad": step, "self_pairs": checker.self_pairs, "invalid_starts_or_goals": bad_ends,
            "configurations_checked": samples}


# --------------------------------------------------------------------------- figures
def _ms(values) -> tuple[float | None, float | None]:
    v = np.asarray([x for x in values if x is not None], dtype=float) * 1e3
    return (float(np.median(v)), float(np.percentile(v, 95))) if len(v) else (None, None)


def figures(results: list[Outcome], max_time: float | None = None) -> dict:
    """Counts, median / p95 times (ms) over the solved problems, median length, invalid paths.

    ``solved``: paths returned; ``within_budget``: those whose total (IK + plan + simplify) time was at most
    ``max_time`` (all of them when ``max_time`` is None) - the count the targets judge. Pose goals add
    ``ik_median_ms`` / ``ik_p95_ms``, ``goal_set_median`` and ``pose_missed`` (paths ending off the pose).
    """
    solved = [r for r in results if r.success]
    within = [r for r in solved if max_time is None or r.total_s <= max_time]
    out = {"n": len(results), "solved": len(solved), "within_budget": len(within)}
    for key, attr in (("plan", "plan_s"), ("simplify", "simplify_s"), ("total", "total_s")):
        out[f"{key}_median_ms"], out[f"{key}_p95_ms"] = _ms(getattr(r, attr) for r in solved)
    out["length_median"] = float(np.median([r.length for r in solved])) if solved else None
    if any("goal_set" in r.extra for r in results):
        out.update(_pose_figures(results, solved))
    out["invalid"] = sum(1 for r in solved if r.invalid)
    out["checked"] = sum(1 for r in solved if r.invalid is not None)
    if any(r.duration_s is not None for r in solved):
        durations = [r.duration_s for r in solved if r.duration_s is not None]
        out["duration_median_s"] = float(np.median(durations))
        out["toppra_median_ms"], out["toppra_p95_ms"] = _ms(r.toppra_s for r in solved)
    return out


def _pose_figures(results: list[Outcome], solved: list[Outcome]) -> dict:
    """The pose variant's extra figures (see :func:`figures`)."""
    out = {}
    out["ik_median_ms"], out["ik_p95_ms"] = _ms(r.ik_s for r in results)
    out["goal_set_median"] = float(np.median([r.extra["goal_set"] for r in results]))
    errors = [r.extra.get("pose_error", (np.inf, np.inf)) for r in solved]
    out["pose_missed"] = sum(1 for e in errors if e[0] > POSE_TOL[0] or e[1] > POSE_TOL[1])
    return out


def summarise(problems: list[Problem], outcomes: dict[str, list[Outcome]],
              max_time: float | None = None) -> dict:
    """``{"overall": {planner: figures}, "per_set": {set: {planner: figures}}}``."""
    sets = list(dict.fromkeys(p.set for p in problems))
    per_set = {s: {name: figures([r for p, r in zip(problems, results) if p.set == s], max_time)
                   for name, results in outcomes.items()} for s in sets}
    return {"overall": {name: figures(results, max_time) for name, results in outcomes.items()},
            "per_set": per_set}


def targets_met(summary: dict) -> dict:
    """The issue's targets for kinserve (scaled to the problems run: 699 of 700 is ceil(n * 699 / 700))."""
    k = summary["overall"].get("kinserve")
    if not k:
        return {}
    need = math.ceil(k["n"] * TARGETS["solved_of_700"] / 700)
    total = k["total_median_ms"] if k["total_median_ms"] is not None else math.inf
    met = {f"solved within the budget >= {need}/{k['n']}": k["within_budget"] >= need,
           "0 invalid paths": k["invalid"] == 0 and k["checked"] == k["solved"],
           f"median total <= {TARGETS['median_total_ms']:g} ms": total <= TARGETS["median_total_ms"]}
    cage = summary["per_set"].get("cage", {}).get("kinserve")
    if cage and cage["total_median_ms"] is not None:
        met[f"cage median total <= {TARGETS['cage_median_total_ms']:g} ms"] = \
            cage["total_median_ms"] <= TARGETS["cage_median_total_ms"]
    rp = summary["overall"].get("roboplan")
    if rp and rp["length_median"] is not None and k["length_median"] is not None:
        met["median path length <= roboplan's"] = k["length_median"] <= rp["length_median"]
    met[f"stretch: median total <= {TARGETS['stretch_median_total_ms']:g} ms"] = \
        total <= TARGETS["stretch_median_total_ms"]
    return met


def _fmt(v, unit="") -> str:
    return "–" if v is None else (f"{v:.3g}{unit}" if abs(v) < 100 else f"{v:.0f}{unit}")


def print_table(summary: dict, met: dict) -> None:
    rows = [("overall", summary["overall"])] + list(summary["per_set"].items())
    print(f"\n{'set':<18} {'planner':<9} {'solved':>9} {'plan ms':>15} {'simplify ms':>15} {'total ms':>15} "
          f"{'length':>7} {'invalid':>7} {'traj s':>7} {'toppra ms':>9} {'ik ms':>7}")
    for label, per_planner in rows:
        for name, f in per_planner.items():
            times = " ".join(f"{_fmt(f[f'{k}_median_ms']) + '/' + _fmt(f[f'{k}_p95_ms']):>15}"
                             for k in ("plan", "simplify", "total"))
            print(f"{label:<18} {name:<9} {f['within_budget']:>4}/{f['n']:<4} {times} "
                  f"{_fmt(f['length_median']):>7} {f['invalid']:>3}/{f['checked']:<3} "
                  f"{_fmt(f.get('duration_median_s')):>7} {_fmt(f.get('toppra_median_ms')):>9} "
                  f"{_fmt(f.get('ik_median_ms')):>7}")
    print("  (solved = paths returned within the budget, IK + plan + simplify; median/p95 over all returned "
          "paths; invalid = returned paths the dense check rejects)")
    for k, v in met.items():
        print(f"  target {k}: {'met' if v else 'NOT met'}")


# --------------------------------------------------------------------------- run
def _record(o: Outcome) -> dict:
    """One planner's answer to one problem in the JSON (the path too, for a later look)."""
    return {"success": o.success, "plan_ms": o.plan_s * 1e3, "simplify_ms": o.simplify_s * 1e3,
            "ik_ms": o.ik_s * 1e3, "length": o.length, "invalid": o.invalid, "message": o.message,
            "path": o.path.tolist(), **{k: o.extra[k] for k in ("goal_set", "pose_error") if k in o.extra}}


def run(dataset: Path, sets=SETS, n: int | None = None, planners=PLANNERS, max_time: float = 1.0,
        work: Path = ROOT / "bench-out" / "motion-bench-maker", check_step: float = DENSE_STEP) -> dict:
    """The whole benchmark on ``n`` problems of each of ``sets``; returns the JSON document."""
    problems_dir = unpack(dataset, work)
    robot = load_robot(dataset)
    problems = load_problems(problems_dir, robot, sets, n)
    print(f"{len(problems)} problems of {len(sets)} sets; planners: {', '.join(planners)}", flush=True)
    running = start_planners(robot, dataset, planners)
    try:
        outcomes = run_problems(running, problems, max_time)
    finally:
        for p in running.values():
            if hasattr(p, "worker"):
                p.worker.close()
    print("dense check of the returned paths ...", flush=True)
    check = dense_check(dataset, problems, outcomes, check_step)
    summary = summarise(problems, outcomes, max_time)
    met = targets_met(summary)
    versions = {name: getattr(p, "worker").version for name, p in running.items() if hasattr(p, "worker")}
    problems_out = [{"set": p.set, "index": p.index,
                     **{name: _record(results[k]) for name, results in outcomes.items()}}
                    for k, p in enumerate(problems)]
    return {"machine": {**machine(), "load_average": list(os.getloadavg())},
            "workload": {"dataset": str(dataset), "sets": list(sets), "per_set": n, "problems": len(problems),
                         "max_time_s": max_time, "planners": list(running), "peer_versions": versions,
                         "dense_check": check},
            **summary, "targets": TARGETS, "targets_met": met, "problems": problems_out}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dataset", type=Path, default=SHARED_DATASET,
                    help="folder with panda/problems.tar.bz2, panda.urdf, panda.srdf, meshes/ (VAMP's "
                         "resources/panda/ from KavrakiLab/vamp; default $KINSERVE_MBM_DATASET, else "
                         "../shared/datasets/motion-bench-maker beside the repository)")
    ap.add_argument("--out", default=None, help="JSON output (default bench-out/motion.json; "
                                                "bench-out/motion_pose.json with --pose-goals)")
    ap.add_argument("--sets", default=",".join(SETS), help=f"comma-separated sets (default: all of {SETS})")
    ap.add_argument("--n", type=int, default=None, help="problems per set (default: all 100)")
    ap.add_argument("--planners", default=",".join(PLANNERS), help="comma-separated planners to run")
    ap.add_argument("--max-time", type=float, default=1.0, help="budget per problem (s)")
    ap.add_argument("--check-step", type=float, default=DENSE_STEP, help="dense check step (rad)")
    ap.add_argument("--docs", default=None, help="Markdown file whose motion section is rewritten (default: "
                                                 "docs/benchmarks.md after a full run, none after a subset)")
    ap.add_argument("--pose-goals", action="store_true",
                    help=f"also run {POSE}: kinserve with goal = the tip's pose at the goal configuration")
    args = ap.parse_args()
    sets = tuple(s for s in args.sets.split(",") if s)
    unknown = sorted(set(sets) - set(SETS))
    if unknown:
        raise SystemExit(f"unknown sets {unknown}; the sets are {SETS}")
    names = tuple(p for p in args.planners.split(",") if p)
    if args.pose_goals:
        names = tuple(dict.fromkeys(("kinserve",) + names + (POSE,)))
    doc = run(args.dataset, sets, args.n, names, args.max_time, check_step=args.check_step)
    print_table({"overall": doc["overall"], "per_set": doc["per_set"]}, doc["targets_met"])
    write_json(args.out or f"bench-out/motion{'_pose' if args.pose_goals else ''}.json", doc)
    docs = args.docs or (str(ROOT / "docs" / "benchmarks.md") if args.n is None and sets == SETS else None)
    if docs:
        section, lines = ("motion_pose", render_motion_pose(doc)) if args.pose_goals else \
            ("motion", render_motion(doc))
        write_section(Path(docs), section, lines)
        print(f"wrote the {section} table into {docs}")


if __name__ == "__main__":
    main()
