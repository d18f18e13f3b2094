"""``kinserve view ROBOT [--q ...] [--html FILE] [--collision --box ...]``: show a robot in the browser.

Starts a local meshcat server, prints its URL and keeps serving until
interrupted (Ctrl-C). ``--html FILE`` instead writes a self-contained static
page (opens offline) and exits.
"""

from __future__ import annotations

import argparse
import os
import sys

from .cli_types import file_in_existing_folder


def cmd_view(args) -> int:
    """``kinserve view``: show the robot live in the browser, or write a static page with ``--html``."""
    from kinserve.service.cli import load_robot, robot_q
    from kinserve.viz import Scene, export_html
    from kinserve.viz.live import serve

    robot = load_robot(args, geometry=True)
    q = robot_q(robot, args)
    obstacles = []
    if args.collision:
        from kinserve.service.cli_collide import obstacles_from_args

        obstacles = obstacles_from_args(args)
    scene = Scene.for_robot(robot, q, collision=args.collision, obstacles=obstacles)
    if args.html:
        path = export_html(scene, args.html)
        print(f"wrote {path}")
        return 0
    try:
        serve(scene, zmq_url=args.zmq_url, announce=lambda line: print(line, flush=True))
        status = 0
    except SystemExit as exc:  # SIGTERM / SIGHUP: the server is stopped already, exit 128 + signal
        status = exc.code if isinstance(exc.code, int) else 1
    # The meshcat server is stopped (serve's finally). Leave at once: interpreter teardown terminates
    # meshcat's ZeroMQ context, which can block on a socket whose peer died with a signal.
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``view`` sub-command to ``sub``."""
    from kinserve.service.cli import add_robot_args

    p = sub.add_parser("view", help="show a robot in the browser (live meshcat viewer, "
                                    "or --html for a static page)")
    add_robot_args(p)
    p.add_argument("--html", metavar="FILE", type=file_in_existing_folder,
                   help="write a self-contained HTML page instead of serving (its folder must exist)")
    p.add_argument("--zmq-url", help="use an existing meshcat server instead of starting one")
    p.add_argument("--collision", action="store_true",
                   help="also draw the collision shapes and the --box/--sphere/--cylinder obstacles, "
                        "colliding ones red")
    p.add_argument("--box", nargs=6, action="append", metavar="V",
                   help="box obstacle CX CY CZ SX SY SZ (m), with --collision")
    p.add_argument("--sphere", nargs=4, action="append", metavar="V",
                   help="sphere obstacle CX CY CZ R (m), with --collision")
    p.add_argument("--cylinder", nargs=5, action="append", metavar="V",
                   help="vertical cylinder CX CY CZ R L (m)")
    p.set_defaults(func=cmd_view)
