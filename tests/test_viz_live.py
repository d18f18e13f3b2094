"""kinserve.viz.LiveViewer / viz.serve: a real meshcat server on 127.0.0.1 receives the scene."""

import re
import threading
import urllib.request

import numpy as np
import pytest

from kinserve import robots, viz


@pytest.fixture(scope="module")
def scene():
    arm = robots.load("planar4r")
    s = viz.Scene("live")
    s.add_robot(arm, np.array([0.3, -0.2, 0.4, 0.1]))
    s.add_sphere("target", [1.2, 0.8, 0.0], 0.05)
    return s


def test_live_viewer_serves_the_scene(scene):
    with viz.LiveViewer() as viewer:
        assert viewer.running
        assert re.fullmatch(r"http://127\.0\.0\.1:\d+/static/", viewer.url)
        n = viewer.show(scene)
        assert n == len(scene.commands())
        page = urllib.request.urlopen(viewer.url, timeout=10).read().decode()
        assert "MeshCat.Viewer" in page  # meshcat's own page, served locally
        # the server keeps the scene: its static export holds one drawing command per object
        html = viewer.static_html()
        assert html.count('fetch("data:application/octet-binary;base64,') >= len(scene.paths())
        proc = viewer._proc
    assert not viewer.running and proc.poll() is not None


def test_serve_announces_and_stops(scene):
    lines, stop = [], threading.Event()
    result = {}
    thread = threading.Thread(target=lambda: result.setdefault("url", viz.serve(scene, announce=lines.append,
                                                                                stop=stop, poll=0.05)))
    thread.start()
    for _ in range(200):
        if lines:
            break
        threading.Event().wait(0.05)
    stop.set()
    thread.join(timeout=20)
    assert not thread.is_alive()
    assert len(lines) == 1 and result["url"] in lines[0] and "Ctrl-C" in lines[0]


def test_a_viewer_never_closed_stops_its_server_when_python_exits(tmp_path):
    """Normal interpreter exit without close(): the atexit stop ends the meshcat server."""
    import subprocess
    import sys

    from process_leaks import alive, wait_gone

    code = ("from kinserve.viz import LiveViewer; v = LiveViewer(); print(v.server_pid, flush=True); "
            "assert v.running")
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                         text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    server = int(out.stdout.split()[0])
    assert not wait_gone([server], timeout=10), f"meshcat server {server} outlived its Python process"
    assert not alive(server)
