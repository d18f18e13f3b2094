"""Idle, slow and surplus connections are closed (service.connection), on a real server over raw sockets."""

from __future__ import annotations

import socket
import time

import httpx
import pytest

from service_server import Server

HEADER_TIMEOUT = 1.0
KEEP_ALIVE = 1.0
MAX_CONNECTIONS = 8


@pytest.fixture(scope="module")
def server():
    srv = Server("--header-timeout", str(HEADER_TIMEOUT), "--keep-alive", str(KEEP_ALIVE),
                 "--max-connections", str(MAX_CONNECTIONS))
    yield srv
    srv.stop()


def closed_after(sock: socket.socket, limit: float) -> float | None:
    """Seconds until the server closes ``sock`` (reading and discarding), None if still open after
    ``limit``."""
    t0 = time.perf_counter()
    sock.settimeout(0.05)
    while time.perf_counter() - t0 < limit:
        try:
            if sock.recv(65536) == b"":
                return time.perf_counter() - t0
        except socket.timeout:
            continue
        except ConnectionResetError:
            return time.perf_counter() - t0
    return None


def one_response(sock: socket.socket) -> bytes:
    """Read exactly one HTTP response (headers + Content-Length body) from ``sock``."""
    sock.settimeout(5)
    data = b""
    while b"\r\n\r\n" not in data:
        data += sock.recv(65536)
    headers, _, body = data.partition(b"\r\n\r\n")
    length = int(next(v for k, _, v in (ln.partition(b":") for ln in headers.split(b"\r\n")[1:])
                      if k.lower() == b"content-length"))
    while len(body) < length:
        body += sock.recv(65536)
    return headers + b"\r\n\r\n" + body


def connect(server) -> socket.socket:
    return socket.create_connection(("127.0.0.1", server.port))


def test_a_silent_new_connection_is_closed_after_the_header_timeout(server):
    sock = connect(server)
    dt = closed_after(sock, 5 * HEADER_TIMEOUT)
    sock.close()
    assert dt is not None and 0.8 * HEADER_TIMEOUT < dt < 1.5 * HEADER_TIMEOUT + 0.3


def test_headers_trickled_slowly_are_cut_at_the_header_timeout(server):
    sock = connect(server)
    t0 = time.perf_counter()
    sock.sendall(b"GET /health HTTP/1.1\r\n")
    closed = False
    while time.perf_counter() - t0 < 5 * HEADER_TIMEOUT:
        time.sleep(0.1)
        try:
            sock.sendall(b"X-Slow: 1\r\n")
        except OSError:
            closed = True
            break
    dt = time.perf_counter() - t0
    sock.close()
    assert closed and dt < 1.5 * HEADER_TIMEOUT + 0.5


def test_an_idle_keep_alive_connection_is_closed_and_a_busy_one_is_not(server):
    sock = connect(server)
    for _ in range(3):  # requests spaced below the keep-alive timeout reuse the connection
        sock.sendall(b"GET /health HTTP/1.1\r\nHost: t\r\n\r\n")
        assert one_response(sock).startswith(b"HTTP/1.1 200")
        time.sleep(0.5 * KEEP_ALIVE)
    dt = closed_after(sock, 5 * KEEP_ALIVE)
    sock.close()
    assert dt is not None and dt < 1.5 * KEEP_ALIVE + 0.3


def test_connections_beyond_the_cap_are_closed_at_once_and_the_server_recovers(server):
    held = [connect(server) for _ in range(MAX_CONNECTIONS)]
    try:
        time.sleep(0.2)
        extra = connect(server)
        dt = closed_after(extra, 0.8 * HEADER_TIMEOUT)
        extra.close()
        assert dt is not None and dt < 0.5, "a connection beyond the cap was kept open"
    finally:
        for s in held:
            s.close()
    time.sleep(0.2)
    assert httpx.get(server.url + "/health", timeout=5).status_code == 200
    assert server.alive()
