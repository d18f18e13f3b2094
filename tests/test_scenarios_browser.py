"""A real browser on a scenario's page: headless Chromium opens the exported S4 ``pick-place`` scene.html.

Skipped only when no Chromium binary exists (``make test`` installs Debian's
``chromium``). The scenario runs once; its ``scene.html`` is rendered by
:func:`viz.screenshot` (``--headless --no-sandbox --disable-gpu``, WebGL in
software by SwiftShader). The robot's pixels are the difference from a second
page holding exactly the same commands (camera included) minus the robot's:
they must cover a sensible share of the image, be mostly the Panda's light
grey, and sit where the camera projects the arm's base and flange.
"""

from __future__ import annotations

import base64
import gzip
import json
import re

import numpy as np
import pytest

from kinserve import scenarios, viz
from kinserve.planners import JointTrajectory
from kinserve.viz.export import pack_commands

from browser_checks import assert_panda_drawn, robot_mask
from browser_checks import project as camera_project

pytestmark = pytest.mark.skipif(viz.find_browser() is None,
                                reason="no Chromium binary found (apt-get install chromium)")

SIZE = (800, 600)
ROBOT = "/meshcat/panda"


def without_robot(src, dst):
    """Copy the exported page ``src`` to ``dst`` with every command (and animation track) of the robot
    removed."""
    text = src.read_text(encoding="utf-8")
    keep = []
    for c in viz.read_html_commands(src):
        if c.get("path", "").startswith(ROBOT):
            continue
        if c["type"] == "set_animation":
            c = dict(c, animations=[a for a in c["animations"] if not a["path"].startswith(ROBOT)])
        keep.append(c)
    payload = base64.b64encode(gzip.compress(pack_commands(keep), mtime=0)).decode("ascii")
    i = text.index('<script id="kinserve-scene"')
    head_end = text.index(">", i)
    body_end = text.index("</script>", head_end)
    head = re.sub(r'data-commands="\d+"', f'data-commands="{len(keep)}"', text[i:head_end])
    dst.write_text(text[:i] + head + ">" + payload + text[body_end:], encoding="utf-8")
    return dst, keep


def camera(commands):
    """(eye, target) of an exported page: the drawing is shifted by -target, the camera sits at eye -
    target."""
    shift = next(c for c in commands if c["type"] == "set_transform" and c["path"] == "/meshcat")
    target = -np.asarray(shift["matrix"], dtype=float).reshape(4, 4).T[:3, 3]
    pos = next(c for c in commands
               if c.get("property") == "position" and c["path"].startswith("/Cameras/default"))
    p = np.asarray(pos["value"], dtype=float)  # three.js y-up: (x, z, -y) of the world
    return target + np.array([p[0], -p[2], p[1]]), target


def project(points, eye, target, size=SIZE):
    """Pixel coordinates (u right, v down) of world points seen by meshcat's perspective camera."""
    return camera_project(points, eye, target, size)


@pytest.fixture(scope="module")
def pick_place(tmp_path_factory):
    out = tmp_path_factory.mktemp("pick-place-browser")
    scenarios.run("pick-place", out)
    full = out / "scene.html"
    bare, _ = without_robot(full, out / "bare.html")
    r = json.loads((out / "result.json").read_text())
    q0 = JointTrajectory.load(out / "trajectory.json").positions[0]
    return out, full, bare, r, q0


def test_pick_place_page_loads_without_errors(pick_place):
    _, full, _, _, _ = pick_place
    status = viz.page_status(full, play=True)
    assert status["status"] == "ready", status
    assert status["errors"] == "0" and status["console-errors"] == "0", status
    assert int(status["commands"]) == len(viz.read_html_commands(full))
    assert int(status["animation-clips"]) == 8 + 2  # the arm's 8 link meshes, the flange triad, the cylinder
    assert float(status["animation-duration"]) == pytest.approx(15.0, rel=1e-3)


def test_pick_place_screenshot_shows_the_robot(pick_place):
    from kinserve import robots

    out, full, bare, r, q0 = pick_place
    image, robot = robot_mask(viz, full, bare, out, SIZE)
    # the robot is where the page's camera puts the arm at the first frame (q_start, home pose)
    eye, target = camera(viz.read_html_commands(full))
    fk = robots.load("panda").fk_all(q0)
    assert_panda_drawn(image, robot, fk, lambda pts: project(pts, eye, target),
                       ("panda_link0", "panda_link4", "panda_link8"))
