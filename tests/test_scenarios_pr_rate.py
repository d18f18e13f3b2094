"""S5 (PR robot, resolved rate) end to end: ``scenarios.run("pr-rate")`` once per module, checked
independently.

The robot's kinematics are written out here from SCENARIOS.md
(``x = d1 + d2 cos t2``, ``y = d2 sin t2``, ``J = [[1, -d2 sin t2], [0, d2 cos t2]]``);
the tests recompute errors, workspace exits, singular steps and circle
tracking errors from the saved joint histories with these formulas.
"""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from kinserve import robots

from scenario_runs import figures, run_into

ROOT = Path(__file__).resolve().parents[1]
D2 = 1.0
SIGMA = 0.05

#: SCENARIOS.md S5, written out again: (v, [d1, theta2 deg], n, Delta).
TABLE = [([2, 0], [1, 0], 50, 0.2), ([0.2, 4], [1, 0], 25, 0.2), ([0.2, 4], [1, 0], 25, 1),
         ([0.2, 4], [1, 0], 25, 0.5), ([0.2, 4], [1, 0], 25, 0.75), ([1, 4], [1, 0], 15, 0.75),
         ([4, 4], [1, 0], 15, 0.75), ([4, 4], [1, 0], 35, 0.75), ([4, 4], [1, 90], 35, 0.75),
         ([0.2, 0.2], [1, 45], 35, 0.75), ([0.5, 1], [1, 45], 35, 0.75)]
CIRCLES = [([1, 0.25], 0.2, 5000, 0.001), ([1, 0.5], 0.5, 5000, 0.001), ([1, 0.5], 0.5, 5000, 0.01),
           ([1, 0.3], 0.3, 5000, 0.001)]


def tool(q):
    q = np.atleast_2d(q)
    return np.c_[q[:, 0] + D2 * np.cos(q[:, 1]), D2 * np.sin(q[:, 1])]


def jac(t2):
    return np.array([[1.0, -D2 * math.sin(t2)], [0.0, D2 * math.cos(t2)]])


@pytest.fixture(scope="module")
def s5(tmp_path_factory):
    out = tmp_path_factory.mktemp("pr-rate")
    run_into(out, "pr-rate")
    return json.loads((out / "result.json").read_text()), out


def test_fk_and_jacobian_formula_match_the_urdf_model():
    robot = robots.load("pr")
    rng = np.random.default_rng(1)
    for q in [np.array([1.0, math.pi / 2]), np.array([0.3, -math.pi / 2])] + list(robot.random_q(rng, 30)):
        np.testing.assert_allclose(robot.fk(q)[:2, 3], tool(q)[0], atol=1e-12)
        np.testing.assert_allclose(robot.jacobian(q)[:2], jac(q[1]), atol=1e-12)
        h = 1e-6  # the formula is the derivative of the FK
        fd = np.column_stack([(tool(q + h * e)[0] - tool(q - h * e)[0]) / (2 * h) for e in np.eye(2)])
        np.testing.assert_allclose(fd, jac(q[1]), atol=1e-8)


def test_result_reports_the_formula_checks(s5):
    r, _ = s5
    assert r["jacobian_formula_error"] < 1e-12 and r["fk_formula_error"] < 1e-12
    assert r["d2"] == D2


def test_the_table_is_the_documents(s5):
    r, _ = s5
    assert [(row["v"], row["q_init"], row["n"], row["dt"]) for row in r["table"]] == \
        [(list(map(float, v)), list(map(float, q)), n, float(dt)) for v, q, n, dt in TABLE]


def test_each_run_is_reported_against_the_ideal_line(s5):
    r, _ = s5
    for row, (v, qi, n, dt) in zip(r["table"], TABLE):
        Q = np.array(row["q"])
        assert Q.shape == (n + 1, 2)
        np.testing.assert_allclose(Q[0], [qi[0], math.radians(qi[1])], atol=1e-15)
        P = tool(Q)
        line = P[0] + np.outer(dt * np.arange(n + 1), v)
        err = np.linalg.norm(P - line, axis=1)
        assert row["final_error"] == pytest.approx(err[-1], rel=1e-9, abs=1e-12)
        assert row["max_error"] == pytest.approx(err.max(), rel=1e-9, abs=1e-12)
        np.testing.assert_allclose(row["final_position"], P[-1], atol=1e-9)
        # the first step on which the line is out of reach, |y| > d2
        out = np.flatnonzero(np.abs(line[:, 1]) > D2 + 1e-12)
        assert row["leaves_workspace_step"] == (int(out[0]) if out.size else None)
        w = np.abs(D2 * np.cos(Q[:, 1]))  # |det J|
        assert row["min_manipulability"] == pytest.approx(w.min(), abs=1e-12)


def test_run_along_x_follows_the_line_exactly(s5):
    r, _ = s5
    row = r["table"][0]
    assert row["leaves_workspace_step"] is None and not row["singular"]
    assert row["final_error"] < 1e-9 and row["max_error"] < 1e-9
    np.testing.assert_allclose(row["final_position"], [2.0 + 2.0 * 50 * 0.2, 0.0], atol=1e-9)
    assert r["run1_final_error"] < 1e-9


def test_singular_steps_are_where_the_jacobian_loses_rank(s5):
    r, _ = s5
    for row in r["table"]:
        Q = np.array(row["q"])
        smin = np.array([np.linalg.svd(jac(t2), compute_uv=False)[-1] for t2 in Q[:, 1]])
        low = smin < SIGMA
        starts = [k for k in range(len(Q)) if low[k] and (k == 0 or not low[k - 1])]
        assert row["singular_steps"] == starts, row["run"]
        assert row["singular"] == bool(starts)


def test_run_starting_at_90_degrees_reports_the_singularity_at_step_0(s5):
    r, _ = s5
    row = next(x for x in r["table"] if x["q_init"][1] == 90.0)
    assert row["run"] == r["singular_start_run"] == 9
    assert row["singular_steps"][0] == 0 == r["singular_start_event_step"]
    first = [e for e in row["events"] if e["step"] == 0 and e["kind"] == "low_manipulability"]
    assert first and first[0]["value"] < 1e-12  # sigma_min = d2 |cos 90 deg|
    assert row["min_manipulability"] < 1e-12


def test_damping_bounds_the_joint_rates(s5):
    """|qdot| <= |v| / sigma_threshold with the adaptive damping; the plain inverse far exceeds it near theta2
    = 90 deg (the two runs part ways after the first near-singular step, so only the largest ratio is
    compared)."""
    r, _ = s5
    for row in r["table"]:
        assert row["max_joint_rate"] <= np.linalg.norm(row["v"]) / SIGMA * (1 + 1e-9)
    assert max(row["max_joint_rate_undamped"] / row["max_joint_rate"] for row in r["table"]) > 10


def test_straight_line_error_vanishes_with_the_step(s5):
    """Inside the workspace the tool follows v: the open-loop error is O(Delta), closed loop smaller still."""
    r, _ = s5
    rows = r["step_study"]["rows"]
    dts = np.array([x["dt"] for x in rows])
    op = np.array([x["open_loop_final_error"] for x in rows])
    cl = np.array([x["closed_loop_final_error"] for x in rows])
    assert np.all(np.diff(dts) < 0) and np.all(np.diff(op) < 0)
    slope = np.polyfit(np.log(dts[-4:]), np.log(op[-4:]), 1)[0]
    assert 0.9 < slope < 1.1
    assert op[-1] < 2e-4 and np.all(cl < op) and cl[-1] < 1e-6
    slope_cl = np.polyfit(np.log(dts[-4:]), np.log(cl[-4:]), 1)[0]
    assert 1.8 < slope_cl < 2.2  # closed loop keeps one step's linearisation error, O(Delta^2)


def test_closed_loop_beats_open_loop_on_every_circle(s5):
    r, out = s5
    assert r["closed_beats_open_on_all_circles"] is True
    assert len(r["circles"]) == 4
    for row, (c, rad, n, dt) in zip(r["circles"], CIRCLES):
        assert (row["centre"], row["radius"], row["n"], row["dt"]) == (list(map(float, c)), rad, n, dt)
        data = np.loadtxt(out / row["file"], delimiter=",", skiprows=1)
        assert data.shape == (n + 1, 11)
        t = data[:, 0]
        np.testing.assert_allclose(t, dt * np.arange(n + 1), atol=1e-9)
        # the reference circle at 1 rad/s from c + (r, 0), counter-clockwise, written out here
        ref = np.asarray(c) + rad * np.c_[np.cos(t), np.sin(t)]
        np.testing.assert_allclose(data[:, 1:3], ref, atol=1e-9)
        errs = {}
        for key, cols in (("open", slice(3, 5)), ("closed", slice(7, 9))):
            P = tool(data[:, cols])
            e = np.linalg.norm(P - ref, axis=1)
            errs[key] = e
            assert row[key]["max_error"] == pytest.approx(e.max(), rel=1e-6, abs=1e-12)
        assert errs["closed"].max() < errs["open"].max()
        assert np.sqrt(np.mean(errs["closed"] ** 2)) < np.sqrt(np.mean(errs["open"] ** 2))
    # the circle well inside the workspace: open loop drifts by 1e-4 m, closed loop stays at 1e-7 m
    assert r["circles"][0]["open"]["max_error"] > 1e-4 > 1e-7 > r["circles"][0]["closed"]["max_error"]
    # the circles touching y = d2 pass the singularity, and report it
    for row in r["circles"][1:3]:
        assert row["touches_singularity"]
        assert any(e["kind"] == "low_manipulability" for e in row["closed"]["events"])


def test_pngs_are_real_plots(s5):
    _, out = s5
    for name in ("runs_xy", "runs_joints", "step_size", "circles", "circle_errors", "manipulability"):
        img = np.asarray(Image.open(out / f"{name}.png").convert("RGB"))
        assert img.shape[0] > 300 and img.shape[1] > 500, name
        packed = (img[..., 0].astype(np.int32) << 16) | (img[..., 1].astype(np.int32) << 8) | img[..., 2]
        assert len(np.unique(packed)) > 100, name
        assert 0.02 < (img.min(axis=2) < 200).mean() < 0.6, name  # ink, but not a filled canvas


def test_cli_demo_pr_rate_end_to_end(tmp_path):
    env = dict(os.environ, MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, "-m", "kinserve.service.cli", "demo", "pr-rate", "--out",
                           str(tmp_path)], cwd=ROOT,
                          env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert "[pr-rate]" in proc.stdout and "singular_start_event_step=0" in proc.stdout
    r = json.loads((tmp_path / "pr-rate" / "result.json").read_text())
    assert r["runs"] == 11 and r["closed_beats_open_on_all_circles"] is True
    assert (tmp_path / "pr-rate" / "circles.png").is_file()


def test_runs_joints_plot_shows_every_run(s5):
    """runs_joints.png: one panel per run of the table (all 11), each with d1 and theta2 over n + 1 steps."""
    from figure_checks import axis_labels, titles_inside

    r, out = s5
    fig = figures(out)["runs_joints.png"]
    titles_inside(fig)
    panels = {}
    for ax in fig.axes:
        m = re.match(r"run (\d+):", ax.get_title())
        if m:
            assert m.group(1) not in panels
            panels[m.group(1)] = ax
    assert len(panels) == len(r["table"]) == 11
    for row in r["table"]:
        ax = panels[str(row["run"])]
        axis_labels(ax)
        (d1,) = [ln for ln in ax.lines if ln.get_label() == "d₁ (m)"]
        assert len(d1.get_xdata()) == row["n"] + 1 and d1.get_ydata()[0] == pytest.approx(row["q_init"][0])
        twins = [a for a in fig.axes if a is not ax and a.bbox.bounds == ax.bbox.bounds]
        assert any(ln.get_label() == "θ₂ (deg)" for a in twins for ln in a.lines)

def test_readme_row_matches_a_fresh_run(s5):
    from scenario_runs import assert_readme_row

    assert_readme_row("pr-rate", s5[0])
