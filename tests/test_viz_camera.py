"""kinserve.viz.camera: the framing of a scene, checked with an independent pixel projection
(browser_checks.project) against the robot's real mesh vertices; the live viewer (`kinserve view`)
and the static export (`kinserve view --html`) send the same camera."""

import base64
import os
import re
import signal
import subprocess
import sys

import numpy as np
import pytest
import umsgpack

from kinserve import robots, viz
from kinserve.kinematics.errors import InputError
from kinserve.viz import camera

from browser_checks import page_camera as exported_camera
from browser_checks import project as pixel_project

SIZE = (800, 600)  # a 4:3 window, the framing's design aspect


def mesh_vertices_world(scene_robot) -> np.ndarray:
    """Every vertex of every drawn mesh/primitive of a scene robot, in the world (from coal's own
    vertices)."""
    poses = scene_robot.geometry_poses(scene_robot.q)
    out = []
    for g in scene_robot.geometry.geometryObjects:
        T = poses.get(scene_robot.nodes.get(g.name))
        if T is None:
            continue
        geo = g.geometry
        if hasattr(geo, "vertices"):
            V = np.asarray(geo.vertices(), dtype=float)
        else:  # a primitive: its bounding box corners are on or outside the shape (a test of containment)
            geo.computeLocalAABB()
            V = camera.box_corners(geo.aabb_local.min_, geo.aabb_local.max_)
        out.append(V @ T[:3, :3].T + T[:3, 3])
    return np.vstack(out)


def test_project_matches_the_independent_pixel_projection(rng):
    for _ in range(20):
        eye = rng.uniform(-3, 3, 3) + np.array([0, 0, 2.0])
        target = rng.uniform(-0.5, 0.5, 3)
        pts = target + rng.normal(scale=0.3, size=(30, 3))
        ndc = camera.project(pts, eye, target, aspect=SIZE[0] / SIZE[1])
        px = pixel_project(pts, eye, target, SIZE)
        # ndc (x right, y up, [-1, 1]) -> pixels (u right, v down)
        np.testing.assert_allclose(px[:, 0], SIZE[0] / 2 * (1 + ndc[:, 0]), rtol=1e-9, atol=1e-6)
        np.testing.assert_allclose(px[:, 1], SIZE[1] / 2 * (1 - ndc[:, 1]), rtol=1e-9, atol=1e-6)


def test_fit_points_centres_the_projection_and_fills_the_limiting_axis(rng):
    checked = {"all": 0, "held back": 0}
    for _ in range(40):
        P = rng.normal(size=(40, 3)) * rng.uniform(0.05, 3.0, 3) + rng.uniform(-2, 2, 3)
        d = rng.normal(size=3)
        d[2] = abs(d[2]) + 0.2
        eye, target = camera.fit_points(P, d, aspect=4 / 3, fill=0.9)
        np.testing.assert_allclose(np.cross(eye - target, d), 0.0,
                                   atol=1e-9 * np.linalg.norm(eye - target) * np.linalg.norm(d))
        px = pixel_project(P, eye, target, SIZE)
        x = px[:, 0] / SIZE[0] * 2 - 1
        y = 1 - px[:, 1] / SIZE[1] * 2
        assert np.all(np.abs(x) <= 0.9 + 1e-6) and np.all(np.abs(y) <= 0.9 + 1e-6)
        assert abs(x.max() + x.min()) < 1e-4 and abs(y.max() + y.min()) < 1e-4  # centred
        depth = (P - eye) @ (target - eye) / np.linalg.norm(target - eye)
        ratio = depth.max() / depth.min()
        assert depth.min() >= camera.NEAR_MARGIN - 1e-9 and ratio <= camera.MAX_DEPTH_RATIO + 1e-9
        if depth.min() > camera.NEAR_MARGIN + 1e-9 and ratio < camera.MAX_DEPTH_RATIO - 1e-9:
            assert max(x.max(), y.max()) == pytest.approx(0.9, abs=1e-5)  # the limiting axis spans 90 %
        else:  # the camera stepped back to bound the wide-angle distortion
            assert max(x.max(), y.max()) < 0.9
            checked["held back"] += 1
        checked["all"] += 1
    assert checked["held back"] < checked["all"]  # both cases occur


def test_panda_scene_shows_every_mesh_vertex_large_and_centred():
    panda = robots.load("panda", geometry=True)
    scene = viz.Scene.for_robot(panda)
    eye, target = exported_camera(scene.commands())
    V = mesh_vertices_world(scene.robots["panda"])
    assert len(V) > 10_000
    px = pixel_project(V, eye, target, SIZE)
    w, h = SIZE
    assert px[:, 0].min() >= 0 and px[:, 0].max() <= w and px[:, 1].min() >= 0 and px[:, 1].max() <= h
    span = max(np.ptp(px[:, 0]) / w, np.ptp(px[:, 1]) / h)
    assert span > 0.75, f"the robot spans only {span:.0%} of the window"
    # centred: the robot's pixel box has its middle within 8 % of the window's centre
    assert abs(0.5 * (px[:, 0].min() + px[:, 0].max()) / w - 0.5) < 0.08
    assert abs(0.5 * (px[:, 1].min() + px[:, 1].max()) / h - 0.5) < 0.08


def test_a_row_of_robots_is_in_view_without_wide_angle_distortion():
    """Six youBots 0.6 m apart in a row: every vertex in the window, the row spanning most of its
    width, and no robot drawn more than 3 times the size of another by perspective."""
    arm = robots.load("youbot", geometry=True)
    scene = viz.Scene("row")
    for k in range(6):
        base = np.eye(4)
        base[1, 3] = 0.6 * k
        scene.add_robot(arm, arm.neutral(), name=f"b{k}", base=base)
    eye, target = exported_camera(scene.commands())
    V = np.vstack([mesh_vertices_world(r) for r in scene.robots.values()])
    px = pixel_project(V, eye, target, SIZE)
    w, h = SIZE
    assert px[:, 0].min() >= 0 and px[:, 0].max() <= w and px[:, 1].min() >= 0 and px[:, 1].max() <= h
    assert np.ptp(px[:, 0]) > 0.7 * w
    assert abs(0.5 * (px[:, 1].min() + px[:, 1].max()) / h - 0.5) < 0.08  # centred, not in the lower half
    f = (target - eye) / np.linalg.norm(target - eye)
    bases = np.array([r.base[:3, 3] for r in scene.robots.values()])
    depth = (bases - eye) @ f
    assert depth.max() / depth.min() <= camera.MAX_DEPTH_RATIO + 1e-9


def test_framing_rejects_bad_input():
    with pytest.raises(InputError, match="points"):
        camera.frame_points(np.zeros((0, 3)))
    with pytest.raises(InputError, match="points"):
        camera.fit_points([[0, 0, np.nan]], [1, 0, 0])
    with pytest.raises(InputError, match="direction"):
        camera.fit_points([[0, 0, 0]], [0, 0, 0])
    with pytest.raises(InputError, match="differ"):
        camera.view_commands([1, 1, 1], [1, 1, 1])
    # a single point is framed as a small box around it, not a division by zero
    eye, target = camera.frame_points([[0.2, 0.1, 0.3]])
    assert np.isfinite(eye).all() and 0.05 < np.linalg.norm(eye - target) < 1.0


def server_commands(static_html: str) -> list[dict]:
    """The commands a meshcat server holds, decoded from its static page (one base64 msgpack blob each)."""
    blobs = re.findall(r'fetch\("data:application/octet-binary;base64,([^"]+)"\)', static_html)
    return [umsgpack.unpackb(base64.b64decode(b)) for b in blobs]


def camera_part(commands) -> list[dict]:
    keep = ("/meshcat", "/Grid", "/Axes")
    return sorted(
        (c for c in commands
         if (c["type"] == "set_transform" and c["path"] in keep) or c["path"].startswith("/Cameras")),
        key=lambda c: (c["path"], c["type"]))


def test_live_view_and_html_export_send_the_same_camera(tmp_path):
    """`kinserve view youbot` on a live server (ours, 127.0.0.1) shows the camera of `kinserve view youbot
    --html`."""
    page = tmp_path / "youbot.html"
    cli = [sys.executable, "-m", "kinserve.service.cli", "view", "youbot", "--q", "0.3", "0.5", "-0.8",
           "0.4", "0.1"]
    done = subprocess.run(cli + ["--html", str(page)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    exported = camera_part(viz.read_html_commands(page))
    assert len(exported) == 5
    with viz.LiveViewer() as server:
        proc = subprocess.Popen(cli + ["--zmq-url", server.zmq_url], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True, start_new_session=True)
        try:
            line = proc.stdout.readline()  # announced once the scene has been sent
            assert "meshcat viewer" in line, proc.stderr.read() if proc.poll() is not None else line
            live = camera_part(server_commands(server.static_html()))
        finally:
            os.killpg(proc.pid, signal.SIGINT)
            proc.communicate(timeout=20)  # waits and closes both pipes
    assert live == exported
    eye, target = exported_camera(live)
    assert np.linalg.norm(eye - target) > 0.1


def test_the_automatic_camera_frames_the_whole_animation():
    """A planar 4R arm swinging through half a turn: its links at every keyed frame stay in the window."""
    arm = robots.load("planar4r", geometry=True)
    scene = viz.Scene("swing", grid=False)
    scene.add_robot(arm, np.zeros(4))
    Q = np.outer(np.linspace(0.0, 1.0, 61), [np.pi, 0.3, -0.2, 0.1])
    anim = viz.Animation(scene, fps=30)
    anim.robot("planar4r", Q)
    anim.apply()
    eye, target = exported_camera(scene.commands())
    # every frame at every sample (base at 0)
    V = np.array([T[:3, 3] for q in Q for T in arm.fk_all(q).values()])
    px = pixel_project(V, eye, target, SIZE)
    assert (px[:, 0].min() >= 0 and px[:, 0].max() <= SIZE[0] and px[:, 1].min() >= 0
            and px[:, 1].max() <= SIZE[1])
    scene.delete("planar4r")  # the motion's extent goes with the robot
    assert scene.bounds() is None
