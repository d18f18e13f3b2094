"""``kinserve collide ROBOT --q ... [--box ...] [--sphere ...] [--scene ...]``: self-collision and obstacle
check at one configuration.

Obstacles: the shared ``--sphere`` / ``--box`` / ``--cylinder`` / ``--scene`` options
(:mod:`.cli_obstacles`), each repeatable. Prints whether the robot is in collision, the colliding pairs
(links / ``obstacle[k]:kind``) and the smallest signed distance (m) with its pair; ``--distances`` lists
every checked pair. Exit status 0 either way (1 with ``--fail-on-collision`` when in collision), 2 for bad
input.
"""

from __future__ import annotations

import argparse

from .cli_obstacles import add_obstacle_args, obstacles_from_args


def cmd_collide(args: argparse.Namespace) -> int:
    """``kinserve collide``: collisions and distances at ``--q``; 1 with ``--fail-on-collision`` and a hit."""
    from kinserve.service.cli import emit, load_robot, robot_q

    robot = load_robot(args)
    q = robot_q(robot, args)
    obstacles = obstacles_from_args(args)
    kw = dict(obstacles=obstacles, self_collision=not args.no_self)
    dist = robot.distances(q, **kw)
    pairs = robot.collisions(q, **kw)
    closest = min(dist.items(), key=lambda kv: kv[1].distance) if dist else None
    payload = {
        "robot": robot.name, "q": q.tolist(), "in_collision": bool(pairs), "pairs": [list(p) for p in pairs],
        "min_distance": closest[1].distance if closest else None,
        "closest_pair": list(closest[0]) if closest else None,
        "obstacles": [o.to_dict() for o in obstacles],
    }
    if args.distances:
        payload["distances"] = [{"a": a, "b": b, **d.to_dict()} for (a, b), d in dist.items()]
    lines = [f"{robot.name}: {'IN COLLISION' if pairs else 'collision free'} "
             f"({len(dist)} pairs checked, {len(obstacles)} obstacle(s))"]
    lines += [f"  colliding: {a} / {b}" for a, b in pairs]
    if closest:
        lines.append(f"  min distance {closest[1].distance:.6f} m between {closest[0][0]} and "
                     f"{closest[0][1]}")
    if args.distances:
        lines += [f"  {a} / {b}: {d.distance:.6f} m"
                  for (a, b), d in sorted(dist.items(), key=lambda kv: kv[1].distance)]
    emit(args, payload, "\n".join(lines))
    return 1 if (pairs and args.fail_on_collision) else 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``collide`` sub-command to ``sub``."""
    from kinserve.service.cli import add_robot_args

    p = sub.add_parser("collide",
                       help="self-collision and obstacle check at a configuration (coal, convex hulls)")
    add_robot_args(p)
    add_obstacle_args(p, "checked against every link")
    p.add_argument("--no-self", action="store_true", help="skip self-collision (obstacles only)")
    p.add_argument("--distances", action="store_true", help="list every checked pair's distance")
    p.add_argument("--fail-on-collision", action="store_true", help="exit status 1 when in collision")
    p.set_defaults(func=cmd_collide)
