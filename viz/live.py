"""A live meshcat viewer: a local meshcat server showing a :class:`viz.Scene`.

``LiveViewer()`` starts meshcat's own server (``python -m
meshcat.servers.zmqserver``, the process ``meshcat.Visualizer()`` starts) as a
child process listening on 127.0.0.1, connects to it over ZeroMQ, and
:meth:`LiveViewer.show` sends it a scene's commands. The server keeps the scene
and pushes it to every browser that opens :attr:`LiveViewer.url` (and it
answers meshcat's ``get_scene`` request with the same static HTML that
meshcat would export). :meth:`LiveViewer.close` (or leaving a ``with`` block)
stops the server. :func:`serve` is the blocking loop behind ``kinserve view``.
"""

from __future__ import annotations

import contextlib
import io
import time

import meshcat
import meshcat.commands
import meshcat.path
import meshcat.visualizer

from kinserve.kinematics.errors import InputError

from .scene import ROOT, Scene


class LiveViewer:
    """A meshcat server (started here, or an existing one at ``zmq_url``) and a client to it.

    Attributes: ``url`` (the page to open in a browser), ``zmq_url``,
    ``visualizer`` (a ``meshcat.Visualizer`` talking to the server).
    """

    def __init__(self, zmq_url: str | None = None):
        self._proc = None
        if zmq_url is None:
            from meshcat.servers.zmqserver import start_zmq_server_as_subprocess  # imports tornado: only when serving

            self._proc, zmq_url, _ = start_zmq_server_as_subprocess()
        with contextlib.redirect_stdout(io.StringIO()):  # meshcat prints the URL itself; callers decide
            window = meshcat.visualizer.ViewerWindow(zmq_url=zmq_url, start_server=False, server_args=[])
        self.zmq_url = zmq_url
        self.url = window.web_url
        self.window = window
        self.visualizer = meshcat.Visualizer(window=window)

    def send(self, command: dict) -> None:
        """Send one lowered meshcat command (as in :meth:`Scene.commands`)."""
        self.window.send(_Lowered(command))

    def show(self, scene: Scene, clear: bool = True) -> int:
        """Send the whole scene (after deleting what the server showed, if ``clear``); returns the command count.

        The commands end with the scene's camera (:meth:`Scene.camera_commands`, framed by
        :func:`viz.camera.frame_points`): the live page opens on the view of the static export.
        """
        if not isinstance(scene, Scene):
            raise InputError(f"LiveViewer.show needs a viz.Scene, got {type(scene).__name__}")
        if clear:
            self.send({"type": "delete", "path": ROOT})
        commands = scene.commands()
        for cmd in commands:
            self.send(cmd)
        return len(commands)

    def static_html(self) -> str:
        """The server's own static export of what it currently shows (meshcat's ``get_scene``)."""
        return self.window.get_scene()

    def close(self) -> None:
        """Stop the server if this viewer started it."""
        try:
            self.window.zmq_socket.close(linger=0)
        except Exception:  # already closed
            pass
        if self._proc is not None and self._proc.poll() is None:
            self._proc.terminate()
            try:
                self._proc.wait(timeout=5)
            except Exception:
                self._proc.kill()
                self._proc.wait()
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


def serve(scene: Scene, *, zmq_url: str | None = None, announce=print, poll: float = 0.5, stop=None) -> str:
    """Show ``scene`` in a live viewer and keep serving until interrupted (Ctrl-C).

    ``announce`` receives one line with the URL to open. ``stop`` (a
    ``threading.Event`` or anything with ``is_set()``) ends the loop too, for
    embedding and tests. Returns the URL once the server has been stopped.
    """
    viewer = LiveViewer(zmq_url)
    try:
        viewer.show(scene)
        announce(f"meshcat viewer: {viewer.url}  (Ctrl-C to stop)")
        while stop is None or not stop.is_set():
            if zmq_url is None and not viewer.running:
                raise RuntimeError("the meshcat server process exited")
            time.sleep(poll)
    except KeyboardInterrupt:
        pass
    finally:
        viewer.close()
    return viewer.url
