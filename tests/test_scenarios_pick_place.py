"""S4 (Franka Panda pick-and-place) end to end: ``scenarios.run("pick-place")`` once per module.

The document's poses and the corrected screw axes are written out here
(SCENARIOS.md S4); the tests recompute forward kinematics from the saved joint
trajectory, the product of exponentials with ``scipy.linalg.expm``, the
segments' boundary twists by finite differences, and the cylinder's final
pose from the two event configurations.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from PIL import Image
from scipy.linalg import expm

from kinserve import robots, viz
from kinserve.planners import JointTrajectory
from kinserve.scenarios import pick_place, pick_place_clearance
from kinserve.service.cli_demo import _summary
from kinserve.viz.animation import pose_at

from scenario_runs import figures, run_into

HOME = np.array([[1, 0, 0, 0.088], [0, -1, 0, 0], [0, 0, -1, 0.926], [0, 0, 0, 1.0]])
GRASP = np.array([[1, 0, 0, 0.65], [0, -1, 0, 0.095], [0, 0, -1, 0.05], [0, 0, 0, 1.0]])
RELEASE = np.array([[0, 0, 1, 0.45], [0, -1, 0, 0.5], [1, 0, 0, 0.35], [0, 0, 0, 1.0]])
CYLINDER = np.array([[1, 0, 0, 0.695], [0, 1, 0, 0.095], [0, 0, 1, 0.025], [0, 0, 0, 1.0]])
#: Space-frame screw axes (w, v) of the URDF: the document's, with S4 at x = 0.0825 and S7 reversed.
SCREWS = np.array([[0, 0, 1, 0, 0, 0], [0, 1, 0, -0.333, 0, 0], [0, 0, 1, 0, 0, 0],
                   [0, -1, 0, 0.649, 0, -0.0825], [0, 0, 1, 0, 0, 0], [0, -1, 0, 1.033, 0, 0],
                   [0, 0, -1, 0, 0.088, 0]], dtype=float)


def pos_rot_error(A, B):
    dR = A[:3, :3].T @ B[:3, :3]
    return (float(np.linalg.norm(A[:3, 3] - B[:3, 3])),
            float(np.arccos(np.clip((np.trace(dR) - 1) / 2, -1, 1))))


def twist_matrix(S):
    w, v = S[:3], S[3:]
    return np.array([[0, -w[2], w[1], v[0]], [w[2], 0, -w[0], v[1]], [-w[1], w[0], 0, v[2]], [0, 0, 0, 0.0]])


def poe(screws, q, M):
    T = np.eye(4)
    for S, qi in zip(screws, q):
        T = T @ expm(twist_matrix(S) * qi)
    return T @ M


@pytest.fixture(scope="module")
def s4(tmp_path_factory):
    out = tmp_path_factory.mktemp("pick-place")
    run_into(out, "pick-place")
    r = json.loads((out / "result.json").read_text())
    traj = JointTrajectory.load(out / "trajectory.json")
    panda = robots.load("panda")
    flange = np.array([panda.fk(q, "panda_link8") for q in traj.positions])
    return r, out, traj, panda, flange


def test_home_fk_is_the_documents_home_pose(s4):
    r, _, _, panda, _ = s4
    np.testing.assert_allclose(panda.fk(np.zeros(7), "panda_link8"), HOME, atol=1e-12)
    assert r["home_fk_error"] < 1e-12
    np.testing.assert_allclose(r["home_fk"], HOME, atol=1e-12)
    # q = 0 is outside joint 4's range, so the motion starts from an in-limits configuration with that pose
    assert r["q_zero_outside_limits"] == ["panda_joint4"]
    q0 = np.array(r["q_start"])
    assert panda.within_limits(q0)
    assert max(pos_rot_error(panda.fk(q0, "panda_link8"), HOME)) < 1e-8


def test_screw_axes_document_vs_urdf(s4):
    r, _, traj, panda, flange = s4
    np.testing.assert_allclose(r["screw_axes_urdf"], SCREWS, atol=1e-12)
    assert r["screw_axes_differ"] == [4, 7]
    for k in range(0, traj.n_points, 50):  # the corrected product of exponentials is the URDF's FK
        np.testing.assert_allclose(poe(SCREWS, traj.positions[k], HOME), flange[k], atol=1e-10)
    doc = np.array(r["screw_axes_document"])
    worst = max(pos_rot_error(poe(doc, traj.positions[k], HOME), flange[k])[0]
                for k in range(0, traj.n_points, 10))
    assert worst > 1e-3  # the document's axes are off by cm along this motion ...
    assert r["poe_document_max_position_error"] >= worst - 1e-12  # ... and the result says so
    assert r["poe_urdf_axes_max_error"] < 1e-12


def test_segments_start_and_end_at_their_boundary_poses_and_twists():
    wps = pick_place.waypoints(0.12, 0.05)
    assert [w.name for w in wps] == ["home", "pre-grasp", "grasp", "lift", "pre-release", "release",
                                     "retreat", "home"]
    np.testing.assert_array_equal(wps[2].pose, GRASP)
    np.testing.assert_array_equal(wps[5].pose, RELEASE)
    durations = pick_place.segment_durations(wps, 3.0, 1.5)
    h = 1e-5
    for order in ("quintic", "cubic"):
        for seg, a, b, d in zip(pick_place.plan_segments(wps, durations, order), wps[:-1],
                                wps[1:], durations):
            np.testing.assert_allclose(seg.pose(0.0), a.pose, atol=1e-12)
            np.testing.assert_allclose(seg.pose(d), b.pose, atol=1e-12)
            for t, V, sign in ((0.0, a.twist, 1), (d, b.twist, -1)):
                # one-sided second-order difference into the segment: body twist [T^-1 dT/dt]^vee
                T0, T1, T2 = seg.pose(t), seg.pose(t + sign * h), seg.pose(t + 2 * sign * h)
                W = np.linalg.inv(T0) @ (-3 * T0 + 4 * T1 - T2) / (2 * sign * h)
                twist = np.r_[W[:3, 3], W[2, 1], W[0, 2], W[1, 0]]
                np.testing.assert_allclose(twist, V, atol=1e-6)


def test_trajectory_passes_the_waypoints_and_tracking_error_is_small(s4):
    r, _, traj, panda, flange = s4
    assert r["tracking_failures"] == []
    assert r["max_tracking_position_error"] < 1e-4 and r["max_tracking_orientation_error"] < 1e-3
    for wp in r["waypoints"]:
        p, a = pos_rot_error(flange[wp["index"]], np.array(wp["pose"]))
        assert p < 1e-4 and a < 1e-3, wp["name"]
        assert traj.times[wp["index"]] == pytest.approx(wp["time"])
    # every sample against the planned pose (rebuilt from the scenario's own segments)
    wps = pick_place.waypoints(0.12, 0.05)
    segs = pick_place.plan_segments(wps, pick_place.segment_durations(wps, 3.0, 1.5), r["order"])
    times, targets, _, _ = pick_place.sample_segments(segs, r["dt"])
    np.testing.assert_allclose(times, traj.times, atol=1e-9)
    errs = np.array([pos_rot_error(F, T) for F, T in zip(flange, targets)])
    assert errs[:, 0].max() < 1e-4 and errs[:, 1].max() < 1e-3
    assert errs[:, 0].max() == pytest.approx(r["max_tracking_position_error"], rel=1e-3, abs=1e-9)
    assert all(panda.within_limits(q) for q in traj.positions)
    # a continuous joint path (no branch switch): small steps at 0.03 s
    assert np.abs(np.diff(traj.positions, axis=0)).max() < 0.1
    # null-space centring: no self-motion drift, the arm ends in the configuration it started from
    drift = np.linalg.norm(traj.positions[-1] - traj.positions[0])
    assert drift < 1e-3 and r["final_configuration_drift"] == pytest.approx(drift, abs=1e-9)


def test_grasp_and_release_events_at_the_first_step_within_tolerance(s4):
    r, _, _, _, flange = s4
    tp, tr = r["grasp_tolerance"]
    g, rel = r["grasp_step"], r["release_step"]
    assert 0 < g < rel < len(flange) - 1
    for step, target in ((g, GRASP), (rel, RELEASE)):
        p, a = pos_rot_error(flange[step], target)
        assert p <= tp and a <= tr
        p, a = pos_rot_error(flange[step - 1], target)
        assert p > tp or a > tr  # the first such step
    np.testing.assert_allclose(r["flange_at_grasp"], flange[g], atol=1e-9)
    assert [e["kind"] for e in r["events"]] == ["grasped", "released"]


def test_cylinder_ends_within_5_mm_of_the_release(s4):
    r, _, _, _, flange = s4
    g, rel = r["grasp_step"], r["release_step"]
    carried = flange[rel] @ np.linalg.inv(flange[g]) @ CYLINDER  # rigidly attached between the events
    np.testing.assert_allclose(r["cylinder_final_pose"], carried, atol=1e-9)
    exact = RELEASE @ np.linalg.inv(GRASP) @ CYLINDER  # where an exact release puts it
    np.testing.assert_allclose(exact[:3, 3], [0.475, 0.5, 0.395], atol=1e-12)
    p, a = pos_rot_error(carried, exact)
    assert p < 5e-3 and a < 0.02
    assert r["cylinder_release_error"] == pytest.approx(p, abs=1e-9)
    np.testing.assert_allclose([r["cylinder_final_x"], r["cylinder_final_y"], r["cylinder_final_z"]],
                               carried[:3, 3], atol=1e-12)


def test_demo_summary_prints_the_events_and_the_cylinder(s4):
    r = s4[0]
    line = _summary(r)
    assert f"grasp_step={r['grasp_step']}" in line and f"release_step={r['release_step']}" in line
    x, y, z = (r[f"cylinder_final_{c}"] for c in "xyz")
    assert f"cylinder_final=position ({x:.4f}, {y:.4f}, {z:.4f}) m, axis (-1.000, 0.000, 0.000)" in line
    assert "cylinder_release_error=" in line


def test_document_cubic_misses_nonzero_boundary_twists(s4):
    r = s4[0]
    assert r["document_cubic_twist_error"] > 1e-3  # the global exp(c3 t^3 + ...) construction
    zero = np.zeros(6)
    assert pick_place.document_cubic_twist_error(HOME, GRASP, zero, zero, 3.0) < 1e-6  # fine at rest


def test_scene_html_is_self_contained_and_animates_the_carried_cylinder(s4):
    r, out, traj, _, _ = s4
    path = out / "scene.html"
    text = path.read_text(encoding="utf-8")
    assert not re.search(r"<script[^>]*\bsrc\s*=", text, re.I)
    assert not re.search(r"\b(src|href)\s*=\s*[\"']?(https?:)?//", text, re.I)
    cmds = viz.read_html_commands(path)
    objects = [c["path"] for c in cmds if c["type"] == "set_object"]
    meshes = [p for p in objects if p.startswith("/meshcat/panda/visuals/")]
    assert len(meshes) == 8 and not any("hand" in p or "finger" in p for p in meshes)  # arm up to the flange
    for name in ("/meshcat/cylinder", "/meshcat/tool_path", "/meshcat/box/bottom",
                 "/meshcat/targets/grasp/x"):
        assert name in objects
    (anim,) = [c for c in cmds if c["type"] == "set_animation"]
    last = traj.n_points - 1
    np.testing.assert_allclose(pose_at(anim, "/meshcat/cylinder", 0), CYLINDER, atol=1e-6)
    np.testing.assert_allclose(pose_at(anim, "/meshcat/cylinder", r["grasp_step"] - 1), CYLINDER, atol=1e-6)
    np.testing.assert_allclose(pose_at(anim, "/meshcat/cylinder", last), r["cylinder_final_pose"], atol=1e-6)
    mid = (r["grasp_step"] + r["release_step"]) // 2  # carried: off the floor, rigidly below the flange
    assert pose_at(anim, "/meshcat/cylinder", mid)[2, 3] > 0.1


def test_pngs_are_real_plots(s4):
    out = s4[1]
    for name in ("joints", "tracking_errors", "manipulability", "flange_trajectory"):
        img = np.asarray(Image.open(out / f"{name}.png").convert("RGB"))
        assert img.shape[0] > 300 and img.shape[1] > 500, name
        packed = (img[..., 0].astype(np.int32) << 16) | (img[..., 1].astype(np.int32) << 8) | img[..., 2]
        assert len(np.unique(packed)) > 100, name
        assert 0.02 < (img.min(axis=2) < 200).mean() < 0.6, name


def test_direct_motion_reports_infeasible_samples_without_joint_jumps(tmp_path):
    """approach=0 (the document's direct motions) drives joint 1 into its limit on the way home.

    Those samples must be reported as tracking failures, and the joint path must stay continuous.
    Regression: full-gain null-space centring in DLS let the arm jump 5.8 rad between two samples there.
    """
    r = pick_place.run(tmp_path, approach=0.0, scene=False)
    assert r["tracking_failures"], "the direct motion is expected to be infeasible somewhere"
    Q = JointTrajectory.load(tmp_path / "trajectory.json").positions
    jumps = np.abs(np.diff(Q, axis=0)).max(axis=1)
    assert jumps.max() < 0.5, f"joint jump of {jumps.max():.2f} rad at sample {int(jumps.argmax()) + 1}"


def test_tracking_errors_plot_title_inside_legend_off_the_curves(s4):
    from figure_checks import axis_labels, legends_clear_of_data, titles_inside

    _, out, _, _, _ = s4
    fig = figures(out)["tracking_errors.png"]
    titles_inside(fig)
    legends_clear_of_data(fig)
    axis_labels(fig.axes[0])
    labels = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
    assert "position error (m)" in labels and any(lbl.startswith("grasped") for lbl in labels)

def test_readme_row_matches_a_fresh_run(s4):
    from scenario_runs import assert_readme_row

    assert_readme_row("pick-place", s4[0])


def test_clearance_between_arm_and_scene_matches_independent_coal(s4):
    """result.json's smallest arm-scene distance, recomputed with coal on the saved trajectory (links 0-7
    hulls)."""
    import coal
    import pinocchio as pin

    r, _out, traj, panda, _flange = s4
    c = r["clearance"]
    assert [o["kind"] for o in c["scene_obstacles"]] == ["box"] * 6  # table top + the open box's five plates
    boxes = [(coal.Box(*o["size"]), coal.Transform3s(np.array(o["pose"])[:3, :3], np.array(o["pose"])[:3, 3]))
             for o in c["scene_obstacles"]]
    geoms = []
    for g in panda.collision_model.geometryObjects:
        if panda.model.frames[g.parentFrame].name in pick_place_clearance.ARM_LINKS and g.parentJoint:
            mesh = g.geometry
            mesh.buildConvexHull(True, "Qt")
            geoms.append((g, mesh.convex))
    data = panda.model.createData()
    req, res = coal.DistanceRequest(), coal.DistanceResult()

    def min_distance(q):
        pin.forwardKinematics(panda.model, data, q)
        best = np.inf
        for g, hull in geoms:
            M = data.oMi[g.parentJoint] * g.placement
            for box, T in boxes:
                res.clear()
                best = min(best, coal.distance(hull, coal.Transform3s(M.rotation, M.translation),
                                               box, T, req, res))
        return best

    k = c["min_arm_scene_distance_step"]
    assert min_distance(traj.positions[k]) == pytest.approx(c["min_arm_scene_distance"], abs=1e-6)
    for q in traj.positions[::10]:
        assert min_distance(q) >= c["min_arm_scene_distance"] - 1e-6
    assert r["min_arm_scene_distance"] == c["min_arm_scene_distance"] > 0.0
    assert c["self_collision_free"] is True
    # the carried cylinder: within a grasp tolerance (1 mm) of the table / box floor at worst
    assert -1e-3 <= r["min_cylinder_scene_distance"] < 0.05
