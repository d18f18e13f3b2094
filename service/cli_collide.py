"""``kinserve collide ROBOT --q ... [--box ...] [--sphere ...]``: self-collision and obstacle check at one
configuration.

Obstacles: ``--box CX CY CZ SX SY SZ`` (axis-aligned box: centre and full edge
lengths, m), ``--sphere CX CY CZ R``, ``--cylinder CX CY CZ R L`` (vertical),
each repeatable. Prints whether the robot is in collision, the colliding pairs
(links / ``obstacle[k]:kind``) and the smallest signed distance (m) with its pair;
``--distances`` lists every checked pair. Exit status 0 either way (1 with
``--fail-on-collision`` when in collision), 2 for bad input.
"""

from __future__ import annotations

import argparse

import numpy as np


def _pose(c) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = c
    return T


def obstacles_from_args(args) -> list:
    """The ``--box`` / ``--sphere`` / ``--cylinder`` obstacles as shapes (metres)."""
    from kinserve.kinematics.shapes import Box, Cylinder, Sphere
    from kinserve.service.cli import parse_vector

    out = []
    for vals in args.box or []:
        v = parse_vector(vals, "--box")
        if v.size != 6:
            from kinserve.kinematics.errors import ShapeError

            raise ShapeError(f"--box expects 6 numbers CX CY CZ SX SY SZ, got {v.size}")
        out.append(Box(_pose(v[:3]), v[3:]))
    for vals in args.sphere or []:
        v = parse_vector(vals, "--sphere")
        if v.size != 4:
            from kinserve.kinematics.errors import ShapeError

            raise ShapeError(f"--sphere expects 4 numbers CX CY CZ R, got {v.size}")
        out.append(Sphere(v[:3], v[3]))
    for vals in args.cylinder or []:
        v = parse_vector(vals, "--cylinder")
        if v.size != 5:
            from kinserve.kinematics.errors import ShapeError

            raise ShapeError(f"--cylinder expects 5 numbers CX CY CZ R L, got {v.size}")
        out.append(Cylinder(_pose(v[:3]), v[3], v[4]))
    return out


def cmd_collide(args) -> int:
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
    p.add_argument("--box", nargs=6, action="append", metavar="V", help="box obstacle: CX CY CZ SX SY SZ (m)")
    p.add_argument("--sphere", nargs=4, action="append", metavar="V", help="sphere obstacle: CX CY CZ R (m)")
    p.add_argument("--cylinder", nargs=5, action="append", metavar="V",
                   help="vertical cylinder: CX CY CZ R L (m)")
    p.add_argument("--no-self", action="store_true", help="skip self-collision (obstacles only)")
    p.add_argument("--distances", action="store_true", help="list every checked pair's distance")
    p.add_argument("--fail-on-collision", action="store_true", help="exit status 1 when in collision")
    p.set_defaults(func=cmd_collide)
