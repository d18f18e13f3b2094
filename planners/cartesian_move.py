"""``plan_cartesian``: a straight-line move of a frame in SE(3), stopped with its reason where it cannot go.

**The line** from the frame's pose at ``start`` to ``T_goal`` is cut into ``n`` equal
steps of the progress ``s`` (:func:`line_steps`), so that no step moves the frame's
origin by more than ``max_step`` (m) along its path or turns it by more than
``max_rotation_step`` (rad): decoupled, the origin moves on the chord and the
rotation is the slerp (``|p1 - p0|`` and ``|log(R0^T R1)|`` in ``n`` parts); screw,
``T(s) = T0 exp(s X)``, ``X = log(T0^-1 T1) = [v; w]``: the origin moves at the
constant speed ``|v|`` (``dp/ds = R(s) v``) and turns at ``|w|``.

**The poses** ``s_i = i / n`` are solved in order by the loop of
:func:`~kinserve.planners.cartesian.cartesian_to_joint`
(:func:`~kinserve.planners.cartesian.follow_poses`), each warm started from the
solution before (``prefer_q0``), and the move stops at the first pose where:

* ``ik_failed`` - the pose is not reached within ``tol_pos`` / ``tol_rot``;
* ``joint_limit`` - a joint of the solution is within ``limit_margin`` of a bound
  (a pose missed with a joint at its bound is this case too: the solver stopped at
  the bound);
* ``joint_jump`` - ``max_k |q_i,k - q_i-1,k| > jump_threshold`` (a branch switch or
  a wrist flip: the joint path is not continuous); the joint and the size are reported;
* ``singularity`` - the smallest singular value of the task Jacobian (rows
  ``robot.task_axes``) is below ``singular_tol``;
* ``collision`` - with ``obstacles`` or ``self_collision``: the solution is in
  collision (the pairs named by ``robot.collisions``), closer than the clearance
  floor to one, or the straight joint motion from the waypoint before cannot be
  certified collision free as a continuous motion
  (:class:`~kinserve.planners.motion.edges.EdgeCertifier`; the pairs found on
  dense samples of it are named, or the closest one);
* ``time_cap`` - ``max_time`` (s, the whole move) was spent.

When one solution meets several, the first in that order names the stop, except that
a solution that jumps to a configuration near a bound (and reaches its pose) is a
``joint_jump``: the jump is the cause. The collision test runs only on solutions
that passed the others. The IK itself ignores the obstacles (the line fixes the
frame's path; only a redundant arm's posture could go round them).

**The result** (:class:`CartesianMove`): ``path`` holds ``start`` and the valid
waypoints before the stop, ``fraction`` is the progress ``s`` of the last of them
(1 only when the goal was reached: ``success``), ``trajectory`` is ``path`` timed
by TOPP-RA as :func:`~kinserve.planners.motion.plan.plan_motion` times its paths
(:func:`~kinserve.planners.motion.timing.time_parameterize`: at rest at both ends,
within the velocity limits of the URDF and ``acceleration_limits`` at every
instant; corners rounded inside balls certified collision free when collisions are
checked, else within half of each segment - the waypoints of a move are a few
millimetres apart, so the rounding is far below ``max_step``).

**Determinism**: each pose's IK runs on ``iteration_budget`` iterations; with
``max_time=None`` the clock is never read and the answer depends on the inputs alone.
"""

from __future__ import annotations

import numbers
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pinocchio as pin

from kinserve import ik
from kinserve.ik.arguments import check_method
from kinserve.ik.options import OPTIONS
from kinserve.ik.targets import parse_relax
from kinserve.kinematics import se3
from kinserve.kinematics.errors import InputError
from kinserve.kinematics.robot import TASK_AXES, Robot
from kinserve.kinematics.shapes import Shape
from kinserve.kinematics.types import ArrayLike, PoseLike
from kinserve.kinematics.validation import as_choice, as_nonnegative, as_pose, as_positive

from .cartesian import PoseSolving, PoseTrack, follow_poses
from .checks import step_count
from .joint_trajectory import JointTrajectory
from .motion.blended_path import corner_directions, distinct_points
from .motion.clearance import CLEARANCE_FLOOR, Clearance, ClearanceOracle
from .motion.edges import EdgeCertifier
from .motion.reach import pair_reach
from .motion.request import MotionRequest, motion_request
from .motion.timing import load_toppra, time_parameterize
from .se3_interpolation import METHODS, intermediate_poses

#: The stop codes of a move, ``"completed"`` first.
STOPS = ("completed", "ik_failed", "joint_limit", "joint_jump", "singularity", "collision", "time_cap")
#: The event kinds of :func:`~kinserve.planners.cartesian.follow_poses` that stop a move, by stop code.
STOP_OF_EVENT = {"ik_failed": "ik_failed", "limit_contact": "joint_limit", "joint_jump": "joint_jump",
                 "singular": "singularity", "collision": "collision", "time_cap": "time_cap"}
#: Samples of a joint segment searched for the colliding pairs when its certificate fails.
SEGMENT_SAMPLES = 32


@dataclass(frozen=True)
class CartesianMove:
    """The answer of :func:`plan_cartesian` (module docstring).

    * ``success``: the whole line was followed (``fraction == 1``); ``message``: what happened, in words;
    * ``stop``: one of :data:`STOPS`; ``stop_detail``: the event that stopped the move (``{}`` when
      completed): ``kind``, ``index`` (of the pose, ``s = index / n``), ``detail`` and its values
      (``joint`` and ``size`` of a jump, ``joints`` / ``sides`` at a limit, ``pairs`` of a collision,
      ``sigma_min``, ``position_error`` / ``orientation_error`` of a pose not reached);
    * ``fraction``: the progress ``s`` in ``[0, 1]`` of the last valid waypoint;
    * ``path`` ``(k, nq)``: ``start`` and the valid waypoints (``(0, nq)`` when ``start`` itself is in
      collision); ``s`` ``(k,)``: their progress; ``position_errors`` (m), ``orientation_errors`` (rad),
      ``sigma_min`` ``(k,)``: their IK errors and the smallest singular value of their task Jacobian;
    * ``trajectory``: ``path`` timed (None when ``path`` is empty); ``timing``: ``"toppra"``,
      ``"rest-to-rest"`` or ``"none"``;
    * ``poses`` ``(n + 1, 4, 4)``: the line's poses at ``s = i / n``; ``events``: every event met;
    * ``stop_q`` ``(nq,)``: the solution of the pose the move stopped at, rejected (None when it completed,
      ran out of time or did not start).
    """

    success: bool
    message: str
    stop: str
    fraction: float
    path: np.ndarray
    trajectory: JointTrajectory | None
    s: np.ndarray
    position_errors: np.ndarray
    orientation_errors: np.ndarray
    sigma_min: np.ndarray
    poses: np.ndarray
    events: list[dict] = field(default_factory=list)
    stop_detail: dict = field(default_factory=dict)
    timing: str = "none"
    stop_q: np.ndarray | None = None

    def __repr__(self) -> str:
        return (f"CartesianMove({self.stop}: fraction {self.fraction:.3f}, {len(self.path)} waypoints, "
                f"{self.message!r})")


def line_steps(T0: PoseLike, T1: PoseLike, max_step: float, max_rotation_step: float,
               interpolation: str = "decoupled") -> int:
    """The least ``n >= 1`` such that each of ``n`` equal steps of ``s`` moves the frame's origin by at most
    ``max_step`` (m) along its path and turns the frame by at most ``max_rotation_step`` (rad) (module
    docstring). A step so small that ``n`` would exceed :data:`~kinserve.planners.checks.MAX_SAMPLES` is
    refused (:class:`InputError` naming it and the smallest step accepted), as are steps that are not numbers
    in ``(0, 1e6]`` and an ``interpolation`` other than ``"decoupled"`` or ``"screw"``."""
    A, B = as_pose(T0, "T0"), as_pose(T1, "T1")
    max_step = as_positive(max_step, "max_step")
    max_rotation_step = as_positive(max_rotation_step, "max_rotation_step")
    if as_choice(interpolation, "interpolation", METHODS) == "screw":
        X = pin.log6(se3.to_se3(A).actInv(se3.to_se3(B))).vector
        length, angle = float(np.linalg.norm(X[:3])), float(np.linalg.norm(X[3:]))
    else:
        length = float(np.linalg.norm(B[:3, 3] - A[:3, 3]))
        angle = float(np.linalg.norm(se3.log3(A[:3, :3].T @ B[:3, :3])))
    if length / max_step >= angle / max_rotation_step:
        return step_count(length, max_step, "max_step", "m", "path")
    return step_count(angle, max_rotation_step, "max_rotation_step", "rad", "turn")


def _budgets(max_time: Any, iteration_budget: Any) -> tuple[float | None, int | None]:
    if max_time is not None:
        max_time = as_positive(max_time, "max_time")
    if iteration_budget is not None and (isinstance(iteration_budget, bool)
                                         or not isinstance(iteration_budget, numbers.Integral)
                                         or iteration_budget < 1):
        raise InputError(f"iteration_budget must be None or an integer >= 1, got {iteration_budget!r}")
    if max_time is None and iteration_budget is None:
        raise InputError("max_time and iteration_budget are both None: give at least one budget")
    return max_time, None if iteration_budget is None else int(iteration_budget)


def _pairs_text(pairs: Sequence[tuple[str, str]]) -> str:
    return ", ".join(f"{a} with {b}" for a, b in pairs) or "a checked pair"


def waypoint_collision(robot: Robot, request: MotionRequest, certifier: EdgeCertifier,
                       q: np.ndarray) -> tuple[dict | None, Clearance | None]:
    """``(why q cannot be a waypoint, None)`` - in collision, or closer than the clearance floor to a
    collision: a dict with ``pairs`` (names), ``where`` (``"waypoint"``) and ``detail`` - or ``(None, its
    clearance)``."""
    if certifier.in_collision(q):
        pairs = robot.collisions(q, request.obstacles, self_collision=request.self_collision)
        return {"pairs": pairs, "where": "waypoint", "detail": f"in collision: {_pairs_text(pairs)}"}, None
    c = certifier.clearance(q)
    k = certifier.closest_violation(c)
    if k >= 0:
        a, b = certifier.oracle.scene.pair_names[k]
        return {"pairs": [(a, b)], "where": "waypoint",
                "detail": f"closer than the clearance floor {CLEARANCE_FLOOR:g} m to a collision: "
                          f"{a} with {b} at {c.distance[k]:.3g} m"}, None
    return None, c


def segment_pairs(robot: Robot, request: MotionRequest, q_a: np.ndarray, q_b: np.ndarray) -> dict:
    """The pairs that stop the certificate of the joint motion ``q_a -> q_b``: those in collision at the first
    of :data:`SEGMENT_SAMPLES` evenly spaced samples that is, else the closest pair over the samples (a dict
    with ``pairs``, ``where`` = ``"segment"`` and ``detail``)."""
    kw = dict(self_collision=request.self_collision)
    samples = q_a + np.linspace(0.0, 1.0, SEGMENT_SAMPLES)[:, None] * (q_b - q_a)
    for t, q in zip(np.linspace(0.0, 1.0, SEGMENT_SAMPLES), samples):
        if robot.in_collision(q, request.obstacles, **kw):
            pairs = robot.collisions(q, request.obstacles, **kw)
            return {"pairs": pairs, "where": "segment",
                    "detail": f"the joint motion to it collides at {t:.2f} of the way: {_pairs_text(pairs)}"}
    closest = min(((d.distance, key) for q in samples
                   for key, d in robot.distances(q, request.obstacles, **kw).items()), default=(np.inf, None))
    pairs = [] if closest[1] is None else [closest[1]]
    return {"pairs": pairs, "where": "segment",
            "detail": f"the joint motion to it cannot be certified collision free (closest: "
                      f"{_pairs_text(pairs)} at {closest[0]:.3g} m)"}


class LineCollisions:
    """The collision stop of a move (a :data:`~kinserve.planners.cartesian.PoseCheck`): each new waypoint is
    free and the straight joint motion from the waypoint before is certified; ``clearances`` holds the
    :class:`~.motion.clearance.Clearance` of ``start`` and of every waypoint accepted."""

    def __init__(self, robot: Robot, request: MotionRequest, certifier: EdgeCertifier,
                 start: Clearance) -> None:
        self.robot, self.request, self.certifier = robot, request, certifier
        self.clearances = [start]

    def __call__(self, index: int, q: np.ndarray) -> list[dict]:
        """The ``collision`` event of waypoint ``index`` at ``q`` (empty list when it is accepted)."""
        why, c = waypoint_collision(self.robot, self.request, self.certifier, q)
        if why is None and not self.certifier.certify(self.clearances[-1], c):
            why = segment_pairs(self.robot, self.request, self.clearances[-1].q, q)
        if why is not None:
            return [{"kind": "collision", "index": index, **why}]
        self.clearances.append(c)
        return []


def line_poses(robot: Robot, start: np.ndarray, T_goal: PoseLike, frame: str | None, relax: Sequence[str],
               max_step: float, max_rotation_step: float, interpolation: str) -> np.ndarray:
    """The poses ``(n + 1, 4, 4)`` of the line from ``frame``'s pose at ``start`` to ``T_goal`` at
    ``s = i / n`` (:func:`line_steps`), after checking ``T_goal``, ``frame``, ``relax`` and the steps."""
    goal = as_pose(T_goal, "T_goal")
    as_choice(interpolation, "interpolation", METHODS)
    step = as_positive(max_step, "max_step")
    turn = as_positive(max_rotation_step, "max_rotation_step")
    ik.Target(robot, goal, frame, relax)  # checks frame and relax
    T0 = robot.fk(start, frame)
    n = line_steps(T0, goal, step, turn, interpolation)
    return intermediate_poses(T0, goal, n - 1, interpolation, include_ends=True)


def _solving(frame: str | None, relax: Sequence[str], method: str, tol_pos: float, tol_rot: float,
             seed: int | None, iteration_budget: int | None, jump_threshold: Any, limit_margin: Any,
             singular_tol: Any) -> PoseSolving:
    """The :class:`~kinserve.planners.cartesian.PoseSolving` of a move: no per-pose clock (the move's
    deadline bounds each pose), warm starts preferred, ``method``, ``relax`` (as :func:`ik.solve` takes them)
    and the thresholds checked."""
    method = check_method(method)
    relax = tuple(TASK_AXES[i] for i in parse_relax(relax))  # checked; as the component names
    accepted = OPTIONS.get(method, ())
    options = {"prefer_q0": True} if "prefer_q0" in accepted else {}
    budget = iteration_budget if "iteration_budget" in accepted else None
    return PoseSolving(frame, relax, (), 0.0, method, None, tol_pos, tol_rot, seed, budget,
                       as_positive(jump_threshold, "jump_threshold"),
                       as_nonnegative(limit_margin, "limit_margin"),
                       as_nonnegative(singular_tol, "singular_tol"),
                       options)


def _certifier(robot: Robot, request: MotionRequest) -> EdgeCertifier | None:
    """The edge certifier of the move's scene (as :func:`~.motion.plan.plan_motion` builds it), None when
    nothing is checked (no obstacles, no self-collision)."""
    if not request.obstacles and not request.self_collision:
        return None
    scene = robot.collision_scene(request.obstacles, request.self_collision)
    return EdgeCertifier(ClearanceOracle(scene), pair_reach(robot.model, scene))


def _stop_of(track: PoseTrack, limit_margin: float) -> tuple[str, dict]:
    """The stop code of ``track`` and the event behind it (module docstring: the order of the tests; a pose
    missed with a joint at its bound is a ``joint_limit``)."""
    if track.stop_reason == "completed":
        return "completed", {}
    kinds = {e["kind"]: e for e in track.stop_events}
    if "limit_contact" in kinds:
        limit = kinds["limit_contact"]
        at = ", ".join(f"{j} at its {side} limit" for j, side in zip(limit["joints"], limit["sides"]))
        missed = kinds.get("ik_failed")
        if missed is not None:
            return "joint_limit", {**missed, **limit, "detail": (
                f"pose not reached ({missed['position_error']:.3g} m, {missed['orientation_error']:.3g} rad "
                f"off) with {at}")}
        if "joint_jump" not in kinds:
            return "joint_limit", {**limit, "detail": f"{at} (within limit_margin = {limit_margin:g})"}
    for kind in ("ik_failed", "joint_jump", "singular", "collision", "time_cap"):
        if kind in kinds:
            return STOP_OF_EVENT[kind], kinds[kind]
    raise AssertionError(f"no stop event among {sorted(kinds)}")  # follow_poses stops on these kinds only


def _timed(toppra: Any, path: np.ndarray, watch: LineCollisions | None, request: MotionRequest,
           joint_names: list[str]) -> tuple[JointTrajectory | None, str]:
    """``path`` timed (:func:`~.motion.timing.time_parameterize`): its distinct waypoints, each corner rounded
    within the room certified along both of its directions (:meth:`~.motion.edges.EdgeCertifier.room`;
    unbounded when nothing is checked)."""
    if len(path) == 0:
        return None, "none"
    keep = distinct_points(path)
    points = path[keep]
    room = np.full(len(points), np.inf)
    if watch is not None and len(points) > 2:
        clear = [watch.clearances[k] for k in keep]
        e_in, e_out = corner_directions(points)
        room[1:-1] = [min(watch.certifier.room(c, a), watch.certifier.room(c, b))
                      for c, a, b in zip(clear[1:-1], e_in, e_out)]
    timed = time_parameterize(toppra, points, room, request.velocity_limits, request.acceleration_limits,
                              joint_names)
    return timed.trajectory, timed.method


def _message(stop: str, event: dict, fraction: float, n: int) -> str:
    if stop == "completed":
        return f"line followed to the goal in {n} steps"
    where = f"at step {event['index'] + 1} of {n} (s = {(event['index'] + 1) / n:.3f})"
    return f"stopped by {stop.replace('_', ' ')} {where}: {event['detail']}; {fraction:.1%} of the line done"


def _move_of(robot: Robot, request: MotionRequest, solving: PoseSolving, poses: np.ndarray, track: PoseTrack,
             watch: LineCollisions | None, toppra: Any) -> CartesianMove:
    """The :class:`CartesianMove` of ``track`` (the poses ``poses[1:]`` solved from ``request.start``)."""
    n = len(poses) - 1
    stop, event = _stop_of(track, solving.limit_margin)
    valid = len(track.q) - (0 if stop in ("completed", "time_cap") else 1)
    path = np.concatenate([request.start[None, :], track.q[:valid]])
    sigma0 = robot.singular_values(request.start, solving.frame)[-1]
    trajectory, timing = _timed(toppra, path, watch, request, robot.joint_names)
    fraction = valid / n
    return CartesianMove(stop == "completed", _message(stop, event, fraction, n), stop, fraction, path,
                         trajectory, np.arange(valid + 1) / n,
                         np.concatenate([[0.0], track.position_errors[:valid]]),
                         np.concatenate([[0.0], track.orientation_errors[:valid]]),
                         np.concatenate([[sigma0], track.sigma_min[:valid]]), poses, track.events, event,
                         timing, None if valid == len(track.q) else track.q[valid].copy())


def _blocked_start(robot: Robot, request: MotionRequest, poses: np.ndarray, why: dict) -> CartesianMove:
    """The move that does not start: ``start`` is in collision (or closer than the clearance floor)."""
    event = {"kind": "collision", "index": -1, **why, "detail": f"start {why['detail']}"}
    empty = np.zeros((0, robot.nq))
    return CartesianMove(False, f"stopped by collision before the first step: {event['detail']}", "collision",
                         0.0, empty, None, np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0), poses, [event],
                         event, "none")


def plan_cartesian(robot: Robot, start: ArrayLike, T_goal: PoseLike, *, frame: str | None = None,
                   max_step: float = 0.01, max_rotation_step: float = 0.05, jump_threshold: float = 0.25,
                   interpolation: str = "decoupled", obstacles: Shape | Sequence[Shape] = (),
                   self_collision: bool = True, relax: Sequence[str] = (),
                   acceleration_limits: float | ArrayLike | None = None, iteration_budget: int | None = 300,
                   max_time: float | None = None, tol_pos: float = 1e-4, tol_rot: float = 1e-3,
                   limit_margin: float = 1e-3, singular_tol: float = 1e-3, method: str = "auto",
                   seed: int | None = 0) -> CartesianMove:
    """Move ``frame`` (default ``robot.tip``) on the straight line in SE(3) from its pose at ``start`` to
    ``T_goal``, as far as it can go (module docstring).

    ``max_step`` (m) and ``max_rotation_step`` (rad) bound each step of the line (a step so small that the
    line would need more than :data:`~kinserve.planners.checks.MAX_SAMPLES` steps is refused);
    ``interpolation``:
    ``"decoupled"`` (straight origin, slerp) or ``"screw"``. Stops: ``jump_threshold`` (rad or m, on the
    largest joint change of a step), ``limit_margin`` (rad or m), ``singular_tol`` (on the smallest singular
    value of the task Jacobian), collisions with ``obstacles`` (shapes of :mod:`kinserve.kinematics.shapes`)
    and, with ``self_collision``, of the robot with itself. ``relax``, ``tol_pos`` (m), ``tol_rot`` (rad),
    ``method`` and ``seed`` go to :func:`ik.solve`; ``iteration_budget`` is each pose's IK iterations,
    ``max_time`` (s) the whole move's IK (at least one of them; with ``max_time=None`` the answer does not
    depend on the clock; the set-up before and the timing after are not counted). ``acceleration_limits``
    (rad/s^2, per joint or one value; default 2 x the URDF velocity limits) and the URDF velocity limits
    bound the trajectory.

    A move cut short is a :class:`CartesianMove` with ``success=False``, its ``stop`` and reason; invalid
    arguments raise :class:`InputError` / :class:`ShapeError` naming the argument (``relax``: component
    names as :func:`ik.solve` reads them; ``method``: one of :data:`kinserve.ik.options.METHODS`).
    """
    # start, obstacles, self_collision and the limits, checked as plan_motion checks them
    request = motion_request(robot, start, start, obstacles, self_collision, None, None, acceleration_limits,
                             False, 1)
    max_time, iteration_budget = _budgets(max_time, iteration_budget)
    solving = _solving(frame, relax, method, tol_pos, tol_rot, seed, iteration_budget, jump_threshold,
                       limit_margin, singular_tol)
    poses = line_poses(robot, request.start, T_goal, frame, solving.relax, max_step, max_rotation_step,
                       interpolation)
    certifier = _certifier(robot, request)
    toppra = load_toppra()
    watch = None
    if certifier is not None:
        why, c0 = waypoint_collision(robot, request, certifier, request.start)
        if why is not None:
            return _blocked_start(robot, request, poses, why)
        watch = LineCollisions(robot, request, certifier, c0)
    deadline = None if max_time is None else time.monotonic() + max_time
    track = follow_poses(robot, poses[1:], request.start, solving, stop_on=tuple(STOP_OF_EVENT),
                         q_before=request.start, deadline=deadline, check=watch)
    return _move_of(robot, request, solving, poses, track, watch, toppra)


__all__ = ["STOPS", "CartesianMove", "LineCollisions", "line_poses", "line_steps", "plan_cartesian",
           "segment_pairs", "waypoint_collision"]
