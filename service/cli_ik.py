"""``kinserve ik ROBOT --xyz X Y Z [--quat QX QY QZ QW | --rpy R P Y]``: inverse kinematics from the command
line.

The target is ``--xyz`` with ``--quat`` (x y z w) or ``--rpy`` (rad; ``R = Rz(Y) Ry(P) Rx(R)``) - the pose
form every sub-command shares (:mod:`.cli_pose`) - or ``--target``, a 4x4 pose (16 numbers, row major, or a
JSON list of rows). Without an orientation the orientation is relaxed (position-only IK). Obstacles are the
shared ``--sphere`` / ``--box`` / ``--cylinder`` / ``--scene`` options (:mod:`.cli_obstacles`);
``--self-collision`` keeps the robot's collision geometry free of self-collision and checks the obstacles
against it instead of the link segments. Exit status 0 when the target is reached, 1 otherwise (the
output then shows the closest pose found, never a "reached" one), 2 for bad input.
"""

from __future__ import annotations

import argparse

import numpy as np

from kinserve.kinematics.errors import InputError

from .cli_obstacles import add_obstacle_args, obstacles_from_args
from .cli_pose import add_pose_args, pose_from_args
from .cli_types import Numbers, non_negative_float, positive_float


def parse_target(args: argparse.Namespace) -> tuple[np.ndarray, tuple[str, ...]]:
    """(4x4 pose, extra relaxed components) from ``--target`` or ``--xyz`` [``--quat`` | ``--rpy``]."""
    given = pose_from_args(args)
    if args.target is not None:
        if given is not None:
            raise InputError("give either --target or --xyz [--quat | --rpy], not both")
        return args.target.reshape(4, 4), ()
    if given is None:
        raise InputError("a target is needed: --xyz X Y Z [--quat QX QY QZ QW | --rpy R P Y] or --target "
                         "(16 numbers, a 4x4 pose)")
    return given


def pose_label(success: bool) -> str:
    """What the pose printed after a solve is: reached, or only the closest one found."""
    return "reached pose" if success else "closest pose (not reached)"


def cmd_ik(args: argparse.Namespace) -> int:
    """``kinserve ik``: solve for the target pose; returns 0 when it is reached, 1 otherwise."""
    from kinserve import ik
    from kinserve.service.cli import emit, fmt_matrix, load_robot, parse_vector, robot_frame

    robot = load_robot(args)
    frame = robot_frame(robot, args)
    T, relax_extra = parse_target(args)
    relax = tuple(dict.fromkeys(tuple(args.relax or ()) + relax_extra))
    q0 = parse_vector(args.q0, "--q0")
    obstacles = obstacles_from_args(args)
    res = ik.solve(robot, T, q0, frame=frame, relax=relax, obstacles=tuple(obstacles),
                   centring=args.centring, method=args.method, max_time=args.max_time, seed=args.seed,
                   self_collision=args.self_collision)
    checks = f"{len(obstacles)} obstacle(s)" + (", self-collision" if args.self_collision else "")
    text = (
        f"{robot.name}  frame {frame}  method {res.method}  relax {list(relax) or 'none'}  {checks}\n"
        f"success {res.success}: {res.message}\n"
        f"q = {np.array2string(np.asarray(res.q), precision=6)}\n"
        f"position error {res.position_error:.3e} m, orientation error {res.orientation_error:.3e} rad, "
        f"{res.iterations} iterations, {res.restarts} restarts, {1e3 * res.elapsed:.2f} ms\n"
        f"{pose_label(res.success)}:\n{fmt_matrix(robot.fk(res.q, frame))}"
    )
    payload = {
        "robot": robot.name, "frame": frame, "method": res.method, "relax": list(relax),
        "success": bool(res.success), "q": np.asarray(res.q).tolist(),
        "position_error": float(res.position_error), "orientation_error": float(res.orientation_error),
        "iterations": int(res.iterations), "restarts": int(res.restarts), "elapsed": float(res.elapsed),
        "message": res.message, "obstacles": [o.to_dict() for o in obstacles],
        "self_collision": bool(args.self_collision),
    }
    emit(args, payload, text)
    return 0 if res.success else 1


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``ik`` sub-command to ``sub``."""
    from kinserve.service.cli import add_robot_args

    p = sub.add_parser("ik", help="inverse kinematics: joint values placing a frame at a pose")
    add_robot_args(p, q=False)
    p.add_argument("--frame", help="frame to place (default: the robot's tool frame)")
    add_pose_args(p, "target")
    p.add_argument("--target", action=Numbers, counts=(16,), form="T11 ... T44",
                   help="the target as a 4x4 pose instead: 16 numbers row major, or a JSON list of rows "
                        "(default: none)")
    p.add_argument("--relax", nargs="+", choices=["x", "y", "z", "roll", "pitch", "yaw", "phi"],
                   metavar="AXIS",
                   help="task components left free, any of x y z roll pitch yaw (phi = yaw), world axes "
                        "(default: none; roll pitch yaw without an orientation)")
    p.add_argument("--q0", nargs="+", metavar="Q",
                   help="initial guess, joint values (default: the neutral configuration)")
    add_obstacle_args(p, "kept clear of the robot's link segments, or of its collision geometry with "
                         "--self-collision")
    p.add_argument("--self-collision", action="store_true",
                   help="keep the robot's collision geometry free of self-collision and of the obstacles")
    p.add_argument("--centring", type=non_negative_float, default=0.0, metavar="WEIGHT",
                   help="weight of joint-range centring in the free DOF (0 = off)")
    p.add_argument("--method", default="auto",
                   help="IK method, one of kinserve.ik.METHODS (auto picks per problem, e.g. qp, lm, "
                        "analytic, dls)")
    p.add_argument("--max-time", type=positive_float, default=None, metavar="SECONDS",
                   help="time budget (s) (default: the solver's own, 0.1 s for LM, 0.5 s with the QP)")
    p.add_argument("--seed", type=int, default=0, help="seed of the random restarts (same seed, same answer)")
    p.set_defaults(func=cmd_ik)
