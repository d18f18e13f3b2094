"""Headless Chromium: screenshots of exported scenes and their load status.

Needs a Chromium binary (Debian's ``chromium`` package; ``chromium-browser``
or ``google-chrome`` also work, or set ``KINSERVE_CHROMIUM``). WebGL is
rendered in software by SwiftShader (``--use-angle=swiftshader
--enable-unsafe-swiftshader``), so no GPU and no display are needed; the
network stays off (``file://`` page, no background services). Virtual time
(``--virtual-time-budget``) lets the page finish loading and animating
before the capture, independently of the machine's speed.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

from kinematics.errors import KinserveError

#: Binaries tried in order (after ``$KINSERVE_CHROMIUM``).
CANDIDATES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")

#: Flags for a headless, offline, software-rendered (SwiftShader WebGL) Chromium.
FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
    "--disable-quic",
    "--no-first-run",
    "--no-default-browser-check",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-extensions",
    "--hide-scrollbars",
    "--mute-audio",
)


class BrowserUnavailable(KinserveError):
    """No Chromium binary was found (install Debian's ``chromium`` package)."""


def find_browser() -> str | None:
    """Path of a Chromium binary, or None."""
    env = os.environ.get("KINSERVE_CHROMIUM")
    if env:
        return shutil.which(env) or (env if Path(env).is_file() else None)
    for name in CANDIDATES:
        found = shutil.which(name)
        if found:
            return found
    return None


def _run(args: list[str], timeout: float) -> subprocess.CompletedProcess:
    browser = find_browser()
    if browser is None:
        raise BrowserUnavailable("no Chromium found (tried $KINSERVE_CHROMIUM, " + ", ".join(CANDIDATES)
                                 + "); on Debian: apt-get install chromium")
    with tempfile.TemporaryDirectory(prefix="kinserve-chromium-") as profile:
        cmd = [browser, *FLAGS, f"--user-data-dir={profile}", *args]
        return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, stdin=subprocess.DEVNULL)


def _url(html_path) -> str:
    path = Path(html_path).resolve()
    if not path.is_file():
        raise FileNotFoundError(f"no such HTML file: {path}")
    return path.as_uri()


def screenshot(html_path, png_path, *, size=(800, 600), budget_ms: int = 4000, timeout: float = 120.0) -> Path:
    """Render ``html_path`` headless and write a ``size = (width, height)`` PNG at ``png_path``.

    ``budget_ms`` is the virtual time the page gets before the capture.
    """
    png = Path(png_path).resolve()
    png.parent.mkdir(parents=True, exist_ok=True)
    if png.exists():
        png.unlink()
    w, h = (int(v) for v in size)
    proc = _run([f"--window-size={w},{h}", f"--virtual-time-budget={int(budget_ms)}", f"--screenshot={png}", _url(html_path)], timeout)
    if not png.is_file() or png.stat().st_size == 0:
        tail = "\n".join(proc.stderr.strip().splitlines()[-8:])
        raise RuntimeError(f"chromium wrote no screenshot (exit {proc.returncode}):\n{tail}")
    return png


def dump_dom(html_path, *, budget_ms: int = 4000, timeout: float = 120.0) -> str:
    """The page's DOM after ``budget_ms`` of virtual time (Chromium's ``--dump-dom``)."""
    proc = _run([f"--virtual-time-budget={int(budget_ms)}", "--dump-dom", _url(html_path)], timeout)
    if proc.returncode != 0 or "<html" not in proc.stdout:
        tail = "\n".join(proc.stderr.strip().splitlines()[-8:])
        raise RuntimeError(f"chromium --dump-dom failed (exit {proc.returncode}):\n{tail}")
    return proc.stdout


def page_status(html_path, *, budget_ms: int = 4000, timeout: float = 120.0) -> dict[str, str]:
    """The ``data-*`` attributes of an exported page's ``<div id="kinserve-status">`` after loading.

    E.g. ``{"status": "ready", "errors": "0", "commands": "45", "animation-clips": "12", ...}``.
    """
    dom = dump_dom(html_path, budget_ms=budget_ms, timeout=timeout)
    m = re.search(r'<div id="kinserve-status"([^>]*)>', dom)
    if m is None:
        raise RuntimeError("the page has no kinserve-status element (not a viz.export_html file?)")
    return {k: v for k, v in re.findall(r'data-([\w-]+)="([^"]*)"', m.group(1))}
