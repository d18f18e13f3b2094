"""Start a real ``kinserve serve`` process on a free loopback port, for the service tests."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parents[1]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Server:
    """``kinserve serve`` in a subprocess; ``url`` is its base address."""

    def __init__(self, *extra: str, max_time_cap: float = 1.0):
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        cmd = [sys.executable, "-m", "kinserve.service.cli", "serve", "--port", str(self.port), "--log-level",
               "warning", "--max-time-cap", str(max_time_cap), *extra]
        env = dict(os.environ)
        self.proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, text=True)
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise RuntimeError(f"server exited early:\n{self.proc.stdout.read()}")
            try:
                if httpx.get(self.url + "/health", timeout=1).status_code == 200:
                    return
            except httpx.HTTPError:
                time.sleep(0.2)
        self.stop()
        raise RuntimeError("server did not become healthy within 60 s")

    def alive(self) -> bool:
        return self.proc.poll() is None

    def stop(self) -> str:
        self.proc.terminate()
        try:
            out, _ = self.proc.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            out, _ = self.proc.communicate()
        return out or ""


def running(*extra: str, max_time_cap: float = 1.0):
    """A module fixture's body: yield a :class:`Server` started with ``extra`` options; stop it after."""
    srv = Server(*extra, max_time_cap=max_time_cap)
    try:
        yield srv
    finally:
        srv.stop()


def client_of(server: "Server", timeout: float = 120.0):
    """A module fixture's body: yield an ``httpx.Client`` on ``server`` (closed after)."""
    with httpx.Client(base_url=server.url, timeout=timeout) as c:
        yield c


class KeepAliveClient:
    """One raw HTTP/1.1 keep-alive connection: cheap enough on the client side to time the server.

    (An ``httpx`` client costs milliseconds of CPU to create; with dozens of them in one process the
    client, not the server, would dominate the measured latencies.)
    """

    def __init__(self, port: int, timeout: float = 60):
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=timeout)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.buf = b""

    def request(self, method: str, path: str, body: bytes = b"") -> tuple[int, dict, bytes]:
        """``(status, headers, body)`` of one request on this connection."""
        head = f"{method} {path} HTTP/1.1\r\nHost: test\r\n"
        if body:
            head += f"Content-Type: application/json\r\nContent-Length: {len(body)}\r\n"
        self.sock.sendall(head.encode() + b"\r\n" + body)
        while b"\r\n\r\n" not in self.buf:
            self._more()
        header, _, self.buf = self.buf.partition(b"\r\n\r\n")
        lines = header.decode("latin-1").split("\r\n")
        headers = {k.strip().lower(): v.strip() for k, _, v in (ln.partition(":") for ln in lines[1:])}
        length = int(headers.get("content-length", 0))
        while len(self.buf) < length:
            self._more()
        out, self.buf = self.buf[:length], self.buf[length:]
        return int(lines[0].split()[1]), headers, out

    def _more(self) -> None:
        chunk = self.sock.recv(65536)
        if not chunk:
            raise ConnectionError("server closed the connection")
        self.buf += chunk

    def close(self) -> None:
        self.sock.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
