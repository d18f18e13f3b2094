"""``kinserve reach ROBOT --samples N [--backend ray]``: a reachability map saved as .npz and PNG.

Obstacles are the shared ``--sphere`` / ``--box`` / ``--cylinder`` / ``--scene`` options
(:mod:`.cli_obstacles`): with any (or ``--self-collision``) only collision-free solutions count.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from .cli_obstacles import add_obstacle_args, obstacles_from_args
from .cli_types import file_in_existing_folder, positive_float, positive_int, seed_number


def cmd_reach(args: argparse.Namespace) -> int:
    """``kinserve reach``: the reachability map of a frame, written as ``.npz`` and ``.png``; returns 0."""
    from kinserve.ik.batch.reachability import reachability_map
    from kinserve.service.cli import load_robot
    from kinserve.viz import save_png
    from kinserve.viz.reachability_plot import reachability_figure

    robot = load_robot(args)
    orientation = {"free": "free", "random": "random", "down": np.diag([1.0, -1.0, -1.0])}[args.orientation]
    obstacles = obstacles_from_args(args)
    rmap = reachability_map(robot, args.samples, frame=args.frame, resolution=args.resolution,
                            orientation=orientation, backend=args.backend, processes=args.processes,
                            ray_address=args.ray_address, max_time=args.max_time, seed=args.seed,
                            self_collision=args.self_collision, obstacles=obstacles)
    out = Path(args.out)
    npz = rmap.save(out.with_suffix(".npz"))
    png = save_png(reachability_figure(rmap.edges, rmap.counts, rmap.hits,
                                       title=f"{robot.name} ({args.orientation})"), out.with_suffix(".png"))
    print(f"{robot.name} frame {rmap.frame}: {rmap.reached.sum()}/{rmap.reached.size} sampled poses reached "
          f"({100 * rmap.overall:.1f} %), orientation {args.orientation}, backend {args.backend}"
          + (f", collision-free solutions only ({len(obstacles)} obstacle(s)"
             f"{', self-collision' if args.self_collision else ''})"
             if args.self_collision or obstacles else ""))
    print(f"wrote {npz}\nwrote {png}")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``reach`` sub-command to ``sub``."""
    from kinserve.service.cli import add_robot_args

    p = sub.add_parser("reach", help="reachability map: share of sampled workspace poses that IK reaches")
    add_robot_args(p, q=False)
    p.add_argument("--frame", help="tool frame (default: the robot's tip)")
    p.add_argument("--samples", type=positive_int, default=1000,
                   help="target poses sampled (positions uniform in the workspace box)")
    p.add_argument("--resolution", type=positive_int, default=8, help="cells per axis of the map")
    p.add_argument("--orientation", choices=["free", "random", "down"], default="free",
                   help="free = position only; random = uniform on SO(3); down = tool z pointing down")
    p.add_argument("--backend", choices=["processes", "serial", "ray"], default="processes",
                   help="where the IK solves run: a local process pool, this process, or a Ray cluster")
    p.add_argument("--processes", type=positive_int, default=None,
                   help="worker processes of the pool (default: every available core)")
    p.add_argument("--ray-address", default=None, help="Ray cluster address (default: start a local Ray)")
    p.add_argument("--max-time", type=positive_float, default=0.05, help="IK time budget per sample (s)")
    p.add_argument("--seed", type=seed_number, default=0, help="seed of the sampled poses and of the solves")
    p.add_argument("--out", type=file_in_existing_folder, default="reach",
                   help="output path stem in an existing folder: writes STEM.npz and STEM.png")
    p.add_argument("--self-collision", action="store_true",
                   help="count only solutions free of self-collision")
    add_obstacle_args(p, "only solutions clear of them count")
    p.set_defaults(func=cmd_reach)
