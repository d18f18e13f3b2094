"""Cartesian path -> joint trajectory through inverse kinematics, and the per-pose loop behind it.

Given poses ``T_0 ... T_m`` of a frame, ``steps`` poses are interpolated per
segment (decoupled: linear translation + slerp; or screw:
``T_k exp(s log(T_k^-1 T_{k+1}))``, see :mod:`planners.se3_interpolation`).
Each pose is solved with :func:`ik.solve`, warm started from the previous
solution so the arm follows one continuous branch; relaxation, spheres and
centring are passed through. The joint positions become a
:class:`JointTrajectory` with ``time_from_start = i * dt`` and finite-difference
velocities/accelerations.

**One loop** (:func:`follow_poses`) solves and judges the poses, for
:func:`cartesian_to_joint` and for :func:`~kinserve.planners.cartesian_move.plan_cartesian`
alike; the callers differ only in which events end it (``stop_on``) and in an
optional extra check of each solution (``check``: the collision test of a move).

Reported events (each a dict with ``"kind"``, ``"index"`` (of the pose), ``"detail"`` (text) and the
values named below):

* ``ik_failed`` - the pose at this index was not reached within tolerance
  (``position_error`` m, ``orientation_error`` rad);
* ``joint_jump`` - ``max |q_i - q_{i-1}| > jump_threshold`` rad (or m): the
  solution switched branch, the path is not continuous in joint space
  (``joint``: the name of the joint that moved most, ``size``: its ``|dq|``);
* ``limit_contact`` - a joint within ``limit_margin`` of a limit (``joints``: their names, ``sides``:
  ``"lower"`` / ``"upper"`` for each);
* ``singular`` - the task Jacobian's smallest singular value (rows ``robot.task_axes``) below
  ``singular_tol`` (manipulability near zero; ``sigma_min``);
* ``time_cap`` - the whole plan's time was spent before this pose.

Bounded work: ``total_time`` (s) caps the whole plan - each pose's IK budget
is ``min(max_time, time left)`` and no pose is started once it is spent - and
``stop_on_failure=True`` stops at the first pose that is not reached. A plan
cut short holds the poses attempted so far (the failed one last);
``CartesianPlan.stop_reason`` says why it ended (``"completed"``,
``"ik_failed"``, ``"time_cap"``) and ``total_poses`` how many were asked for.
"""

from __future__ import annotations

import numbers
import time
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from kinserve import ik
from kinserve.kinematics import Robot
from kinserve.kinematics.errors import InputError, ShapeError
from kinserve.kinematics.robot import as_robot
from kinserve.kinematics.types import PoseLike, VectorLike
from kinserve.kinematics.validation import as_choice, as_flag, as_nonnegative, as_positive

from .checks import MAX_SAMPLES
from .joint_trajectory import JointTrajectory, check_last_time
from .se3_interpolation import METHODS, interpolate_checkpoints

#: A pose's IK is not started with less than this much of the plan's time left (s).
MIN_POSE_TIME = 1e-3


@dataclass(frozen=True)
class PoseSolving:
    """How :func:`follow_poses` solves and judges each pose.

    ``frame`` .. ``seed`` and ``iteration_budget`` (None: not passed) are :func:`ik.solve`'s arguments of
    those names; ``max_time`` (s, None = no clock) is each pose's IK budget. ``jump_threshold`` (rad or m),
    ``limit_margin`` (rad or m) and ``singular_tol`` are the thresholds of the events (module docstring).
    ``options``: further :func:`ik.solve` options (e.g. ``prefer_q0``).
    """

    frame: str | None = None
    relax: Sequence[str] = ()
    spheres: Sequence[ik.Sphere] = ()
    centring: float | VectorLike = 0.0
    method: str = "auto"
    max_time: float | None = 0.2
    tol_pos: float = 1e-4
    tol_rot: float = 1e-3
    seed: int | None = 0
    iteration_budget: int | None = None
    jump_threshold: float = 0.5
    limit_margin: float = 1e-3
    singular_tol: float = 1e-4
    options: dict[str, Any] = field(default_factory=dict)

    def solve(self, robot: Robot, T: np.ndarray, q0: np.ndarray, max_time: float | None) -> ik.Result:
        """:func:`ik.solve` of pose ``T`` from ``q0`` within ``max_time`` (s, None = no clock)."""
        extra = dict(self.options)
        if self.iteration_budget is not None:
            extra["iteration_budget"] = self.iteration_budget
        return ik.solve(robot, T, q0, frame=self.frame, relax=self.relax, spheres=self.spheres,
                        centring=self.centring, method=self.method, max_time=max_time, tol_pos=self.tol_pos,
                        tol_rot=self.tol_rot, seed=self.seed, **extra)


@dataclass
class PoseTrack:
    """What :func:`follow_poses` found for the poses it attempted (``k`` of ``total``).

    ``q`` ``(k, nq)``: the IK solutions (the last one is the pose it stopped at, if any);
    ``position_errors`` (m), ``orientation_errors`` (rad), ``manipulability`` and ``sigma_min`` (smallest
    singular value of the task Jacobian) ``(k,)``; ``events``: every event (module docstring);
    ``stop_reason``: ``"completed"``, ``"time_cap"`` or the kind of the event that ended the loop;
    ``stop_events``: the events of the pose it stopped at (empty when it did not stop early).
    """

    q: np.ndarray
    position_errors: np.ndarray
    orientation_errors: np.ndarray
    manipulability: np.ndarray
    sigma_min: np.ndarray
    events: list[dict]
    stop_reason: str
    stop_events: list[dict]
    total: int


#: An extra check of a pose's solution: ``check(index, q)`` returns its events (empty when it passes).
PoseCheck = Callable[[int, np.ndarray], list[dict]]


def pose_events(robot: Robot, solving: PoseSolving, index: int, res: ik.Result,
                q_prev: np.ndarray | None) -> tuple[list[dict], np.ndarray]:
    """The events of solution ``res`` of pose ``index`` (module docstring; ``q_prev``: the configuration
    before it, None for no jump test) and the singular values of its task Jacobian."""
    q, events = res.q, []
    if not res.success:
        events.append({"kind": "ik_failed", "index": index, "detail": res.message,
                       "position_error": float(res.position_error),
                       "orientation_error": float(res.orientation_error)})
    if q_prev is not None:
        dq = np.abs(q - q_prev)
        j = int(np.argmax(dq))
        if dq[j] > solving.jump_threshold:
            name = robot.joint_names[j]
            events.append({"kind": "joint_jump", "index": index, "joint": name, "size": float(dq[j]),
                           "detail": f"max |dq| = {dq[j]:.3f} > {solving.jump_threshold} ({name})"})
    low = q - robot.lower < solving.limit_margin
    near = np.flatnonzero(low | (robot.upper - q < solving.limit_margin))
    if near.size:
        names = [robot.joint_names[j] for j in near]
        events.append({"kind": "limit_contact", "index": index, "detail": ", ".join(names), "joints": names,
                       "sides": ["lower" if low[j] else "upper" for j in near]})
    sv = robot.singular_values(q, solving.frame)
    if sv[-1] < solving.singular_tol:
        events.append({"kind": "singular", "index": index, "detail": f"sigma_min = {sv[-1]:.2e}",
                       "sigma_min": float(sv[-1])})
    return events, sv


def _pose_budget(max_time: float | None, deadline: float | None) -> float | None:
    """A pose's IK budget (s): ``max_time`` within the time left before ``deadline`` (-1 when spent)."""
    if deadline is None:
        return max_time
    left = deadline - time.monotonic()
    if left <= MIN_POSE_TIME:
        return -1.0
    return left if max_time is None else min(max_time, left)


def follow_poses(robot: Robot, poses: np.ndarray, q_start: np.ndarray, solving: PoseSolving, *,
                 stop_on: Collection[str] = (), q_before: np.ndarray | None = None,
                 deadline: float | None = None, check: PoseCheck | None = None) -> PoseTrack:
    """Solve ``poses`` ``(n, 4, 4)`` in order, each warm started from the solution before (the first from
    ``q_start``), judging each solution (:func:`pose_events`).

    ``stop_on``: the event kinds that end the loop at the pose where they occur; ``q_before``: the
    configuration the first solution is tested against for a joint jump (None: no test);
    ``deadline`` (``time.monotonic()`` value, None = none): no pose is started after it (a ``time_cap``
    event); ``check``: run on every solution that raised no event of ``stop_on``, its events added.
    With ``solving.max_time`` None and no ``deadline`` the clock decides nothing.
    """
    n, nq = len(poses), robot.nq
    Q = np.empty((n, nq))
    errors = np.empty((4, n))  # position, orientation, manipulability, sigma_min
    events: list[dict] = []
    stop_events: list[dict] = []
    stop_reason, done, q_prev, q_jump = "completed", 0, q_start, q_before
    for i, T in enumerate(poses):
        budget = _pose_budget(solving.max_time, deadline)
        if budget is not None and budget < 0:
            stop_reason = "time_cap"
            stop_events = [{"kind": "time_cap", "index": i,
                            "detail": f"the plan's time was spent; {n - i} of {n} poses not attempted"}]
            events += stop_events
            break
        res = solving.solve(robot, T, q_prev, budget)
        Q[i], done = res.q, i + 1
        new, sv = pose_events(robot, solving, i, res, q_jump)
        errors[:, i] = res.position_error, res.orientation_error, float(np.prod(sv)), sv[-1]
        if check is not None and not any(e["kind"] in stop_on for e in new):
            new += check(i, Q[i])
        events += new
        hit = [e["kind"] for e in new if e["kind"] in stop_on]
        if hit:
            stop_reason, stop_events = hit[0], new
            break
        q_prev = q_jump = Q[i]
    return PoseTrack(Q[:done], errors[0, :done], errors[1, :done], errors[2, :done], errors[3, :done], events,
                     stop_reason, stop_events, n)


@dataclass
class CartesianPlan:
    """Result of :func:`cartesian_to_joint`."""

    trajectory: JointTrajectory
    poses: np.ndarray  #: (n, 4, 4) the interpolated target poses
    position_errors: np.ndarray  #: (n,) m, kept components
    orientation_errors: np.ndarray  #: (n,) rad, kept components
    manipulability: np.ndarray  #: (n,) along the path, task rows
    events: list[dict] = field(default_factory=list)
    success: bool = True
    message: str = ""
    stop_reason: str = "completed"  #: "completed", "ik_failed" (stop_on_failure) or "time_cap" (total_time)
    total_poses: int = 0  #: interpolated poses requested (``len(poses)`` unless the plan stopped early)

    @property
    def max_position_error(self) -> float:
        """Largest position error over the solved poses (m; 0 when none was solved)."""
        return float(np.max(self.position_errors)) if self.position_errors.size else 0.0

    @property
    def max_orientation_error(self) -> float:
        """Largest orientation error over the solved poses (rad; 0 when none was solved)."""
        return float(np.max(self.orientation_errors)) if self.orientation_errors.size else 0.0


def _checked_arguments(poses: Any, steps: Any, dt: Any, interpolation: Any, total_time: Any) -> list:
    """``poses`` as a list, after checking the arguments of :func:`cartesian_to_joint` named here (``steps``
    an integer >= 1 making at most :data:`~kinserve.planners.checks.MAX_SAMPLES` poses in all)."""
    if isinstance(poses, np.ndarray) and poses.ndim == 3:
        poses = list(poses)
    if not isinstance(poses, (list, tuple)) or len(poses) < 2:
        raise ShapeError("poses must be a list of at least two 4x4 poses")
    most = (MAX_SAMPLES - 1) // (len(poses) - 1) - 1
    if not (isinstance(steps, numbers.Integral) and not isinstance(steps, bool)) or not 1 <= steps <= most:
        raise InputError(f"steps must be an integer from 1 to {most:,} ({MAX_SAMPLES:,} poses at most over "
                         f"{len(poses) - 1} segments), got {steps!r}")
    check_last_time(as_positive(dt, "dt"), (steps + 1) * (len(poses) - 1) + 1)  # before any pose is solved
    as_choice(interpolation, "interpolation", METHODS)
    if total_time is not None:
        as_positive(total_time, "total_time")
    return list(poses)


def _checked_thresholds(max_time: Any, jump_threshold: Any, limit_margin: Any,
                        singular_tol: Any) -> tuple[float | None, float, float, float]:
    """``max_time`` (None or a number of seconds in ``(0, 1e6]``), ``jump_threshold`` (> 0),
    ``limit_margin`` and ``singular_tol`` (>= 0), each finite and at most 1e6, as floats (a NaN threshold
    would switch its check off silently)."""
    return (None if max_time is None else as_positive(max_time, "max_time"),
            as_positive(jump_threshold, "jump_threshold"), as_nonnegative(limit_margin, "limit_margin"),
            as_nonnegative(singular_tol, "singular_tol"))


def _plan_of(robot: Robot, path: np.ndarray, q0: np.ndarray, track: PoseTrack, solving: PoseSolving,
             dt: float, total_time: float | None) -> CartesianPlan:
    """The :class:`CartesianPlan` of ``track`` over ``path`` (a plan stopped before its first pose holds the
    start configuration ``q0``)."""
    Q, manip = track.q, track.manipulability
    pos_err, rot_err = track.position_errors, track.orientation_errors
    if len(Q) == 0:  # the time cap was spent before the first pose: the path is the start configuration
        Q = q0[None, :].copy()
        pos_err, rot_err = (np.array([e]) for e in ik.Target(robot, path[0], solving.frame,
                                                              solving.relax).errors_at(robot, q0))
        manip = np.array([float(np.prod(robot.singular_values(q0, solving.frame)))])
    done, n, events = len(Q), track.total, track.events
    traj = JointTrajectory.from_positions(robot.joint_names, Q, dt)
    failed = [e for e in events if e["kind"] in ("ik_failed", "joint_jump", "time_cap")]
    message = "all poses reached, joint path continuous" if not failed else (
        f"{sum(e['kind'] == 'ik_failed' for e in events)} poses not reached, "
        f"{sum(e['kind'] == 'joint_jump' for e in events)} joint jumps"
    )
    if track.stop_reason == "ik_failed":
        message += f"; stopped at the first pose not reached (index {done - 1} of {n})"
    elif track.stop_reason == "time_cap":
        message += f"; stopped by the time cap of {total_time:g} s after {len(track.q)} of {n} poses"
    return CartesianPlan(traj, path[:done], pos_err, rot_err, manip, events, success=not failed,
                         message=message, stop_reason=track.stop_reason, total_poses=n)


def cartesian_to_joint(
    robot: Robot,
    poses: Sequence[PoseLike],
    q0: VectorLike | None = None,
    *,
    frame: str | None = None,
    steps: int = 10,
    dt: float = 0.1,
    interpolation: str = "decoupled",
    relax: Sequence[str] = (),
    spheres: Sequence[ik.Sphere] = (),
    centring: float = 0.0,
    method: str = "auto",
    max_time: float | None = 0.2,
    tol_pos: float = 1e-4,
    tol_rot: float = 1e-3,
    jump_threshold: float = 0.5,
    limit_margin: float = 1e-3,
    singular_tol: float = 1e-4,
    seed: int | None = 0,
    total_time: float | None = None,
    stop_on_failure: bool = False,
    iteration_budget: int | None = None,
) -> CartesianPlan:
    """Joint trajectory through ``poses`` (a list of 4x4), ``steps`` interpolated poses per segment.

    ``q0`` is the configuration the path starts from (default: the robot's
    neutral configuration); the first pose is solved from it. ``dt`` (s) is the
    time between consecutive points. ``max_time`` (s) is each pose's IK budget,
    ``total_time`` (s, None = unbounded) the whole plan's; ``stop_on_failure``
    ends the plan at the first pose not reached (module docstring).
    ``iteration_budget`` (None = none) is each pose's IK option of that name;
    with ``max_time=None`` and no ``total_time`` the clock then decides nothing.
    The poses are solved by :func:`follow_poses`.

    Refused (:class:`InputError` / :class:`ShapeError` naming the argument): ``robot`` not a
    :class:`~kinserve.kinematics.Robot`; fewer than two poses; ``steps``
    not an integer from 1 to the bound that keeps the path within
    :data:`~kinserve.planners.checks.MAX_SAMPLES` poses; ``dt``, ``total_time``, ``max_time`` (when not
    None) or ``jump_threshold`` not finite numbers in ``(0, 1e6]``; ``limit_margin`` or ``singular_tol``
    not finite numbers in ``[0, 1e6]``; an unknown ``interpolation``; ``stop_on_failure`` not True or False;
    a ``dt`` whose path's last time, ``dt`` times the number of poses less one, would pass 1e6 s.
    """
    robot = as_robot(robot)
    poses = _checked_arguments(poses, steps, dt, interpolation, total_time)
    stop_on_failure = as_flag(stop_on_failure, "stop_on_failure")
    max_time, jump_threshold, limit_margin, singular_tol = _checked_thresholds(max_time, jump_threshold,
                                                                               limit_margin, singular_tol)
    deadline = None if total_time is None else time.monotonic() + float(total_time)
    q = robot.neutral() if q0 is None else robot.check_q(q0, "q0")
    path = interpolate_checkpoints(poses, steps, method=interpolation)  # validates every pose
    solving = PoseSolving(frame, relax, spheres, centring, method, max_time, tol_pos, tol_rot, seed,
                          iteration_budget, jump_threshold, limit_margin, singular_tol)
    track = follow_poses(robot, path, q, solving, stop_on=("ik_failed",) if stop_on_failure else (),
                         deadline=deadline)
    return _plan_of(robot, path, q, track, solving, dt, total_time)
