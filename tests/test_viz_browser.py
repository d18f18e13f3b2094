"""A real browser: headless Chromium (SwiftShader WebGL, driven over the DevTools pipe) opens an
exported scene and draws the robot.

Skipped only when no Chromium binary exists (``make test`` installs Debian's
``chromium``). The robot's pixels are found as the difference between two
screenshots taken with the same camera: the full scene (Panda with its
meshes, a sphere, a path, an animation) and the same scene without the robot.
"""

import numpy as np
import pytest

from kinserve import robots, viz
from kinserve.kinematics import se3

from browser_checks import assert_panda_drawn, robot_mask
from browser_checks import project as camera_project

pytestmark = pytest.mark.skipif(viz.find_browser() is None,
                                reason="no Chromium binary found (apt-get install chromium)")

SIZE = (800, 600)
EYE, TARGET = np.array([1.25, 0.85, 0.85]), np.array([0.25, 0.0, 0.4])


def project(points, eye=EYE, target=TARGET, size=SIZE):
    """Pixel coordinates (u right, v down) of world points seen from this test's camera."""
    return camera_project(points, eye, target, size)


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
    # ends back at q0
    Q = q0 + np.outer(np.sin(np.linspace(0, np.pi, 31)), [0.5, 0.3, 0.0, 0.3, 0.0, 0.0, 0.0])
    out = tmp_path_factory.mktemp("browser")
    full = viz.export_html(build(True, panda, q0, Q), out / "full.html")
    bare = viz.export_html(build(False, panda, q0, Q), out / "bare.html")
    return panda, q0, full, bare, out


def test_page_loads_without_errors_and_plays_the_animation(pages):
    _, _, full, _, _ = pages
    status = viz.page_status(full, play=True)
    assert status["status"] == "ready", status
    # no uncaught error, no console error
    assert status["errors"] == "0" and status["console-errors"] == "0", status
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
    image, robot = robot_mask(viz, full, bare, out, SIZE)
    # the robot is where the camera model puts it: base, elbow and hand inside the robot's pixel box
    assert_panda_drawn(image, robot, panda.fk_all(q0), project, ("panda_link0", "panda_link4", "panda_hand"))
