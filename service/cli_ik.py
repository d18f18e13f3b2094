"""``kinserve ik ROBOT --target ...``: inverse kinematics from the command line.

The target is a 4x4 pose (16 numbers, row major, or a JSON list of rows),
or ``--xyz X Y Z`` with an optional ``--rpy R P Y`` (rad; ``R = Rz(Y) Ry(P) Rx(R)``).
Without ``--rpy`` and ``--target`` the orientation is relaxed (position-only IK).
"""

from __future__ import annotations

import argparse

import numpy as np

from kinserve.kinematics import se3
from kinserve.kinematics.errors import ShapeError

from .cli_types import non_negative_float, positive_float


def parse_target(args) -> tuple[np.ndarray, tuple]:
    """(4x4 pose, extra relaxed components) from --target or --xyz/--rpy."""
    from kinserve.service.cli import parse_vector

    if args.target:
        if args.xyz or args.rpy:
            raise ShapeError("give either --target or --xyz/--rpy, not both")
        v = parse_vector(args.target, "--target")
        if v.size != 16:
            raise ShapeError(f"--target expects 16 numbers (a 4x4 pose, row major), got {v.size}")
        return v.reshape(4, 4), ()
    if not args.xyz:
        raise ShapeError("a target is needed: --target (4x4) or --xyz X Y Z [--rpy R P Y]")
    p = parse_vector(args.xyz, "--xyz")
    if p.size != 3:
        raise ShapeError(f"--xyz expects 3 numbers, got {p.size}")
    if args.rpy:
        rpy = parse_vector(args.rpy, "--rpy")
        if rpy.size != 3:
            raise ShapeError(f"--rpy expects 3 numbers, got {rpy.size}")
        return se3.pose(se3.matrix_from_rpy(*rpy), p), ()
    return se3.pose(None, p), ("roll", "pitch", "yaw")


def cmd_ik(args) -> int:
    """``kinserve ik``: solve for the target pose; returns 0 when it is reached, 1 otherwise."""
    from kinserve import ik
    from kinserve.service.cli import emit, fmt_matrix, load_robot, parse_vector

    robot = load_robot(args)
    T, relax_extra = parse_target(args)
    relax = tuple(dict.fromkeys(tuple(args.relax or ()) + relax_extra))
    q0 = parse_vector(args.q0, "--q0")
    spheres = []
    for text in args.sphere or []:
        v = parse_vector([text], "--sphere")
        if v.size != 4:
            raise ShapeError(f"--sphere expects CX,CY,CZ,R (4 numbers), got {text!r}")
        spheres.append(ik.Sphere(v[:3], v[3]))
    res = ik.solve(robot, T, q0, frame=args.frame, relax=relax, spheres=spheres, centring=args.centring,
                   method=args.method, max_time=args.max_time, seed=args.seed)
    frame = args.frame or robot.tip
    text = (
        f"{robot.name}  frame {frame}  method {res.method}  relax {list(relax) or 'none'}\n"
        f"success {res.success}: {res.message}\n"
        f"q = {np.array2string(np.asarray(res.q), precision=6)}\n"
        f"position error {res.position_error:.3e} m, orientation error {res.orientation_error:.3e} rad, "
        f"{res.iterations} iterations, {res.restarts} restarts, {1e3 * res.elapsed:.2f} ms\n"
        f"reached pose:\n{fmt_matrix(robot.fk(res.q, frame))}"
    )
    payload = {
        "robot": robot.name, "frame": frame, "method": res.method, "relax": list(relax),
        "success": bool(res.success), "q": np.asarray(res.q).tolist(),
        "position_error": float(res.position_error), "orientation_error": float(res.orientation_error),
        "iterations": int(res.iterations), "restarts": int(res.restarts), "elapsed": float(res.elapsed),
        "message": res.message,
    }
    emit(args, payload, text)
    return 0 if res.success else 1


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``ik`` sub-command to ``sub``."""
    from kinserve.service.cli import add_robot_args

    p = sub.add_parser("ik", help="inverse kinematics: joint values placing a frame at a pose")
    add_robot_args(p, q=False)
    p.add_argument("--frame", help="frame to place (default: the robot's tool frame)")
    p.add_argument("--target", nargs="+", metavar="T", help="4x4 pose, 16 numbers row major (or a JSON list)")
    p.add_argument("--xyz", nargs="+", metavar="P", help="target position (m)")
    p.add_argument("--rpy", nargs="+", metavar="A",
                   help="target roll pitch yaw (rad); omitted = orientation free")
    p.add_argument("--relax", nargs="+", choices=["x", "y", "z", "roll", "pitch", "yaw", "phi"],
                   help="task components left free")
    p.add_argument("--q0", nargs="+", metavar="Q", help="initial guess")
    p.add_argument("--sphere", action="append", metavar="CX,CY,CZ,R", help="spherical obstacle (repeatable)")
    p.add_argument("--centring", type=non_negative_float, default=0.0,
                   help="weight of joint-range centring in the free DOF")
    p.add_argument("--method", default="auto")
    p.add_argument("--max-time", type=positive_float, default=None, help="time budget (s)")
    p.add_argument("--seed", type=int, default=0)
    p.set_defaults(func=cmd_ik)
