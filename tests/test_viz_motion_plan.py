"""kinserve.viz.motion_plan_scene: a Panda's motion plan around a box, carrying a cylinder, as a page.

The plan is made here with ``planners.plan_motion`` (iteration budget and seed: the same plan on every
machine). The exported page's commands are checked against kinserve's FK, computed here from the
plan's own trajectory (``JointTrajectory.position_at``), not through viz: each link's key at the middle
frame, the obstacle node, the tool-path vertices, the carried object's keys. A headless Chromium then
shows the page at the middle of the motion (the test seeks meshcat's animator) and at its start: the
robot's light-grey pixels and the carried object's orange ones are where the page's camera projects
FK at that time, and not where they were at the start.
"""

from __future__ import annotations

import base64
import contextlib
import importlib
import io
import math
import time
from types import SimpleNamespace

import numpy as np
import pytest

from kinserve import ik, planners, robots, viz
from kinserve.kinematics import se3
from kinserve.kinematics.errors import InputError, ShapeError
from kinserve.viz.animation import pose_at

from browser_checks import page_camera
from browser_checks import project as camera_project

FPS = 30.0
Q_START = np.array([-1.0, 0.3, 0.0, -2.0, 0.0, 2.3, 0.8])
Q_GOAL = np.array([1.0, 0.3, 0.0, -2.0, 0.0, 2.3, 0.8])
BOX = ik.Box(se3.pose(p=[0.5, 0.0, 0.35]), [0.15, 0.5, 0.04])
PART = ik.Cylinder(np.eye(4), 0.03, 0.12)
PART_IN_HAND = se3.pose(p=[0.0, 0.0, 0.15])
SIZE = (800, 600)


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    panda = robots.load("panda")
    panda.attach("part", PART, "panda_hand", PART_IN_HAND)
    plan = planners.plan_motion(panda, Q_START, Q_GOAL, obstacles=[BOX], max_time=None, max_iterations=2000,
                                seed=1)
    assert plan.success, plan.message
    scene = viz.motion_plan_scene(panda, plan, [BOX], fps=FPS)
    page = viz.export_html(scene, tmp_path_factory.mktemp("motion_plan") / "plan.html")
    return panda, plan, page, viz.read_html_commands(page)


def frames_of(plan) -> tuple[np.ndarray, np.ndarray]:
    """Frame times ``k / fps`` from the trajectory's start, clamped to its end, and the configurations there
    by the planners' own interpolation."""
    tr = plan.trajectory
    n = math.ceil((tr.times[-1] - tr.times[0]) * FPS - 1e-9) + 1
    t = np.minimum(tr.times[0] + np.arange(n) / FPS, tr.times[-1])
    return t, tr.position_at(t)


def animation(commands) -> dict:
    (anim,) = [c for c in commands if c["type"] == "set_animation"]
    return anim


def geometry_pose(panda, q, g) -> np.ndarray:
    """World pose of visual geometry ``g`` from kinserve's FK of its parent joint's frame."""
    return panda.fk(q, panda.model.names[g.parentJoint]) @ g.placement.homogeneous


def test_links_are_keyed_at_fk_of_the_trajectory(planned):
    panda, plan, _, commands = planned
    anim = animation(commands)
    t, Q = frames_of(plan)
    tracks = {a["path"]: a for a in anim["animations"]}
    assert len(tracks) == 11 + 1  # the Panda's visual meshes and the carried part
    lengths = {max(k["time"] for tr in a["clip"]["tracks"] for k in tr["keys"]) for a in tracks.values()}
    assert lengths == {len(t) - 1}  # one key per frame, the last at the trajectory's end
    assert t[-1] == pytest.approx(plan.trajectory.duration) and len(t) > 20
    mid = len(t) // 2
    moved = 0.0
    for g in panda.visual_model.geometryObjects:
        path = f"/meshcat/panda/visuals/{g.name}"
        key = pose_at(anim, path, mid)
        np.testing.assert_allclose(key, geometry_pose(panda, Q[mid], g), atol=1e-9)
        np.testing.assert_allclose(pose_at(anim, path, 0), geometry_pose(panda, Q_START, g), atol=1e-9)
        np.testing.assert_allclose(pose_at(anim, path, len(t) - 1), geometry_pose(panda, Q_GOAL, g),
                                   atol=1e-9)
        moved = max(moved, float(np.linalg.norm(key[:3, 3] - pose_at(anim, path, 0)[:3, 3])))
    assert moved > 0.2  # mid-motion is not the start


def test_obstacle_tool_path_and_carried_part(planned):
    panda, plan, _, commands = planned
    anim = animation(commands)
    t, Q = frames_of(plan)
    objects = {c["path"]: c["object"] for c in commands if c["type"] == "set_object"}
    transforms = {c["path"]: np.asarray(c["matrix"], float).reshape(4, 4).T
                  for c in commands if c["type"] == "set_transform"}
    # the box obstacle: its size and pose
    (box,) = objects["/meshcat/obstacles/0"]["geometries"]
    assert (box["type"], box["width"], box["height"], box["depth"]) == ("BoxGeometry", 0.15, 0.5, 0.04)
    np.testing.assert_allclose(transforms["/meshcat/obstacles/0"], BOX.pose)
    # the tool path: one vertex per frame at FK of the tip (float32 in the page)
    line = objects["/meshcat/tool_path"]
    assert line["object"]["type"] == "Line"
    packed = line["geometries"][0]["data"]["attributes"]["position"]["array"]  # a msgpack Float32Array
    vertices = np.frombuffer(packed.data, np.float32)
    np.testing.assert_allclose(vertices.reshape(-1, 3), [panda.fk(q, "panda_hand")[:3, 3] for q in Q],
                               atol=1e-6)
    # the carried part: a cylinder of its size in its own frame, keyed at fk(hand) @ placement every frame
    (cyl,) = objects["/meshcat/attached/part/shape"]["geometries"]
    assert cyl["type"] == "CylinderGeometry"
    assert (cyl["radiusTop"], cyl["height"]) == pytest.approx((0.03, 0.12))
    for k in (0, len(t) // 2, len(t) - 1):
        np.testing.assert_allclose(pose_at(anim, "/meshcat/attached/part", k),
                                   panda.fk(Q[k], "panda_hand") @ PART_IN_HAND @ PART.pose, atol=1e-9)
    np.testing.assert_allclose(transforms["/meshcat/attached/part"],
                               panda.fk(Q_START, "panda_hand") @ PART_IN_HAND, atol=1e-12)


def test_path_pairs_and_plans_without_a_trajectory():
    planar = robots.load("planar4r")
    a, b = np.array([0.0, 0.2, -0.4, 0.1]), np.array([1.0, -0.3, 0.6, 0.5])
    # a (times, positions) pair moving linearly: the frames sample the straight line exactly
    t, Q = viz.sample_motion((np.array([0.5, 1.5]), np.vstack([a, b])), fps=10)
    np.testing.assert_allclose(t, 0.5 + np.arange(11) / 10)
    np.testing.assert_allclose(Q, a + np.outer(t - 0.5, b - a), atol=1e-12)
    # a path without timing: constant joint-space speed, a repeated waypoint is skipped
    path = np.vstack([a, a, b])
    plan = SimpleNamespace(path=path, trajectory=None, message="")
    t, Q = viz.sample_motion(plan, fps=20, path_speed=0.5)
    assert t[-1] == pytest.approx(np.linalg.norm(b - a) / 0.5)
    assert len(t) == math.ceil(np.linalg.norm(b - a) / 0.5 * 20) + 1
    np.testing.assert_allclose(Q[[0, -1]], [a, b], atol=1e-12)
    scene = viz.motion_plan_scene(planar, plan, fps=20)
    assert scene.animation is not None and "/meshcat/tool_path" in scene.paths()
    assert "/meshcat/attached" not in scene  # the robot carries nothing


def test_invalid_plans_are_refused():
    planar = robots.load("planar4r")
    failed = SimpleNamespace(path=np.zeros((0, 4)), trajectory=None, message="no path found")
    with pytest.raises(InputError, match="no path to draw.*no path found"):
        viz.motion_plan_scene(planar, failed)
    with pytest.raises(InputError, match="strictly increasing"):
        viz.sample_motion(([0.0, 0.0], np.zeros((2, 4))))
    with pytest.raises(ShapeError, match="positions"):
        viz.sample_motion(([0.0, 1.0], np.zeros((3, 4))))
    with pytest.raises(ShapeError, match="plan positions"):
        viz.motion_plan_scene(planar, ([0.0, 1.0], np.zeros((2, 7))))
    with pytest.raises(InputError, match="fps"):
        viz.sample_motion(([0.0, 1.0], np.zeros((2, 4))), fps=0)
    with pytest.raises(InputError, match="plan must be"):
        viz.motion_plan_scene(planar, object())


# ---------------------------------------------------------------------------------------------- browser
def render_at(page, seconds: float):
    """RGB image (int array) of the page paused at ``seconds`` of its animation, seen in headless Chromium."""
    from PIL import Image

    shot = importlib.import_module("kinserve.viz.screenshot")  # viz.screenshot is also a function
    w, h = SIZE
    dt = shot._DevTools(shot.find_browser(), SIZE, 120.0)
    try:
        dt.attach_page()
        dt.call("Emulation.setDeviceMetricsOverride", {"width": w, "height": h, "deviceScaleFactor": 1,
                                                       "mobile": False})
        for domain in ("Page", "Runtime", "Log"):
            dt.call(f"{domain}.enable")
        dt.call("Page.navigate", {"url": page.resolve().as_uri() + "#paused"})
        status = None
        while not (status and status.get("status") in ("ready", "error")):
            dt._remaining()
            time.sleep(0.05)
            with contextlib.suppress(RuntimeError):  # the document is replaced while navigating
                status = dt.evaluate(shot._STATUS_JS)
        assert status["status"] == "ready" and status["errors"] == "0", status
        assert status["animation-playing"] == "false", status
        dt.evaluate(f"window.viewer.animator.seek({float(seconds)!r})")
        dt.evaluate(shot._TWO_FRAMES_JS, await_promise=True)
        assert dt.errors() == []
        png = base64.b64decode(dt.call("Page.captureScreenshot", {"format": "png"})["data"])
    finally:
        dt.close()
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)


def share(mask: np.ndarray, uv, half: int = 12) -> float:
    """Share of ``mask`` pixels in the square of side ``2 half`` around pixel ``uv``."""
    u, v = np.round(uv).astype(int)
    return float(mask[max(v - half, 0):v + half, max(u - half, 0):u + half].mean())


def light_grey(image):  # the Panda's shell (as in browser_checks.assert_panda_drawn)
    return (image.min(axis=2) > 150) & (image.max(axis=2) - image.min(axis=2) < 40)


def orange(image):  # the carried part, viz.colors "orange" (0xE69F00) under Lambert/Phong shading
    r, g, b = image[..., 0], image[..., 1], image[..., 2]
    return (r > 100) & (g > 0.5 * r) & (g < 0.85 * r) & (b < 0.3 * r)


@pytest.mark.skipif(viz.find_browser() is None, reason="no Chromium binary found (apt-get install chromium)")
def test_the_browser_draws_the_robot_where_fk_puts_it_mid_motion(planned):
    panda, plan, page, commands = planned
    t, Q = frames_of(plan)
    eye, target = page_camera(commands)

    def uv(point):
        return camera_project([point], eye, target, SIZE)[0]

    def moved(k):  # the smaller on-screen displacement of the two links from the start to frame k (px)
        return min(np.linalg.norm(uv(panda.fk(Q[k], link)[:3, 3]) - uv(panda.fk(Q[0], link)[:3, 3]))
                   for link in ("panda_link7", "panda_hand"))

    # mid-motion: the frame nearest the middle where both links are apart on screen from their start
    mid = next(k for k in sorted(range(len(t) // 4, 3 * len(t) // 4 + 1), key=lambda k: abs(2 * k - len(t)))
               if moved(k) > 40)
    start, middle = render_at(page, 0.0), render_at(page, mid / FPS)
    changed = np.abs(start - middle).max(axis=2) > 40

    for link in ("panda_link7", "panda_hand"):
        at_mid, at_start = uv(panda.fk(Q[mid], link)[:3, 3]), uv(panda.fk(Q[0], link)[:3, 3])
        assert np.linalg.norm(at_mid - at_start) > 40, (link, at_mid, at_start)  # apart on screen
        # mid-motion: the robot's grey is drawn where FK puts the link, and that is new since the start
        assert share(light_grey(middle) & changed, at_mid) > 0.25, link
        # and it has left the link's start place, where it was drawn at t = 0
        assert share(light_grey(start) & changed, at_start) > 0.25, link
    part_mid = (panda.fk(Q[mid], "panda_hand") @ PART_IN_HAND)[:3, 3]
    part_start = (panda.fk(Q[0], "panda_hand") @ PART_IN_HAND)[:3, 3]
    assert share(orange(middle) & changed, uv(part_mid), half=6) > 0.5
    assert share(orange(start), uv(part_mid), half=6) < 0.05  # the part was not there at the start
    assert share(orange(middle), uv(part_start), half=6) < 0.05  # nor is it still where it started


@pytest.mark.parametrize("kwargs, message", [
    ({"robot": "planar4r"}, r"robot must be a kinserve Robot .*robots.load\('planar4r'\)"),
    ({"obstacles": 2.5}, "obstacles must be a sequence of shapes"),
    ({"obstacle_opacity": "no"}, r"obstacle_opacity must be a number in \(0, 1\]"),
    ({"obstacle_opacity": True}, r"obstacle_opacity must be a number in \(0, 1\]"),
    ({"obstacle_opacity": 0.0}, r"obstacle_opacity must be a number in \(0, 1\]"),
])
def test_motion_plan_scene_names_a_bad_argument(kwargs, message):
    """A robot's name raised "'str' object has no attribute 'nq'", ``obstacle_opacity="no"`` Python's
    float() error and ``True`` was drawn as opaque; each is refused by name before anything is drawn. None
    means no obstacles."""
    from kinserve.kinematics.errors import InputError

    arm = robots.load("planar4r", geometry=False)
    Q = np.linspace(0.0, 0.5, 4)[:, None] * np.ones(arm.nq)
    plan = (np.linspace(0.0, 1.0, 4), Q)
    args = {"robot": arm, "plan": plan, "obstacles": ()}
    args.update(kwargs)
    with pytest.raises(InputError, match=message):
        viz.motion_plan_scene(args.pop("robot"), args.pop("plan"), **args)
    assert viz.motion_plan_scene(arm, plan, obstacles=None).animation is not None


@pytest.mark.parametrize("kwargs, message", [
    ({"title": np.zeros(0)}, "title must be a str or None"),
    ({"title": 3}, "title must be a str or None, got 3"),
    ({"name": np.zeros(0)}, "name must be a str or None"),
    ({"name": 0}, "name must be a str or None, got 0"),
    ({"attached_color": "nocolor"}, "attached_color: unknown color 'nocolor'"),
    ({"obstacle_color": (1, 2)}, "obstacle_color: color sequence"),
    ({"path_color": None}, "path_color: color must be"),
])
def test_motion_plan_scene_checks_title_name_and_colours_first(kwargs, message):
    """``title`` / ``name`` given an empty array raised NumPy's ambiguous-truth error (``0`` fell back to the
    default name), and a colour the scene would not use (nothing carried, no obstacle) was never read; each is
    refused by name before anything is drawn."""
    from kinserve.kinematics.errors import InputError

    arm = robots.load("planar4r", geometry=False)
    plan = (np.linspace(0.0, 1.0, 3), np.zeros((3, arm.nq)))
    with pytest.raises(InputError, match=message):
        viz.motion_plan_scene(arm, plan, **kwargs)
    scene = viz.motion_plan_scene(arm, plan, title="t", name="arm", attached_color="#00ff00")
    assert scene.title == "t" and list(scene.robots) == ["arm"]
