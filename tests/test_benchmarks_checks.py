"""The benchmarks' own judges and plumbing: independent obstacle checks, the peers' arm URDF, table rendering.

The benchmark modules live in ``benchmarks/`` (not installed); they are loaded
from their files, as ``benchmarks/_common.load_test_helper`` does the other way.
"""

from __future__ import annotations

import json
import sys

import numpy as np
import pinocchio as pin
import pytest

from kinserve import robots

from benchmark_scripts import BENCH, load_benchmark

oc = load_benchmark("_obstacle_check", "_kinserve_bench__obstacle_check")
peers = load_benchmark("_peers", "_kinserve_bench__peers")
render = load_benchmark("render_tables", "_kinserve_bench_render_tables")


def _random_pose(rng) -> np.ndarray:
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    if np.linalg.det(q) < 0:
        q[:, 0] *= -1
    T = np.eye(4)
    T[:3, :3] = q
    T[:3, 3] = rng.normal(scale=0.3, size=3)
    return T


def _sampled_box_distance(a, b, T, size, k=4001):
    s = np.linspace(0.0, 1.0, k)
    P = a + s[:, None] * (b - a)
    p = (P - T[:3, 3]) @ T[:3, :3]
    h = 0.5 * np.asarray(size)
    e = np.maximum(np.abs(p) - h, 0.0)
    inside = np.all(np.abs(p) <= h, axis=1)
    return np.sqrt((e * e).sum(axis=1)).min(), inside.any()


def test_segment_box_clearance_matches_dense_sampling():
    rng = np.random.default_rng(3)
    n_inside = 0
    for _ in range(300):
        T = _random_pose(rng)
        size = rng.uniform(0.05, 0.5, 3)
        a, b = rng.normal(scale=0.5, size=3), rng.normal(scale=0.5, size=3)
        c = oc.segment_box_clearance(a, b, T, size)
        d, inside = _sampled_box_distance(a, b, T, size)
        if inside:
            n_inside += 1
            assert c <= 0.0
        else:
            # the exact minimum is <= every sample, and the samples are 1/4000 of the segment apart
            assert c <= d + 1e-12
            assert c >= d - np.linalg.norm(b - a) / 4000
    assert 10 < n_inside < 290  # both branches exercised


def test_segment_box_clearance_closed_form_cases():
    T = np.eye(4)
    size = (0.2, 0.2, 0.2)
    # parallel to a face, 0.1 m above it
    assert oc.segment_box_clearance(np.array([-1, 0, 0.2]),
                                    np.array([1, 0, 0.2]), T, size) == pytest.approx(0.1)
    # passing a corner: closest box point (0.1, 0.1, 0.1), segment along x at y = z = 0.4
    assert oc.segment_box_clearance(np.array([-1, 0.4, 0.4]), np.array([1, 0.4, 0.4]), T, size) == \
        pytest.approx(np.hypot(0.3, 0.3))
    # straight through the centre: penetration depth = half edge
    assert oc.segment_box_clearance(np.array([-1, 0, 0]), np.array([1, 0, 0]), T, size) == pytest.approx(-0.1)


def test_segment_sphere_clearance():
    c = np.array([0.0, 0.3, 0.0])
    assert oc.segment_sphere_clearance(np.array([-1.0, 0, 0]),
                                       np.array([1.0, 0, 0]), c, 0.1) == pytest.approx(0.2)
    # closest point is an end point
    assert oc.segment_sphere_clearance(np.array([0.5, 0, 0]), np.array([1.0, 0, 0]), c, 0.1) == \
        pytest.approx(np.hypot(0.5, 0.3) - 0.1)
    assert oc.segment_sphere_clearance(np.array([-1.0, 0.3, 0]), np.array([1.0, 0.3, 0]), c, 0.1) == \
        pytest.approx(-0.1)


def test_skeleton_points_are_joint_origins_and_flange():
    robot = robots.load("panda", tip="panda_link8", geometry=False)
    sk = oc.Skeleton(robot.model, "panda_link8")
    q = robot.random_q(np.random.default_rng(0))
    P = sk.points(q)
    assert P.shape == (robot.model.njoints + 1, 3)
    assert np.allclose(P[0], 0.0)
    assert np.allclose(P[-1], robot.fk(q, "panda_link8")[:3, 3])
    # a sphere on the forearm (between joints 4 and 5... origins 4 and 6) is entered; one far away is not
    mid = 0.5 * (P[4] + P[5])
    assert sk.clearance(q, [oc.SphereSpec(tuple(mid), 0.02)]) < 0
    assert sk.clearance(q, [oc.SphereSpec((5.0, 5.0, 5.0), 0.1)]) > 4


def test_coal_checker_scene_and_self_collision():
    d = robots.example_robot_data_dir() / "panda_description"
    pkg = [str(robots.example_robot_data_package_dir())]
    locked = {"panda_finger_joint1": 0.0, "panda_finger_joint2": 0.0}
    robot = robots.load("panda", tip="panda_link8", geometry=False)
    checker = oc.CoalChecker(str(d / "urdf/panda.urdf"), pkg, srdf_path=str(d / "srdf/panda.srdf"),
                             self_collision=True, locked=locked)
    q_home = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])  # the SRDF's default state
    assert not checker.in_collision(q_home)
    # a box around the flange collides; the same box far away does not
    T = np.eye(4)
    T[:3, 3] = robot.fk(q_home, "panda_link8")[:3, 3]
    near = oc.BoxSpec(tuple(T.reshape(16)), (0.1, 0.1, 0.1))
    T[:3, 3] += 3.0
    far = oc.BoxSpec(tuple(T.reshape(16)), (0.1, 0.1, 0.1))
    assert checker.in_collision(q_home, (near,))
    assert not checker.in_collision(q_home, (far,))
    assert checker.colliding_pairs(q_home) == []
    # random configurations: some self-collide, and no reported pair is one the SRDF disables
    import xml.etree.ElementTree as ET

    disabled = {frozenset((e.get("link1"), e.get("link2")))
                for e in ET.parse(d / "srdf/panda.srdf").getroot().iter("disable_collisions")}
    hits = 0
    for q in robot.random_q(np.random.default_rng(2), 100):
        pairs = checker.colliding_pairs(q)
        assert checker.in_collision(q) == bool(pairs)
        hits += bool(pairs)
        for a, b in pairs:
            links = frozenset(n.rsplit("_", 1)[0] for n in (a, b))  # geometry "panda_link3_0" -> link
            assert links not in disabled
    assert 1 <= hits <= 60


def test_arm_urdf_matches_kinserve_fk_and_segments():
    robot = robots.load("panda", tip="panda_link8", geometry=False)
    text = (robots.example_robot_data_dir() / "panda_description/urdf/panda.urdf").read_text()
    box_pose = _random_pose(np.random.default_rng(7))
    obstacles = [{"kind": "sphere", "center": [0.4, 0.1, 0.5], "radius": 0.05},
                 {"kind": "box", "pose": box_pose.tolist(), "size": [0.1, 0.2, 0.3]}]
    urdf, pairs = peers.arm_urdf(text, segment_radius=1e-3, obstacles=obstacles)
    model = pin.buildModelFromXML(urdf)
    geom = pin.buildGeomFromUrdfString(model, urdf, pin.GeometryType.COLLISION)
    assert model.nq == 7
    data = model.createData()
    gdata = pin.GeometryData(geom)
    fid = model.getFrameId("panda_link8")
    for q in robot.random_q(np.random.default_rng(1), 5):
        pin.framesForwardKinematics(model, data, q)
        assert np.allclose(data.oMf[fid].homogeneous, robot.fk(q, "panda_link8"), atol=1e-12)
        pin.updateGeometryPlacements(model, data, geom, gdata)
        # both ends of every segment cylinder are skeleton points (joint origins / flange)
        P = oc.Skeleton(robot.model, "panda_link8").points(q)
        n_segments = 0
        for g, go in enumerate(geom.geometryObjects):
            if go.name.startswith("obstacle"):
                continue
            n_segments += 1
            M = gdata.oMg[g]
            axis = go.geometry.halfLength * M.rotation[:, 2]
            for end in (M.translation - axis, M.translation + axis):
                assert np.min(np.linalg.norm(P - end, axis=1)) < 1e-9
        assert n_segments == 5
        placed = {go.name: gdata.oMg[g].homogeneous for g, go in enumerate(geom.geometryObjects)}
        assert np.allclose(placed["obstacle_1_0"], box_pose, atol=1e-9)
        assert np.allclose(placed["obstacle_0_0"][:3, 3], [0.4, 0.1, 0.5])
    assert len(pairs) == 2 * 5  # 5 non-degenerate segments x 2 obstacles
    assert {p[1] for p in pairs} == {"obstacle_0", "obstacle_1"}


def test_render_tables_copies_the_figures(tmp_path):
    payload = {
        "machine": {"cpu": "test cpu", "cores": 2, "python": "3.11"},
        "workload": {"robot": "panda", "n": 4, "budget_s": 0.5, "starts_in_collision_pct": 25.0},
        "workloads": {"open scene": {"n": 4, "per_solver": {
            "kinserve": {"success_pct": 100.0, "median_ms": 0.1234, "p95_ms": 0.5, "mean_ms": 0.2,
                         "median_vs_unconstrained": 1.25, "p95_vs_unconstrained_p95": 2.0}}}},
        "collision_check_us": {"roboplan Scene.hasCollisions": 6.04,
                               "roboplan Scene.hasCollisions: CPU": 5.96},
        "targets_met": {"open_100pct": True, "open_median_le_1.5x_unconstrained": False},
    }
    (tmp_path / "collision.json").write_text(json.dumps(payload))
    (tmp_path / "kinematics.json").write_text(json.dumps({"fk_us": 1.5, "nested": {"rate": 7.0e5}}))
    md = render.render(tmp_path)
    assert "| kinserve | 100.0 % | 0.123 ms | 0.500 ms | 0.200 ms | 1.25× | 2.00× | – | – |" in md
    assert "| roboplan Scene.hasCollisions | 6.0 | 6.0 |" in md
    assert "`open_median_le_1.5x_unconstrained` **not met**" in md
    assert "`nested.rate` = 700000" in md
    assert "ik.json: not found" in md


@pytest.mark.parametrize("script, args, sections", [
    ("bench_ik_constrained.py", ["--n", "3", "--budget", "0.05", "--no-pink", "--no-placo", "--no-mesh",
                                 "--step-calls", "5"], ("workloads", "step_us")),
    ("bench_collision.py", ["--n", "2", "--budget", "0.05", "--no-pink", "--no-roboplan"],
     ("workloads", "collision_check_us")),
])
def test_benchmark_runs_end_to_end_and_renders(tmp_path, script, args, sections):
    """A tiny run (peers off) writes its JSON, every success figure is a percentage, and it renders."""
    import subprocess

    out = tmp_path / ("ik_constrained.json" if "constrained" in script else "collision.json")
    proc = subprocess.run([sys.executable, str(BENCH / script), *args, "--out", str(out)],
                          capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    data = json.loads(out.read_text())
    for key in sections:
        assert data[key]
    for workload in data["workloads"].values():
        per = workload["per_solver"]
        assert "kinserve unconstrained" in per and "kinserve" in per
        for s in per.values():
            assert 0.0 <= s["success_pct"] <= 100.0 and s["median_ms"] > 0 and s["median_cpu_ms"] > 0
        assert per["kinserve unconstrained"]["median_vs_unconstrained"] == pytest.approx(1.0)
    md = render.render(tmp_path)
    assert "| kinserve unconstrained | " in md
