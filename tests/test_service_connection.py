"""Idle, slow and surplus connections are closed (service.connection), on a real server over raw sockets.

No bound here depends on the machine's speed: a timeout is checked as "not before it" (the server cannot
close early because the machine is slow) and "at all" (within GRACE seconds after it - only a missing
timeout takes that long); requests meant to keep a connection alive are spaced at a quarter of the
keep-alive time; the header timeout (3 s) leaves room to tell a cap's immediate close from its own.
"""

from __future__ import annotations

import socket
import time

import httpx
import pytest

from service_server import Server

HEADER_TIMEOUT = 3.0
KEEP_ALIVE = 2.0
MAX_CONNECTIONS = 8
GRACE = 10.0  # s a close may come after its timeout on a busy machine


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
    dt = closed_after(sock, HEADER_TIMEOUT + GRACE)
    sock.close()
    assert dt is not None and 0.8 * HEADER_TIMEOUT < dt


def test_headers_trickled_slowly_are_cut_at_the_header_timeout(server):
    sock = connect(server)
    t0 = time.perf_counter()
    sock.sendall(b"GET /health HTTP/1.1\r\n")
    closed = False
    while time.perf_counter() - t0 < HEADER_TIMEOUT + GRACE:
        time.sleep(0.1)
        try:
            sock.sendall(b"X-Slow: 1\r\n")
        except OSError:
            closed = True
            break
    dt = time.perf_counter() - t0
    sock.close()
    assert closed and 0.8 * HEADER_TIMEOUT < dt  # each header line arrived within 0.1 s: not a reprieve


def test_an_idle_keep_alive_connection_is_closed_and_a_busy_one_is_not(server):
    sock = connect(server)
    # requests spaced well below the keep-alive timeout reuse the connection, longer than one timeout in all
    for i in range(5):
        if i:
            time.sleep(0.25 * KEEP_ALIVE)
        sock.sendall(b"GET /health HTTP/1.1\r\nHost: t\r\n\r\n")
        assert one_response(sock).startswith(b"HTTP/1.1 200")
    dt = closed_after(sock, KEEP_ALIVE + GRACE)  # counted from the last response
    sock.close()
    assert dt is not None and 0.8 * KEEP_ALIVE < dt


def test_connections_beyond_the_cap_are_closed_at_once_and_the_server_recovers(server):
    held = [connect(server) for _ in range(MAX_CONNECTIONS)]
    try:
        time.sleep(0.2)
        extra = connect(server)
        dt = closed_after(extra, 0.8 * HEADER_TIMEOUT)  # closed before a header timeout could have
        extra.close()
        assert dt is not None, "a connection beyond the cap was kept open"
    finally:
        for s in held:
            s.close()
    time.sleep(0.2)
    assert httpx.get(server.url + "/health", timeout=5).status_code == 200
    assert server.alive()
