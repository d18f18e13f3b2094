"""Request bodies bounded in size and time (service.limits), on a real server over loopback sockets.

No bound here depends on the machine's speed: "refused early" is "before the client could send the body",
a timeout is checked as "not before it" and "at all" (within GRACE seconds after it - only a missing
timeout takes that long), and /health's latency only has to stay far from a blocked event loop's.
"""

from __future__ import annotations

import json
import socket
import threading
import time

import httpx
import pytest

from kinserve import robots

from service_server import Server

BODY_TIMEOUT = 1.0
GRACE = 10.0  # s an answer may come after its timeout on a busy machine


@pytest.fixture(scope="module")
def server():
    srv = Server("--max-body", "64k", "--body-timeout", str(BODY_TIMEOUT), max_time_cap=0.2)
    yield srv
    srv.stop()


def rss_mb(pid: int) -> float:
    with open(f"/proc/{pid}/status") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    raise RuntimeError("no VmRSS")


def head(path: str, extra: str) -> bytes:
    return f"POST {path} HTTP/1.1\r\nHost: t\r\nContent-Type: application/json\r\n{extra}\r\n".encode()


def read_response(sock: socket.socket, timeout: float) -> tuple[int, bytes]:
    """Status code and everything the server sent until it closed the connection (or ``timeout``)."""
    sock.settimeout(timeout)
    data = b""
    try:
        while True:
            chunk = sock.recv(65536)
            if not chunk:
                break
            data += chunk
    except (socket.timeout, ConnectionResetError):
        pass
    return (int(data.split()[1]) if data else 0), data


def health_latencies(url: str, stop: threading.Event, out: list[float], ready: threading.Event) -> None:
    with httpx.Client(base_url=url, timeout=10) as c:
        c.get("/health")
        ready.set()
        while not stop.is_set():
            t0 = time.perf_counter()
            assert c.get("/health").status_code == 200
            out.append(time.perf_counter() - t0)
            time.sleep(0.01)


def test_50_mb_body_is_refused_early_without_memory_or_blocking_the_server(server):
    body = b"x" * (50 << 20)
    rss0 = rss_mb(server.proc.pid)
    stop, ready, lat = threading.Event(), threading.Event(), []
    sampler = threading.Thread(target=health_latencies, args=(server.url, stop, lat, ready))
    sampler.start()
    ready.wait(10)
    try:
        for framing in ("length", "chunked"):
            sock = socket.create_connection(("127.0.0.1", server.port))
            extra = (f"Content-Length: {len(body)}\r\n" if framing == "length"
                     else "Transfer-Encoding: chunked\r\n")
            sock.sendall(head("/ik", extra))
            sent_all = []

            def send_body():
                try:
                    if framing == "length":
                        sock.sendall(body)
                    else:
                        for i in range(0, len(body), 1 << 20):
                            sock.sendall(b"%x\r\n" % (1 << 20) + body[i:i + (1 << 20)] + b"\r\n")
                        sock.sendall(b"0\r\n\r\n")
                    sent_all.append(True)
                except OSError:
                    pass  # the server answered and closed: exactly what we want

            sender = threading.Thread(target=send_body)
            sender.start()
            status, data = read_response(sock, timeout=10)
            sender.join(30)
            sock.close()
            assert status == 413, data[:300]
            # early: the server closed before the body got through (it does not read 50 MB to refuse them)
            assert not sent_all, f"{framing}: the whole body was read before the 413"
            assert b"limit of 65536 bytes" in data
        time.sleep(0.2)  # /health keeps being sampled after the refusals
    finally:
        stop.set()
        sampler.join()
    assert rss_mb(server.proc.pid) - rss0 < 20, "the server buffered the oversized body"
    assert lat and max(lat) < 5.0, lat  # answered all along (a loop blocked on the body: the whole upload)
    assert server.alive()


def test_body_within_limit_is_served_and_limit_is_configurable(server):
    panda = robots.load("panda", geometry=False)
    q = panda.random_q(1).tolist()
    ok = json.dumps({"robot": "panda", "q": q}).encode()
    r = httpx.post(server.url + "/fk", content=ok, headers={"content-type": "application/json"}, timeout=10)
    assert r.status_code == 200, r.text
    padded = json.dumps({"robot": "panda", "q": q,
                         "frame": "panda_link8" + " " * 0}).encode() + b" " * (70 << 10)
    r = httpx.post(server.url + "/fk", content=padded,
                   headers={"content-type": "application/json"}, timeout=10)
    assert r.status_code == 413 and r.json()["detail"][0]["type"] == "body_too_large"


def test_body_shorter_than_its_content_length_gets_408_within_the_timeout(server):
    sock = socket.create_connection(("127.0.0.1", server.port))
    t0 = time.perf_counter()
    sock.sendall(head("/fk", "Content-Length: 1000\r\n") + b'{"robot": "panda", ')
    status, data = read_response(sock, timeout=BODY_TIMEOUT + GRACE)
    elapsed = time.perf_counter() - t0
    sock.close()
    assert status == 408, data[:300]
    assert BODY_TIMEOUT * 0.9 < elapsed
    assert data.endswith(b"}")  # a complete JSON error answer, then the server closed the connection
    assert b"did not arrive within" in data


def test_trickled_body_is_cut_at_the_timeout(server):
    """A client sending a byte at a time cannot hold a connection past the body timeout. (The announced
    length is within the 64 KiB limit: a larger one is refused at once with a 413, which is not this test.)"""
    sock = socket.create_connection(("127.0.0.1", server.port))
    sock.sendall(head("/fk", "Content-Length: 60000\r\n"))
    t0 = time.perf_counter()
    closed = False
    while time.perf_counter() - t0 < BODY_TIMEOUT + GRACE:
        try:
            sock.sendall(b" ")
        except OSError:
            closed = True
            break
        sock.settimeout(0.1)
        try:
            if sock.recv(4096).startswith(b"HTTP/1.1 408"):
                closed = True
                break
        except socket.timeout:
            pass
        except OSError:  # the server reset the connection after its 408: closed as well
            closed = True
            break
    sock.close()
    assert closed and BODY_TIMEOUT * 0.9 < time.perf_counter() - t0
