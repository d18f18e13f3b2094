"""``kinserve plan ROBOT --start Q... (--goal Q... | --xyz X Y Z [--quat ... | --rpy ...]) [--box ...]
[--out traj.json] [--html plan.html]``: a collision-free joint-space motion from the command line.

Calls :func:`kinserve.planners.plan_motion` (RRT-Connect, shortcut, toppra timing; every segment certified
collision free) and prints a summary: success and message, waypoints, duration, the search statistics.
``--out`` writes the trajectory (:class:`kinserve.planners.JointTrajectory`, JSON or CSV by the file's
extension: times (s), positions, velocities, accelerations per joint, at rest at both ends); ``--html`` a
self-contained page animating the motion among the obstacles (:func:`kinserve.viz.motion_plan_scene`).

``--start`` / ``--goal``: joint values (rad / m), or the name of one of the robot's SRDF states
(``kinserve frames ROBOT`` lists them). Instead of ``--goal``, a pose of ``--frame`` (default: the tool
frame) in the shared pose form (:mod:`.cli_pose`): ``--xyz`` with ``--quat`` or ``--rpy`` (``--xyz`` alone
leaves the orientation free; ``--relax`` frees more components); the planner turns it into a goal set of
collision-free IK solutions and reaches one of them. Obstacles: the shared ``--sphere`` / ``--box`` /
``--cylinder`` / ``--scene`` options (:mod:`.cli_obstacles`). ``--attach-box FRAME SX SY SZ [X Y Z]``:
the robot carries a box (full edges, centre in ``FRAME``, m; ``Robot.attach``) that the plan keeps clear
too. Budget: ``--max-time`` (s, or ``none`` for no clock) and ``--max-iterations`` (RRT-Connect samples;
with ``--max-time none`` the answer depends only on the inputs and ``--seed``).

Exit status: 0 with a plan; 1 when no plan was found (the reason, e.g. the colliding pair of a start in
collision, on stderr; nothing written); 2 for bad input (one ``error:`` line).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from kinserve.kinematics.errors import ShapeError

from .cli_obstacles import add_obstacle_args, obstacles_from_args
from .cli_pose import add_pose_args, pose_from_args
from .cli_types import (
    Numbers,
    file_in_existing_folder,
    positive_float,
    positive_int,
    seconds_or_none,
    trajectory_file,
)

#: ``plan_motion``'s own default time budget (s); a test keeps the two equal.
DEFAULT_MAX_TIME = 1.0


class AttachBox(Numbers):
    """``--attach-box FRAME SX SY SZ [X Y Z]``: appends ``(FRAME, numbers)`` to ``args.attach_box``."""

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        """Check the frame name and the 3 or 6 numbers after it; append them."""
        values = list(values)
        if len(values) < 2:
            raise argparse.ArgumentError(self, f"expected {self.form}, got {' '.join(values)!r}")
        items = list(getattr(namespace, self.dest, None) or [])
        setattr(namespace, self.dest, [*items, (values[0], self.values_of(values[1:]))])


def attach_boxes(robot, args: argparse.Namespace) -> list[str]:
    """Attach the ``--attach-box`` boxes to ``robot`` (names ``box0``, ``box1``, ...); returns the names."""
    from kinserve.kinematics import se3
    from kinserve.kinematics.shapes import Box

    names = []
    for k, (frame, v) in enumerate(args.attach_box or []):
        centre = v[3:6] if v.size == 6 else None
        robot.attach(f"box{k}", Box(se3.pose(None, centre), v[:3]), frame, touch_links=args.touch_links)
        names.append(f"box{k}")
    return names


def configuration(robot, values: list[str] | None, option: str) -> np.ndarray | None:
    """``--start`` / ``--goal``: joint values, or the name of an SRDF state of ``robot``; None when absent.

    :class:`ShapeError` naming ``option`` for a wrong count or an unknown name.
    """
    from kinserve.service.cli import parse_vector

    if not values:
        return None
    if len(values) == 1 and values[0] in robot.named_states:
        return np.array(robot.named_states[values[0]], dtype=float)
    names = ", ".join(robot.named_states) or "none"
    try:
        q = parse_vector(values, option)
    except ShapeError:
        raise ShapeError(f"{option}: expected {robot.nq} joint values or a named state (the robot's: "
                         f"{names}), got {' '.join(values)!r}") from None
    if q.size != robot.nq:
        raise ShapeError(f"{option}: expected {robot.nq} joint values (rad / m), got {q.size}")
    return q


def goal_of(robot, args: argparse.Namespace) -> tuple[object, dict]:
    """``(goal, plan_motion keywords)``: ``--goal``'s configuration, or the pose of ``--xyz`` ... as a
    ``pinocchio.SE3`` with ``frame`` and ``relax``. :class:`ShapeError` unless exactly one is given."""
    import pinocchio as pin

    q = configuration(robot, args.goal, "--goal")
    pose = pose_from_args(args)
    if (q is None) == (pose is None):
        raise ShapeError("give one goal: --goal Q... (joint values or a named state) or --xyz X Y Z "
                         "[--quat QX QY QZ QW | --rpy R P Y] (a pose of --frame)" if q is None else
                         "give either --goal or a goal pose (--xyz ...), not both")
    if q is not None:
        if args.relax or args.frame:
            raise ShapeError("--frame and --relax belong to a goal pose (--xyz ...), not to --goal")
        return q, {}
    T, free = pose
    relax = tuple(dict.fromkeys(tuple(args.relax or ()) + free))
    return pin.SE3(T[:3, :3], T[:3, 3]), {"frame": args.frame, "relax": relax}


def pose_goal_lines(robot, plan, goal, frame: str | None) -> tuple[dict, list[str]]:
    """For a pose goal: the goal set's size and the pose error of the configuration reached."""
    from kinserve.kinematics import se3

    frame = frame or robot.tip
    info = {"goal_pose": goal.homogeneous.tolist(), "frame": frame,
            "goal_set": 0 if plan.goals is None else int(len(plan.goals))}
    stats = plan.stats
    lines = [f"  goal: pose of {frame}, {info['goal_set']} collision-free IK solution(s) in the goal set "
             f"({stats.get('ik_starts', 0)} IK starts, {1e3 * stats.get('ik_time', 0.0):.1f} ms)"]
    if plan.success:
        dp, dr = se3.pose_error(robot.fk(plan.path[-1], frame), goal.homogeneous)
        info.update(position_error=dp, orientation_error=dr)
        lines.append(f"  reached goal {plan.goal_index}: position error {dp:.2e} m, orientation error "
                     f"{dr:.2e} rad (all components, relaxed ones included)")
    return info, lines


def plan_summary(robot, plan, obstacles: list, self_collision: bool) -> tuple[dict, str]:
    """``(JSON payload, text)`` describing ``plan``: success, message, waypoints, duration, statistics."""
    traj = plan.trajectory
    duration = traj.duration if traj is not None else None
    stats = {k: (float(v) if isinstance(v, (float, np.floating)) else v) for k, v in plan.stats.items()}
    payload = {
        "robot": robot.name, "success": bool(plan.success), "message": plan.message,
        "waypoints": int(len(plan.path)), "path": plan.path.tolist(), "duration": duration,
        "trajectory_points": traj.n_points if traj is not None else 0, "goal_index": int(plan.goal_index),
        "obstacles": [o.to_dict() for o in obstacles], "self_collision": bool(self_collision), "stats": stats,
        "attached": {name: {"frame": obj.frame, "placement": obj.placement.tolist(), **obj.shape.to_dict()}
                     for name, obj in robot.attached.items()},
    }
    checks = (f"{len(obstacles)} obstacle(s)" + (f", {len(robot.attached)} carried" if robot.attached else "")
              + (", self-collision" if self_collision else ""))
    lines = [f"{robot.name}: {'plan found' if plan.success else 'NO PLAN'} ({checks})",
             f"  {plan.message}"]
    if plan.success:
        lines.append(f"  {len(plan.path)} waypoints, duration {duration:.3f} s, {traj.n_points} trajectory "
                     f"points, path length {stats['length_after']:.3f} rad (before shortcuts "
                     f"{stats['length_before']:.3f})")
    lines.append(f"  search: {stats['iterations']} iterations, {stats['nodes']} nodes, "
                 f"{stats['checks']} collision checks; plan {1e3 * stats['plan_time']:.1f} ms, simplify "
                 f"{1e3 * stats['simplify_time']:.1f} ms, timing {1e3 * stats['parameterize_time']:.1f} ms "
                 f"({stats['timing']})")
    return payload, "\n".join(lines)


def write_outputs(robot, plan, obstacles: list, args: argparse.Namespace) -> list[Path]:
    """Write ``--out`` (the trajectory) and ``--html`` (the animated page) of a successful ``plan``."""
    written = []
    if args.out is not None:
        written.append(plan.trajectory.save(args.out))
    if args.html is not None:
        from kinserve.viz import export_html, motion_plan_scene

        written.append(Path(export_html(motion_plan_scene(robot, plan, obstacles), args.html)))
    return written


def cmd_plan(args: argparse.Namespace) -> int:
    """``kinserve plan``: plan, print the summary, write the files; 0 with a plan, 1 without."""
    from kinserve import planners
    from kinserve.service.cli import emit, load_robot

    robot = load_robot(args, geometry=args.html is not None)
    start = configuration(robot, args.start, "--start")
    goal, pose_keywords = goal_of(robot, args)
    if args.max_time is None and args.max_iterations is None:
        raise ShapeError("--max-time none needs --max-iterations N: the search needs a budget")
    obstacles = obstacles_from_args(args)
    attach_boxes(robot, args)
    self_collision = not args.no_self
    plan = planners.plan_motion(robot, robot.neutral() if start is None else start, goal, obstacles=obstacles,
                                self_collision=self_collision, max_time=args.max_time, seed=args.seed,
                                acceleration_limits=args.max_acceleration, simplify=not args.no_simplify,
                                max_iterations=args.max_iterations, **pose_keywords)
    written = write_outputs(robot, plan, obstacles, args) if plan.success else []
    payload, text = plan_summary(robot, plan, obstacles, self_collision)
    if pose_keywords:
        info, lines = pose_goal_lines(robot, plan, goal, args.frame)
        payload.update(info)
        text = "\n".join([text, *lines])
    payload["written"] = [str(p) for p in written]
    emit(args, payload, text + "".join(f"\nwrote {p}" for p in written))
    if not plan.success:
        skipped = [opt for opt in ("out", "html") if getattr(args, opt) is not None]
        note = f" (nothing written to --{' / --'.join(skipped)})" if skipped else ""
        print(f"plan failed: {plan.message}{note}", file=sys.stderr)
        return 1
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``plan`` sub-command to ``sub``."""
    from kinserve.service.cli import add_robot_args

    p = sub.add_parser("plan", help="collision-free motion plan: a timed joint trajectory from a start to a "
                                    "goal among obstacles")
    add_robot_args(p, q=False)
    p.add_argument("--start", nargs="+", metavar="Q",
                   help="start configuration: joint values (rad / m) or a named SRDF state (default: the "
                        "neutral configuration)")
    p.add_argument("--goal", nargs="+", metavar="Q",
                   help="goal configuration: joint values (rad / m) or a named SRDF state (default: none; "
                        "give it or a goal pose)")
    add_pose_args(p, "goal")
    p.add_argument("--frame", help="frame of the goal pose (default: the robot's tool frame)")
    p.add_argument("--relax", nargs="+", choices=["x", "y", "z", "roll", "pitch", "yaw", "phi"],
                   metavar="AXIS",
                   help="goal pose components left free, any of x y z roll pitch yaw (phi = yaw), world "
                        "axes (default: none; roll pitch yaw without an orientation)")
    add_obstacle_args(p, "kept clear of the robot's collision geometry along the whole motion")
    p.add_argument("--attach-box", action=AttachBox, counts=(3, 6), form="FRAME SX SY SZ [X Y Z]",
                   help="carry a box: full edge lengths and its centre in FRAME (m), repeatable; the plan "
                        "keeps it clear of the obstacles and the links (default: none)")
    p.add_argument("--touch-links", nargs="+", metavar="LINK",
                   help="links the carried boxes may touch, e.g. the fingers (default: the link of FRAME)")
    p.add_argument("--no-self", action="store_true", help="do not check the robot's self-collision pairs")
    p.add_argument("--max-time", type=seconds_or_none, default=DEFAULT_MAX_TIME, metavar="SECONDS",
                   help="time budget of the search (s), or 'none' for no clock (then give --max-iterations)")
    p.add_argument("--max-iterations", type=positive_int, default=None, metavar="N",
                   help="iteration budget of the search: RRT-Connect samples (default: none, the clock "
                        "alone)")
    p.add_argument("--seed", type=int, default=0, help="seed of the search's samples (same seed and "
                                                       "--max-time none: same plan)")
    p.add_argument("--max-acceleration", type=positive_float, default=None, metavar="A",
                   help="acceleration limit of every joint (rad/s^2 or m/s^2) (default: per joint, twice "
                        "its URDF velocity limit per second)")
    p.add_argument("--no-simplify", action="store_true", help="keep the search's raw path (no shortcuts)")
    p.add_argument("--out", type=trajectory_file, metavar="FILE",
                   help="write the trajectory as JSON or CSV, by the extension .json / .csv (default: none)")
    p.add_argument("--html", type=file_in_existing_folder, metavar="FILE",
                   help="write a self-contained page animating the motion (default: none)")
    p.set_defaults(func=cmd_plan)
