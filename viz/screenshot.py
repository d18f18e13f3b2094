"""Headless Chromium: screenshots of exported scenes and their load status.

Needs a Chromium binary (Debian's ``chromium`` package; ``chromium-browser``
or ``google-chrome`` also work, or set ``KINSERVE_CHROMIUM``). WebGL is
rendered in software by SwiftShader (``--use-angle=swiftshader
--enable-unsafe-swiftshader``), so neither a GPU nor a display is needed,
and the network stays off (``file://`` page, no background services).

The browser is driven over the DevTools protocol on a pipe
(``--remote-debugging-pipe``: JSON messages ending in a NUL byte, written to
file descriptor 3 and read from 4) rather than with ``--screenshot`` and a
virtual-time budget, which stalls now and then on a busy machine. The page
is loaded, the exported page's status element is polled until it says
``ready`` (the scene replayed, see :mod:`viz.export`), two animation frames are
awaited so the WebGL canvas holds the scene, and the capture is taken.
Uncaught exceptions and console errors are collected on the way.
"""

from __future__ import annotations

import base64
import contextlib
import json
import os
import select
import shutil
import signal
import subprocess
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

from kinserve.kinematics.errors import InputError, KinserveError
from kinserve.kinematics.validation import as_count, as_flag, as_nonnegative, as_positive, describe

#: Largest page width or height, in pixels.
MAX_PIXELS = 8192
#: Longest ``timeout`` or ``settle_ms`` wait, in seconds.
MAX_SECONDS = 3600.0

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

_STATUS_JS = """(() => {
  const el = document.getElementById("kinserve-status");
  if (!el) return null;
  const out = {};
  for (const a of el.attributes) if (a.name.startsWith("data-")) out[a.name.slice(5)] = a.value;
  return out;
})()"""

_TWO_FRAMES_JS = "new Promise(r => requestAnimationFrame(() => requestAnimationFrame(() => r(true))))"


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


@dataclass
class PageResult:
    """What :func:`render` saw: the status attributes, errors, and the PNG bytes (if captured)."""

    status: dict[str, str] | None
    errors: list[str] = field(default_factory=list)
    png: bytes | None = None


class _DevTools:
    """A Chromium process and a DevTools-protocol session with its page, over a pipe."""

    def __init__(self, browser: str, size: tuple[int, int], timeout: float,
                 extra_flags: tuple[str, ...] = ()):
        self.deadline = time.monotonic() + timeout
        self._profile = tempfile.TemporaryDirectory(prefix="kinserve-chromium-")
        to_browser_r, self._to_browser = os.pipe()
        self._from_browser, from_browser_w = os.pipe()
        w, h = size
        cmd = [browser, *FLAGS, *extra_flags, f"--user-data-dir={self._profile.name}",
               f"--window-size={w},{h}", "--remote-debugging-pipe", "about:blank"]
        # the browser reads commands on fd 3 and writes replies on fd 4: hand it our pipe ends
        # as stdin/stdout of a shell that moves them there before exec'ing Chromium
        shell = 'exec "$@" 3<&0 4>&1 </dev/null >/dev/null'
        self.proc = subprocess.Popen(["/bin/sh", "-c", shell, "sh", *cmd], stdin=to_browser_r,
                                     stdout=from_browser_w, stderr=subprocess.DEVNULL, start_new_session=True)
        os.close(to_browser_r)
        os.close(from_browser_w)
        self._buf = b""
        self._id = 0
        self.events: list[dict] = []
        self.session = None

    def _remaining(self) -> float:
        left = self.deadline - time.monotonic()
        if left <= 0:
            raise TimeoutError("chromium did not answer in time")
        return left

    def _read_message(self) -> dict:
        while b"\0" not in self._buf:
            ready, _, _ = select.select([self._from_browser], [], [], self._remaining())
            if not ready:
                continue
            chunk = os.read(self._from_browser, 1 << 20)
            if not chunk:
                raise RuntimeError(f"chromium closed the DevTools pipe (exit code {self.proc.poll()})")
            self._buf += chunk
        raw, self._buf = self._buf.split(b"\0", 1)
        return json.loads(raw)

    def call(self, method: str, params: dict | None = None, session: bool = True) -> dict:
        self._id += 1
        msg = {"id": self._id, "method": method, "params": params or {}}
        if session and self.session:
            msg["sessionId"] = self.session
        os.write(self._to_browser, json.dumps(msg).encode() + b"\0")
        while True:
            reply = self._read_message()
            if reply.get("id") == self._id:
                if "error" in reply:
                    raise RuntimeError(f"DevTools {method} failed: {reply['error']}")
                return reply.get("result", {})
            self.events.append(reply)

    def attach_page(self) -> None:
        targets = self.call("Target.getTargets", session=False)["targetInfos"]
        page = next((t for t in targets if t["type"] == "page"), None)
        if page is None:
            page = {"targetId": self.call("Target.createTarget", {"url": "about:blank"},
                                          session=False)["targetId"]}
        self.session = self.call("Target.attachToTarget", {"targetId": page["targetId"], "flatten": True},
                                 session=False)["sessionId"]

    def evaluate(self, expression: str, await_promise: bool = False):
        res = self.call("Runtime.evaluate",
                        {"expression": expression, "returnByValue": True, "awaitPromise": await_promise})
        if "exceptionDetails" in res:
            raise RuntimeError(f"page script failed: {res['exceptionDetails'].get('text')}")
        return res["result"].get("value")

    def errors(self) -> list[str]:
        out = []
        for ev in self.events:
            method, p = ev.get("method"), ev.get("params", {})
            if method == "Runtime.exceptionThrown":
                d = p.get("exceptionDetails", {})
                out.append(str(d.get("exception", {}).get("description") or d.get("text")))
            elif method == "Runtime.consoleAPICalled" and p.get("type") == "error":
                out.append(" ".join(str(a.get("value", a.get("description", ""))) for a in p.get("args", [])))
            elif method == "Log.entryAdded" and p.get("entry", {}).get("level") == "error":
                out.append(str(p["entry"].get("text")))
        return out

    def close(self) -> None:
        with contextlib.suppress(Exception):
            os.write(self._to_browser, json.dumps({"id": 0, "method": "Browser.close"}).encode() + b"\0")
        with contextlib.suppress(Exception):
            self.proc.wait(timeout=5)
        with contextlib.suppress(ProcessLookupError):  # the whole group: renderer, GPU, zygote
            os.killpg(self.proc.pid, signal.SIGKILL)
        with contextlib.suppress(Exception):
            self.proc.wait(timeout=5)
        for fd in (self._to_browser, self._from_browser):
            with contextlib.suppress(OSError):
                os.close(fd)
        self._profile.cleanup()


def _page_size(size: object) -> tuple[int, int]:
    """``size`` as ``(width, height)`` in pixels, each an integer from 16 to :data:`MAX_PIXELS`."""
    if isinstance(size, (str, bytes)) or not hasattr(size, "__len__") or len(size) != 2:
        raise InputError(f"size must be (width, height) in pixels, got {describe(size)}")
    return (as_count(size[0], "size width", minimum=16, maximum=MAX_PIXELS),
            as_count(size[1], "size height", minimum=16, maximum=MAX_PIXELS))


def render(html_path, *, size=(800, 600), capture: bool = True, play: bool = False, settle_ms: int = 0,
           timeout: float = 60.0) -> PageResult:
    """Open an exported page headless, wait until its scene is replayed, and optionally capture it.

    ``play=False`` opens ``page.html#paused`` (the animation is loaded, not
    played: the first frame). ``settle_ms`` waits that long (real time) after
    the scene is ready, e.g. to let an animation run. ``size`` is
    ``(width, height)`` in pixels (16 to :data:`MAX_PIXELS`), ``timeout`` in
    seconds (at most :data:`MAX_SECONDS`). Raises :class:`InputError` for a
    bad argument, :class:`BrowserUnavailable` without Chromium,
    ``TimeoutError`` when the page is not ready within ``timeout`` seconds.
    """
    (w, h), capture, play = _page_size(size), as_flag(capture, "capture"), as_flag(play, "play")
    settle_ms = as_nonnegative(settle_ms, "settle_ms", maximum=MAX_SECONDS * 1000.0)
    timeout = as_positive(timeout, "timeout", maximum=MAX_SECONDS)
    browser = find_browser()
    if browser is None:
        raise BrowserUnavailable("no Chromium found (tried $KINSERVE_CHROMIUM, " + ", ".join(CANDIDATES)
                                 + "); on Debian: apt-get install chromium")
    path = Path(html_path).resolve()
    if not path.is_file():
        raise FileNotFoundError(f"no such HTML file: {path}")
    url = path.as_uri() + ("" if play else "#paused")
    dt = _DevTools(browser, (w, h), timeout)
    try:
        dt.attach_page()
        dt.call("Emulation.setDeviceMetricsOverride",
                {"width": w, "height": h, "deviceScaleFactor": 1, "mobile": False})
        for domain in ("Page", "Runtime", "Log"):
            dt.call(f"{domain}.enable")
        dt.call("Page.navigate", {"url": url})
        status = None
        while True:
            with contextlib.suppress(RuntimeError):  # the document may be replaced while navigating
                status = dt.evaluate(_STATUS_JS)
            if status and status.get("status") in ("ready", "error"):
                break
            dt._remaining()
            time.sleep(0.05)
        if settle_ms:
            time.sleep(settle_ms / 1000.0)
        dt.evaluate(_TWO_FRAMES_JS, await_promise=True)
        status = dt.evaluate(_STATUS_JS)
        png = (base64.b64decode(dt.call("Page.captureScreenshot", {"format": "png"})["data"])
               if capture else None)
        return PageResult(status=status, errors=dt.errors(), png=png)
    finally:
        dt.close()


def screenshot(html_path, png_path, *, size=(800, 600), play: bool = False, settle_ms: int = 0,
               timeout: float = 60.0) -> Path:
    """Write a ``size = (width, height)`` PNG of an exported page at ``png_path``; returns the path.

    By default the animation is paused on its first frame (a deterministic
    picture); ``play=True, settle_ms=...`` captures it mid-motion.
    """
    result = render(html_path, size=size, play=play, settle_ms=settle_ms, timeout=timeout)
    if result.status is None or result.status.get("status") != "ready":
        raise RuntimeError(f"the page did not load its scene: status {result.status}, errors {result.errors}")
    png = Path(png_path)
    png.parent.mkdir(parents=True, exist_ok=True)
    png.write_bytes(result.png)
    return png


def page_status(html_path, *, play: bool = False, timeout: float = 60.0) -> dict[str, str]:
    """The ``data-*`` attributes of an exported page's status element once loaded, plus
    ``console-errors``: the number of uncaught exceptions and console errors seen.

    E.g. ``{"status": "ready", "errors": "0", "commands": "45", "animation-clips": "12",
    "animation-playing": "true", "console-errors": "0", ...}``.
    """
    result = render(html_path, capture=False, play=play, timeout=timeout)
    if result.status is None:
        raise RuntimeError("the page has no kinserve-status element (not a viz.export_html file?)")
    status = dict(result.status)
    status["console-errors"] = str(len(result.errors))
    if result.errors:
        status["console-error"] = result.errors[0]
    return status
