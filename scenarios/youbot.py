"""S2: the KUKA youBot 5-DOF arm - DH forward kinematics, Jacobian, singularity, closed-form IK (SCENARIOS.md
S2).

Model (``robots.load("youbot")``, :mod:`robots.youbot`): standard DH
``A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)`` with

    a = [-0.033, 0.155, 0.135, 0.002, 0.0],  alpha = [pi/2, 0, 0, pi/2, pi],  d = [0.145, 0, 0, 0, -0.185]

and every joint about ``+z`` of the previous DH frame (the youBot's own URDF
turns joint 1 about ``-z``; seed 001 flips ``z0`` to match it - this model is
the DH one, stated in its description). Limits (deg): A1 +-169, A2 -65..90,
A3 -151..146, A4 +-102.5, A5 +-167.5.

1. *FK* - the DH product computed here with NumPy (:func:`robots.dh_fk`)
   against Pinocchio on the URDF model at ``n_random`` random configurations:
   ``fk_max_difference`` (max entry of ``|T_DH - T_URDF|``).
2. *Jacobian* - the 6x5 geometric Jacobian, column ``i`` (all joints revolute)
   ``[z_{i-1} x (p_e - o_{i-1}); z_{i-1}]`` from the DH frames, against
   ``Robot.jacobian`` (Pinocchio, world axes): ``jacobian_max_difference``.
3. *Singularity* - a 6x5 matrix has no determinant (seed 001's ``det(J)`` is
   wrong). Measures from the singular values ``sigma_1 >= ... >= sigma_5``:
   numerical rank (``sigma_i > tol sigma_1``), ``sigma_min`` and Yoshikawa's
   manipulability ``w = sqrt(det(J^T J)) = prod sigma_i``. Joints 2, 3, 4 are
   parallel; their planar sub-chain loses rank when ``a2 a3 sin(q3) = 0``:
   the stretched elbow ``q3 = 0`` is singular (rank 4), detected by the sweep
   of ``q3`` over its range (``manipulability.png``).
4. *Closed-form IK* (:func:`ik.solve_all`, kinematic decoupling, see
   :mod:`ik.closed_form.youbot`): ``theta1 = atan2(p_y, p_x)`` and the
   reach-over-the-back ``theta1 + pi``; the wrist point ``W = p - d5 z5``;
   law of cosines for ``theta3`` (+-), ``theta2``; ``theta4 = Theta - theta2 -
   theta3``; ``theta5`` from the orientation. Every branch inside the limits
   is returned and checked here with the URDF model's FK. Two targets: one
   reached forwards (elbow up / down), one above the base where the
   reach-over-the-back branch is also inside the limits.
5. *Off the reachable set* - a 5-DOF arm reaches only orientations whose
   approach axis ``z5`` lies in the arm plane (normal ``n = (s1, -c1, 0)``).
   The target tilted out of that plane is reported (``off_reachable.note``)
   and the nearest reachable pose solved: same position, the target frame
   turned by the smallest rotation taking ``z5`` into the plane, so its
   orientation error equals the lower bound ``asin |z5 . n|``
   (``orientation_error_bound``).

Artefacts: ``manipulability.png`` (``w`` and ``sigma_min`` along the ``q3``
sweep), ``branches.png`` (joint values of every branch against the limits),
``scene.html`` (the arm at every branch, one row per target, with target
triads; the off-set target with its nearest reachable pose at the end of the
front row).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pinocchio as pin
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from kinserve import ik, robots, viz
from kinserve.kinematics import se3, singularity
from kinserve.robots.youbot import YOUBOT_DH

#: Configurations (rad) whose tool poses are the two IK targets.
Q_FORWARD = (0.4, 0.5, -0.9, -0.6, 0.3)
Q_ABOVE = (2.8, 1.3, 0.15, -1.5, 0.6)
#: Tilt (rad) about the tool x axis that takes the forward target off the reachable set.
OFF_TILT = 0.35
#: Relative singular-value tolerance of the rank test.
RANK_TOL = 1e-6


def dh_frames(q) -> list[np.ndarray]:
    """DH frames ``T_0 = I, T_1, ..., T_5`` (base = world) of the youBot at ``q``."""
    T = np.eye(4)
    out = [T]
    for (a, alpha, d, theta), qi in zip(YOUBOT_DH, q):
        T = T @ robots.dh_matrix(a, alpha, d, theta + qi)
        out.append(T)
    return out


def column_jacobian(q) -> np.ndarray:
    """6x5 geometric Jacobian from the DH frames: column ``i`` = ``[z_{i-1} x (p_e - o_{i-1}); z_{i-1}]``."""
    F = dh_frames(q)
    pe = F[-1][:3, 3]
    J = np.zeros((6, 5))
    for i in range(5):
        z, o = F[i][:3, 2], F[i][:3, 3]
        J[:3, i] = np.cross(z, pe - o)
        J[3:, i] = z
    return J


def measures(J: np.ndarray) -> dict:
    """Rank, singular values, ``sigma_min``, manipulability and condition number of ``J``."""
    s = singularity.singular_values(J)
    return {"rank": singularity.rank(J, RANK_TOL), "singular_values": s, "sigma_min": float(s[-1]),
            "manipulability": singularity.manipulability(J),
            "condition_number": singularity.condition_number(J),
            "singular": singularity.is_singular(J, RANK_TOL)}


def solve_branches(robot, T) -> dict:
    """Every closed-form branch for ``T``, each re-checked with the robot's FK and limits."""
    res = ik.solve_all(robot, T)
    rows = []
    for r in res:
        pe, re = se3.pose_error(robot.fk(r.q), T)
        rows.append({"branch": r.info["branch"], "q": r.q, "fk_position_error": pe,
                     "fk_orientation_error": re, "within_limits": robot.within_limits(r.q),
                     "success": r.success, "message": r.message})
    return {"target": T, "branches": rows, "n_branches": len(rows),
            "max_fk_position_error": max((b["fk_position_error"] for b in rows), default=math.nan),
            "max_fk_orientation_error": max((b["fk_orientation_error"] for b in rows), default=math.nan)}


def _tilted(T: np.ndarray, angle: float) -> np.ndarray:
    out = T.copy()
    out[:3, :3] = T[:3, :3] @ pin.exp3(np.array([angle, 0.0, 0.0]))
    return out


def _sweep_figure(q3, w, smin, q_ref, tol_line):
    fig = Figure(figsize=(7.0, 5.6), layout="constrained")
    FigureCanvasAgg(fig)
    top, bottom = fig.add_subplot(2, 1, 1), fig.add_subplot(2, 1, 2, sharex=None)
    deg = np.degrees(q3)
    top.plot(deg, w, color=viz.colors.to_rgb("blue"), linewidth=1.8, label="w = √det(JᵀJ) = ∏σᵢ (6×5 J)")
    bottom.plot(deg, smin, color=viz.colors.to_rgb("orange"), linewidth=1.8,
                label="σ_min (5th singular value)")
    bottom.axhline(tol_line, color="red", linestyle="--", linewidth=1.0,
                   label=f"rank tolerance {RANK_TOL:g}·σ₁")
    for ax in (top, bottom):
        ax.axvline(0.0, color="black", linestyle=":", linewidth=1.0)
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper right", fontsize=8)
    top.annotate("q3 = 0: elbow stretched,\nrank 4 (singular)", xy=(0.0, 0.0),
                 xytext=(25, 0.6 * float(np.max(w))), fontsize=8,
                 arrowprops=dict(arrowstyle="->", color="black"))
    top.set_ylabel("w (mixed linear/angular units)")
    bottom.set_ylabel("σ_min")
    bottom.set_xlabel("q3 (deg), over its limits; q1, q2, q4, q5 fixed")
    top.set_title("youBot 6×5 Jacobian along a sweep of q3 (q_ref = "
                  + ", ".join(f"{math.degrees(v):.0f}°" for v in q_ref) + ")", fontsize=10)
    return fig


def _branches_figure(robot, cases):
    fig = Figure(figsize=(8.0, 5.0), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    x = np.arange(robot.nq)
    lo, hi = np.degrees(robot.lower), np.degrees(robot.upper)
    ax.bar(x, hi - lo, bottom=lo, width=0.7, color="lightgrey", edgecolor="grey",
           label="joint range (limits)")
    rows = [(name, b) for name, case in cases.items() for b in case["branches"]]
    offsets = np.linspace(-0.28, 0.28, max(len(rows), 1))
    markers = "o^sDvP*X"
    for k, ((name, b), dx) in enumerate(zip(rows, offsets)):
        ax.plot(x + dx, np.degrees(b["q"]), marker=markers[k % len(markers)], linestyle="none", markersize=7,
                color=viz.colors.to_rgb(viz.colors.PALETTE[k % len(viz.colors.PALETTE)]),
                markeredgecolor="black", label=f"{name}: {b['branch']}")
    ax.set_xticks(x, [f"A{i + 1}" for i in x])
    ax.set_xlabel("joint (A1-A5 = q1-q5; markers side by side within a joint's range bar)")
    ax.set_ylabel("joint value (deg)")
    ax.set_title("youBot closed-form IK: every branch inside the limits, per target", fontsize=10)
    ax.grid(True, axis="y", alpha=0.3)
    fig.legend(*ax.get_legend_handles_labels(), fontsize=7, loc="outside lower center", ncol=3, frameon=False)
    return fig


def run(out: Path, *, n_random: int = 500, q_forward=Q_FORWARD, q_above=Q_ABOVE, off_tilt: float = OFF_TILT,
        sweep_points: int = 601, seed: int = 2, scene: bool = True) -> dict:
    """Run S2 into ``out``; returns the key numbers (see the module docstring)."""
    out = Path(out)
    robot = robots.load("youbot")
    rng = np.random.default_rng(seed)

    # 1-2. FK and Jacobian against the DH formulas
    Q = robot.random_q(rng, int(n_random))
    fk_diff = max(float(np.abs(robot.fk(q) - robots.dh_fk(YOUBOT_DH, "RRRRR", q)).max()) for q in Q)
    jac_diff = max(float(np.abs(robot.jacobian(q) - column_jacobian(q)).max()) for q in Q)
    ranks = [singularity.rank(robot.jacobian(q), RANK_TOL) for q in Q]
    sig_min = [float(singularity.singular_values(robot.jacobian(q))[-1]) for q in Q]

    # 3. singularity: the stretched elbow, and the sweep of q3
    q_ref = np.array(q_forward, dtype=float)
    q_sing = q_ref.copy()
    q_sing[2] = 0.0
    at_ref, at_sing = measures(robot.jacobian(q_ref)), measures(robot.jacobian(q_sing))
    q3 = np.linspace(robot.lower[2], robot.upper[2], int(sweep_points))
    if not np.any(q3 == 0.0):
        q3 = np.sort(np.r_[q3, 0.0])
    sweep = []
    for v in q3:
        q = q_ref.copy()
        q[2] = v
        sweep.append(measures(robot.jacobian(q)))
    w = np.array([m["manipulability"] for m in sweep])
    smin = np.array([m["sigma_min"] for m in sweep])
    singular_q3 = q3[[m["singular"] for m in sweep]]

    # 4. closed-form IK, all branches
    T_fwd = robot.fk(q_ref).copy()
    T_above = robot.fk(np.array(q_above, dtype=float)).copy()
    cases = {"forward": solve_branches(robot, T_fwd), "above the base": solve_branches(robot, T_above)}

    # 5. a 6-D pose off the 5-D reachable set
    T_off = _tilted(T_fwd, off_tilt)
    off = ik.solve_all(robot, T_off)
    n_plane = np.array([math.sin(off[0].q[0]), -math.cos(off[0].q[0]), 0.0]) if off else np.zeros(3)
    bound = math.asin(min(1.0, abs(float(T_off[:3, 2] @ n_plane))))
    reached = off[0].info.get("reached_pose") if off else None
    off_rows = []
    for r in off:
        T = robot.fk(r.q)
        pe, re = se3.pose_error(T, T_off)
        pr, rr = se3.pose_error(T, reached)
        off_rows.append({"branch": r.info["branch"], "q": r.q, "position_error": pe, "orientation_error": re,
                         "error_to_reached_pose": max(pr, rr), "within_limits": robot.within_limits(r.q)})

    # plots
    viz.save_png(_sweep_figure(q3, w, smin, q_ref,
                               RANK_TOL * float(np.max([m["singular_values"][0] for m in sweep]))),
                 out / "manipulability.png")
    viz.save_png(_branches_figure(robot, cases), out / "branches.png")

    if scene:
        sc = viz.Scene("kinserve S2 youBot: closed-form IK branches, one row per target (front: "
                       "forward target, then the off-set target's nearest pose in grey; back: "
                       "target above the base)")

        def slot(row: int, col: int) -> np.ndarray:  # rows 0.8 m apart along -x, robots 0.6 m apart along +y
            base = np.eye(4)
            base[:2, 3] = (-0.8 * row, 0.6 * col)
            return base

        k = 0
        for row, (name, case) in enumerate(cases.items()):
            for col, b in enumerate(case["branches"]):
                base = slot(row, col)
                sc.add_robot(robot, b["q"], name=f"branch{k}", base=base, color=viz.colors.PALETTE[k % 8])
                sc.add_frame(f"target{k}", base @ case["target"], length=0.08)
                k += 1
        if off:
            base = slot(0, len(cases["forward"]["branches"]))
            sc.add_robot(robot, off[0].q, name="nearest_reachable", base=base, color="grey")
            sc.add_frame("off_set_target", base @ T_off, length=0.1)
            sc.add_frame("nearest_reachable_pose", base @ reached, length=0.06)
        viz.export_html(sc, out / "scene.html")

    return {  # scalars first: `kinserve demo` prints the first few
        "fk_max_difference": fk_diff,
        "jacobian_max_difference": jac_diff,
        "n_random": int(n_random),
        "singular_rank": at_sing["rank"],
        "singular_sigma_min": at_sing["sigma_min"],
        "branches_forward": cases["forward"]["n_branches"],
        "branches_above": cases["above the base"]["n_branches"],
        "off_set_orientation_error": off_rows[0]["orientation_error"] if off_rows else None,
        "convention": "standard DH, every joint about +z of the previous DH frame (URDF joint 1 axis +z); "
                      "the youBot's own URDF turns joint 1 about -z",
        "dh": {"a": [r[0] for r in YOUBOT_DH], "alpha": [r[1] for r in YOUBOT_DH],
               "d": [r[2] for r in YOUBOT_DH]},
        "limits_deg": {"lower": np.degrees(robot.lower), "upper": np.degrees(robot.upper)},
        "random": {"min_rank": int(min(ranks)), "min_sigma_min": float(min(sig_min))},
        "reference": {"q": q_ref, **at_ref},
        "singular": {"q": q_sing, "why": "q3 = 0: links 2 and 3 aligned (a2 a3 sin q3 = 0)", **at_sing},
        "sweep": {"q3": q3, "manipulability": w, "sigma_min": smin, "singular_q3": singular_q3},
        "ik": cases,
        "off_reachable": {
            "target": T_off, "tilt": off_tilt, "note": off[0].info.get("note", "") if off else "no branch",
            "out_of_plane_angle": bound, "orientation_error_bound": bound, "reached_pose": reached,
            "branches": off_rows,
        },
    }
