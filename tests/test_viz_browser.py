"""A real browser: headless Chromium (SwiftShader WebGL, driven over the DevTools pipe) opens an
exported scene and draws the robot.

Skipped only when no Chromium binary exists (``make test`` installs Debian's
``chromium``). The robot's pixels are found as the difference between two
screenshots taken with the same camera: the full scene (Panda with its
meshes, a sphere, a path, an animation) and the same scene without the robot.
"""

import numpy as np
import pytest
from PIL import Image

import robots
import viz
from kinematics import se3
from viz.scene import CAMERA_FOV_DEG

pytestmark = pytest.mark.skipif(viz.find_browser() is None, reason="no Chromium binary found (apt-get install chromium)")

SIZE = (800, 600)
EYE, TARGET = np.array([1.25, 0.85, 0.85]), np.array([0.25, 0.0, 0.4])


def project(points, eye=EYE, target=TARGET, size=SIZE):
    """Pixel coordinates (u right, v down) of world points seen by meshcat's perspective camera
    (vertical field of view CAMERA_FOV_DEG, world z up, looking from eye at target)."""
    f = (target - eye) / np.linalg.norm(target - eye)
    r = np.cross(f, [0, 0, 1.0])
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    w, h = size
    k = (h / 2) / np.tan(np.radians(CAMERA_FOV_DEG / 2))
    d = np.asarray(points, dtype=float) - eye
    depth = d @ f
    return np.c_[w / 2 + k * (d @ r) / depth, h / 2 - k * (d @ u) / depth]


def build(with_robot: bool, panda, q0, Q):
    scene = viz.Scene("browser test", grid=False)
    if with_robot:
        scene.add_robot(panda, q0)
    scene.add_sphere("obstacle", [0.45, -0.45, 0.3], 0.08, color="red")
    scene.add_path("tool_path", np.array([panda.fk(q)[:3, 3] for q in Q]), color="green")
    scene.add_frame("goal", se3.pose(se3.rot_x(np.pi), panda.fk(Q[-1])[:3, 3]), length=0.1)
    if with_robot:
        anim = viz.Animation(scene, fps=30)
        anim.robot("panda", Q)
        anim.apply()
    scene.set_camera(EYE, TARGET)
    return scene


@pytest.fixture(scope="module")
def pages(tmp_path_factory):
    panda = robots.load("panda")
    q0 = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 1.9, 0.8])
    Q = q0 + np.outer(np.sin(np.linspace(0, np.pi, 31)), [0.5, 0.3, 0.0, 0.3, 0.0, 0.0, 0.0])  # ends back at q0
    out = tmp_path_factory.mktemp("browser")
    full = viz.export_html(build(True, panda, q0, Q), out / "full.html")
    bare = viz.export_html(build(False, panda, q0, Q), out / "bare.html")
    return panda, q0, full, bare, out


def test_page_loads_without_errors_and_plays_the_animation(pages):
    _, _, full, _, _ = pages
    status = viz.page_status(full, play=True)
    assert status["status"] == "ready", status
    assert status["errors"] == "0" and status["console-errors"] == "0", status  # no uncaught error, no console error
    assert int(status["commands"]) == len(viz.read_html_commands(full))
    assert int(status["animation-clips"]) == 11  # one clip per Panda visual mesh
    assert float(status["animation-duration"]) == pytest.approx(30 / 30, rel=1e-3)
    assert status["animation-playing"] == "true"
    # "#paused" loads the same animation without playing it
    paused = viz.page_status(full)
    assert paused["animation-playing"] == "false" and paused["animation-clips"] == "11"


def test_screenshot_shows_the_robot(pages):
    panda, q0, full, bare, out = pages
    # screenshots show the animation's first frame (q0), paused
    a = np.asarray(Image.open(viz.screenshot(full, out / "full.png", size=SIZE)).convert("RGB")).astype(int)
    b = np.asarray(Image.open(viz.screenshot(bare, out / "bare.png", size=SIZE)).convert("RGB")).astype(int)
    assert a.shape == b.shape == (SIZE[1], SIZE[0], 3)
    # the WebGL canvas rendered something: not one flat colour, and the sphere differs from the background
    assert len(np.unique(b.reshape(-1, 3), axis=0)) > 50
    robot = np.abs(a - b).max(axis=2) > 40
    frac = robot.mean()
    assert 0.01 < frac < 0.5, f"robot covers {frac:.2%} of the image"
    # the Panda's shell is white/light grey: many robot pixels are bright and unsaturated
    px = a[robot]
    bright_grey = (px.min(axis=1) > 150) & (px.max(axis=1) - px.min(axis=1) < 40)
    assert bright_grey.mean() > 0.3, f"only {bright_grey.mean():.0%} of the robot's pixels are light grey"
    # and it is where the camera model puts it: base and hand project inside the robot's pixel box
    vs, us = np.nonzero(robot)
    fk = panda.fk_all(q0)
    for frame in ("panda_link0", "panda_link4", "panda_hand"):
        u, v = project([fk[frame][:3, 3]])[0]
        assert us.min() - 15 <= u <= us.max() + 15 and vs.min() - 15 <= v <= vs.max() + 15, (frame, u, v)
    # the robot pixels near the projected elbow (link4) really belong to the robot
    u4, v4 = project([fk["panda_link4"][:3, 3]])[0].round().astype(int)
    assert robot[max(v4 - 20, 0):v4 + 20, max(u4 - 20, 0):u4 + 20].mean() > 0.2
