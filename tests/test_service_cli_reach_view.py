"""End-to-end: `kinserve reach` writes its map and plot; `kinserve view` serves a live page."""

import os
import re
import subprocess
import sys
import time

import httpx
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ENV = dict(os.environ, MPLBACKEND="Agg")


def test_reach_writes_npz_and_png(tmp_path):
    stem = tmp_path / "pr_reach"
    out = subprocess.run([sys.executable, "-m", "kinserve.service.cli", "reach", "pr", "--samples", "80", "--resolution", "4",
                          "--backend", "serial", "--out", str(stem)], cwd=ROOT, env=ENV, capture_output=True, text=True,
                         timeout=300)
    assert out.returncode == 0, out.stderr
    assert "sampled poses reached" in out.stdout
    data = np.load(stem.with_suffix(".npz"))
    assert data["counts"].sum() == 80 and data["reached"].shape == (80,)
    png = stem.with_suffix(".png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000


def test_view_serves_the_robot_until_interrupted(tmp_path):
    proc = subprocess.Popen([sys.executable, "-u", "-m", "kinserve.service.cli", "view", "scara", "--q", "0.3", "0.5", "0.4", "0.1"],
                            cwd=ROOT, env=ENV, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        url = None
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and url is None:
            line = proc.stdout.readline()
            if not line and proc.poll() is not None:
                break
            m = re.search(r"(http://127\.0\.0\.1:\d+/static/)", line)
            url = m.group(1) if m else None
        assert url, "no viewer URL printed"
        page = httpx.get(url, timeout=10)
        assert page.status_code == 200 and "meshcat" in page.text.lower()
        assert proc.poll() is None  # still serving
    finally:
        proc.terminate()
        proc.wait(timeout=10)


def test_view_html_writes_a_static_page(tmp_path):
    out = subprocess.run([sys.executable, "-m", "kinserve.service.cli", "view", "planar4r", "--html", str(tmp_path / "p.html")],
                         cwd=ROOT, env=ENV, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    text = (tmp_path / "p.html").read_text()
    assert "<script" in text and len(text) > 100_000  # the meshcat viewer is inlined
    assert not re.search(r"""(src|href)\s*=\s*["']https?://""", text)  # nothing fetched from the network
