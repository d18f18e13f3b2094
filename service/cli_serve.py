"""``kinserve serve``: run the HTTP service with uvicorn."""

from __future__ import annotations

import argparse


def cmd_serve(args) -> int:
    import uvicorn

    if args.workers > 1:
        uvicorn.run("service.app:app", host=args.host, port=args.port, workers=args.workers, log_level=args.log_level)
    else:
        from service.app import create_app

        uvicorn.run(create_app(max_time_cap=args.max_time_cap), host=args.host, port=args.port, log_level=args.log_level)
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("serve", help="run the HTTP kinematics service (FastAPI + uvicorn)")
    p.add_argument("--host", default="127.0.0.1")
    p.add_argument("--port", type=int, default=8000)
    p.add_argument("--workers", type=int, default=1, help="worker processes (each with its own robot cache)")
    p.add_argument("--max-time-cap", type=float, default=5.0, help="upper bound on any IK request's max_time (s)")
    p.add_argument("--log-level", default="info", choices=["critical", "error", "warning", "info", "debug"])
    p.set_defaults(func=cmd_serve)
