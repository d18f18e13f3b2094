"""`kinserve serve --workers N`: the shared listener keeps TCP_NODELAY (uvicorn #3149) and workers answer."""

import asyncio
import socket

import httpx
import numpy as np
import uvicorn

from kinserve import robots
from kinserve.service.cli_serve import tcp_listener

from service_server import Server


def test_listener_reports_tcp_so_accepted_connections_get_nodelay():
    config = uvicorn.Config("kinserve.service.app:app", host="127.0.0.1", port=0, log_level="critical")
    # (uvicorn before its fix of #3149 bound proto 0, and asyncio then skipped TCP_NODELAY; newer uvicorn
    # releases bind proto 6 themselves, so only kinserve's own listener is asserted)
    sock = tcp_listener(config)
    assert sock.proto == socket.IPPROTO_TCP
    port = sock.getsockname()[1]
    seen = {}

    class Probe(asyncio.Protocol):
        def connection_made(self, transport):
            s = transport.get_extra_info("socket")
            seen["nodelay"] = s.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY)
            transport.close()

    async def main():
        server = await asyncio.get_running_loop().create_server(Probe, sock=sock)
        reader, writer = await asyncio.open_connection("127.0.0.1", port)
        await reader.read()
        writer.close()
        server.close()

    asyncio.run(main())
    assert seen["nodelay"] == 1


def test_two_worker_server_answers_fk():
    srv = Server("--workers", "2")
    try:
        panda = robots.load("panda", geometry=False)
        q = panda.random_q(2)
        with httpx.Client(base_url=srv.url, timeout=30) as c:
            for _ in range(6):
                r = c.post("/fk", json={"robot": "panda", "q": q.tolist()})
                assert r.status_code == 200
                assert np.allclose(r.json()["pose"], panda.fk(q), atol=1e-12)
    finally:
        srv.stop()


def test_bad_limits_are_one_error_line_and_exit_2():
    import subprocess
    import sys

    for args, word in ((["--max-body", "0"], "--max-body"), (["--keep-alive", "0"], "--keep-alive")):
        proc = subprocess.run([sys.executable, "-m", "kinserve.service.cli", "serve", "--port", "1", *args],
                              capture_output=True, text=True, timeout=60)
        assert proc.returncode == 2 and proc.stderr.startswith("error: ") and word in proc.stderr


def test_sizes_accept_units():
    from kinserve.service.cli_serve import _size

    assert _size("1M") == _size("1MiB") == 1 << 20 and _size("512k") == 512 << 10 and _size("4096") == 4096
