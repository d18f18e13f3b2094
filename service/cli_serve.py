"""``kinserve serve``: run the HTTP service with uvicorn."""

from __future__ import annotations

import argparse
import math
import os
import socket
import sys
from typing import TYPE_CHECKING

from .cli_types import number_up_to, port_number, whole_number

if TYPE_CHECKING:
    from .settings import ServiceSettings

#: Most worker processes ``kinserve serve --workers`` starts.
MAX_WORKERS = 1024


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


def settings_of(args: argparse.Namespace) -> ServiceSettings:
    """The service settings given by the parsed ``kinserve serve`` arguments ``args``."""
    from kinserve.service.settings import ServiceSettings

    return ServiceSettings(
        max_time_cap=args.max_time_cap, request_time_cap=args.request_time_cap, max_body=args.max_body,
        body_timeout=args.body_timeout, header_timeout=args.header_timeout, keep_alive=args.keep_alive,
        max_connections=args.max_connections, queue=args.queue,
        # the cores are shared by the worker processes: each gets its share of solver processes
        solver_threads=args.solver_threads or max(1, (os.cpu_count() or 1) // max(1, args.workers)),
        robot_cache=args.robot_cache, robot_cache_bytes=int(args.robot_cache_mb * (1 << 20)),
        access_log=args.access_log,
    )


def uvicorn_options(settings) -> dict:
    """uvicorn.Config keywords enforcing ``settings``' connection bounds (see :mod:`service.connection`;
    the protocol class reads the header timeout and connection cap from the environment)."""
    return dict(
        http="kinserve.service.connection:GuardedH11Protocol",  # reads its bounds from the environment
        timeout_keep_alive=settings.keep_alive,
        # uvicorn answers 503 from this many connections or tasks
        limit_concurrency=settings.max_connections + 1,
        h11_max_incomplete_event_size=64 * 1024,  # request line + headers
        access_log=settings.access_log,
    )


def serve(app, settings, *, host: str = "127.0.0.1", port: int = 8000, workers: int = 1,
          log_level: str = "info") -> None:
    """Run ``app`` with uvicorn under ``settings``' bounds, as ``kinserve serve`` does.

    ``app`` is an ASGI application, or its import string (required with
    ``workers > 1``: every worker process imports it; kinserve's own
    ``kinserve.service.app:app`` reads ``settings`` from the environment).
    """
    import uvicorn

    from kinserve.service.settings import ENV_VAR

    options = uvicorn_options(settings)
    # the connection protocol (and, with workers, each worker's kinserve.service.app:app) reads them here
    os.environ[ENV_VAR] = settings.to_env()
    if workers > 1:
        from uvicorn.supervisors import Multiprocess

        config = uvicorn.Config(app, host=host, port=port, workers=workers, log_level=log_level, **options)
        Multiprocess(config, sockets=[tcp_listener(config)]).run()
    else:
        uvicorn.run(app, host=host, port=port, log_level=log_level, **options)


def cmd_serve(args) -> int:
    """``kinserve serve``: run the HTTP service until interrupted; returns the exit status."""
    try:
        settings = settings_of(args)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    check_address(args.host, args.port)
    if args.workers > 1:
        app = "kinserve.service.app:app"
    else:
        from kinserve.service.app import create_app

        app = create_app(settings)
    serve(app, settings, host=args.host, port=args.port, workers=args.workers, log_level=args.log_level)
    return 0


def _size(text: str) -> int:
    """Bytes from ``1048576``, ``512k``, ``1M``, ``1MiB`` (k/M/G are powers of 1024).

    Refused: text that is not a size, NaN, infinite sizes, sizes below 1 byte or above
    ``MAXIMUM["max_body"]`` (1 GiB).
    """
    from kinserve.service.settings import MAXIMUM

    most = int(MAXIMUM["max_body"])
    t = text.strip().lower().removesuffix("ib").removesuffix("b")
    scale = {"k": 1 << 10, "m": 1 << 20, "g": 1 << 30}.get(t[-1:], 1)
    try:
        value = float(t[:-1] if scale > 1 else t) * scale
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a size like 1048576, 512k or 1M, got {text!r}") from None
    if not (math.isfinite(value) and 1 <= value <= most):
        raise argparse.ArgumentTypeError(f"expected a size from 1 byte to {most} bytes (1G), got {text!r}")
    return int(value)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``serve`` sub-command to ``sub``."""
    from kinserve.service.settings import MAXIMUM
    from kinserve.service.settings import ServiceSettings as D

    def seconds(name: str):
        return number_up_to(MAXIMUM[name], unit=" s")

    def count(name: str, minimum: int = 1):
        return whole_number(minimum, int(MAXIMUM[name]))

    p = sub.add_parser("serve", help="run the HTTP kinematics service (FastAPI + uvicorn)")
    p.add_argument("--host", default="127.0.0.1",
                   help="address to listen on (0.0.0.0: every interface; the service has no authentication)")
    p.add_argument("--port", type=port_number, default=8000, help="TCP port 1..65535, or 0 for any free port")
    p.add_argument("--workers", type=whole_number(1, MAX_WORKERS), default=1,
                   help=f"worker processes, 1..{MAX_WORKERS} (each with its own robot cache)")
    p.add_argument("--max-time-cap", type=seconds("max_time_cap"), default=D.max_time_cap,
                   help="upper bound on any IK request's max_time (s)")
    p.add_argument("--request-time-cap", type=seconds("request_time_cap"), default=D.request_time_cap,
                   help="upper bound on a whole /ik/batch or /plan/cartesian request, queueing included (s)")
    p.add_argument("--max-body", type=_size, default=D.max_body,
                   help="largest request body accepted (bytes; 413 above)")
    p.add_argument("--body-timeout", type=seconds("body_timeout"), default=D.body_timeout,
                   help="time to receive a whole body (s; 408 after)")
    p.add_argument("--header-timeout", type=seconds("header_timeout"), default=D.header_timeout,
                   help="time for a connection to send complete request headers (s; closed after)")
    p.add_argument("--keep-alive", type=seconds("keep_alive"), default=D.keep_alive,
                   help="idle keep-alive connections are closed after this (s)")
    p.add_argument("--max-connections", type=count("max_connections"), default=D.max_connections,
                   help="open connections beyond this are closed at accept; requests beyond it get 503")
    p.add_argument("--solver-threads", type=count("solver_threads", 0), default=D.solver_threads,
                   help="IK/plan solver processes per worker (0 = the cores divided among the workers)")
    p.add_argument("--queue", type=count("queue", 0), default=D.queue,
                   help="heavy requests waiting for a solver process (503 beyond)")
    p.add_argument("--robot-cache", type=count("robot_cache"), default=D.robot_cache,
                   help="robot variants (name + params) kept loaded")
    p.add_argument("--robot-cache-mb",
                   type=number_up_to(MAXIMUM["robot_cache_bytes"] / (1 << 20), unit=" MiB"),
                   default=D.robot_cache_bytes / (1 << 20),
                   help="estimated memory of the cached robot variants, seed tables included (MiB)")
    p.add_argument("--access-log", action="store_true", help="log every request")
    p.add_argument("--log-level", default="info", choices=["critical", "error", "warning", "info", "debug"],
                   help="uvicorn's log level")
    p.set_defaults(func=cmd_serve)
