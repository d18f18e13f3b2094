"""S3: the youBot checkpoint tour - shortest order, SE(3) interpolation, position-only IK, a joint trajectory
(SCENARIOS.md S3, seeds 000 / 001 question 6).

1. *Input* - the current joint vector and the checkpoints from a plain file
   (:mod:`scenarios.checkpoint_file`, JSON or CSV; a checkpoint is a joint
   vector or a Cartesian pose). The example ``scenarios/data/youbot_checkpoints.json``
   holds the current configuration and four checkpoint joint vectors;
   ``youbot_checkpoints.csv`` holds the same points with checkpoint D given as
   a Cartesian pose.
2. *Poses* - forward kinematics of every joint vector (``robots.load("youbot")``).
3. *Order* - the shortest open path that starts at the current pose and
   visits every checkpoint once, with the **Euclidean** distance between tool
   positions as the cost, ``sum_k |p_{o_k} - p_{o_{k+1}}|``: exact Held-Karp
   dynamic programming (:func:`planners.shortest_order`; heuristic with a
   certified bound above 12 points). Seed 001 minimises ``0.5 |.|^2`` instead,
   which ranks orders differently; that order is reported for comparison
   (``order_squared_metric``, its Euclidean length ``squared_metric_length``).
4. *Interpolation* - ``n`` intermediate poses between consecutive checkpoints
   (``n + 1`` steps per leg): translation on the straight line and rotation by
   slerp ``R(s) = R_a exp(s log(R_a^T R_b))`` (decoupled, default) or the screw
   motion ``T_a exp(s log(T_a^-1 T_b))`` (``interpolation="screw"``).
5. *Position-only IK* - roll, pitch and yaw relaxed; each pose is solved with
   the Jacobian pseudo-inverse ``dq = J^+ e`` (the seed's method;
   ``ik_method`` picks another) warm started from the previous solution
   (:func:`planners.cartesian_to_joint`), so the arm follows one continuous
   branch; each solve is ended by :data:`IK_ITERATION_BUDGET` iterations, not
   by the clock. The position error of every point is re-measured here with FK.
6. *Trajectory* - a :class:`planners.JointTrajectory` (joint names, points with
   positions, finite-difference velocities and ``time_from_start = i dt``)
   saved as ``trajectory.json`` and ``trajectory.csv``.

Artefacts: ``trajectory.json``, ``trajectory.csv``, ``joints.png`` (joints
against time with their limits), ``position_error.png``, ``path.png`` (top and
side views of the tool path with the checkpoints in visiting order),
``manipulability.png``, ``scene.html`` (the arm animated along the tour,
checkpoint triads, the tool path as a line).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from kinserve import planners, robots, viz
from kinserve.kinematics.errors import InputError

from .checkpoint_file import load_checkpoints

DATA = Path(__file__).resolve().parent / "data"
#: The example checkpoint file shipped with the repository.
CHECKPOINTS = DATA / "youbot_checkpoints.json"
#: Position-only IK: the orientation components left free.
RELAX = ("roll", "pitch", "yaw")


def checkpoint_poses(robot, cf) -> tuple[list[str], np.ndarray]:
    """Names ``["current", ...]`` and poses ``(N, 4, 4)``: FK of joint vectors, Cartesian poses as given."""
    names = ["current"] + cf.names
    poses = [robot.fk(cf.current).copy()]
    for c in cf.checkpoints:
        poses.append(robot.fk(c.q).copy() if c.q is not None else np.asarray(c.pose, dtype=float))
    return names, np.array(poses)


def _path_figure(P_desired, P_tool, positions, names, order):
    fig = Figure(figsize=(11.0, 5.0), layout="constrained")
    FigureCanvasAgg(fig)
    views = ((0, 1, "top view", "x (m)", "y (m)"), (0, 2, "side view", "x (m)", "z (m)"))
    for k, (a, b, title, xl, yl) in enumerate(views):
        ax = fig.add_subplot(1, 2, k + 1)
        ax.plot(P_desired[:, a], P_desired[:, b], "--", color="grey", linewidth=1.2,
                label="interpolated poses (targets)")
        ax.plot(P_tool[:, a], P_tool[:, b], "-", color=viz.colors.to_rgb("blue"), linewidth=1.8,
                label="tool path (FK of the trajectory)")
        for rank, i in enumerate(order):
            p = positions[i]
            ax.plot([p[a]], [p[b]], "o", color=viz.colors.to_rgb("red" if i == 0 else "orange"), markersize=8,
                    markeredgecolor="black", label=None)
            ax.annotate(f"{rank}: {names[i]}", (p[a], p[b]), textcoords="offset points",
                        xytext=(6, 6), fontsize=9)
        ax.plot([0], [0], "ks", markersize=7, label="arm base (world origin)")
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(True, alpha=0.3)
        ax.set_xlabel(xl)
        ax.set_ylabel(yl)
        ax.set_title(title, fontsize=10)
    fig.axes[0].legend(fontsize=8, loc="best")
    fig.suptitle("S3 youBot tour: checkpoints in visiting order (0 = current pose), "
                 "Euclidean shortest path", fontsize=11)
    return fig


#: Iterations each pose's IK may take, all its starts together: the budget, not a wall-clock limit, ends
#: every solve, so the trajectory depends on the inputs only, never on the machine's speed or load.
IK_ITERATION_BUDGET = 500


def run(out: Path, *, checkpoints=CHECKPOINTS, n: int = 20, dt: float = 0.1, interpolation: str = "decoupled",
        ik_method: str = "pseudo_inverse", tol_pos: float = 1e-6, fps: float | None = None,
        scene: bool = True) -> dict:
    """Run S3 into ``out``; returns the key numbers (see the module docstring).

    ``checkpoints``: a ``.json`` / ``.csv`` checkpoint file; ``n``: intermediate
    poses per leg; ``dt`` (s): time between trajectory points.
    """
    out = Path(out)
    if interpolation not in ("decoupled", "screw"):
        raise InputError(f"interpolation must be 'decoupled' or 'screw', got {interpolation!r}")
    robot = robots.load("youbot")
    cf = load_checkpoints(checkpoints, robot.nq)
    names, poses = checkpoint_poses(robot, cf)
    positions = poses[:, :3, 3]

    # order: exact, Euclidean; and what the seed's 0.5 * squared metric would pick
    best = planners.shortest_order(positions, start=0)
    C = planners.euclidean_cost_matrix(positions)
    squared = planners.shortest_order(cost=0.5 * C**2, start=0)

    # interpolation + position-only IK with warm start -> joint trajectory
    tour = [poses[i] for i in best.order]
    plan = planners.cartesian_to_joint(robot, tour, cf.current, steps=int(n), dt=float(dt),
                                       interpolation=interpolation, relax=RELAX, method=ik_method,
                                       tol_pos=tol_pos, max_time=None, iteration_budget=IK_ITERATION_BUDGET)
    traj = plan.trajectory
    traj.save(out / "trajectory.json")
    traj.save(out / "trajectory.csv")

    # independent check of the tracking: FK of every trajectory point against its interpolated target
    P_tool = robot.fk_batch(traj.positions)[:, :3, 3]
    P_desired = plan.poses[:, :3, 3]
    err = np.linalg.norm(P_tool - P_desired, axis=1)
    at_checkpoints = np.arange(len(tour)) * (int(n) + 1)
    jumps = np.abs(np.diff(traj.positions, axis=0)).max(axis=1)

    # plots
    t = traj.times
    fig = viz.joints_figure(t, traj.positions, robot.joint_names, limits=(robot.lower, robot.upper),
                            xlabel="time (s)", ylabel="joint angle (rad)",
                            title=f"S3 joint trajectory ({traj.n_points} points, dt = {dt:g} s); dotted: "
                                  "limits")
    ax = fig.axes[0]
    for rank, k in enumerate(at_checkpoints):
        ax.axvline(t[k], color="grey", linewidth=0.6, linestyle="--")
        ax.annotate(names[best.order[rank]], (t[k], 1.0), xycoords=("data", "axes fraction"), xytext=(2, -12),
                    textcoords="offset points", fontsize=8)
    ax.set_ylim(-3.3, 3.3)
    ax.legend(loc="lower right", fontsize=8, ncol=3)
    viz.save_png(fig, out / "joints.png")
    fig = viz.errors_figure(t, {"|p_tool − p_target| (m)": err}, xlabel="time (s)",
                            ylabel="position error (m)",
                            title=f"S3 position-only IK ({ik_method}, warm start): "
                                  "error per trajectory point", tolerance=tol_pos)
    viz.save_png(fig, out / "position_error.png")
    viz.save_png(_path_figure(P_desired, P_tool, positions, names, best.order), out / "path.png")
    fig = viz.manipulability_figure(t, {"w = √det(JᵀJ) = ∏σᵢ of the 6×5 J": plan.manipulability},
                                    xlabel="time (s)", title="S3 manipulability along the tour")
    viz.save_png(fig, out / "manipulability.png")

    if scene:
        fps = 1.0 / float(dt) if fps is None else float(fps)
        sc = viz.Scene("kinserve S3 youBot tour: checkpoints (triads) in the shortest order, tool path")
        arm = sc.add_robot(robot, traj.positions[0], name="youbot")
        for i, T in enumerate(poses):
            sc.add_frame(f"checkpoint_{names[i]}", T, length=0.06)
        sc.add_path("tool_path", P_tool, color="blue")
        sc.add_path("checkpoint_order", positions[best.order], color="orange", linewidth=1.0)
        anim = viz.Animation(sc, fps=fps)
        anim.robot(arm.name, traj.positions)
        anim.apply()
        viz.export_html(sc, out / "scene.html")

    return {  # scalars first: `kinserve demo` prints the first few
        "visiting_order": " -> ".join(names[i] for i in best.order),
        "tour_length": best.cost,
        "order_names": [names[i] for i in best.order],
        "n_points": traj.n_points,
        "max_position_error": float(err.max()),
        "duration": traj.duration,
        "max_joint_step": float(jumps.max()),
        "ik_success": plan.success,
        "order": best.order,
        "order_method": best.method,
        "order_gap_bound": best.gap_bound,
        "optimal": best.optimal,
        "order_squared_metric": squared.order,
        "squared_metric_length": planners.path_cost(C, squared.order),
        "checkpoint_file": str(checkpoints),
        "checkpoint_names": names,
        "checkpoint_kinds": ["q"] + [c.kind for c in cf.checkpoints],
        "checkpoint_positions": positions,
        "checkpoint_poses": poses,
        "current_q": cf.current,
        "distance_matrix": C,
        "n_intermediate": int(n),
        "dt": float(dt),
        "interpolation": interpolation,
        "ik_method": ik_method,
        "relaxed": list(RELAX),
        "checkpoint_indices": at_checkpoints,
        "position_errors": err,
        "ik_message": plan.message,
        "events": plan.events,
        "joint_names": robot.joint_names,
        "files": {"json": "trajectory.json", "csv": "trajectory.csv"},
    }
