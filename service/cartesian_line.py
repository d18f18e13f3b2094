"""``POST /plan/cartesian`` in line mode, in a solver process: :func:`kinserve.planners.plan_cartesian` from
``q0`` to each pose in turn.

Each leg is a straight line of the frame in SE(3) from where the last one ended,
followed as far as it can go (the move stops at a pose not reached, a joint jump
over ``jump_threshold``, a joint limit, a singularity or a collision); the legs'
trajectories, each at rest at both ends, are joined end to start. The whole
request gets the time left to its deadline; each pose's IK runs on an iteration
budget.
"""

from __future__ import annotations

import numpy as np

from kinserve.kinematics.errors import InputError

from . import schemas as S
from .collision_endpoint import obstacles_of
from .executor import Deadline
from .fields import FieldError, field
from .jobs import robot_of, trajectory_out

#: The fields that choose the line mode (any of them given).
LINE_FIELDS = ("jump_threshold", "obstacles", "self_collision", "max_step", "max_rotation_step")
#: Fields of the interpolated mode only.
INTERPOLATED_FIELDS = ("steps", "dt", "stop_on_failure")


def wants_line(req: S.CartesianPlanRequest) -> bool:
    """True when the request gives a field of the line mode (:data:`LINE_FIELDS`)."""
    return any(name in req.model_fields_set for name in LINE_FIELDS)


def line_options(req: S.CartesianPlanRequest) -> dict:
    """The keyword arguments of ``plan_cartesian`` a request gives (its defaults for the others)."""
    for name in INTERPOLATED_FIELDS:
        if name in req.model_fields_set:
            raise FieldError(name, InputError(f"{name} belongs to the interpolated mode; with "
                                              f"{', '.join(LINE_FIELDS)} the steps come from max_step and "
                                              "max_rotation_step"))
    kw = {"frame": req.frame, "interpolation": req.interpolation, "relax": tuple(req.relax),
          "obstacles": obstacles_of(req.obstacles)}
    for name in ("jump_threshold", "self_collision", "max_step", "max_rotation_step"):
        if getattr(req, name) is not None:
            kw[name] = getattr(req, name)
    return kw


def joined(legs: list, nq: int, joint_names: list[str]) -> dict:
    """The legs' trajectories as one (each leg's times shifted to start where the last one ended, its first
    sample, the last one's end, dropped); no samples when no leg moved."""
    times, parts = [], {"positions": [], "velocities": [], "accelerations": []}
    t_end = 0.0
    for leg in legs:
        traj = leg.trajectory
        if traj is None or traj.velocities is None or traj.accelerations is None:
            continue
        first = 0 if not times else 1
        times.append(np.asarray(traj.times)[first:] + t_end)
        for name in parts:
            parts[name].append(np.asarray(getattr(traj, name))[first:])
        t_end = float(times[-1][-1]) if len(times[-1]) else t_end
    if not times:
        empty = np.zeros((0, nq))
        return {"joint_names": joint_names, "times": [], "positions": empty.tolist(),
                "velocities": empty.tolist(), "accelerations": empty.tolist()}
    from kinserve.planners import JointTrajectory

    return trajectory_out(JointTrajectory(joint_names, np.concatenate(times),
                                          *(np.concatenate(parts[n]) for n in parts)))


def move_through(deadline: Deadline, req: S.CartesianPlanRequest) -> dict:
    """``POST /plan/cartesian`` in line mode: the legs from ``q0`` through ``poses``, until one stops."""
    from kinserve.planners import plan_cartesian
    from kinserve.planners.cartesian_move import line_steps

    r = robot_of(req)
    if req.q0 is None:
        raise FieldError("q0", InputError("q0 (the start configuration) is required in the line mode"))
    with field("q0"):
        q = r.check_q(req.q0, "q0", check_limits=True)
    with field("frame"):
        if req.frame is not None:
            r.frame_id(req.frame)
    kw = line_options(req)
    poses = [np.asarray(p, dtype=float) for p in req.poses]
    step, turn = kw.get("max_step", 0.01), kw.get("max_rotation_step", 0.05)
    ends = [r.fk(q, req.frame), *poses]
    total = sum(line_steps(a, b, step, turn, req.interpolation) for a, b in zip(ends[:-1], ends[1:]))
    legs = []
    for i, T in enumerate(poses):
        with field(f"poses[{i}]"):
            leg = plan_cartesian(r, q, T, max_time=max(deadline.remaining, 1e-3), **kw)
        legs.append(leg)
        if not leg.success:
            break
        q = leg.path[-1]
    last = legs[-1]
    errors = [e for leg in legs for e in (leg.position_errors, leg.orientation_errors)]
    return {
        "success": bool(last.success), "trajectory": joined(legs, r.nq, list(r.joint_names)),
        "max_position_error": float(max((np.max(e) for e in errors[0::2] if len(e)), default=0.0)),
        "max_orientation_error": float(max((np.max(e) for e in errors[1::2] if len(e)), default=0.0)),
        "events": [{**e, "pose": i} for i, leg in enumerate(legs) for e in leg.events],
        "message": last.message if len(poses) == 1 else f"leg {len(legs)} of {len(poses)}: {last.message}",
        "stop_reason": last.stop,
        "poses_attempted": int(sum(len(leg.path) - 1 for leg in legs) + (0 if last.success else 1)),
        "total_poses": int(total),
    }


__all__ = ["INTERPOLATED_FIELDS", "LINE_FIELDS", "joined", "line_options", "move_through", "wants_line"]
