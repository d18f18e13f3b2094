"""A live meshcat viewer: a local meshcat server showing a :class:`kinserve.viz.Scene`.

``LiveViewer()`` starts meshcat's own server (the ``ZMQWebSocketBridge`` of
``meshcat.servers.zmqserver``, which ``meshcat.Visualizer()`` starts) as a
child process, connects to it over ZeroMQ, and
:meth:`LiveViewer.show` sends it a scene's commands. The server keeps the scene
and pushes it to every browser that opens :attr:`LiveViewer.url` (and it
answers meshcat's ``get_scene`` request with the same static HTML that
meshcat would export). :meth:`LiveViewer.close` (or leaving a ``with`` block)
stops the server. :func:`serve` is the blocking loop behind ``kinserve view``.

Where it listens: the web server (page and websocket) on ``host``, by default
127.0.0.1 (this machine only; meshcat's own ``python -m
meshcat.servers.zmqserver`` listens on every interface while it prints
127.0.0.1), the first free port from 7000; ZeroMQ, which takes drawing commands
from any client, always on 127.0.0.1 from port 6000. ``host="0.0.0.0"`` (or
another address of this machine) shows the scene to other machines:
:func:`serve` says where it listens.

No server outlives its viewer: :func:`start_meshcat_server` registers an
``atexit`` stop as soon as the process exists (normal exit, ``sys.exit``, an
exception), :func:`serve` turns SIGTERM and SIGHUP into a normal exit
(``SystemExit(128 + signal)``) so that clean-up runs, SIGINT (Ctrl-C) ends the
loop, and on Linux a server started from the main thread also gets SIGTERM
from the kernel if its parent dies without clean-up (``PR_SET_PDEATHSIG``,
e.g. after SIGKILL).
"""

from __future__ import annotations

import atexit
import contextlib
import ctypes
import io
import os
import re
import select
import signal
import socket
import subprocess
import sys
import threading
import time
import urllib.parse

import meshcat
import meshcat.commands
import meshcat.path
import meshcat.visualizer

from kinserve.kinematics.errors import InputError
from kinserve.kinematics.validation import as_flag

from .scene import ROOT, Scene

#: Linux prctl option: the signal the kernel sends a child when the thread that started it dies.
_PR_SET_PDEATHSIG = 1


def _die_with_parent() -> None:  # runs in the child between fork and exec
    with contextlib.suppress(Exception):
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)


def stop_process(proc: subprocess.Popen, timeout: float = 5.0) -> None:
    """SIGTERM ``proc``, wait up to ``timeout`` s, then SIGKILL; reaps it either way."""
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    for stream in (proc.stdout, proc.stderr):
        if stream is not None:
            stream.close()


#: meshcat servers started by this process and not stopped yet; stopped at interpreter exit at the latest.
_SERVERS: set[subprocess.Popen] = set()


@atexit.register
def _stop_all_servers() -> None:
    for proc in list(_SERVERS):
        stop_process(proc)
        _SERVERS.discard(proc)


#: The address the web server listens on unless told otherwise: this machine only.
DEFAULT_HOST = "127.0.0.1"

#: Addresses that mean "every interface".
_WILDCARDS = ("0.0.0.0", "::")

#: The server process: meshcat's bridge, its web server bound to ``argv[1]`` (meshcat's own binds every
#: interface), ZeroMQ on meshcat's default host 127.0.0.1; the page's URL is ``argv[2]`` with the port.
_SERVER_SCRIPT = """
import errno, sys
from meshcat.servers.zmqserver import ZMQWebSocketBridge

HOST, URL = sys.argv[1], sys.argv[2]


class Bridge(ZMQWebSocketBridge):
    def make_app(self):
        app = super().make_app()
        listen = app.listen

        def listen_on_host(port, **kwargs):
            try:
                return listen(port, address=HOST, **kwargs)
            except OSError as exc:
                if exc.errno == errno.EADDRINUSE:
                    raise  # meshcat tries the next port
                print("error=" + str(exc.strerror or exc), flush=True)
                sys.exit(2)

        app.listen = listen_on_host
        return app


bridge = Bridge()
bridge.web_url = URL.format(port=bridge.fileserver_port)
print("zmq_url=" + bridge.zmq_url, flush=True)
print("web_url=" + bridge.web_url, flush=True)
try:
    bridge.run()
except KeyboardInterrupt:
    pass
"""


def check_host(host) -> str:
    """``host`` if it names an address of some machine (a numeric address or a name that resolves), else
    :class:`InputError` naming it."""
    if not isinstance(host, str) or not host.strip():
        raise InputError(f"host must be an address to listen on (e.g. 127.0.0.1 or 0.0.0.0), got {host!r}")
    try:
        socket.getaddrinfo(host, None, type=socket.SOCK_STREAM)
    except (OSError, UnicodeError) as exc:
        raise InputError(f"host {host!r} is not an address to listen on ({exc})") from None
    return host


def host_port(host: str, port: int) -> str:
    """``host:port``, an IPv6 address in brackets (``[::1]:7000``)."""
    return f"[{host}]:{port}" if ":" in host else f"{host}:{port}"


def _page_url(host: str) -> str:
    """The page's URL template (``{port}`` left open): on ``host``, or on 127.0.0.1 for a wildcard address."""
    shown = DEFAULT_HOST if host in _WILDCARDS else host
    shown = f"[{shown}]" if ":" in shown else shown
    return f"http://{shown}:{{port}}/static/"


def start_meshcat_server(timeout: float = 60.0,
                         host: str = DEFAULT_HOST) -> tuple[subprocess.Popen, str, str]:
    """Start a meshcat server whose web server listens on ``host``: ``(process, zmq_url, web_url)``.

    What ``meshcat.servers.zmqserver.start_zmq_server_as_subprocess`` does, but
    the page listens on ``host`` only (meshcat's listens on every interface),
    ZeroMQ on 127.0.0.1, plus: the server is stopped at interpreter exit unless
    stopped before, the server gets its parent's death signal (Linux, main
    thread only: the kernel ties it to the starting *thread*), and stderr is
    not kept in an unread pipe. The server runs in its own session, so a
    Ctrl-C in the terminal reaches the viewer, which then stops the server in
    order. :class:`InputError` when ``host`` is no address of this machine.
    """
    host = check_host(host)
    in_main_thread = threading.current_thread() is threading.main_thread()
    proc = subprocess.Popen(
        [sys.executable, "-u", "-c", _SERVER_SCRIPT, host, _page_url(host)], stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL, start_new_session=True,
        preexec_fn=_die_with_parent if in_main_thread and sys.platform.startswith("linux") else None,
    )
    _SERVERS.add(proc)
    try:
        urls = _read_urls(proc, timeout)
    except BaseException:
        stop_process(proc)
        _SERVERS.discard(proc)
        raise
    if "error" in urls:
        raise InputError(f"host {host!r}: the meshcat server cannot listen there ({urls['error']})")
    return proc, urls["zmq_url"], urls["web_url"]


def _read_urls(proc: subprocess.Popen, timeout: float) -> dict[str, str]:
    """The ``key=value`` lines the server prints on start (``zmq_url``, ``web_url``; or ``error``, after
    which the server process is stopped)."""
    urls: dict[str, str] = {}
    deadline = time.monotonic() + timeout
    fd, pending = proc.stdout.fileno(), b""
    while len(urls) < 2 and "error" not in urls:
        left = deadline - time.monotonic()
        ready = select.select([fd], [], [], max(left, 0.0))[0] if left > 0 else []
        chunk = os.read(fd, 4096) if ready else None
        if chunk is None:
            raise RuntimeError(f"the meshcat server did not report its URLs within {timeout:.0f} s")
        if chunk == b"":
            proc.wait()
            raise RuntimeError(f"the meshcat server exited on start with code {proc.returncode}")
        pending += chunk
        *lines, pending = pending.split(b"\n")
        for line in lines:
            m = re.match(r"^(zmq_url|web_url|error)=(.+)$", line.decode("utf-8", "replace").strip())
            if m:
                urls[m.group(1)] = m.group(2)
    if "error" in urls:
        stop_process(proc)
        _SERVERS.discard(proc)
    return urls


class _Window(meshcat.visualizer.ViewerWindow):
    """meshcat's ``ViewerWindow`` that closes its previous ZeroMQ socket when it reconnects.

    ``ViewerWindow.__init__`` connects twice (it asks for the URL, then
    reconnects) and leaves the first socket to the garbage collector, which
    reports it as a ``ResourceWarning``.
    """

    def connect_zmq(self) -> None:
        previous = getattr(self, "zmq_socket", None)
        super().connect_zmq()
        if previous is not None:
            previous.close(linger=0)


class LiveViewer:
    """A meshcat server (started here, or an existing one at ``zmq_url``) and a client to it.

    A server started here listens on ``host`` (default 127.0.0.1, this machine
    only; ``"0.0.0.0"``: every interface), see the module docstring. Attributes:
    ``url`` (the page to open in a browser), ``zmq_url``, ``visualizer`` (a
    ``meshcat.Visualizer`` talking to the server), ``bind`` (``host:port`` the
    page is served on; None when joining an existing server).
    """

    def __init__(self, zmq_url: str | None = None, *, host: str | None = None) -> None:
        self._proc: subprocess.Popen | None = None
        self.bind: str | None = None
        if zmq_url is not None and host is not None:
            raise InputError(f"host={host!r} applies to a server started here; the server at {zmq_url} "
                             "listens where it was started")
        if zmq_url is None:
            host = DEFAULT_HOST if host is None else host
            self._proc, zmq_url, web_url = start_meshcat_server(host=host)
            self.bind = host_port(host, urllib.parse.urlsplit(web_url).port)
        try:
            with contextlib.redirect_stdout(io.StringIO()):  # meshcat prints the URL itself; callers decide
                window = _Window(zmq_url=zmq_url, start_server=False, server_args=[])
        except BaseException:
            self.close()
            raise
        self.zmq_url = zmq_url
        self.url = window.web_url
        self.window = window
        self.visualizer = meshcat.Visualizer(window=window)

    def send(self, command: dict) -> None:
        """Send one lowered meshcat command (as in :meth:`Scene.commands`)."""
        self.window.send(_Lowered(command))

    def show(self, scene: Scene, clear: bool = True) -> int:
        """Send the whole scene (after deleting what the server showed, if ``clear``); returns the command
        count.

        The commands end with the scene's camera (:meth:`Scene.camera_commands`, framed by
        :func:`viz.camera.frame_points`): the live page opens on the view of the static export.
        """
        if not isinstance(scene, Scene):
            raise InputError(f"LiveViewer.show needs a viz.Scene, got {type(scene).__name__}")
        if as_flag(clear, "clear"):
            self.send({"type": "delete", "path": ROOT})
        commands = scene.commands()
        for cmd in commands:
            self.send(cmd)
        return len(commands)

    def static_html(self) -> str:
        """The server's own static export of what it currently shows (meshcat's ``get_scene``)."""
        return self.window.get_scene()

    @property
    def server_pid(self) -> int | None:
        """Process id of the meshcat server this viewer started (None when it joined an existing one)."""
        return None if self._proc is None else self._proc.pid

    def close(self) -> None:
        """Stop the server if this viewer started it (SIGTERM, then SIGKILL after 5 s)."""
        with contextlib.suppress(Exception):  # not connected yet, or already closed
            self.window.zmq_socket.close(linger=0)
        if self._proc is not None:
            stop_process(self._proc)
            _SERVERS.discard(self._proc)
        self._proc = None

    @property
    def running(self) -> bool:
        """True while the server process started by this viewer is alive."""
        return self._proc is not None and self._proc.poll() is None

    def __enter__(self) -> "LiveViewer":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class _Lowered:
    """Adapter: an already lowered command for ``ViewerWindow.send`` (which calls ``lower()``)."""

    __slots__ = ("cmd",)

    def __init__(self, cmd: dict):
        self.cmd = cmd

    def lower(self) -> dict:
        return self.cmd


def _where(viewer: LiveViewer) -> str:
    """The announce line's note on the server: where it listens and its pid (empty when joined)."""
    if viewer.server_pid is None:
        return ""
    host = viewer.bind.rsplit(":", 1)[0].strip("[]")
    reach = " - every interface: other machines can open it" if host in _WILDCARDS else ""
    return f"meshcat server pid {viewer.server_pid}; listening on {viewer.bind}{reach}; "


@contextlib.contextmanager
def exit_on_termination(signals: tuple[int, ...] = (signal.SIGTERM, signal.SIGHUP)):
    """Inside the block, ``signals`` raise ``SystemExit(128 + signal)`` so ``finally`` and ``atexit`` clean-up
    runs, and SIGINT raises ``KeyboardInterrupt`` (also when the process inherited it ignored).

    By default SIGTERM and SIGHUP end Python at once, skipping both. Only the
    main thread can handle signals; elsewhere the block changes nothing. The
    previous handlers are restored on leaving.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def _exit(signum, frame):
        raise SystemExit(128 + signum)

    previous = {sig: signal.signal(sig, _exit) for sig in signals}
    # Ctrl-C stops the viewer even when the process was started with SIGINT ignored (a background job of a
    # non-interactive shell inherits SIG_IGN, and Python then installs no KeyboardInterrupt handler)
    previous[signal.SIGINT] = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def serve(scene: Scene, *, zmq_url: str | None = None, host: str | None = None, announce=print,
          poll: float = 0.5, stop=None) -> str:
    """Show ``scene`` in a live viewer and keep serving until interrupted (Ctrl-C, SIGTERM, SIGHUP).

    ``host``: the address the page is served on (default 127.0.0.1; see :class:`LiveViewer`).
    ``announce`` receives one line with the URL to open and, for a server
    started here, where it listens (``host:port``, with a warning for every
    interface) and its pid. ``stop`` (a ``threading.Event`` or anything
    with ``is_set()``) ends the loop too, for embedding and tests. Returns the
    URL once the server has been stopped. Ctrl-C returns normally; SIGTERM and
    SIGHUP stop the server and then raise ``SystemExit(128 + signal)``.
    """
    with exit_on_termination():
        viewer = LiveViewer(zmq_url, host=host)
        try:
            viewer.show(scene)
            announce(f"meshcat viewer: {viewer.url}  ({_where(viewer)}Ctrl-C to stop)")
            while stop is None or not stop.is_set():
                if zmq_url is None and not viewer.running:
                    raise RuntimeError("the meshcat server process exited")
                time.sleep(poll)
        except KeyboardInterrupt:
            pass
        finally:
            viewer.close()
    return viewer.url
