"""``kinserve view ROBOT [--q ...] [--html FILE]``: show a robot in the browser.

Starts a local meshcat server, prints its URL and keeps serving until
interrupted (Ctrl-C). ``--html FILE`` instead writes a self-contained static
page (opens offline) and exits.
"""

from __future__ import annotations

import argparse


def cmd_view(args) -> int:
    from kinserve.service.cli import load_robot, robot_q
    from kinserve.viz import Scene, export_html
    from kinserve.viz.live import serve

    robot = load_robot(args, geometry=True)
    q = robot_q(robot, args)
    scene = Scene.for_robot(robot, q)
    if args.html:
        path = export_html(scene, args.html)
        print(f"wrote {path}")
        return 0
    serve(scene, zmq_url=args.zmq_url, announce=lambda line: print(line, flush=True))
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    from kinserve.service.cli import add_robot_args

    p = sub.add_parser("view", help="show a robot in the browser (live meshcat viewer, or --html for a static page)")
    add_robot_args(p)
    p.add_argument("--html", metavar="FILE", help="write a self-contained HTML page instead of serving")
    p.add_argument("--zmq-url", help="use an existing meshcat server instead of starting one")
    p.set_defaults(func=cmd_view)
