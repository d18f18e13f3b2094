"""``kinserve plan``, end to end: the real console script in a subprocess, its trajectory files checked
against an independent collision model (:class:`motion_scenes.IndependentCheck`: the URDF's meshes and
``pinocchio.computeCollisions``, not the planner's hulls and certificates)."""

from __future__ import annotations

import inspect
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from kinserve import planners, robots
from kinserve.planners import JointTrajectory
from kinserve.service.cli_plan import DEFAULT_MAX_TIME

from motion_scenes import IndependentCheck, box, dense, straight_line_collides

START = [-1.0, 0.3, 0.0, -2.0, 0.0, 2.3, 0.8]
GOAL = [1.0, 0.3, 0.0, -2.0, 0.0, 2.3, 0.8]
#: A bar in front of the Panda, between START and GOAL: the straight joint-space line hits it.
BAR = ("0.5", "0", "0.35", "0.1", "0.6", "0.1")
BUDGET = ("--max-time", "none", "--max-iterations", "1500", "--seed", "0")


def kinserve(*args: str, cwd) -> subprocess.CompletedProcess:
    exe = os.path.join(os.path.dirname(sys.executable), "kinserve")
    return subprocess.run([exe, *args], cwd=cwd, env=dict(os.environ, MPLBACKEND="Agg"), capture_output=True,
                          text=True, timeout=300)


def numbers(q) -> list[str]:
    return [repr(float(v)) for v in q]


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda", geometry=False)


@pytest.fixture(scope="module")
def bar_check(panda):
    obstacle = box([float(v) for v in BAR[3:]], [float(v) for v in BAR[:3]])
    return obstacle, IndependentCheck(panda, [obstacle])


@pytest.fixture(scope="module")
def json_run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("plan")
    out = kinserve("plan", "panda", "--start", *numbers(START), "--goal", *numbers(GOAL), "--box", *BAR,
                   *BUDGET, "--out", "traj.json", cwd=folder)
    return out, folder / "traj.json"


def test_plan_writes_a_collision_free_trajectory_at_rest_at_both_ends(json_run, panda, bar_check):
    out, path = json_run
    assert out.returncode == 0, out.stderr
    assert "plan found (1 obstacle(s), self-collision)" in out.stdout and f"wrote {path.name}" in out.stdout
    traj = JointTrajectory.load(path)
    assert traj.joint_names == panda.joint_names and traj.n_points > 10
    np.testing.assert_allclose(traj.positions[0], START, atol=1e-9)
    np.testing.assert_allclose(traj.positions[-1], GOAL, atol=1e-9)
    np.testing.assert_allclose(traj.velocities[[0, -1]], 0.0, atol=1e-9)
    obstacle, check = bar_check
    assert straight_line_collides(panda, [obstacle], np.array(START), np.array(GOAL))
    line = np.linspace(START, GOAL, 64)
    assert check.first_collision(line) >= 0  # the independent check has teeth on this problem
    samples = dense(traj.positions)
    assert check.first_collision(samples) == -1
    assert np.all(samples >= panda.lower - 1e-9) and np.all(samples <= panda.upper + 1e-9)


def test_plan_writes_csv_and_json_summary(json_run, tmp_path):
    out = kinserve("plan", "panda", "--start", *numbers(START), "--goal", *numbers(GOAL), "--box", *BAR,
                   *BUDGET, "--out", "traj.csv", "--json", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    body = json.loads(out.stdout)
    csv = JointTrajectory.load(tmp_path / "traj.csv")
    same_seed = JointTrajectory.load(json_run[1])  # an iteration budget alone: the same plan
    np.testing.assert_array_equal(csv.times, same_seed.times)
    np.testing.assert_array_equal(csv.positions, same_seed.positions)
    assert body["success"] is True and body["written"] == ["traj.csv"]
    assert body["duration"] == pytest.approx(csv.duration) and body["trajectory_points"] == csv.n_points
    np.testing.assert_allclose(body["path"][0], START) and np.testing.assert_allclose(body["path"][-1], GOAL)
    assert body["waypoints"] == len(body["path"]) >= 2
    assert body["stats"]["iterations"] >= 1 and body["stats"]["timing"] == "toppra"


def test_a_start_in_collision_exits_1_naming_the_pair(panda, tmp_path):
    start = [0.0, 0.3, 0.0, -2.0, 0.0, 2.3, 0.8]
    block = ("0.5", "0", "0.35", "0.4", "0.6", "0.4")
    obstacle = box([0.4, 0.6, 0.4], [0.5, 0.0, 0.35])
    assert IndependentCheck(panda, [obstacle], self_collision=False).colliding(np.array(start))
    out = kinserve("plan", "panda", "--start", *numbers(start), "--goal", "default", "--box", *block,
                   "--out", "t.json", cwd=tmp_path)
    assert out.returncode == 1 and "Traceback" not in out.stderr
    assert out.stderr.startswith("plan failed: start is in collision: ")
    assert "panda_hand with obstacle[0]:box" in out.stderr and "nothing written to --out" in out.stderr
    assert "NO PLAN" in out.stdout and not (tmp_path / "t.json").exists()


def test_a_pose_goal_is_reached(panda, tmp_path):
    s = float(np.sqrt(0.5))
    quat = (s, s, 0.0, 0.0)  # x y z w: half a turn about the x+y diagonal - the hand points down
    out = kinserve("plan", "panda", "--xyz", "0.45", "0.45", "0.4", "--quat", *map(repr, quat), "--box", *BAR,
                   *BUDGET, "--out", "p.json", "--json", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    body = json.loads(out.stdout)
    assert body["goal_set"] >= 1 and body["frame"] == panda.tip
    T = panda.fk(JointTrajectory.load(tmp_path / "p.json").positions[-1])
    np.testing.assert_allclose(T[:3, 3], [0.45, 0.45, 0.4], atol=1e-4)
    R = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])  # 2 n n^T - I, n = (1, 1, 0)/sqrt 2
    np.testing.assert_allclose(T[:3, :3], R, atol=2e-3)


def test_html_page_of_the_motion(tmp_path):
    out = kinserve("plan", "panda", "--start", *numbers(START), "--goal", *numbers(GOAL), "--box", *BAR,
                   *BUDGET, "--html", "plan.html", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    page = tmp_path / "plan.html"
    assert "wrote plan.html" in out.stdout and page.stat().st_size > 100_000
    assert "<script" in page.read_text()


def test_the_default_time_budget_is_plan_motions():
    assert DEFAULT_MAX_TIME == inspect.signature(planners.plan_motion).parameters["max_time"].default


def test_a_carried_box_is_checked(tmp_path):
    """A sphere 13 cm below the hand: the arm alone is clear of it, the box it carries is not."""
    sphere = ("--sphere", "0.325", "-0.506", "0.009", "0.04")
    free = kinserve("plan", "panda", "--start", *numbers(START), "--goal", *numbers(GOAL), *sphere, *BUDGET,
                    "--json", cwd=tmp_path)
    assert free.returncode == 0, free.stderr
    assert json.loads(free.stdout)["attached"] == {}
    out = kinserve("plan", "panda", "--start", *numbers(START), "--goal", *numbers(GOAL), *sphere, *BUDGET,
                   "--attach-box", "panda_hand", "0.04", "0.04", "0.3", "0", "0", "0.2", cwd=tmp_path)
    assert out.returncode == 1 and "(1 obstacle(s), 1 carried, self-collision)" in out.stdout
    assert out.stderr.startswith("plan failed: start is in collision: attached:box0 with obstacle[0]:sphere")
    bad = kinserve("plan", "panda", "--goal", "default", "--attach-box", "panda_hand", "0.1", cwd=tmp_path)
    assert bad.returncode == 2
    assert "argument --attach-box: expected 3 or 6 numbers FRAME SX SY SZ [X Y Z], got 1" in bad.stderr
