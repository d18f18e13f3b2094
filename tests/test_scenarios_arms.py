"""The arm scenarios S1 (planar4r), S2 (youbot), S3 (youbot-tour) and S9 (scara), end to end.

Each scenario runs once per module (``scenarios.run`` into a temporary
folder). The tests read what it wrote - ``result.json``, the trajectory files,
``iterates.json`` - and check the numbers against independent math written
out here: the planar 4R and DH forward kinematics as explicit sums and
products, the 2R law of cosines, a planar segment-crossing test, finite
differences, brute force over every visiting order, and point-to-segment
distances to the S9 sphere.
"""

from __future__ import annotations

import csv
import itertools
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from matplotlib.image import imread

from kinserve import robots, scenarios
from kinserve.kinematics.errors import InputError
from kinserve.planners import JointTrajectory
from kinserve.scenarios.checkpoint_file import load_checkpoints, parse_csv, parse_json

from scenario_runs import assert_readme_row, figures, run_scenario

ROOT = Path(__file__).resolve().parents[1]
LENGTHS = np.array([1.0, 0.8, 0.6, 0.4])


def load(folder: Path) -> dict:
    return json.loads((folder / "result.json").read_text())


def assert_pngs(folder: Path, names):
    for name in names:
        p = folder / name
        assert p.is_file(), f"{name} missing"
        assert p.stat().st_size > 15_000, f"{name} is only {p.stat().st_size} bytes"
        img = imread(p)
        assert img.shape[0] > 300 and img.shape[1] > 400
        rgb = (img[::2, ::2, :3].reshape(-1, 3) * 255).astype(np.int64)
        assert rgb.std(axis=0).max() > 10, f"{name} is (nearly) blank"
        packed = (rgb[:, 0] << 16) | (rgb[:, 1] << 8) | rgb[:, 2]
        assert np.count_nonzero(packed != 0xFFFFFF) > 0.02 * packed.size, f"{name} is mostly white"
        assert len(np.unique(packed)) > 20, f"{name} has almost no colours"


def assert_scene(folder: Path, animated: bool):
    from kinserve import viz

    p = folder / "scene.html"
    assert p.is_file() and p.stat().st_size > 100_000
    kinds = {c["type"] for c in viz.read_html_commands(p)}
    assert "set_object" in kinds
    assert ("set_animation" in kinds) == animated


# --------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def planar(tmp_path_factory):
    return run_scenario(tmp_path_factory, "planar4r")


@pytest.fixture(scope="module")
def youbot(tmp_path_factory):
    return run_scenario(tmp_path_factory, "youbot")


@pytest.fixture(scope="module")
def tour(tmp_path_factory):
    return run_scenario(tmp_path_factory, "youbot-tour")


@pytest.fixture(scope="module")
def scara(tmp_path_factory):
    return run_scenario(tmp_path_factory, "scara")


# --------------------------------------------------------------------------- S1 planar 4R
def planar_fk(q, lengths=LENGTHS):
    """(x, y, theta_e) = (sum l_i cos(q1+..+qi), sum l_i sin(...), q1+..+q4)."""
    phi = np.cumsum(q)
    return np.array([np.sum(lengths * np.cos(phi)), np.sum(lengths * np.sin(phi)), phi[-1]])


def task_residual(q, target):
    x, y, th = planar_fk(q)
    return math.hypot(x - target[0], y - target[1]), abs(math.remainder(th - target[2], 2 * math.pi))


def segments_cross(P):
    """True when two non-adjacent links of the planar chain ``P`` ((5, 2) points) intersect."""
    def orient(a, b, c):
        return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])

    def on(a, b, c):
        e = 1e-12
        return (min(a[0], b[0]) - e <= c[0] <= max(a[0], b[0]) + e
                and min(a[1], b[1]) - e <= c[1] <= max(a[1], b[1]) + e)

    for i in range(len(P) - 1):
        for j in range(i + 2, len(P) - 1):
            a, b, c, d = P[i], P[i + 1], P[j], P[j + 1]
            o1, o2, o3, o4 = orient(a, b, c), orient(a, b, d), orient(c, d, a), orient(c, d, b)
            eps = 1e-12
            if ((o1 > eps and o2 < -eps or o1 < -eps and o2 > eps)
                and (o3 > eps and o4 < -eps or o3 < -eps and o4 > eps)):
                return True
            if (abs(o1) <= eps and on(a, b, c)) or (abs(o2) <= eps and on(a, b, d)) or \
               (abs(o3) <= eps and on(c, d, a)) or (abs(o4) <= eps and on(c, d, b)):
                return True
    return False


def chain_points(q):
    phi = np.cumsum(q)
    return np.vstack([[0.0, 0.0], np.cumsum(LENGTHS[:, None] * np.c_[np.cos(phi), np.sin(phi)], axis=0)])


def test_planar_family_members_all_reach_the_task(planar):
    _, r = planar
    Q = np.array(r["family_q"])
    target = r["target"]
    assert r["family_size"] == len(Q) > 60
    res = np.array([task_residual(q, target) for q in Q])
    assert res.max() < 1e-9
    assert r["max_fk_position_residual"] < 1e-9 and r["max_fk_orientation_residual"] < 1e-9
    # and Pinocchio's model agrees with the explicit sum
    robot = robots.load("planar4r", geometry=False)
    for q in Q[::7]:
        T = robot.fk(q)
        assert np.allclose(T[:2, 3], target[:2], atol=1e-9)
        assert abs(math.remainder(math.atan2(T[1, 0], T[0, 0]) - target[2], 2 * math.pi)) < 1e-9
    lo, hi = robot.lower, robot.upper
    assert np.all(Q >= lo - 1e-12) and np.all(Q <= hi + 1e-12)


def test_planar_family_is_a_one_parameter_set_with_both_branches(planar):
    _, r = planar
    Q = np.array(r["family_q"])
    q1 = np.array(r["family_free_parameter"])
    branch = np.array(r["family_branch"])
    assert np.allclose(Q[:, 0], q1)  # the free parameter is q1
    assert r["elbow_up"] > 20 and r["elbow_down"] > 20
    assert len(np.unique(np.round(q1, 9))) > 30 and q1.max() - q1.min() > 1.0
    # at one value of q1 there are at most two members (the elbow branches), mirror images in q3
    for v in np.unique(np.round(q1, 9)):
        idx = np.flatnonzero(np.abs(q1 - v) < 1e-9)
        assert len(idx) <= 2
        if len(idx) == 2:
            assert abs(math.remainder(Q[idx[0], 2] + Q[idx[1], 2], 2 * math.pi)) < 1e-7
            if set(branch[idx]) != {"elbow up", "elbow down"}:
                # folded end, q3 = +-pi: one pose, two joint values
                assert np.abs(np.remainder(Q[idx[0]] - Q[idx[1]]
                                           + math.pi, 2 * math.pi) - math.pi).max() < 1e-9
    # a continuum: between neighbouring samples every q1 has a solution (2R law of cosines, written out here)
    w = np.array(r["target"][:2]) - LENGTHS[3] * np.array([math.cos(r["target"][2]),
                                                           math.sin(r["target"][2])])
    vals = np.unique(np.round(q1, 12))
    mids = [(a + b) / 2 for a, b in zip(vals[:-1], vals[1:]) if b - a < 0.1]
    assert len(mids) > 30
    for m in mids:
        d = w - LENGTHS[0] * np.array([math.cos(m), math.sin(m)])
        c3 = (d @ d - LENGTHS[1] ** 2 - LENGTHS[2] ** 2) / (2 * LENGTHS[1] * LENGTHS[2])
        assert -1 <= c3 <= 1
        for s in (1, -1):
            q3 = s * math.acos(c3)
            a12 = math.atan2(d[1], d[0]) - math.atan2(LENGTHS[2] * math.sin(q3),
                                                      LENGTHS[1] + LENGTHS[2] * math.cos(q3))
            q = np.array([m, a12 - m, q3, r["target"][2] - a12 - q3])
            assert max(task_residual(q, r["target"])) < 1e-9


def test_planar_chooser_picks_the_best_member_for_each_criterion(planar):
    _, r = planar
    Q = np.array(r["family_q"])
    qc = np.array(r["q_current"])
    chosen = r["chosen"]
    lim = math.pi
    limit_distance = np.min(np.minimum(Q + lim, lim - Q) / (2 * lim), axis=1)
    disp = np.linalg.norm(Q - qc, axis=1)

    def manip(q):  # planar Jacobian rows (x, y, theta), written out
        phi = np.cumsum(q)
        J = np.array([[-np.sum(LENGTHS[k:] * np.sin(phi[k:])) for k in range(4)],
                      [np.sum(LENGTHS[k:] * np.cos(phi[k:])) for k in range(4)], [1.0] * 4])
        return math.sqrt(np.linalg.det(J @ J.T))

    w = np.array([manip(q) for q in Q])
    crossing = np.array([segments_cross(chain_points(q)) for q in Q])
    assert np.isclose(limit_distance[chosen["joint_limit_distance"]["index"]],
                      limit_distance.max(), atol=1e-12)
    assert np.isclose(disp[chosen["displacement"]["index"]], disp.min(), atol=1e-12)
    assert np.isclose(w[chosen["manipulability"]["index"]], w.max(), rtol=1e-9)
    k = chosen["no_self_overlap"]["index"]
    assert not crossing[k] and np.isclose(disp[k], disp[~crossing].min(), atol=1e-12)
    # the demo's point: the nearest member's links cross, so the filter changes the pick
    assert crossing[chosen["displacement"]["index"]] and chosen["displacement"]["self_overlap"]
    assert crossing.sum() == r["self_overlapping"] > 0
    assert not segments_cross(chain_points(qc))
    for name, c in chosen.items():
        assert np.allclose(c["q"], Q[c["index"]])
        assert max(task_residual(np.array(c["q"]), r["target"])) < 1e-9


def test_planar_branches_collapse_at_the_workspace_boundary(planar):
    _, r = planar
    b = r["boundary"]
    x, y, a = b["target"]
    assert math.hypot(x, y) == pytest.approx(LENGTHS.sum())
    assert b["distinct"] == 1 and r["boundary_distinct"] == 1
    for q in b["q"]:  # the stretched arm pointing at the target
        assert np.allclose(q, [a, 0, 0, 0], atol=1e-6)
        assert max(task_residual(np.array(q), b["target"])) < 1e-9
    rows = [row for row in b["sweep"]["rows"] if row["gap"] > 0]
    gaps = np.array([row["gap"] for row in rows])
    width = np.array([row["free_parameter_width"] for row in rows])
    sep = np.array([row["branch_separation"] for row in rows])
    assert np.all(np.diff(width) < 0) and np.all(np.diff(sep) < 0)  # gaps are listed decreasing
    small = gaps <= 1e-3  # width ~ C sqrt(gap) near the boundary
    ratio = width[small] / np.sqrt(gaps[small])
    assert ratio.std() / ratio.mean() < 0.02
    assert all(row["family_size"] > 10 for row in rows)


def test_planar_family_plot_legend_counts_come_from_the_result(planar):
    from figure_checks import axis_labels, legends_clear_of_data, titles_inside

    out, r = planar
    fig = figures(out)["family.png"]
    titles_inside(fig)
    legends_clear_of_data(fig)
    axis_labels(fig.axes[0])
    labels = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
    up = next(lbl for lbl in labels if lbl.startswith("elbow up"))
    down = next(lbl for lbl in labels if lbl.startswith("elbow down"))
    cross = next(lbl for lbl in labels if lbl.startswith("links cross"))
    assert f"elbow up: {r['elbow_up']} members" in up and f"elbow down: {r['elbow_down']} members" in down
    assert f"{r['self_overlapping']} members" in cross
    # the numbers in parentheses are the crossing members of each branch, as result.json lists them
    branch, overlap = np.array(r["family_branch"]), np.array(r["family_self_overlap"], dtype=bool)
    n_up, n_down = (int((overlap & (branch == "elbow up")).sum()),
                    int((overlap & (branch == "elbow down")).sum()))
    assert f"({n_up} with crossing" in up and f"({n_down} with crossing" in down
    assert (r["elbow_up"] == int((branch == "elbow up").sum())
            and r["elbow_down"] == int((branch == "elbow down").sum()))


def test_planar_artefacts(planar):
    out, _ = planar
    assert_pngs(out, ["family.png", "family_joints.png", "chosen.png", "boundary.png"])
    assert_scene(out, animated=False)


# --------------------------------------------------------------------------- S2 youBot
YOUBOT_DH = [(-0.033, math.pi / 2, 0.145), (0.155, 0.0, 0.0), (0.135, 0.0, 0.0), (0.002, math.pi / 2, 0.0),
             (0.0, math.pi, -0.185)]
YOUBOT_LIMITS_DEG = [(-169, 169), (-65, 90), (-151, 146), (-102.5, 102.5), (-167.5, 167.5)]


def dh_chain(q):
    """Frames T_0..T_5 of the standard DH product Rz(theta) Tz(d) Tx(a) Rx(alpha), written out."""
    T, out = np.eye(4), [np.eye(4)]
    for (a, al, d), th in zip(YOUBOT_DH, q):
        ct, st, ca, sa = math.cos(th), math.sin(th), math.cos(al), math.sin(al)
        T = T @ np.array([[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st], [0, sa, ca, d],
                          [0, 0, 0, 1]])
        out.append(T)
    return out


def test_youbot_dh_fk_and_jacobian_match_the_urdf_model(youbot):
    _, r = youbot
    assert r["fk_max_difference"] < 1e-12 and r["jacobian_max_difference"] < 1e-12
    robot = robots.load("youbot", geometry=False)
    rng = np.random.default_rng(41)
    for q in robot.random_q(rng, 10):
        F = dh_chain(q)
        assert np.abs(robot.fk(q) - F[-1]).max() < 1e-12
        # finite differences of the tool position and orientation against the geometric Jacobian
        J = robot.jacobian(q)
        h = 1e-6
        for j in range(5):
            dq = np.zeros(5)
            dq[j] = h
            Ta, Tb = dh_chain(q + dq)[-1], dh_chain(q - dq)[-1]
            assert np.allclose((Ta[:3, 3] - Tb[:3, 3]) / (2 * h), J[:3, j], atol=1e-7)
            W = (Ta[:3, :3] - Tb[:3, :3]) / (2 * h) @ F[-1][:3, :3].T  # [w]_x
            assert np.allclose([W[2, 1], W[0, 2], W[1, 0]], J[3:, j], atol=1e-7)
    assert r["convention"].startswith("standard DH")
    np.testing.assert_allclose(r["limits_deg"]["lower"], [lo for lo, _ in YOUBOT_LIMITS_DEG])
    np.testing.assert_allclose(r["limits_deg"]["upper"], [hi for _, hi in YOUBOT_LIMITS_DEG])


def test_youbot_singularity_by_singular_values_not_det(youbot):
    _, r = youbot
    robot = robots.load("youbot", geometry=False)
    qs = np.array(r["singular"]["q"])
    assert qs[2] == 0.0 and r["singular_rank"] == 4
    s = np.linalg.svd(robot.jacobian(qs), compute_uv=False)
    assert s.shape == (5,) and s[-1] < 1e-10 * s[0]
    s_ref = np.linalg.svd(robot.jacobian(np.array(r["reference"]["q"])), compute_uv=False)
    assert r["reference"]["rank"] == 5 and s_ref[-1] > 1e-3
    assert r["reference"]["manipulability"] == pytest.approx(np.prod(s_ref))
    q3 = np.array(r["sweep"]["q3"])
    w = np.array(r["sweep"]["manipulability"])
    assert r["sweep"]["singular_q3"] == [0.0]
    assert w[q3 == 0.0][0] < 1e-12 and np.all(w[np.abs(q3) > 0.05] > 1e-4)
    assert r["random"]["min_rank"] == 5


def test_youbot_every_branch_satisfies_fk_and_the_limits(youbot):
    _, r = youbot
    lo = np.radians([lo for lo, _ in YOUBOT_LIMITS_DEG])
    hi = np.radians([hi for _, hi in YOUBOT_LIMITS_DEG])
    labels = {}
    for name, case in r["ik"].items():
        T = np.array(case["target"])
        Q = np.array([b["q"] for b in case["branches"]])
        assert len(Q) == case["n_branches"] >= 2
        for q in Q:
            assert np.all(q >= lo - 1e-9) and np.all(q <= hi + 1e-9)
            Tq = dh_chain(q)[-1]
            assert np.abs(Tq - T).max() < 1e-9
        # distinct configurations
        for a, b in itertools.combinations(Q, 2):
            assert np.abs(a - b).max() > 1e-3
        labels[name] = [b["branch"] for b in case["branches"]]
    assert set(labels["forward"]) == {"front, elbow up", "front, elbow down"}
    assert any(lbl.startswith("back") for lbl in labels["above the base"])
    assert r["branches_forward"] == 2 and r["branches_above"] == 3


def test_youbot_off_set_pose_is_reported_and_the_nearest_reachable_pose_solved(youbot):
    _, r = youbot
    off = r["off_reachable"]
    assert "off the 5-DOF reachable set" in off["note"]
    T = np.array(off["target"])
    for b in off["branches"]:
        q = np.array(b["q"])
        Tq = dh_chain(q)[-1]
        n = np.array([math.sin(q[0]), -math.cos(q[0]), 0.0])  # arm-plane normal
        assert abs(Tq[:3, 2] @ n) < 1e-9  # the reached approach axis lies in the arm plane
        assert np.linalg.norm(Tq[:3, 3] - T[:3, 3]) < 1e-9  # position kept
        bound = math.asin(abs(T[:3, 2] @ n))  # no in-plane z axis is closer to the target's
        angle = math.acos(np.clip((np.trace(T[:3, :3].T @ Tq[:3, :3]) - 1) / 2, -1, 1))
        assert bound > 0.1 and angle == pytest.approx(bound, abs=1e-9)
        assert np.abs(Tq - np.array(off["reached_pose"])).max() < 1e-9


def test_youbot_branches_plot_has_both_axis_labels_and_a_clear_legend(youbot):
    from figure_checks import axis_labels, legends_clear_of_data, titles_inside

    out, r = youbot
    fig = figures(out)["branches.png"]
    titles_inside(fig)
    axis_labels(fig.axes[0])
    legends_clear_of_data(fig)
    n = sum(len(case["branches"]) for case in r["ik"].values())
    assert len([ln for ln in fig.axes[0].lines if not ln.get_label().startswith("_")]) == n


def test_youbot_artefacts(youbot):
    out, _ = youbot
    assert_pngs(out, ["manipulability.png", "branches.png"])
    assert_scene(out, animated=False)


def test_youbot_scene_frames_every_branch_centred_and_filling_the_view(youbot):
    """Every frame of every drawn arm (bases read from the page, q from result.json, FK here) projects
    inside a 4:3 window with the page's camera, centred, spanning most of it both ways: not a
    strip in the lower half with the top 40 % empty."""
    from kinserve import viz

    from browser_checks import page_camera as exported_camera
    from browser_checks import project

    out, r = youbot
    commands = viz.read_html_commands(out / "scene.html")
    eye, target = exported_camera(commands)
    qs = {f"branch{k}": b["q"] for k, b in enumerate(b for case in r["ik"].values()
                                                     for b in case["branches"])}
    qs["nearest_reachable"] = r["off_reachable"]["branches"][0]["q"]
    arm = robots.load("youbot", geometry=False)
    points = []
    for name, q in qs.items():
        base = next(c for c in commands if c["type"] == "set_transform" and c["path"] == f"/meshcat/{name}")
        B = np.asarray(base["matrix"], dtype=float).reshape(4, 4).T
        points += [(B @ T)[:3, 3] for T in arm.fk_all(np.array(q)).values()]
    w, h = size = (800, 600)
    px = project(np.array(points), eye, target, size)
    assert px[:, 0].min() >= 0 and px[:, 0].max() <= w and px[:, 1].min() >= 0 and px[:, 1].max() <= h
    assert px[:, 1].min() < 0.4 * h, "the top 40 % of the view is empty"
    # joint frames only: the link shapes and the target triads reach further out
    assert np.ptp(px[:, 0]) > 0.6 * w and np.ptp(px[:, 1]) > 0.35 * h
    assert abs(0.5 * (px[:, 0].min() + px[:, 0].max()) / w - 0.5) < 0.1
    assert abs(0.5 * (px[:, 1].min() + px[:, 1].max()) / h - 0.5) < 0.1


# --------------------------------------------------------------------------- S3 youBot tour
def test_tour_order_is_optimal_by_brute_force_with_euclidean_distances(tour):
    _, r = tour
    robot = robots.load("youbot", geometry=False)
    d = json.loads((ROOT / "scenarios/data/youbot_checkpoints.json").read_text())
    Q = [d["current"]["q"]] + [c["q"] for c in d["checkpoints"]]
    P = np.array([dh_chain(np.array(q))[-1][:3, 3] for q in Q])
    assert np.allclose(P, r["checkpoint_positions"], atol=1e-12)
    assert np.allclose(P, [robot.fk(np.array(q))[:3, 3] for q in Q], atol=1e-12)

    def length(order, metric):
        return sum(metric(P[a], P[b]) for a, b in zip(order[:-1], order[1:]))

    def euclid(a, b):
        return float(np.linalg.norm(a - b))

    perms = [(0,) + p for p in itertools.permutations(range(1, len(P)))]
    best = min(perms, key=lambda o: length(o, euclid))
    assert list(best) == r["order"] and r["optimal"]
    assert r["tour_length"] == pytest.approx(length(best, euclid), abs=1e-12)
    assert r["order_names"] == ["current"] + [d["checkpoints"][i - 1]["name"] for i in best[1:]]
    # the seed's 0.5 * squared metric picks another order here, longer in travelled distance
    sq = min(perms, key=lambda o: length(o, lambda a, b: 0.5 * float(np.sum((a - b) ** 2))))
    assert list(sq) == r["order_squared_metric"] != r["order"]
    assert (r["squared_metric_length"] == pytest.approx(length(sq, euclid))
            and length(sq, euclid) > r["tour_length"])


def test_tour_trajectory_files_reload_and_follow_the_straight_legs(tour):
    out, r = tour
    n, dt = r["n_intermediate"], r["dt"]
    tj, tc = JointTrajectory.load(out / "trajectory.json"), JointTrajectory.load(out / "trajectory.csv")
    assert tj.n_points == tc.n_points == r["n_points"] == 4 * (n + 1) + 1
    assert tj.joint_names == tc.joint_names == [f"arm_joint_{i}" for i in range(1, 6)]
    np.testing.assert_allclose(tj.positions, tc.positions, atol=1e-12)
    np.testing.assert_allclose(tj.velocities, tc.velocities, atol=1e-12)
    np.testing.assert_allclose(tj.times, dt * np.arange(tj.n_points), atol=1e-12)
    # the raw files, read without the library
    doc = json.loads((out / "trajectory.json").read_text())
    assert [p["time_from_start"] for p in doc["points"]] == pytest.approx(list(dt * np.arange(tj.n_points)))
    assert all(len(p["positions"]) == 5 and len(p["velocities"]) == 5 for p in doc["points"])
    with open(out / "trajectory.csv") as fh:
        rows = list(csv.reader(fh))
    assert (rows[0][0] == "time_from_start" and rows[0][1] == "position:arm_joint_1"
            and len(rows) == tj.n_points + 1)
    # velocities are the finite differences of the positions
    np.testing.assert_allclose(tj.velocities[1:-1],
                               (tj.positions[2:] - tj.positions[:-2]) / (2 * dt), atol=1e-9)
    # FK of every point lies on the straight leg between its checkpoints, checkpoints hit
    P = np.array(r["checkpoint_positions"])[r["order"]]
    tool = np.array([dh_chain(q)[-1][:3, 3] for q in tj.positions])
    for k in range(len(P) - 1):
        for i in range(n + 2):
            s = i / (n + 1)
            assert np.linalg.norm(tool[k * (n + 1) + i] - ((1 - s) * P[k] + s * P[k + 1])) < 1e-5
    assert r["max_position_error"] < 1e-5
    assert np.abs(np.diff(tj.positions, axis=0)).max() < 0.5  # one continuous branch
    robot = robots.load("youbot", geometry=False)
    assert all(robot.within_limits(q) for q in tj.positions)


def test_tour_from_the_csv_file_with_a_cartesian_checkpoint(tour, tmp_path):
    _, r = tour
    r2 = scenarios.run("youbot-tour", tmp_path,
                       checkpoints=ROOT / "scenarios/data/youbot_checkpoints.csv", scene=False)
    assert r2["checkpoint_kinds"] == ["q", "q", "q", "q", "pose"]
    assert r2["order"] == r["order"]
    # the CSV pose is the FK rounded to 1e-6 m
    assert r2["tour_length"] == pytest.approx(r["tour_length"], abs=1e-5)
    assert r2["max_position_error"] < 1e-5


def test_checkpoint_file_readers_and_their_errors(tmp_path):
    cf = load_checkpoints(ROOT / "scenarios/data/youbot_checkpoints.json", 5)
    cc = load_checkpoints(ROOT / "scenarios/data/youbot_checkpoints.csv", 5)
    assert cf.names == cc.names == ["A", "B", "C", "D"]
    np.testing.assert_allclose(cf.current, cc.current)
    for a, b in zip(cf.checkpoints[:3], cc.checkpoints[:3]):
        np.testing.assert_allclose(a.q, b.q)
    D = cc.checkpoints[3]
    assert D.kind == "pose" and np.allclose(D.pose[:3, 3], [0.325253, -0.100613, 0.229506])
    # degrees and an explicit pose in JSON
    j = parse_json(json.dumps({"units": "deg", "current": [0, 90, 0, 0, 0],
                               "checkpoints": [{"name": "P",
                                                "pose": {"position": [0.1, 0, 0.3], "rpy": [0, 90, 0]}}]}), 5)
    assert j.current[1] == pytest.approx(math.pi / 2)
    assert np.allclose(j.checkpoints[0].pose[:3, 2], [1, 0, 0], atol=1e-12)  # Ry(90 deg) turns z onto +x
    bad = [
        ('{"current": [0, 0, 0, 0, 0]}', "checkpoints"),
        ('{"current": [0, 0, 0], "checkpoints": [[0, 0, 0, 0, 0]]}', "shape"),
        ('{"current": [0, 0, 0, 0, 0], "checkpoints": [{"q": [0, 0, 0, 0, 0], "pose": [[1]]}]}',
         "exactly one"),
        ('{"current": [0, 0, 0, 0, 0], "units": "grad", "checkpoints": [[0, 0, 0, 0, 0]]}', "units"),
        ("{not json", "malformed"),
    ]
    for text, msg in bad:
        with pytest.raises(InputError, match=msg):
            parse_json(text, 5)
    header = "name,q1,q2,q3,q4,q5,x,y,z,roll,pitch,yaw\n"
    with pytest.raises(InputError, match="exactly one"):
        parse_csv(header + "current,0,0,0,0,0,,,,,,\nA,0,0,0,0,0,0.1,0,0.3,0,0,0\n", 5)
    with pytest.raises(InputError, match="fill all"):
        parse_csv(header + "current,0,0,0,0,0,,,,,,\nA,0,0,,0,0,,,,,,\n", 5)
    with pytest.raises(InputError, match="current configuration"):
        parse_csv(header + "current,,,,,,0.1,0,0.3,0,0,0\nA,0,0,0,0,0,,,,,,\n", 5)
    with pytest.raises(InputError, match=r"\.json or \.csv"):
        load_checkpoints(tmp_path / "points.txt")


def test_tour_artefacts(tour):
    out, _ = tour
    assert_pngs(out, ["joints.png", "position_error.png", "path.png", "manipulability.png"])
    assert_scene(out, animated=True)


# --------------------------------------------------------------------------- S9 SCARA
SPHERE_C = np.array([0.4, -0.7, 0.5])
SPHERE_R = 0.2


def scara_tool(q):
    t1, t2, d3, t4 = q
    return np.array([0.5 * math.cos(t1) + 0.5 * math.cos(t1 + t2),
                     0.5 * math.sin(t1) + 0.5 * math.sin(t1 + t2), 1.0 - d3])


def point_segment_distance(c, a, b):
    ab = b - a
    s = 0.0 if ab @ ab == 0 else min(max((c - a) @ ab / (ab @ ab), 0.0), 1.0)
    return float(np.linalg.norm(a + s * ab - c))


def test_scara_fk_and_jacobians(scara):
    _, r = scara
    assert r["fk_max_position_difference"] < 1e-12 and r["fk_max_phi_difference"] < 1e-12
    assert r["jacobian_geometric_vs_formula"] < 1e-12 and r["jacobian_analytic_vs_geometric"] < 1e-12
    assert r["jacobian_fd_vs_formula"] < 1e-6 and r["jacobian_roll_pitch_rows_max"] < 1e-12
    robot = robots.load("scara", geometry=False)
    q = np.array([0.3, -0.4, 0.5, 0.2])
    T = robot.fk(q)
    assert np.allclose(T[:3, 3], scara_tool(q))
    assert math.atan2(T[1, 0], T[0, 0]) == pytest.approx(q[0] + q[1] - q[3])
    assert np.allclose(robot.jacobian(q)[5], [1, 1, 0, -1])


def test_scara_classical_methods_converge_from_the_same_start(scara):
    out, r = scara
    it = json.loads((out / "iterates.json").read_text())
    target = scara_tool(r["q_goal"])
    phi_goal = r["q_goal"][0] + r["q_goal"][1] - r["q_goal"][3]
    for m, c in r["methods"].items():
        Q = np.array(it[f"ik_{m}"]["q"])
        assert np.allclose(Q[0], r["q_start"])
        assert len(Q) == c["iterations"] + 1 and c["success"]
        q = np.array(c["q_final"])
        assert np.linalg.norm(scara_tool(q) - target) < 1e-4
        assert abs(math.remainder(q[0] + q[1] - q[3] - phi_goal, 2 * math.pi)) < 1e-3
        E = np.array(it[f"ik_{m}"]["task_error"])
        assert E.shape == (len(Q), 4) and it[f"ik_{m}"]["components"] == ["x", "y", "z", "yaw"]
    n = r["iterations"]
    assert n["jacobian_inverse"] <= 8 and n["jacobian_transpose"] > 3 * n["jacobian_inverse"]


def test_scara_relax_phi_centres_theta4_and_meets_the_position(scara):
    _, r = scara
    target = scara_tool(r["q_goal"])
    for m, c in r["relax_phi"].items():
        q = np.array(c["q_final"])
        assert c["success"]
        assert np.linalg.norm(scara_tool(q) - target) < 1e-4
        assert q[3] == pytest.approx(0.0, abs=1e-6) and c["theta4_mid"] == 0.0  # middle of [-2 pi, 2 pi]
    assert abs(r["theta4_final"]) < 1e-6


def test_scara_relax_z_sphere_never_entered_and_centring_where_free(scara):
    out, r = scara
    it = json.loads((out / "iterates.json").read_text())
    for case in ("near_sphere", "away_from_sphere"):
        Q = np.array(it[f"relax_z_{case}"]["q"])
        assert len(Q) > 2
        d_tool = np.array([np.linalg.norm(scara_tool(q) - SPHERE_C) for q in Q])
        assert d_tool.min() >= SPHERE_R - 1e-9  # on every iterate
        # the quill, from the arm plane (z = 1) down to the tool, and the horizontal links at z = 1
        for q in Q:
            t1 = q[0]
            elbow = np.array([0.5 * math.cos(t1), 0.5 * math.sin(t1), 1.0])
            tool = scara_tool(q)
            top = np.array([tool[0], tool[1], 1.0])
            for a, b in ((np.array([0, 0, 1.0]), elbow), (elbow, top), (top, tool)):
                assert point_segment_distance(SPHERE_C, a, b) >= SPHERE_R - 1e-9
        c = r["relax_z"][case]
        q = np.array(c["q_final"])
        assert np.linalg.norm(scara_tool(q)[:2] - np.array(c["target_xy"])) < 1e-6
    near, away = r["relax_z"]["near_sphere"], r["relax_z"]["away_from_sphere"]
    assert away["d3_final"] == pytest.approx(0.625, abs=1e-6)  # unconstrained direction: mid-range
    # near the sphere the constraint binds: the tool stops on the sphere's top, d3 short of 0.625
    x, y = near["target_xy"]
    z_top = SPHERE_C[2] + math.sqrt(SPHERE_R**2 - (x - SPHERE_C[0]) ** 2 - (y - SPHERE_C[1]) ** 2)
    assert scara_tool(near["q_final"])[2] == pytest.approx(z_top, abs=1e-3)
    assert 0.25 < near["d3_final"] < 0.625 - 0.2
    assert r["min_tool_sphere_distance"] >= SPHERE_R - 1e-9 and r["min_clearance_all_segments"] >= -1e-9
    # without the hard constraint, centring drives the tool into the sphere
    Q = np.array(it["relax_z_no_sphere_constraint"]["q"])
    assert min(np.linalg.norm(scara_tool(q) - SPHERE_C) for q in Q) < SPHERE_R - 0.05


def test_scara_artefacts(scara):
    out, _ = scara
    pngs = [f"ik_{m}.png" for m in ("jacobian_inverse", "jacobian_transpose", "pseudo_inverse", "dls")]
    pngs += ["methods.png", "relax_phi_pseudo_inverse.png", "relax_phi_qp.png", "relax_z_near_sphere.png",
             "relax_z_away_from_sphere.png", "relax_z_no_sphere_constraint.png", "sphere.png"]
    assert_pngs(out, pngs)
    assert_scene(out, animated=True)


def test_cli_demo_scara_end_to_end(tmp_path):
    env = dict(os.environ, MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, "-m", "kinserve.service.cli", "demo", "scara", "--out",
                           str(tmp_path)], cwd=ROOT,
                          env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert "[scara]" in proc.stdout
    r = load(tmp_path / "scara")
    assert r["scenario"] == "scara" and r["min_tool_sphere_distance"] >= SPHERE_R - 1e-9
    assert (tmp_path / "scara" / "scene.html").is_file() and (tmp_path / "scara" / "methods.png").is_file()


# --------------------------------------------------------------------------- README table
@pytest.mark.parametrize("fixture", ["planar", "youbot", "tour", "scara"])
def test_readme_row_matches_a_fresh_run(fixture, request):
    out, result = request.getfixturevalue(fixture)
    assert_readme_row(result["scenario"], result)
