"""End-to-end: `kinserve reach` writes its map and plot; `kinserve view` serves a live page."""

import contextlib
import os
import re
import signal
import subprocess
import sys
import time

import httpx
import numpy as np
import pytest

from process_leaks import alive, parent_of, wait_gone

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ENV = dict(os.environ, MPLBACKEND="Agg")


def test_reach_writes_npz_and_png(tmp_path):
    stem = tmp_path / "pr_reach"
    out = subprocess.run([sys.executable, "-m", "kinserve.service.cli", "reach", "pr", "--samples", "80",
                          "--resolution", "4", "--backend", "serial", "--out", str(stem)], cwd=ROOT, env=ENV,
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert "sampled poses reached" in out.stdout
    data = np.load(stem.with_suffix(".npz"))
    assert data["counts"].sum() == 80 and data["reached"].shape == (80,)
    png = stem.with_suffix(".png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000


def start_view(*args: str, sigint_ignored: bool = False) -> tuple[subprocess.Popen, str, int]:
    """``kinserve view ...`` in a subprocess: (process, page URL, pid of its meshcat server) once it serves.

    ``sigint_ignored``: start it with SIGINT ignored, as a background job of a non-interactive shell is.
    """
    preexec = (lambda: signal.signal(signal.SIGINT, signal.SIG_IGN)) if sigint_ignored else None
    proc = subprocess.Popen([sys.executable, "-u", "-m", "kinserve.service.cli", "view", *args],
                            cwd=ROOT, env=ENV, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            preexec_fn=preexec)
    deadline = time.monotonic() + 60
    seen = []
    while time.monotonic() < deadline:
        line = proc.stdout.readline()
        seen.append(line)
        if not line and proc.poll() is not None:
            break
        m = re.search(r"(http://127\.0\.0\.1:\d+/static/)\s+\(meshcat server pid (\d+);", line)
        if m:
            return proc, m.group(1), int(m.group(2))
    proc.kill()
    proc.wait()
    raise AssertionError(f"no viewer URL printed: {''.join(seen)}")


@contextlib.contextmanager
def running_view(*args: str, sigint_ignored: bool = False):
    """:func:`start_view` whose viewer and meshcat server are gone afterwards, whatever the test did."""
    proc, url, server = start_view(*args, sigint_ignored=sigint_ignored)
    try:
        yield proc, url, server
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        proc.stdout.close()
        if alive(server):
            os.kill(server, signal.SIGKILL)


@pytest.mark.parametrize("sig, status", [(signal.SIGTERM, 128 + signal.SIGTERM), (signal.SIGINT, 0),
                                         (signal.SIGHUP, 128 + signal.SIGHUP)],
                         ids=["SIGTERM", "SIGINT", "SIGHUP"])
def test_view_serves_the_robot_until_signalled_and_stops_its_server(sig, status):
    with running_view("scara", "--q", "0.3", "0.5", "0.4", "0.1") as (proc, url, server):
        assert alive(server) and parent_of(server) == proc.pid
        page = httpx.get(url, timeout=10)
        assert page.status_code == 200 and "meshcat" in page.text.lower()
        assert proc.poll() is None  # still serving
        proc.send_signal(sig)
        assert proc.wait(timeout=20) == status
        assert not wait_gone([server], timeout=10), f"meshcat server {server} outlived the viewer"
        assert "Traceback" not in proc.stdout.read()


def test_ctrl_c_stops_a_viewer_started_with_sigint_ignored():
    """A background job of a non-interactive shell inherits SIGINT ignored; Ctrl-C must still stop the
    viewer."""
    with running_view("planar4r", sigint_ignored=True) as (proc, _, server):
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=20) == 0
        assert not wait_gone([server], timeout=10), f"meshcat server {server} outlived the viewer"


def test_viewer_killed_outright_still_takes_its_server_down():
    """SIGKILL allows no clean-up in the viewer: the server's parent-death signal (Linux) ends it."""
    with running_view("planar4r") as (proc, _, server):
        proc.kill()
        proc.wait(timeout=10)
        assert not wait_gone([server], timeout=10), f"meshcat server {server} outlived the killed viewer"


def test_view_html_writes_a_static_page(tmp_path):
    out = subprocess.run([sys.executable, "-m", "kinserve.service.cli", "view", "planar4r", "--html",
                          str(tmp_path / "p.html")],
                         cwd=ROOT, env=ENV, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    text = (tmp_path / "p.html").read_text()
    assert "<script" in text and len(text) > 100_000  # the meshcat viewer is inlined
    assert not re.search(r"""(src|href)\s*=\s*["']https?://""", text)  # nothing fetched from the network
