"""kinserve.viz.LiveViewer / viz.serve: a real meshcat server on 127.0.0.1 receives the scene.

Where the server listens is read from the kernel (``/proc/net/tcp[6]``, the sockets among the server
process's file descriptors), and checked by connecting: by default only 127.0.0.1 answers (another
loopback address, 127.0.0.2, is refused, or answered by another process's socket: tests run in parallel and
meshcat counts its ports up from 7000); ``host=`` moves the page and says so, ZeroMQ stays on 127.0.0.1.
"""

import errno
import os
import re
import socket
import threading
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from kinserve import robots, viz
from kinserve.kinematics.errors import InputError

from process_leaks import alive, parent_of


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
        with pytest.raises(InputError, match="clear must be True or False"):
            viewer.show(scene, clear="no")
        n = viewer.show(scene)
        assert n == len(scene.commands())
        page = urllib.request.urlopen(viewer.url, timeout=10).read().decode()
        assert "MeshCat.Viewer" in page  # meshcat's own page, served locally
        # the server keeps the scene: its static export holds one drawing command per object
        html = viewer.static_html()
        assert html.count('fetch("data:application/octet-binary;base64,') >= len(scene.paths())
        proc = viewer._proc
    assert not viewer.running and proc.poll() is not None


def test_the_live_viewer_keeps_a_motion_plan_animation():
    """viz.motion_plan_scene on the live server: its own export of the scene holds the same animation."""
    import base64

    import umsgpack

    from kinserve.viz.animation import pose_at

    arm = robots.load("planar4r")
    a, b = np.zeros(4), np.array([1.0, 0.5, -0.5, 0.2])
    plan_scene = viz.motion_plan_scene(arm, ([0.0, 1.0], np.vstack([a, b])), fps=10)
    with viz.LiveViewer() as viewer:
        viewer.show(plan_scene)
        html = viewer.static_html()
    blobs = re.findall(r"data:application/octet-binary;base64,([A-Za-z0-9+/=]+)", html)
    (anim,) = [c for c in map(umsgpack.unpackb, map(base64.b64decode, blobs)) if c["type"] == "set_animation"]
    g = arm.visual_model.geometryObjects[-1]  # the last link's mesh
    path = "/meshcat/planar4r/visuals/" + g.name
    for k in (0, 5, 10):  # frame k at t = k / 10 s on the straight line from a to b
        q = a + (b - a) * k / 10
        np.testing.assert_allclose(pose_at(anim, path, k),
                                   arm.fk(q, arm.model.names[g.parentJoint]) @ g.placement.homogeneous,
                                   atol=1e-9)


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


def _address(hex_address: str) -> tuple[str, int]:
    """``(ip, port)`` of a ``/proc/net/tcp[6]`` address: the IP as 32-bit words in host (little-endian)
    order, the port big-endian, in hex."""
    ip_hex, port_hex = hex_address.split(":")
    raw = b"".join(bytes.fromhex(ip_hex[i:i + 8])[::-1] for i in range(0, len(ip_hex), 8))
    return socket.inet_ntop(socket.AF_INET if len(raw) == 4 else socket.AF_INET6, raw), int(port_hex, 16)


def _listeners() -> list[tuple[str, int, str]]:
    """Every listening TCP socket of this machine (state 0A = LISTEN): ``(ip, port, inode)``."""
    out = []
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        for line in Path(table).read_text().splitlines()[1:]:
            fields = line.split()
            if fields[3] == "0A":
                out.append((*_address(fields[1]), fields[9]))
    return out


def _socket_inodes(pid: int) -> set[str]:
    """The inodes of the sockets among process ``pid``'s file descriptors."""
    inodes = set()
    for fd in os.listdir(f"/proc/{pid}/fd"):
        try:
            target = os.readlink(f"/proc/{pid}/fd/{fd}")
        except OSError:
            continue
        if target.startswith("socket:["):
            inodes.add(target[8:-1])
    return inodes


def listening(pid: int) -> set[tuple[str, int]]:
    """The ``(ip, port)`` TCP sockets process ``pid`` listens on."""
    inodes = _socket_inodes(pid)
    return {(ip, port) for ip, port, inode in _listeners() if inode in inodes}


def refused(host: str, port: int) -> bool:
    """True when nothing accepts a TCP connection at ``host:port``."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.settimeout(5)
        return s.connect_ex((host, port)) == errno.ECONNREFUSED


def not_served_by(pid: int, host: str, port: int) -> bool:
    """True when process ``pid`` does not accept TCP connections at ``host:port``: none of its sockets
    listens there or on a wildcard address, and a connection there is refused - or, when another test's
    server (the suite runs in parallel and meshcat counts its ports up from 7000) took that very address,
    accepted by a socket of another process."""
    ours = _socket_inodes(pid)
    if any(p == port and ip in (host, "0.0.0.0", "::") and inode in ours for ip, p, inode in _listeners()):
        return False
    return refused(host, port) or any(ip == host and p == port and inode not in ours
                                      for ip, p, inode in _listeners())


def test_the_viewer_listens_on_127_0_0_1_only_by_default(scene):
    with viz.LiveViewer() as viewer:
        pid, port = viewer.server_pid, int(viewer.url.split(":")[2].split("/")[0])
        zmq_port = int(viewer.zmq_url.rsplit(":", 1)[1])
        assert listening(pid) == {("127.0.0.1", port), ("127.0.0.1", zmq_port)}
        assert viewer.bind == f"127.0.0.1:{port}"
        assert urllib.request.urlopen(viewer.url, timeout=10).status == 200
        # another address of this machine (loopback 127.0.0.2) is refused: meshcat's own server accepts it
        assert not_served_by(pid, "127.0.0.2", port)
    assert not alive(pid)


def test_host_moves_the_page_and_serve_says_where_it_listens(scene):
    lines, stop, result = [], threading.Event(), {}
    thread = threading.Thread(target=lambda: result.setdefault(
        "url", viz.serve(scene, host="127.0.0.2", announce=lines.append, stop=stop, poll=0.05)))
    thread.start()
    try:
        for _ in range(400):
            if lines or not thread.is_alive():
                break
            threading.Event().wait(0.05)
        (line,) = lines
        m = re.search(r"(http://127\.0\.0\.2:(\d+)/static/) +\(meshcat server pid (\d+); "
                      r"listening on 127\.0\.0\.2:(\d+);", line)
        assert m and m.group(2) == m.group(4), line
        url, port, pid = m.group(1), int(m.group(2)), int(m.group(3))
        web = {(ip, p) for ip, p in listening(pid) if p == port}
        assert web == {("127.0.0.2", port)}  # the page on the address asked for; ZeroMQ stays on 127.0.0.1
        assert all(ip == "127.0.0.1" for ip, p in listening(pid) if p != port)
        assert "MeshCat.Viewer" in urllib.request.urlopen(url, timeout=10).read().decode()
        assert not_served_by(pid, "127.0.0.1", port)
    finally:
        stop.set()
        thread.join(timeout=20)
    assert not thread.is_alive() and result["url"] == url
    assert not alive(pid)


def test_a_host_that_is_no_address_here_is_refused_and_leaves_no_server():
    def children() -> set[int]:
        return {int(p) for p in os.listdir("/proc") if p.isdigit() and parent_of(int(p)) == os.getpid()
                and alive(int(p))}

    before = children()
    for host in ("", "no-such-host.invalid", "192.0.2.1"):  # the last is TEST-NET-1: not on this machine
        with pytest.raises(InputError, match="host"):
            viz.LiveViewer(host=host)
    assert children() <= before  # the server that could not listen was stopped and reaped
    with pytest.raises(InputError, match="started here"):
        viz.LiveViewer("tcp://127.0.0.1:6000", host="127.0.0.2")
