"""Shared assertion of the browser tests: a Panda is really drawn in a screenshot.

``robot_mask(viz, full_html, bare_html, out, size)`` screenshots a page and the
same page with the robot removed; the pixels that differ are the robot's.
``assert_panda_drawn`` checks they cover a sensible share of the image, are
mostly the Panda's light-grey shell, and lie where the page's camera projects
the arm's joints (``project(points) -> (u, v)`` pixel coordinates).
"""

from __future__ import annotations

import numpy as np
from PIL import Image

from kinserve.viz.scene import CAMERA_FOV_DEG


def project(points, eye, target, size) -> np.ndarray:
    """Pixel coordinates (u right, v down) of world points seen by meshcat's perspective camera
    (vertical field of view CAMERA_FOV_DEG, world z up, looking from ``eye`` at ``target``)."""
    f = (target - eye) / np.linalg.norm(target - eye)
    r = np.cross(f, [0, 0, 1.0])
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    w, h = size
    k = (h / 2) / np.tan(np.radians(CAMERA_FOV_DEG / 2))
    d = np.asarray(points, dtype=float) - eye
    depth = d @ f
    return np.c_[w / 2 + k * (d @ r) / depth, h / 2 - k * (d @ u) / depth]


def page_camera(commands) -> tuple[np.ndarray, np.ndarray]:
    """(eye, target) of a page's replayed commands: the drawing is shifted by -target, the camera sits at
    eye - target."""
    shift = next(c for c in commands if c["type"] == "set_transform" and c["path"] == "/meshcat")
    target = -np.asarray(shift["matrix"], dtype=float).reshape(4, 4).T[:3, 3]
    pos = next(c for c in commands
               if c.get("property") == "position" and c["path"].startswith("/Cameras/default"))
    p = np.asarray(pos["value"], dtype=float)  # three.js y-up: (x, z, -y) of the world
    return target + np.array([p[0], -p[2], p[1]]), target


def robot_mask(viz, full_html, bare_html, out, size) -> tuple[np.ndarray, np.ndarray]:
    """(screenshot with the robot as an int RGB array, boolean mask of the robot's pixels)."""
    a = np.asarray(Image.open(viz.screenshot(full_html,
                                             out / "full.png", size=size)).convert("RGB")).astype(int)
    b = np.asarray(Image.open(viz.screenshot(bare_html,
                                             out / "bare.png", size=size)).convert("RGB")).astype(int)
    assert a.shape == b.shape == (size[1], size[0], 3)
    # the WebGL canvas rendered the rest of the scene: not one flat colour
    assert len(np.unique(b.reshape(-1, 3), axis=0)) > 50
    return a, np.abs(a - b).max(axis=2) > 40


def assert_panda_drawn(image: np.ndarray, robot: np.ndarray, fk: dict, project, frames) -> None:
    """The robot's pixels: 1-50 % of the image, >30 % light grey, around the projected ``frames``."""
    frac = robot.mean()
    assert 0.01 < frac < 0.5, f"robot covers {frac:.2%} of the image"
    px = image[robot]
    bright_grey = (px.min(axis=1) > 150) & (px.max(axis=1) - px.min(axis=1) < 40)
    assert bright_grey.mean() > 0.3, f"only {bright_grey.mean():.0%} of the robot's pixels are light grey"
    vs, us = np.nonzero(robot)
    for frame in frames:
        u, v = project([fk[frame][:3, 3]])[0]
        assert us.min() - 15 <= u <= us.max() + 15 and vs.min() - 15 <= v <= vs.max() + 15, (frame, u, v)
    # the pixels around the projected elbow (link4) really belong to the robot
    u4, v4 = project([fk["panda_link4"][:3, 3]])[0].round().astype(int)
    assert robot[max(v4 - 20, 0):v4 + 20, max(u4 - 20, 0):u4 + 20].mean() > 0.2


#: Chromium with no way out but loopback: every host name fails to resolve and any other request
#: goes to a closed local proxy port (loopback itself bypasses the proxy).
OFFLINE_FLAGS = ("--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1",
                 "--proxy-server=http://127.0.0.1:9")


def open_offline(url: str, ready_js: str, *, size=(1200, 900), timeout: float = 60.0):
    """Open ``url`` in headless Chromium with the network off (loopback only) and poll ``ready_js``.

    Returns ``(value, requested, errors)``: the first truthy value of the
    expression, every URL the page requested, and the page's uncaught
    exceptions / console errors. Raises ``TimeoutError`` when ``ready_js``
    stays falsy for ``timeout`` seconds.
    """
    import importlib
    import time

    # kinserve.viz.screenshot is also a function
    screenshot = importlib.import_module("kinserve.viz.screenshot")

    browser = screenshot.find_browser()
    dt = screenshot._DevTools(browser, size, timeout, extra_flags=OFFLINE_FLAGS)
    try:
        dt.attach_page()
        for domain in ("Page", "Runtime", "Log", "Network"):
            dt.call(f"{domain}.enable")
        dt.call("Page.navigate", {"url": url})
        value = None
        while not value:
            try:
                value = dt.evaluate(ready_js)
            except RuntimeError:  # the document is being replaced while navigating
                value = None
            if not value:
                dt._remaining()
                time.sleep(0.1)
        requested = [ev["params"]["request"]["url"] for ev in dt.events
                     if ev.get("method") == "Network.requestWillBeSent"]
        return value, requested, dt.errors()
    finally:
        dt.close()
