"""bench_motion.py's pieces: the independent dense check, the figures, the table, and a tiny end-to-end run.

The benchmark modules live in ``benchmarks/`` (not installed) and import each other by bare name: they are
loaded from their files in dependency order and registered under those names (no ``sys.path`` edit). The
dataset-dependent tests skip with a message when
``../shared/datasets/motion-bench-maker/`` is absent. kinserve's plans use iteration budgets here
(``max_time=None``), so no answer depends on the machine's speed.
"""

from __future__ import annotations

import json
import sys

import numpy as np
import pytest

from benchmark_scripts import load_benchmark
from shared_data import MBM_DATASET

DATASET = MBM_DATASET


for _dep in ("_common", "_motion_check", "_peers", "_motion_peers", "render_tables"):
    load_benchmark(_dep)
bm = load_benchmark("bench_motion")
render_tables = sys.modules["render_tables"]
DenseChecker = sys.modules["_motion_check"].DenseChecker

from kinserve.kinematics.shapes import Box, Sphere  # noqa: E402

needs_dataset = pytest.mark.skipif(not (DATASET / "panda" / "problems.tar.bz2").exists(),
                                   reason=f"MotionBenchMaker dataset not found at {DATASET}")


@pytest.fixture(scope="module")
def checker():
    if not (DATASET / "panda" / "panda.urdf").exists():
        pytest.skip(f"MotionBenchMaker dataset not found at {DATASET}")
    urdf, srdf, package = bm.model_files(DATASET)
    return DenseChecker(urdf, package, srdf)


READY = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])


def test_broad_phase_agrees_with_every_pair(checker):
    rng = np.random.default_rng(0)
    checker.set_obstacles([Box(_at([0.45, 0.0, 0.3]), [0.3, 0.6, 0.05]).to_dict(),
                           Sphere([0.0, 0.5, 0.5], 0.15).to_dict()])
    Q = checker.lower + (checker.upper - checker.lower) * rng.random((150, 7))
    fast = [checker.in_collision(q) for q in Q]
    slow = [checker.in_collision_every_pair(q) for q in Q]
    assert fast == slow
    assert 0 < sum(fast) < len(fast)  # both kinds of answer occur


def _at(p):
    T = np.eye(4)
    T[:3, 3] = p
    return T


def test_dense_check_finds_a_collision_between_valid_waypoints(checker):
    # joint 1 sweeps the arm through a ball placed half way; both ends are clear of it
    a, b = READY.copy(), READY.copy()
    a[0], b[0] = -1.2, 1.2
    hand_mid = _hand_position(checker, READY)
    checker.set_obstacles([Sphere(hand_mid, 0.05).to_dict()])
    assert not checker.in_collision(a) and not checker.in_collision(b)
    hit = checker.first_invalid(np.array([a, b]))
    assert hit is not None and hit[0] == 0 and 0.0 < hit[1] < 0.5  # met before the middle, where the ball is
    n = checker.samples(np.array([a, b])) - 1
    assert checker.in_collision(a + hit[1] * (b - a))
    assert not checker.in_collision(a + (hit[1] - 1 / n) * (b - a))  # the first: one step before is clear
    # the same ball moved far away: the path is valid; the samples are ceil(2.4 / 5e-4) + 1
    checker.set_obstacles([Sphere([3.0, 3.0, 3.0], 0.05).to_dict()])
    assert checker.first_invalid(np.array([a, b])) is None
    assert checker.samples(np.array([a, b])) == int(np.ceil(2.4 / 5e-4)) + 1


def _hand_position(checker, q):
    import pinocchio as pin

    data = checker.model.createData()
    pin.framesForwardKinematics(checker.model, data, q)
    return data.oMf[checker.model.getFrameId("panda_hand")].translation.copy()


def test_self_collision_and_limits_are_invalid(checker):
    checker.set_obstacles([])
    assert not checker.in_collision(READY)
    folded = READY.copy()
    folded[3], folded[5] = -3.0, 3.7  # elbow and wrist folded onto the upper arm
    assert checker.in_collision(folded) == checker.in_collision_every_pair(folded)
    outside = READY.copy()
    outside[0] = 3.0
    assert checker.in_collision(outside)


def _outcome(success, path, plan, simplify, invalid=None, duration=None):
    return bm.Outcome(success, np.asarray(path, float), plan, simplify, invalid=invalid, duration_s=duration,
                      toppra_s=0.002 if duration else None)


def test_figures_medians_lengths_and_invalid_counts():
    path = [[0.0] * 7, [3.0, 4.0] + [0.0] * 5, [3.0, 4.0, 12.0] + [0.0] * 4]  # lengths 5 + 12
    results = [_outcome(True, path, 0.001, 0.002, invalid=False, duration=1.0),
               _outcome(True, path[:2], 0.003, 0.004, invalid=True, duration=3.0),
               _outcome(False, np.zeros((0, 7)), 1.0, 0.0)]
    f = bm.figures(results)
    assert (f["n"], f["solved"], f["within_budget"], f["invalid"], f["checked"]) == (3, 2, 2, 1, 2)
    assert bm.figures(results, max_time=0.005)["within_budget"] == 1  # 3 ms in, 7 ms late
    assert f["plan_median_ms"] == pytest.approx(2.0) and f["total_median_ms"] == pytest.approx(5.0)
    assert f["length_median"] == pytest.approx((17.0 + 5.0) / 2)
    assert f["duration_median_s"] == pytest.approx(2.0)


def test_render_and_write_section(tmp_path):
    f = {"n": 2, "solved": 2, "invalid": 0, "checked": 2, "plan_median_ms": 1.0, "plan_p95_ms": 2.0,
         "simplify_median_ms": 1.0, "simplify_p95_ms": 2.0, "total_median_ms": 2.0, "total_p95_ms": 4.0,
         "length_median": 3.2}
    workload = {"problems": 2, "max_time_s": 1.0, "peer_versions": {}, "dense_check": {"step_rad": 5e-4}}
    doc = {"machine": {"cpu": "x", "cores": 2, "python": "3"}, "workload": workload,
           "overall": {"kinserve": f}, "per_set": {"cage": {"kinserve": f}},
           "targets_met": {"0 invalid": True}}
    lines = render_tables.render_motion(doc)
    assert sum(line.startswith("| ") for line in lines) == 3  # header + overall + cage
    md = tmp_path / "benchmarks.md"
    md.write_text("# Benchmarks\n\nkept text\n")
    render_tables.write_section(md, "motion", lines)
    render_tables.write_section(md, "motion", lines)  # rewritten in place, not appended twice
    text = md.read_text()
    assert text.count("<!-- motion:begin") == 1 and "kept text" in text and "| cage | kinserve |" in text
    (tmp_path / "motion.json").write_text(json.dumps(doc))
    assert "MotionBenchMaker" in render_tables.render(tmp_path)


@needs_dataset
def test_tiny_subset_end_to_end(tmp_path):
    problems_dir = bm.unpack(DATASET, tmp_path / "mbm")
    robot = bm.load_robot(DATASET)
    problems = bm.load_problems(problems_dir, robot, ("table_pick", "bookshelf_small"), 2)[:3]
    assert [(p.set, p.index, p.seed) for p in problems] == [("table_pick", 1, 0), ("table_pick", 2, 1),
                                                             ("bookshelf_small", 1, 2)]
    planners = {"kinserve": lambda p, t: bm.run_kinserve(robot, p, None, max_iterations=20000)}
    outcomes = bm.run_problems(planners, problems, max_time=None)
    check = bm.dense_check(DATASET, problems, outcomes)
    assert check["invalid_starts_or_goals"] == 0 and check["configurations_checked"] > 0
    summary = bm.summarise(problems, outcomes)
    k = summary["overall"]["kinserve"]
    assert k["solved"] >= 1 and k["checked"] == k["solved"]
    assert k["invalid"] == 0
    assert set(summary["per_set"]) == {"table_pick", "bookshelf_small"}
    assert "0 invalid paths" in bm.targets_met(summary)
