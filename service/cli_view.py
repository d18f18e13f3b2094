"""``kinserve view ROBOT [--q ...] [--html FILE] [--collision] [--box ...]``: show a robot in the browser.

Starts a local meshcat server, prints its URL and keeps serving until
interrupted (Ctrl-C). ``--html FILE`` instead writes a self-contained static
page (opens offline) and exits. Every obstacle given (the shared ``--sphere`` /
``--box`` / ``--cylinder`` / ``--scene`` options, :mod:`.cli_obstacles`) is
drawn, the ones the robot touches in red; ``--collision`` adds the robot's
collision shapes, those in collision (self-collision included) in red.
"""

from __future__ import annotations

import argparse
import os
import sys

from .cli_obstacles import add_obstacle_args, obstacles_from_args
from .cli_types import file_in_existing_folder


def draw_obstacles(scene, robot, q, obstacles: list) -> None:
    """Draw ``obstacles`` in ``scene`` (nodes ``obstacles/<k>``), the ones touching the robot at ``q`` red,
    without the robot's collision shapes."""
    from kinserve.viz.collision_drawing import draw_collision_scene

    hits = robot.collisions(q, obstacles, self_collision=False)
    draw_collision_scene(scene, robot.name, (), [o.to_dict() for o in obstacles], hits)


def cmd_view(args: argparse.Namespace) -> int:
    """``kinserve view``: show the robot live in the browser, or write a static page with ``--html``."""
    from kinserve.service.cli import load_robot, robot_q
    from kinserve.viz import Scene, export_html
    from kinserve.viz.live import serve

    robot = load_robot(args, geometry=True)
    q = robot_q(robot, args)
    obstacles = obstacles_from_args(args)
    scene = Scene.for_robot(robot, q, collision=args.collision, obstacles=obstacles)
    if obstacles and not args.collision:
        draw_obstacles(scene, robot, q, obstacles)
    if args.html:
        path = export_html(scene, args.html)
        print(f"wrote {path}")
        return 0
    try:
        serve(scene, zmq_url=args.zmq_url, host=args.host, announce=lambda line: print(line, flush=True))
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
                   help="write a self-contained HTML page instead of serving, its folder must exist "
                        "(default: serve live)")
    p.add_argument("--zmq-url", help="use an existing meshcat server (default: start one)")
    p.add_argument("--host", default=None,
                   help="address the started viewer's page listens on; 0.0.0.0 lets other machines open it "
                        "(default: 127.0.0.1, this machine only)")
    p.add_argument("--collision", action="store_true",
                   help="also draw the robot's collision shapes, colliding ones red")
    add_obstacle_args(p, "all drawn, the ones the robot touches in red")
    p.set_defaults(func=cmd_view)
