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
"""

from __future__ import annotations

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

    @property
    def max_position_error(self) -> float:
        return float(np.max(self.position_errors)) if self.position_errors.size else 0.0

    @property
    def max_orientation_error(self) -> float:
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
) -> CartesianPlan:
    """Joint trajectory through ``poses`` (a list of 4x4), ``steps`` interpolated poses per segment.

    ``q0`` is the configuration the path starts from (default: the robot's
    neutral configuration); the first pose is solved from it. ``dt`` (s) is the
    time between consecutive points.
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
    q = robot.neutral() if q0 is None else robot.check_q(q0, "q0")
    path = interpolate_checkpoints(poses, steps, method=interpolation)  # validates every pose

    n = len(path)
    Q = np.empty((n, robot.nq))
    pos_err = np.empty(n)
    rot_err = np.empty(n)
    manip = np.empty(n)
    events: list[dict] = []
    q_prev = q
    for i, T in enumerate(path):
        res = ik.solve(robot, T, q_prev, frame=frame, relax=relax, spheres=spheres, centring=centring,
                       method=method, max_time=max_time, tol_pos=tol_pos, tol_rot=tol_rot, seed=seed)
        Q[i] = res.q
        pos_err[i], rot_err[i] = res.position_error, res.orientation_error
        if not res.success:
            events.append({"kind": "ik_failed", "index": i, "detail": res.message})
        if i > 0:
            jump = float(np.max(np.abs(Q[i] - Q[i - 1])))
            if jump > jump_threshold:
                events.append({"kind": "joint_jump", "index": i, "detail": f"max |dq| = {jump:.3f} > {jump_threshold}"})
        near = np.flatnonzero((Q[i] - robot.lower < limit_margin) | (robot.upper - Q[i] < limit_margin))
        if near.size:
            names = ", ".join(robot.joint_names[j] for j in near)
            events.append({"kind": "limit_contact", "index": i, "detail": names})
        sv = robot.singular_values(Q[i], frame)
        manip[i] = float(np.prod(sv))
        if sv[-1] < singular_tol:
            events.append({"kind": "singular", "index": i, "detail": f"sigma_min = {sv[-1]:.2e}"})
        q_prev = Q[i]

    traj = JointTrajectory.from_positions(robot.joint_names, Q, dt)
    failed = [e for e in events if e["kind"] in ("ik_failed", "joint_jump")]
    message = "all poses reached, joint path continuous" if not failed else (
        f"{sum(e['kind'] == 'ik_failed' for e in events)} poses not reached, "
        f"{sum(e['kind'] == 'joint_jump' for e in events)} joint jumps"
    )
    return CartesianPlan(traj, path, pos_err, rot_err, manip, events, success=not failed, message=message)
