"""``kinserve serve``: run the HTTP service with uvicorn."""

from __future__ import annotations

import argparse
import os
import socket

from .cli_types import port_number, positive_float, positive_int


def tcp_listener(config) -> socket.socket:
    """``config.bind_socket()`` re-wrapped so the socket reports ``proto == IPPROTO_TCP``.

    uvicorn creates the shared listener of ``--workers N`` with ``proto`` 0;
    accepted connections inherit it and asyncio then never sets
    ``TCP_NODELAY``, so every keep-alive response waits ~40 ms for the
    client's delayed ACK (uvicorn issue #3149). Re-wrapping the file descriptor
    lets Python read the real protocol (6) from the kernel.
    """
    sock = config.bind_socket()
    if sock.family in (socket.AF_INET, socket.AF_INET6) and sock.proto == 0:
        fixed = socket.socket(fileno=sock.detach())
        fixed.set_inheritable(True)
        return fixed
    return sock


def check_address(host: str, port: int) -> None:
    """Raise ``OSError`` (one ``error:`` line from the CLI) when ``host:port`` cannot be listened on.

    uvicorn would log the failure among its start-up lines and exit with 1 or 3;
    binding a probe socket first (with ``SO_REUSEADDR``, as uvicorn does) turns
    a busy port or an unknown host into a clear message and exit status 2.
    """
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)
    except socket.gaierror as exc:
        raise OSError(f"cannot listen on {host}:{port}: {exc.strerror}") from None
    family, kind, proto, _, address = infos[0]
    with socket.socket(family, kind, proto) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind(address)
        except OSError as exc:
            raise OSError(f"cannot listen on {host}:{port}: {exc.strerror}") from None


def cmd_serve(args) -> int:
    import uvicorn

    check_address(args.host, args.port)

    if args.workers > 1:
        from uvicorn.supervisors import Multiprocess

        # worker processes import service.app:app; they read the time cap from the environment
        os.environ["KINSERVE_MAX_TIME_CAP"] = str(args.max_time_cap)
        config = uvicorn.Config("kinserve.service.app:app", host=args.host, port=args.port, workers=args.workers,
                                log_level=args.log_level)
        Multiprocess(config, sockets=[tcp_listener(config)]).run()
    else:
        from kinserve.service.app import create_app

        uvicorn.run(create_app(max_time_cap=args.max_time_cap), host=args.host, port=args.port, log_level=args.log_level)
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("serve", help="run the HTTP kinematics service (FastAPI + uvicorn)")
    p.add_argument("--host", default="127.0.0.1")
    p.add_argument("--port", type=port_number, default=8000, help="TCP port 1..65535, or 0 for any free port")
    p.add_argument("--workers", type=positive_int, default=1, help="worker processes (each with its own robot cache)")
    p.add_argument("--max-time-cap", type=positive_float, default=5.0, help="upper bound on any IK request's max_time (s)")
    p.add_argument("--log-level", default="info", choices=["critical", "error", "warning", "info", "debug"])
    p.set_defaults(func=cmd_serve)
