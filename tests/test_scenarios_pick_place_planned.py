"""S4 planned (``kinserve demo pick-place --planned``) end to end: ``scenarios.run("pick-place",
variant="planned")`` once per module.

The scene is written out here again (the document's grasp pose and cylinder, the open box, the table, the
release of the cylinder upright in the box); the tests read the saved trajectory and recompute with
Pinocchio's forward kinematics and coal directly: the straight lines, the cylinder carried rigidly from the
grasp to the release, and the clearance of the arm's link hulls (built here from the URDF's meshes) and of
the cylinder to the box and the table on dense samples.
"""

from __future__ import annotations

import json
import re

import coal
import numpy as np
import pinocchio as pin
import pytest

from kinserve import robots, viz
from kinserve.planners import JointTrajectory
from kinserve.scenarios import pick_place_planned
from kinserve.viz.animation import pose_at

from scenario_runs import run_into

FLANGE = "panda_link8"
GRASP = np.array([[1, 0, 0, 0.65], [0, -1, 0, 0.095], [0, 0, -1, 0.05], [0, 0, 0, 1.0]])
CYLINDER = np.array([[1, 0, 0, 0.695], [0, 1, 0, 0.095], [0, 0, 1, 0.025], [0, 0, 0, 1.0]])
RADIUS, HEIGHT = 0.05, 0.05
#: The open box: centre, outer size, wall; the table top (top face z = 0).
BOX_C, BOX_S, WALL = np.array([0.5, 0.5, 0.1]), 0.2, 0.01
TABLE = ((0.35, 0.25, -0.025), (1.3, 1.3, 0.05))
#: The release (defaults): the cylinder upright, axis at (0.52, 0.52), bottom 0.10 m above the floor plate.
CYL_RELEASE = np.array([[1, 0, 0, 0.52], [0, 1, 0, 0.52], [0, 0, 1, 0.01 + 0.10 + 0.025], [0, 0, 0, 1.0]])
RELEASE = CYL_RELEASE @ np.linalg.inv(CYLINDER) @ GRASP
UP = np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, -0.12], [0, 0, 0, 1.0]])  # 0.12 m back along z
STAGES = [("pre-grasp IK", "ik"), ("to pre-grasp", "plan_motion"), ("approach", "plan_cartesian"),
          ("lift", "plan_cartesian"), ("pre-release IK", "ik"), ("transfer", "plan_motion"),
          ("lower", "plan_cartesian"), ("retreat", "plan_cartesian"), ("home", "plan_motion")]
#: Straight lines: (stage, flange pose at its start, at its end).
LINES = [("approach", GRASP @ UP, GRASP), ("lift", GRASP, GRASP @ UP), ("lower", RELEASE @ UP, RELEASE),
         ("retreat", RELEASE, RELEASE @ UP)]


@pytest.fixture(scope="module")
def s4p(tmp_path_factory):
    out = tmp_path_factory.mktemp("pick-place-planned")
    run_into(out, "pick-place", variant="planned")
    r = json.loads((out / "result.json").read_text())
    traj = JointTrajectory.load(out / "trajectory.json")
    return r, out, traj, robots.load("panda")


def stage(r, name):
    (s,) = [s for s in r["stages"] if s["name"] == name]
    return s


def dense(traj, step=0.01):
    """The trajectory's points and linear interpolation between them, no joint moving more than ``step``."""
    t, Q = [traj.times[:1]], [traj.positions[:1]]
    for k in range(traj.n_points - 1):
        a, b = traj.positions[k], traj.positions[k + 1]
        s = np.linspace(0, 1, max(1, int(np.ceil(np.abs(b - a).max() / step))) + 1)[1:]
        t.append(traj.times[k] + s * (traj.times[k + 1] - traj.times[k]))
        Q.append(a + s[:, None] * (b - a))
    return np.concatenate(t), np.concatenate(Q)


def box_shapes():
    """(coal.Box, Transform3s) of the table, then of the box's floor plate and four walls."""
    c = BOX_C
    parts = [(TABLE[1], TABLE[0]), ((BOX_S, BOX_S, WALL), c + [0, 0, -BOX_S / 2 + WALL / 2])]
    for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        size = (WALL, BOX_S, BOX_S) if dx else (BOX_S, WALL, BOX_S)
        parts.append((size, c + [dx * (BOX_S - WALL) / 2, dy * (BOX_S - WALL) / 2, 0]))
    return [(coal.Box(*size), coal.Transform3s(np.eye(3), np.asarray(p, float))) for size, p in parts]


class Distances:
    """coal distances of the arm's link hulls (links 1-7, built here from the URDF meshes) and of a
    cylinder to the table and to the box's plates."""

    def __init__(self, panda):
        self.model, self.data = panda.model, panda.model.createData()
        self.links = []
        for g in panda.collision_model.geometryObjects:
            link = panda.model.frames[g.parentFrame].name
            if g.parentJoint and link in [f"panda_link{i}" for i in range(8)]:
                mesh = g.geometry
                mesh.buildConvexHull(True, "Qt")
                self.links.append((g, mesh.convex))
        shapes = box_shapes()
        self.table, self.box = shapes[:1], shapes[1:]
        self.req, self.res = coal.DistanceRequest(), coal.DistanceResult()

    def _min(self, geom, T, obstacles):
        best = np.inf
        for shape, To in obstacles:
            self.res.clear()
            best = min(best, coal.distance(geom, T, shape, To, self.req, self.res))
        return best

    def arm(self, q, obstacles):
        pin.forwardKinematics(self.model, self.data, q)
        best = np.inf
        for g, hull in self.links:
            M = self.data.oMi[g.parentJoint] * g.placement
            best = min(best, self._min(hull, coal.Transform3s(M.rotation, M.translation), obstacles))
        return best

    def cylinder(self, W, obstacles):
        return self._min(coal.Cylinder(RADIUS, HEIGHT), coal.Transform3s(W[:3, :3], W[:3, 3]), obstacles)


def test_every_stage_succeeded_in_order(s4p):
    r = s4p[0]
    assert r["success"] is True and r["variant"] == "planned"
    assert [(s["name"], s["kind"]) for s in r["stages"]] == STAGES
    for s in r["stages"]:
        assert s["success"] is True, (s["name"], s["message"])
        assert s["carrying"] == (s["name"] in ("lift", "pre-release IK", "transfer", "lower")), s["name"]
        if s["kind"] == "plan_cartesian":
            assert s["fraction"] == 1.0 and s["stop"] == "completed"
    # the standing cylinder is an obstacle before the grasp, the placed one after the release
    assert "cylinder (standing)" in stage(r, "to pre-grasp")["checked"]
    assert "cylinder (placed)" in stage(r, "home")["checked"]
    assert {f"box/plate{i}" for i in range(5)} <= set(stage(r, "transfer")["checked"])
    assert r["duration"] == pytest.approx(s4p[2].duration)


def test_trajectory_starts_and_ends_at_rest_at_home(s4p):
    r, out, traj, panda = s4p
    assert np.abs(traj.velocities[0]).max() < 1e-9 and np.abs(traj.velocities[-1]).max() < 1e-9
    np.testing.assert_allclose(traj.positions[0], r["q_start"], atol=1e-12)
    np.testing.assert_allclose(traj.positions[-1], r["q_start"], atol=1e-9)
    home = np.array([[1, 0, 0, 0.088], [0, -1, 0, 0], [0, 0, -1, 0.926], [0, 0, 0, 1.0]])
    np.testing.assert_allclose(panda.fk(traj.positions[0], FLANGE), home, atol=1e-6)
    assert np.all(traj.positions >= panda.lower - 1e-9) and np.all(traj.positions <= panda.upper + 1e-9)
    csv = JointTrajectory.load(out / "trajectory.csv")
    np.testing.assert_allclose(csv.positions, traj.positions, atol=1e-9)


def test_straight_line_stages_keep_the_flange_on_the_line(s4p):
    r, _, traj, panda = s4p
    for name, A, B in LINES:
        s = stage(r, name)
        t = np.linspace(s["t0"], s["t1"], 200)
        F = np.array([panda.fk(q, FLANGE) for q in traj.position_at(t)])
        np.testing.assert_allclose(F[0], A, atol=1e-5, err_msg=name)
        np.testing.assert_allclose(F[-1], B, atol=1e-5, err_msg=name)
        a, d = A[:3, 3], B[:3, 3] - A[:3, 3]
        u = (F[:, :3, 3] - a) @ d / (d @ d)
        off = np.linalg.norm(F[:, :3, 3] - (a + u[:, None] * d), axis=1)
        assert off.max() < 1e-3 and u.min() > -1e-3 and u.max() < 1 + 1e-3, name
        assert np.all(np.diff(u) >= -1e-6), f"{name}: the flange goes back along its line"
        angle = np.arccos(np.clip((np.einsum("kij,ij->k", F[:, :3, :3], A[:3, :3]) - 1) / 2, -1, 1))
        assert angle.max() < 1e-3, name  # start and end orientations are equal: it must stay so
        assert s["line_deviation"] < 1e-3


def test_cylinder_is_carried_rigidly_and_ends_inside_the_box(s4p):
    r, _, traj, panda = s4p
    g, rel = r["grasp_time"], r["release_time"]
    assert stage(r, "approach")["t1"] == g and stage(r, "lower")["t1"] == rel
    Fg, Fr = (panda.fk(traj.position_at(t)[0], FLANGE) for t in (g, rel))
    np.testing.assert_allclose(Fg, GRASP, atol=1e-5)
    np.testing.assert_allclose(Fr, RELEASE, atol=1e-5)
    final = np.array(r["cylinder_final_pose"])
    np.testing.assert_allclose(final, Fr @ np.linalg.inv(Fg) @ CYLINDER, atol=1e-9)
    np.testing.assert_allclose(final, CYL_RELEASE, atol=1e-5)
    np.testing.assert_allclose(r["cylinder_pose_in_flange"], np.linalg.inv(Fg) @ CYLINDER, atol=1e-12)
    # inside the box: upright, the disc within the inner faces of the walls, above the floor, below the rim
    inner = BOX_S / 2 - WALL
    p = final[:3, 3]
    assert final[2, 2] > 1 - 1e-9
    assert max(abs(p[0] - BOX_C[0]), abs(p[1] - BOX_C[1])) + RADIUS < inner
    assert p[2] - HEIGHT / 2 > BOX_C[2] - BOX_S / 2 + WALL and p[2] + HEIGHT / 2 < BOX_C[2] + BOX_S / 2
    inbox = r["cylinder_in_box"]  # exact for a tilted cylinder too; this one leans by about 2e-8 rad
    assert inbox["wall_gap"] == pytest.approx(inner - max(abs(p[:2] - BOX_C[:2])) - RADIUS, abs=1e-8)
    assert inbox["above_floor"] == pytest.approx(p[2] - HEIGHT / 2 - WALL, abs=1e-8)
    # the document's release pose: the cylinder on its side 0.395 m up; reported as the distance from it
    doc = np.array([[0, 0, 1, 0.45], [0, -1, 0, 0.5], [1, 0, 0, 0.35], [0, 0, 0, 1.0]]) @ np.linalg.inv(GRASP)
    doc = doc @ CYLINDER
    assert r["cylinder_document_release_error"][0] == pytest.approx(np.linalg.norm(doc[:3, 3] - p), abs=1e-6)
    assert r["cylinder_document_release_error"][1] == pytest.approx(np.pi / 2, abs=1e-6)


def test_clearance_is_positive_and_agrees_with_independent_coal(s4p):
    r, _, traj, panda = s4p
    c, dist = r["clearance"], Distances(panda)
    t, Q = dense(traj)
    assert len(t) == r["dense_samples"]
    g, rel, lifted = r["grasp_time"], r["release_time"], stage(r, "lift")["t1"]
    carried = (t >= g - 1e-9) & (t <= rel + 1e-9)
    cylinder_in_flange = np.linalg.inv(panda.fk(traj.position_at(g)[0], FLANGE)) @ CYLINDER

    def linear(time):  # the samples' own interpolation of the trajectory's points
        return np.array([np.interp(time, traj.times, column) for column in traj.positions.T])

    measure = {"min_arm_box_distance": lambda q: dist.arm(q, dist.box),
               "min_arm_table_distance": lambda q: dist.arm(q, dist.table),
               "min_cylinder_box_distance": lambda q: dist.cylinder(
                   panda.fk(q, FLANGE) @ cylinder_in_flange, dist.box),
               "min_cylinder_table_distance": lambda q: dist.cylinder(
                   panda.fk(q, FLANGE) @ cylinder_in_flange, dist.table)}
    every, lifted_carried = np.ones(len(t), dtype=bool), carried & (t >= lifted - 1e-9)
    # the samples each minimum is taken over
    over = {"min_arm_box_distance": every, "min_arm_table_distance": every,
            "min_cylinder_box_distance": carried, "min_cylinder_table_distance": lifted_carried}
    sampled = {name: min(measure[name](q) for q in Q[over[name]]) for name in measure}
    for name, low in sampled.items():
        # each minimum is at most the samples' (refined between them), and is the distance at its time
        assert 0.0 < r[name] <= low + 1e-9 and c[name] == r[name], name
        assert measure[name](linear(c[name + "_time"])) == pytest.approx(r[name], abs=1e-6), name
    # four times denser around the closest approaches: still clear, the minima hardly lower
    fine_t, fine_Q = dense(traj, 0.0025)
    near = np.abs(fine_t - c["min_cylinder_box_distance_time"]) < 0.1
    fine = min(measure["min_cylinder_box_distance"](q) for q in fine_Q[near])
    assert 0.0 < fine and fine > r["min_cylinder_box_distance"] - 2e-4
    near = np.abs(fine_t - c["min_arm_box_distance_time"]) < 0.1
    assert min(measure["min_arm_box_distance"](q) for q in fine_Q[near]) > r["min_arm_box_distance"] - 2e-4


def test_scene_html_animates_the_arm_and_the_carried_cylinder(s4p):
    r, out, traj, panda = s4p
    path = out / "scene.html"
    text = path.read_text(encoding="utf-8")
    assert not re.search(r"<script[^>]*\bsrc\s*=", text, re.I)
    cmds = viz.read_html_commands(path)
    objects = [c["path"] for c in cmds if c["type"] == "set_object"]
    meshes = [p for p in objects if p.startswith("/meshcat/panda/visuals/")]
    assert len(meshes) == 8 and not any("hand" in p or "finger" in p for p in meshes)
    for name in ("/meshcat/cylinder", "/meshcat/tool_path", "/meshcat/box/bottom", "/meshcat/table"):
        assert name in objects
    (anim,) = [c for c in cmds if c["type"] == "set_animation"]
    fps = 30.0
    n = r["animation_frames"]
    assert abs(n - (traj.duration * fps + 1)) <= 1
    cyl = "/meshcat/cylinder"
    np.testing.assert_allclose(pose_at(anim, cyl, 0), CYLINDER, atol=1e-6)
    np.testing.assert_allclose(pose_at(anim, cyl, n - 1), r["cylinder_final_pose"], atol=1e-5)
    k = int((stage(r, "transfer")["t0"] + stage(r, "transfer")["t1"]) / 2 * fps)  # carried, mid-transfer
    F = panda.fk(traj.position_at(k / fps)[0], FLANGE)
    np.testing.assert_allclose(pose_at(anim, cyl, k), F @ np.array(r["cylinder_pose_in_flange"]), atol=1e-5)


def test_pngs_are_real_plots(s4p):
    from PIL import Image

    for name in ("joints", "clearance"):
        img = np.asarray(Image.open(s4p[1] / f"{name}.png").convert("RGB"))
        assert img.shape[0] > 300 and img.shape[1] > 500, name
        packed = (img[..., 0].astype(np.int32) << 16) | (img[..., 1].astype(np.int32) << 8) | img[..., 2]
        assert len(np.unique(packed)) > 100, name


def test_same_inputs_same_trajectory(s4p, tmp_path):
    r = pick_place_planned.run(tmp_path, scene=False)
    again = JointTrajectory.load(tmp_path / "trajectory.json")
    np.testing.assert_array_equal(again.positions, s4p[2].positions)
    np.testing.assert_array_equal(again.times, s4p[2].times)
    assert r["min_cylinder_box_distance"] == s4p[0]["min_cylinder_box_distance"]


def test_a_release_on_the_floor_is_a_failed_stage_not_an_exception(tmp_path):
    # the cylinder's bottom on the floor plate: link 5 and 6 would have to enter the box
    r = pick_place_planned.run(tmp_path, release_height=0.0, scene=False)
    assert r["success"] is False and r["failed_stage"] == "lower"
    assert "collision" in r["message"] and "box" in r["message"]
    assert [s["name"] for s in r["stages"]][-1] == "lower"
    assert not (tmp_path / "trajectory.json").exists()


def test_demo_cli_runs_the_planned_variant(tmp_path, capsys):
    from kinserve.service import cli

    assert cli.main(["demo", "scara", "--planned", "--out", str(tmp_path)]) == 2
    assert "has no variant 'planned'" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())
