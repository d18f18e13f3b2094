"""S9: the SCARA-type RRPR arm - Jacobian methods, relaxed phi / z, joint-limit centring, a sphere
(SCENARIOS.md S9).

Arm (``robots.load("scara")``, seed 004): standard DH rows ``(a, alpha, d, theta)``
``(a1, 0, 0, theta1)``, ``(a2, pi, 0, theta2)``, ``(0, 0, d3, 0)`` (prismatic),
``(0, 0, 0, theta4)``; ``a1 = a2 = 0.5`` m, base at ``z = 1`` m, limits
``theta1 +-pi``, ``theta2 +-5 pi/6``, ``d3 in [0.25, 1.0]`` m, ``theta4 +-2 pi``.

1. *Forward kinematics* - position ``(a1 c1 + a2 c12, a1 s1 + a2 s12, 1 - d3)``
   (world) and tool yaw ``phi = theta1 + theta2 - theta4`` (``alpha2 = pi``
   turns the quill down, so ``theta4`` turns the tool about ``-z``), checked
   against Pinocchio at random configurations (``fk_max_difference``).
2. *Jacobians* - the task ``(x, y, z, phi)`` has the analytic Jacobian

       [[-a1 s1 - a2 s12, -a2 s12,  0,  0],
        [ a1 c1 + a2 c12,  a2 c12,  0,  0],
        [ 0,               0,      -1,  0],
        [ 1,               1,       0, -1]]

   (seed 004 writes ``+1`` for ``theta4`` in the last row, contradicting its
   own ``T``). The geometric Jacobian's rows ``(v_x, v_y, v_z, w_z)`` are the
   same matrix: the tool's ``z`` axis is always vertical, so its angular
   velocity is ``w = (0, 0, phi_dot)`` - orientation is one angle about a fixed
   axis and ``w_z = phi_dot`` exactly; the geometric and analytic Jacobians
   differ only when the orientation needs several angles whose rates are not
   the angular velocity. Checked three ways here: the formula above, the
   geometric Jacobian (Pinocchio, rows x y z yaw; the roll / pitch rows are
   identically zero) and ``Robot.analytic_jacobian`` (RPY rates), plus
   central finite differences of ``(x, y, z, phi)(q)``.
3. *IK by Jacobian inverse and transpose* (and pseudo-inverse, DLS), all from
   the same start ``q0`` to the same target (:mod:`ik.classical.methods`):
   ``dq = J^-1 e``, ``dq = alpha J^T e`` (``alpha`` minimising the linearised
   error), ``dq = J^+ e``, ``dq = J^T (J J^T + lambda^2 I)^-1 e``; the joint
   variables and the operational-space errors ``(e_x, e_y, e_z, e_phi)`` at
   every iteration are plotted per method (``ik_<method>.png``) and together
   (``methods.png``).
4. *Relax phi* - drop the yaw row: ``J`` is 3x4, ``J^+ = J^T (J J^T)^-1``, and
   the free direction (``theta4`` alone: it does not move the tool point) is
   used to centre ``theta4`` at the middle of its range, 0 - by the
   pseudo-inverse with the null-space term ``(I - J^+ J)(m - q)`` and by the QP
   with its second (centring) stage. The position is met and ``theta4 -> 0``.
5. *Relax z* - drop the z row: the free direction is ``d3``, pulled to the
   middle ``0.625`` m, while the sphere at ``(0.4, -0.7, 0.5)``, radius 0.2,
   must not be entered by the tool nor by any link or the quill: a hard
   inequality in the QP (:class:`ik.Sphere`), enforced on every iterate.
   Two targets: ``(x, y)`` above the sphere - centring would put the tool at
   ``z = 0.375``, inside the sphere, so the constraint binds and stops it on
   the sphere's top - and ``(x, y)`` away from it, where ``d3`` reaches 0.625.
   For contrast, the pseudo-inverse with centring and no constraint is run on
   the first target: its tool ends inside the sphere.

Artefacts: ``ik_<method>.png`` for the four classical methods, ``methods.png``,
``relax_phi_<method>.png``, ``relax_z_<case>.png``, ``sphere.png`` (tool
distance to the sphere centre and tool height over the iterations),
``iterates.json`` (every iterate of every case), ``scene.html`` (the arm
replaying the cases, the sphere, the targets, the tool path of the binding case).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from kinserve import ik, robots, viz
from kinserve.kinematics.errors import InputError
from kinserve.kinematics.robot import Robot

from .artefacts import write_json

A1 = A2 = 0.5
BASE_Z = 1.0
SPHERE_CENTER = (0.4, -0.7, 0.5)
SPHERE_RADIUS = 0.2
#: The task (x, y, z, phi): the roll / pitch rows of a SCARA are identically zero.
TASK_RELAX = ("roll", "pitch")
METHOD_NAMES = {
    "jacobian_inverse": "Jacobian inverse  dq = J⁻¹e",
    "jacobian_transpose": "Jacobian transpose  dq = αJᵀe",
    "pseudo_inverse": "pseudo-inverse  dq = J⁺e",
    "dls": "damped least squares  dq = Jᵀ(JJᵀ+λ²I)⁻¹e",
}
#: Default target and start of the classical methods (rad, rad, m, rad).
Q_GOAL = (0.6, 1.1, 0.55, 0.4)
Q_START = (0.2, 0.6, 0.4, 0.0)
#: Relax-phi start: theta4 far from its middle.
Q_START_PHI = (0.2, 0.6, 0.4, 1.5)
#: Relax-z: the target (x, y) above the sphere (constraint binds) and one away from it.
XY_NEAR_SPHERE = (0.42, -0.68)
Q_FREE_TARGET = (1.0, 0.8, 0.3, 0.4)
Q_START_Z = (0.0, 0.5, 0.25, 0.0)
#: Iterations each IK solve of S9 may take, all its starts together. The budget, not a wall-clock limit,
#: ends every solve: the answers depend on the inputs only, never on the machine's speed or load.
ITERATION_BUDGET = 1000


def fk_formula(q, a1: float = A1, a2: float = A2, base_z: float = BASE_Z) -> tuple[np.ndarray, float]:
    """Tool position (world) and yaw ``phi = theta1 + theta2 - theta4`` (seed 004's ``T``, base at
    ``base_z``)."""
    t1, t2, d3, t4 = q
    p = np.array([a1 * math.cos(t1) + a2 * math.cos(t1 + t2),
                  a1 * math.sin(t1) + a2 * math.sin(t1 + t2), base_z - d3])
    return p, t1 + t2 - t4


def analytic_jacobian_formula(q, a1: float = A1, a2: float = A2) -> np.ndarray:
    """``d(x, y, z, phi) / dq`` (4x4), the corrected seed 004 matrix (last row ``[1, 1, 0, -1]``)."""
    t1, t2, _, _ = q
    s1, c1, s12, c12 = math.sin(t1), math.cos(t1), math.sin(t1 + t2), math.cos(t1 + t2)
    return np.array([[-a1 * s1 - a2 * s12, -a2 * s12, 0.0, 0.0], [a1 * c1 + a2 * c12, a2 * c12, 0.0, 0.0],
                     [0.0, 0.0, -1.0, 0.0], [1.0, 1.0, 0.0, -1.0]])


def yaw_of(T) -> float:
    """Tool yaw: angle of the tool x axis in the world xy plane (the tool z axis is vertical)."""
    return math.atan2(T[1, 0], T[0, 0])


def wrap(a):
    """Angles into ``(-pi, pi]``."""
    return np.angle(np.exp(1j * np.asarray(a, dtype=float)))


def task_of(robot, q) -> np.ndarray:
    """``(x, y, z, phi)`` of the tool at ``q`` (phi from the rotation, in ``(-pi, pi]``)."""
    T = robot.fk(q)
    return np.r_[T[:3, 3], yaw_of(T)]


def fd_jacobian(robot, q, h: float = 1e-6) -> np.ndarray:
    """Central finite differences of ``task_of`` (phi differences wrapped)."""
    J = np.zeros((4, robot.nq))
    for j in range(robot.nq):
        dq = np.zeros(robot.nq)
        dq[j] = h
        d = task_of(robot, q + dq) - task_of(robot, q - dq)
        d[3] = wrap(d[3])
        J[:, j] = d / (2 * h)
    return J


def xy_to_q12(x: float, y: float, elbow: float = 1.0) -> tuple[float, float]:
    """``(theta1, theta2)`` placing the tool at ``(x, y)`` (2R law of cosines, ``elbow`` = sign of theta2)."""
    c2 = (x * x + y * y - A1 * A1 - A2 * A2) / (2 * A1 * A2)
    if abs(c2) > 1:
        raise InputError(f"(x, y) = ({x}, {y}) is out of the SCARA's reach {A1 + A2} m")
    t2 = elbow * math.acos(c2)
    t1 = math.atan2(y, x) - math.atan2(A2 * math.sin(t2), A1 + A2 * math.cos(t2))
    return t1, t2


def relax_z_solve(robot: Robot, T: np.ndarray, q_start: np.ndarray, sphere: ik.Sphere,
                  iteration_budget: int = ITERATION_BUDGET) -> ik.Result:
    """The relax-z case (module docstring, 5): the QP with ``(x, y, phi)`` at level 1, ``d3`` centring at
    level 2 and ``sphere`` a hard constraint, from ``q_start`` first (then seeded random starts), ended by
    ``iteration_budget`` iterations over all its starts (no time limit)."""
    return ik.solve(robot, T, q_start, method="qp", relax=TASK_RELAX + ("z",), centring=1.0, spheres=[sphere],
                    prefer_q0=True, seed_table=False, iteration_budget=iteration_budget)


def near_sphere_target(robot: Robot, xy: tuple = XY_NEAR_SPHERE) -> np.ndarray:
    """The relax-z target whose ``(x, y)`` is above the sphere (the tool at the top of the quill's stroke,
    ``d3`` at its lower limit, ``theta4 = 0``): centring ``d3`` would take the tool into the sphere."""
    t1, t2 = xy_to_q12(*xy)
    return robot.fk(np.array([t1, t2, robot.lower[2], 0.0])).copy()


def min_segment_clearance(robot, sphere: ik.Sphere, Q) -> float:
    """Smallest clearance (m) between ``sphere`` and the arm's link, quill and tool segments over the
    configurations ``Q`` (:class:`ik.ObstacleAvoidance`'s bare segments, ``link_radius=0``)."""
    avoid = ik.ObstacleAvoidance([sphere], tool_frames=robot.tip).bind(robot)
    out = math.inf
    for q in Q:
        robot.fk(q)  # forward kinematics on the robot's data, read by margin()
        out = min(out, avoid.margin(robot, robot.data, q))
    return float(out)


def case_record(robot, result, target, sphere: ik.Sphere | None = None) -> dict:
    """Plain data of one IK run: iterations, final errors, every iterate and its tool position."""
    h = result.history
    P = robot.fk_batch(h.q)[:, :3, 3]
    rec = {
        "method": result.method, "success": result.success, "message": result.message,
        "iterations": int(result.iterations), "q_final": result.q,
        "position_error": result.position_error, "orientation_error": result.orientation_error,
        "components": list(h.components), "task_error": h.task_error, "q": h.q, "tool": P, "target": target,
    }
    if sphere is not None:
        d = np.linalg.norm(P - np.asarray(sphere.center), axis=1)
        rec["tool_sphere_distance"] = d
        rec["min_tool_sphere_distance"] = float(d.min())
        rec["min_clearance_all_segments"] = min_segment_clearance(robot, sphere, h.q)
    return rec


def _errors(rec) -> dict:
    units = {"x": "m", "y": "m", "z": "m", "roll": "rad", "pitch": "rad", "yaw": "rad"}
    names = {"yaw": "φ"}
    E = np.asarray(rec["task_error"])
    return {f"|e_{names.get(c, c)}| ({units[c]})": E[:, k] for k, c in enumerate(rec["components"])}


def _plot_case(robot, rec, path: Path, title: str, extra_lines=()):
    names = ["θ1 (rad)", "θ2 (rad)", "d3 (m)", "θ4 (rad)"]
    it = np.arange(len(rec["q"]))
    fig = viz.joints_and_errors_figure(it, rec["q"], _errors(rec), names, limits=None, title=title)
    top, bottom = fig.axes
    if len(it) <= 40:  # few iterates: show each one
        for line in top.lines + bottom.lines:
            line.set_marker("o")
            line.set_markersize(3)
    for value, label, color in extra_lines:
        top.axhline(value, color=color, linestyle="--", linewidth=1.0, label=label)
    top.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    bottom.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    top.set_ylabel("joint value (rad; d3 in m)")
    bottom.set_ylabel("|operational-space error| (m, rad)")
    viz.save_png(fig, path)


def _methods_figure(records):
    series = {METHOD_NAMES[m]: np.linalg.norm(np.asarray(r["task_error"]), axis=1)
              for m, r in records.items()}
    n = max(len(v) for v in series.values())
    padded = {f"{k} ({len(v) - 1} it.)": np.r_[v, np.full(n - len(v), np.nan)] for k, v in series.items()}
    fig = viz.series_figure(np.arange(1, n + 1), padded, xlabel="iteration + 1 (log scale)",
                            ylabel="‖e‖ of (x, y, z, φ) (m, rad)",
                            title="S9: the four methods from the same start to the same target", logy=True)
    ax = fig.axes[0]
    ax.set_xscale("log")
    styles = ({"marker": "o", "markersize": 8, "fillstyle": "none"}, {"marker": "."},
              {"marker": "x", "markersize": 7}, {"marker": "s", "markersize": 4})
    for line, style in zip(ax.lines, styles):
        line.set(**style)
    ax.legend(loc="lower left", fontsize=8)
    return fig


def _sphere_figure(cases, radius, center_z):
    fig = Figure(figsize=(7.0, 4.6), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    for i, (label, rec) in enumerate(cases.items()):
        c = viz.colors.to_rgb(viz.colors.PALETTE[i])
        it = np.arange(len(rec["q"]))
        ax.plot(it, rec["tool_sphere_distance"], "-o", markersize=3, color=c, label=f"{label}: |p_tool − c|")
        ax.plot(it, rec["tool"][:, 2], ":", color=c, label=f"{label}: tool height z")
    ax.axhline(radius, color="red", linestyle="--", linewidth=1.2,
               label=f"sphere radius {radius:g} m (keep ≥)")
    ax.axhline(center_z + radius, color="grey", linestyle="-.", linewidth=0.9, label="sphere top z")
    ax.set_xlabel("iteration")
    ax.set_ylabel("distance / height (m)")
    ax.set_title("S9 relax z: tool distance to the sphere centre on every iterate", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    return fig


def run(out: Path, *, q_goal=Q_GOAL, q_start=Q_START, q_start_phi=Q_START_PHI, xy_near_sphere=XY_NEAR_SPHERE,
        q_free_target=Q_FREE_TARGET, q_start_z=Q_START_Z, n_random: int = 200, seed: int = 9,
        dls_damping: float = 0.05, scene: bool = True, fps: float = 12.0) -> dict:
    """Run S9 into ``out``; returns the key numbers (see the module docstring)."""
    out = Path(out)
    robot = robots.load("scara")
    rng = np.random.default_rng(seed)
    lo, hi = robot.lower, robot.upper
    mid = robot.middle()

    # 1. FK against the closed form
    Q = robot.random_q(rng, int(n_random))
    fk_p = max(float(np.abs(robot.fk(q)[:3, 3] - fk_formula(q)[0]).max()) for q in Q)
    fk_phi = max(float(abs(wrap(yaw_of(robot.fk(q)) - fk_formula(q)[1]))) for q in Q)
    vertical = max(float(np.abs(robot.fk(q)[:3, 2] - (0.0, 0.0, -1.0)).max()) for q in Q)

    # 2. geometric vs analytic Jacobian
    rows = [0, 1, 2, 5]
    jg = max(float(np.abs(robot.jacobian(q)[rows] - analytic_jacobian_formula(q)).max()) for q in Q)
    ja = max(float(np.abs(robot.analytic_jacobian(q)[rows] - robot.jacobian(q)[rows]).max()) for q in Q)
    jfd = max(float(np.abs(fd_jacobian(robot, q) - analytic_jacobian_formula(q)).max()) for q in Q[:50])
    zero_rows = max(float(np.abs(robot.jacobian(q)[3:5]).max()) for q in Q)

    # 3. the classical methods from the same start
    q_goal, q_start = np.asarray(q_goal, float), np.asarray(q_start, float)
    T_goal = robot.fk(q_goal).copy()
    methods = {}
    for m in METHOD_NAMES:
        kw = {"damping": dls_damping} if m == "dls" else {}
        res = ik.solve(robot, T_goal, q_start, method=m, relax=TASK_RELAX, iteration_budget=ITERATION_BUDGET,
                       **kw)
        methods[m] = case_record(robot, res, T_goal)
        _plot_case(robot, methods[m], out / f"ik_{m}.png",
                   f"S9 {METHOD_NAMES[m]}: {res.iterations} iterations")
    viz.save_png(_methods_figure(methods), out / "methods.png")

    # 4. relax phi, centring theta4
    relax_phi = {}
    qs_phi = np.asarray(q_start_phi, float)
    for m in ("pseudo_inverse", "qp"):
        kw = {"prefer_q0": True, "seed_table": False} if m == "qp" else {}
        res = ik.solve(robot, T_goal, qs_phi, method=m, relax=TASK_RELAX + ("yaw",), centring=1.0,
                       iteration_budget=ITERATION_BUDGET, **kw)
        rec = case_record(robot, res, T_goal)
        rec["theta4_final"] = float(res.q[3])
        rec["theta4_mid"] = float(mid[3])
        rec["position_residual"] = float(np.linalg.norm(robot.fk(res.q)[:3, 3] - T_goal[:3, 3]))
        relax_phi[m] = rec
        _plot_case(robot, rec, out / f"relax_phi_{m}.png",
                   f"S9 relax φ, {'QP' if m == 'qp' else 'pseudo-inverse'} + centring: "
                   f"θ4 → {res.q[3]:.2e} (mid-range 0)",
                   [(mid[3], "θ4 mid-range", "black")])

    # 5. relax z, centring d3, the sphere
    sphere = ik.Sphere(SPHERE_CENTER, SPHERE_RADIUS)
    T_near = near_sphere_target(robot, xy_near_sphere)
    T_free = robot.fk(np.asarray(q_free_target, float)).copy()
    qs_z = np.asarray(q_start_z, float)
    relax_z = {}
    for case, T in (("near_sphere", T_near), ("away_from_sphere", T_free)):
        res = relax_z_solve(robot, T, qs_z, sphere)
        rec = case_record(robot, res, T, sphere)
        rec["d3_final"] = float(res.q[2])
        rec["d3_mid"] = float(mid[2])
        rec["xy_residual"] = float(np.linalg.norm(robot.fk(res.q)[:2, 3] - T[:2, 3]))
        rec["phi_residual"] = float(abs(wrap(yaw_of(robot.fk(res.q)) - yaw_of(T))))
        rec["tool_height"] = float(robot.fk(res.q)[2, 3])
        relax_z[case] = rec
    res = ik.solve(robot, T_near, qs_z, method="pseudo_inverse", relax=TASK_RELAX + ("z",), centring=1.0,
                   iteration_budget=ITERATION_BUDGET)
    unconstrained = case_record(robot, res, T_near, sphere)
    unconstrained["d3_final"] = float(res.q[2])
    cx, cy, cz = SPHERE_CENTER
    x, y = xy_near_sphere
    z_top = cz + math.sqrt(max(SPHERE_RADIUS**2 - (x - cx) ** 2 - (y - cy) ** 2, 0.0))
    for case, rec in relax_z.items():
        _plot_case(robot, rec, out / f"relax_z_{case}.png",
                   f"S9 relax z, QP + centring + sphere ({case.replace('_', ' ')}): "
                   f"d3 → {rec['d3_final']:.4f} m",
                   [(mid[2], "d3 mid-range 0.625 m", "black")])
    _plot_case(robot, unconstrained, out / "relax_z_no_sphere_constraint.png",
               "S9 relax z, pseudo-inverse + centring, NO sphere constraint: "
               f"d3 → {unconstrained['d3_final']:.4f} m",
               [(mid[2], "d3 mid-range 0.625 m", "black")])
    viz.save_png(_sphere_figure({"QP, near the sphere": relax_z["near_sphere"],
                                 "QP, away from it": relax_z["away_from_sphere"],
                                 "pseudo-inverse, no constraint": unconstrained}, SPHERE_RADIUS, cz),
                 out / "sphere.png")

    all_cases = {**{f"ik_{m}": r for m, r in methods.items()},
                 **{f"relax_phi_{m}": r for m, r in relax_phi.items()},
                 **{f"relax_z_{c}": r for c, r in relax_z.items()},
                 "relax_z_no_sphere_constraint": unconstrained}
    write_json(out / "iterates.json", {k: {"q": r["q"], "tool": r["tool"], "task_error": r["task_error"],
                                           "components": r["components"]} for k, r in all_cases.items()})

    if scene:
        sc = viz.Scene("kinserve S9 SCARA: classical IK, relaxed φ with θ4 centring, "
                       "relaxed z with d3 centring and a sphere")
        arm = sc.add_robot(robot, q_start, name="scara")
        sc.add_sphere("sphere", SPHERE_CENTER, SPHERE_RADIUS, color="red", opacity=0.35)
        sc.add_frame("target_full_task", T_goal, length=0.12)
        sc.add_frame("target_near_sphere", robot.fk(relax_z["near_sphere"]["q_final"]), length=0.12)
        sc.add_frame("target_away_from_sphere", robot.fk(relax_z["away_from_sphere"]["q_final"]), length=0.12)
        for name, T in (("near_sphere", T_near), ("away_from_sphere", T_free)):  # z is free: a vertical line
            sc.add_path(f"free_z_{name}",
                        [[T[0, 3], T[1, 3], BASE_Z - hi[2]], [T[0, 3], T[1, 3], BASE_Z - lo[2]]],
                        color="grey", linewidth=1.0)
        sc.add_path("tool_path_near_sphere", relax_z["near_sphere"]["tool"], color="blue")
        frames = []
        for key in ("ik_pseudo_inverse", "relax_phi_qp", "relax_z_near_sphere", "relax_z_away_from_sphere"):
            q = np.asarray(all_cases[key]["q"])
            frames.extend([q[0]] * 6 + list(q) + [q[-1]] * int(fps))
        anim = viz.Animation(sc, fps=fps)
        anim.robot(arm.name, np.array(frames), step=2)
        anim.apply()
        viz.export_html(sc, out / "scene.html")

    near, away = relax_z["near_sphere"], relax_z["away_from_sphere"]
    return {  # scalars first: `kinserve demo` prints the first few
        "iterations_per_method": ", ".join(f"{m} {r['iterations']}" for m, r in methods.items()),
        "iterations": {m: r["iterations"] for m, r in methods.items()},
        "theta4_final": relax_phi["qp"]["theta4_final"],
        "d3_final_near_sphere": near["d3_final"],
        "d3_final_away": away["d3_final"],
        "min_tool_sphere_distance": min(near["min_tool_sphere_distance"], away["min_tool_sphere_distance"]),
        "min_clearance_all_segments": min(near["min_clearance_all_segments"],
                                          away["min_clearance_all_segments"]),
        "unconstrained_min_tool_sphere_distance": unconstrained["min_tool_sphere_distance"],
        "fk_max_position_difference": fk_p,
        "fk_max_phi_difference": fk_phi,
        "tool_axis_vertical_max_deviation": vertical,
        "jacobian_geometric_vs_formula": jg,
        "jacobian_analytic_vs_geometric": ja,
        "jacobian_fd_vs_formula": jfd,
        "jacobian_roll_pitch_rows_max": zero_rows,
        "sphere": {"center": SPHERE_CENTER, "radius": SPHERE_RADIUS, "top_above_target_xy": z_top},
        "d3_mid": float(mid[2]),
        "theta4_mid": float(mid[3]),
        "limits": {"lower": lo, "upper": hi},
        "methods": {m: {k: r[k] for k in ("iterations", "success", "position_error", "orientation_error",
                                          "q_final", "message")} for m, r in methods.items()},
        "q_goal": q_goal,
        "q_start": q_start,
        "relax_phi": {m: {k: r[k] for k in ("iterations", "success", "position_error", "position_residual",
                                            "theta4_final", "theta4_mid", "q_final", "message")}
                      for m, r in relax_phi.items()},
        "relax_z": {c: {k: r[k] for k in ("iterations", "success", "d3_final", "d3_mid", "xy_residual",
                                          "phi_residual", "tool_height", "min_tool_sphere_distance",
                                          "min_clearance_all_segments", "q_final", "message")}
                    | {"target_xy": r["target"][:2, 3]}
                    for c, r in relax_z.items()},
        "relax_z_no_sphere_constraint": {
            k: unconstrained[k] for k in ("iterations", "d3_final", "min_tool_sphere_distance", "q_final")},
        "iterates_file": "iterates.json",
    }
