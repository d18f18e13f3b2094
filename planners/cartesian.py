"""Cartesian path -> joint trajectory through inverse kinematics.

Given poses ``T_0 ... T_m`` of a frame, ``steps`` poses are interpolated per
segment (decoupled: linear translation + slerp; or screw:
``T_k exp(s log(T_k^-1 T_{k+1}))``, see :mod:`planners.se3_interpolation`).
Each pose is solved with :func:`ik.solve`, warm started from the previous
solution so the arm follows one continuous branch; relaxation, spheres and
centring are passed through. The joint positions become a
:class:`JointTrajectory` with ``time_from_start = i * dt`` and finite-difference
velocities/accelerations.

Reported events (``CartesianPlan.events``, each ``{"kind", "index", "detail"}``):

* ``ik_failed`` - the pose at this index was not reached within tolerance;
* ``joint_jump`` - ``max |q_i - q_{i-1}| > jump_threshold`` rad (or m): the
  solution switched branch, the path is not continuous in joint space;
* ``limit_contact`` - a joint within ``limit_margin`` of a limit;
* ``singular`` - the task Jacobian's smallest singular value below
  ``singular_tol`` (manipulability near zero).

Bounded work: ``total_time`` (s) caps the whole plan - each pose's IK budget
is ``min(max_time, time left)`` and no pose is started once it is spent - and
``stop_on_failure=True`` stops at the first pose that is not reached. A plan
cut short holds the poses attempted so far (the failed one last);
``CartesianPlan.stop_reason`` says why it ended (``"completed"``,
``"ik_failed"``, ``"time_cap"``) and ``total_poses`` how many were asked for.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from kinserve import ik
from kinserve.kinematics import Robot
from kinserve.kinematics.errors import InputError, ShapeError
from kinserve.kinematics.types import PoseLike, VectorLike

from .joint_trajectory import JointTrajectory
from .se3_interpolation import interpolate_checkpoints


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
    """
    if isinstance(poses, np.ndarray) and poses.ndim == 3:
        poses = list(poses)
    if not isinstance(poses, (list, tuple)) or len(poses) < 2:
        raise ShapeError("poses must be a list of at least two 4x4 poses")
    if not isinstance(steps, (int, np.integer)) or steps < 1:
        raise InputError(f"steps must be a positive integer, got {steps!r}")
    if not np.isfinite(dt) or dt <= 0:
        raise InputError(f"dt must be a positive number of seconds, got {dt!r}")
    if interpolation not in ("decoupled", "screw"):
        raise InputError(f"interpolation must be 'decoupled' or 'screw', got {interpolation!r}")
    if (total_time is not None
        and not (isinstance(total_time, (int, float)) and np.isfinite(total_time) and total_time > 0)):
        raise InputError(f"total_time must be a positive number of seconds or None, got {total_time!r}")
    t_end = None if total_time is None else time.monotonic() + float(total_time)
    q = robot.neutral() if q0 is None else robot.check_q(q0, "q0")
    path = interpolate_checkpoints(poses, steps, method=interpolation)  # validates every pose

    n = len(path)
    Q = np.empty((n, robot.nq))
    pos_err = np.empty(n)
    rot_err = np.empty(n)
    manip = np.empty(n)
    events: list[dict] = []
    q_prev = q
    stop_reason = "completed"
    done = 0
    for i, T in enumerate(path):
        budget = max_time
        if t_end is not None:
            left = t_end - time.monotonic()
            if left <= 1e-3:
                stop_reason = "time_cap"
                events.append({"kind": "time_cap", "index": i,
                               "detail": f"total_time {total_time:g} s spent; "
                                         f"poses {i}..{n - 1} not attempted"})
                break
            budget = left if budget is None else min(budget, left)
        res = ik.solve(robot, T, q_prev, frame=frame, relax=relax, spheres=spheres, centring=centring,
                       method=method, max_time=budget, tol_pos=tol_pos, tol_rot=tol_rot, seed=seed,
                       **({} if iteration_budget is None else {"iteration_budget": iteration_budget}))
        done = i + 1
        Q[i] = res.q
        pos_err[i], rot_err[i] = res.position_error, res.orientation_error
        if not res.success:
            events.append({"kind": "ik_failed", "index": i, "detail": res.message})
            if stop_on_failure:
                stop_reason = "ik_failed"
        if i > 0:
            jump = float(np.max(np.abs(Q[i] - Q[i - 1])))
            if jump > jump_threshold:
                events.append({"kind": "joint_jump", "index": i,
                               "detail": f"max |dq| = {jump:.3f} > {jump_threshold}"})
        near = np.flatnonzero((Q[i] - robot.lower < limit_margin) | (robot.upper - Q[i] < limit_margin))
        if near.size:
            names = ", ".join(robot.joint_names[j] for j in near)
            events.append({"kind": "limit_contact", "index": i, "detail": names})
        sv = robot.singular_values(Q[i], frame)
        manip[i] = float(np.prod(sv))
        if sv[-1] < singular_tol:
            events.append({"kind": "singular", "index": i, "detail": f"sigma_min = {sv[-1]:.2e}"})
        q_prev = Q[i]
        if stop_reason != "completed":
            break

    if done == 0:  # the time cap was spent before the first pose: the path is the start configuration
        Q[0], done = q, 1
        pos_err[0], rot_err[0] = ik.Target(robot, path[0], frame, relax).errors_at(robot, q)
        manip[0] = float(np.prod(robot.singular_values(q, frame)))
    traj = JointTrajectory.from_positions(robot.joint_names, Q[:done], dt)
    failed = [e for e in events if e["kind"] in ("ik_failed", "joint_jump", "time_cap")]
    message = "all poses reached, joint path continuous" if not failed else (
        f"{sum(e['kind'] == 'ik_failed' for e in events)} poses not reached, "
        f"{sum(e['kind'] == 'joint_jump' for e in events)} joint jumps"
    )
    if stop_reason == "ik_failed":
        message += f"; stopped at the first pose not reached (index {done - 1} of {n})"
    elif stop_reason == "time_cap":
        message += f"; stopped by the time cap of {total_time:g} s after {done} of {n} poses"
    return CartesianPlan(traj, path[:done], pos_err[:done], rot_err[:done], manip[:done], events,
                         success=not failed, message=message, stop_reason=stop_reason, total_poses=n)
