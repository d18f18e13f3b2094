"""S5: the PR planar robot - resolved-rate motion, singularities, circle following (SCENARIOS.md S5, seed
003).

Robot (``robots.load("pr", d2=...)``): ``T = Tx(d1) Rz(theta2) Tx(d2)``, tool
at ``x = d1 + d2 cos theta2``, ``y = d2 sin theta2``; position Jacobian

    ``J = [[1, -d2 sin theta2], [0, d2 cos theta2]]``,  ``det J = d2 cos theta2``,

singular at ``theta2 = +-90 deg`` (the arm is perpendicular to the rail and
cannot move the tool along y). The reachable set is the band ``|y| <= d2``
(the rail is long: ``d1`` in [-25, 25] m). ``jacobian_formula_error`` checks
the formula against Pinocchio's ``robot.jacobian`` rows x, y.

1. *The document's table of runs* ``(v, q_init = [d1, theta2 deg], n, Delta)``
   through :func:`planners.resolved_rate`: the document's open-loop scheme
   ``q_{k+1} = q_k + J^+ v Delta`` from the straight line ``x(q0) + v t``,
   with the adaptive damped inverse (``lambda`` grows as ``sigma_min`` drops
   below 0.05) so joint rates stay bounded at the singularity. For each run:
   ``final_error`` / ``max_error`` (m) against the ideal straight line,
   ``max_joint_rate`` (norm of ``qdot``; ``max_joint_rate_undamped`` for the
   plain inverse), ``min_manipulability`` (``|det J|``), the events
   (``low_manipulability`` when ``sigma_min < 0.05``, ``joint_rate``,
   ``large_step`` when a step's motion is far from the Jacobian's prediction,
   ``joint_limit``) with their steps, and ``leaves_workspace_step``: the first
   step whose reference point has ``|y| > d2`` (no configuration reaches it).
   Only the run along x from ``theta2 = 0`` (run 1) keeps its reference
   reachable: ``theta2`` then never changes and the line is followed
   exactly. The run starting at ``theta2 = 90 deg`` reports the singularity
   at step 0.
2. *Step size* - run 10's velocity ``v = (0.2, 0.2)`` from ``(1, 45 deg)`` over
   the time the line stays inside the workspace (to ``y = 0.95 d2``), for
   decreasing ``Delta``: the open-loop (Euler) error falls in proportion to
   ``Delta``; closed loop keeps only one step's linearisation error, which
   falls with ``Delta^2``.
3. *Circles* (``follow_circle``, 1 rad/s, counter-clockwise from the point
   ``c + (r, 0)``): centre ``[1, 0.25]`` r 0.2, ``[1, 0.5]`` r 0.5 with
   ``Delta`` 0.001 and 0.01 (touching ``y = d2``: through the singularity),
   ``[1, 0.3]`` r 0.3, each ``n = 5000`` steps, open loop (the document's
   tangent-velocity scheme: errors accumulate into a spiral) against closed
   loop (``q_{k+1} = q_k + J^+ (x_ref(t_{k+1}) - x_ref(t_k) + e_k)``, error
   feedback): ``closed_beats_open`` compares the max and RMS errors.

Units: metres, radians (table in degrees where named), seconds.
Artefacts: ``runs_xy.png``, ``runs_joints.png``, ``step_size.png``,
``circles.png``, ``circle_errors.png``, ``manipulability.png``, ``runs.csv`` (the table),
``circle1.csv`` .. ``circle4.csv`` (reference, joints and tool positions, open and closed loop);
``result.json`` holds every run's joint history ``q`` (rows ``[d1, theta2 rad]``).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from kinserve import robots, viz
from kinserve.planners import follow_circle, resolved_rate

#: The document's table: (v [m/s], q_init [d1 m, theta2 deg], n steps, Delta s).
RUNS = (
    ((2.0, 0.0), (1.0, 0.0), 50, 0.2),
    ((0.2, 4.0), (1.0, 0.0), 25, 0.2),
    ((0.2, 4.0), (1.0, 0.0), 25, 1.0),
    ((0.2, 4.0), (1.0, 0.0), 25, 0.5),
    ((0.2, 4.0), (1.0, 0.0), 25, 0.75),
    ((1.0, 4.0), (1.0, 0.0), 15, 0.75),
    ((4.0, 4.0), (1.0, 0.0), 15, 0.75),
    ((4.0, 4.0), (1.0, 0.0), 35, 0.75),
    ((4.0, 4.0), (1.0, 90.0), 35, 0.75),
    ((0.2, 0.2), (1.0, 45.0), 35, 0.75),
    ((0.5, 1.0), (1.0, 45.0), 35, 0.75),
)

#: The document's circles: (centre, radius, n, Delta).
CIRCLES = (
    ((1.0, 0.25), 0.2, 5000, 0.001),
    ((1.0, 0.5), 0.5, 5000, 0.001),
    ((1.0, 0.5), 0.5, 5000, 0.01),
    ((1.0, 0.3), 0.3, 5000, 0.001),
)

#: Step sizes of the step-size study (s).
STEP_SIZES = (0.75, 0.25, 0.1, 0.03, 0.01, 0.003, 0.001)

SIGMA_THRESHOLD = 0.05


def position_jacobian(d2: float, theta2: float) -> np.ndarray:
    """``[[1, -d2 sin theta2], [0, d2 cos theta2]]``: d(x, y)/d(d1, theta2)."""
    return np.array([[1.0, -d2 * math.sin(theta2)], [0.0, d2 * math.cos(theta2)]])


def inverse_kinematics(p, d2: float) -> np.ndarray:
    """``(d1, theta2)`` placing the tool at ``p = (x, y)`` with ``|theta2| <= 90 deg`` (``|y| <= d2``)."""
    theta = math.asin(float(p[1]) / d2)
    return np.array([float(p[0]) - d2 * math.cos(theta), theta])


def _events(res) -> list[dict]:
    return [{"step": e.step, "kind": e.kind, "value": e.value, "message": e.message} for e in res.events]


def _rate_norms(res) -> np.ndarray:
    return np.linalg.norm(res.joint_rates, axis=1) if len(res.joint_rates) else np.zeros(1)


def straight_run(robot, d2: float, v, q_init_deg, n: int, dt: float, index: int) -> tuple[dict, object]:
    """One row of the table (see the module docstring) and its :class:`planners.ResolvedRateResult`."""
    q0 = np.array([q_init_deg[0], math.radians(q_init_deg[1])])
    res = resolved_rate(robot, v, q0, n, dt, sigma_threshold=SIGMA_THRESHOLD)
    bare = resolved_rate(robot, v, q0, n, dt, damping=0.0, sigma_threshold=SIGMA_THRESHOLD)
    outside = np.flatnonzero(np.abs(res.reference[:, 1]) > d2 + 1e-12)
    leaves = int(outside[0]) if outside.size else None
    inside = slice(0, leaves if leaves is not None else len(res.errors))
    low = [e.step for e in res.events if e.kind == "low_manipulability"]
    rates = _rate_norms(res)
    row = {
        "run": index,
        "v": list(v),
        "q_init": [q_init_deg[0], q_init_deg[1]],
        "n": n,
        "dt": dt,
        "final_error": res.final_error,
        "max_error": res.max_error,
        "max_error_while_reachable": float(res.errors[inside].max()),
        "leaves_workspace_step": leaves,
        "max_joint_rate": float(rates.max()),
        "max_joint_rate_step": int(rates.argmax()),
        "max_joint_rate_undamped": float(_rate_norms(bare).max()),
        "min_manipulability": float(res.manipulability.min()),
        "min_manipulability_step": int(res.manipulability.argmin()),
        "singular": bool(low),
        "singular_steps": low,
        "events": _events(res),
        "final_q": [float(res.q[-1, 0]), math.degrees(res.q[-1, 1])],
        "q": res.q,
        "final_position": res.positions[-1],
        "final_reference": res.reference[-1],
    }
    return row, res


def step_study(robot, d2: float, v=(0.2, 0.2), q_init_deg=(1.0, 45.0), steps=STEP_SIZES) -> dict:
    """Errors at the end of the in-workspace part of a straight line, for decreasing step sizes."""
    q0 = np.array([q_init_deg[0], math.radians(q_init_deg[1])])
    y0 = d2 * math.sin(q0[1])
    duration = (0.95 * d2 - y0) / v[1]
    rows = []
    for dt in steps:
        n = max(1, int(round(duration / dt)))
        op = resolved_rate(robot, v, q0, n, duration / n)
        cl = resolved_rate(robot, v, q0, n, duration / n, closed_loop=True)
        rows.append({"dt": duration / n, "n": n, "open_loop_final_error": op.final_error,
                     "closed_loop_final_error": cl.final_error, "open_loop_max_error": op.max_error,
                     "closed_loop_max_error": cl.max_error})
    return {"v": list(v), "q_init": list(q_init_deg), "duration": duration, "rows": rows}


def circle_run(robot, d2: float, centre, radius: float, n: int, dt: float) -> tuple[dict, object, object]:
    """Open vs closed loop on one circle."""
    q0 = inverse_kinematics((centre[0] + radius, centre[1]), d2)
    res = {}
    for key, closed in (("open", False), ("closed", True)):
        res[key] = follow_circle(robot, centre, radius, q0, n, dt, closed_loop=closed,
                                 sigma_threshold=SIGMA_THRESHOLD)
    row = {"centre": list(centre), "radius": radius, "n": n, "dt": dt, "q0": q0,
           "touches_singularity": bool(centre[1] + radius >= d2 - 1e-12)}
    for key, r in res.items():
        radial = np.abs(np.linalg.norm(r.positions - np.asarray(centre), axis=1) - radius)
        row[key] = {"max_error": r.max_error, "rms_error": r.rms_error, "final_error": r.final_error,
                    "max_radial_error": float(radial.max()),
                    "min_manipulability": float(r.manipulability.min()),
                    "max_joint_rate": float(_rate_norms(r).max()), "events": _events(r)}
    row["closed_beats_open"] = bool(row["closed"]["max_error"] < row["open"]["max_error"]
                                    and row["closed"]["rms_error"] < row["open"]["rms_error"])
    row["improvement"] = row["open"]["max_error"] / max(row["closed"]["max_error"], 1e-300)
    return row, res["open"], res["closed"]


# ------------------------------------------------------------------ plots
def _figure(rows: int, cols: int, size):
    fig = Figure(figsize=size, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(rows, cols, squeeze=False)
    return fig, axes


def _color(i):
    return viz.colors.to_rgb(viz.colors.cycle(i))


def plot_runs_xy(rows, results, d2: float, path: Path) -> None:
    """One panel per run: the followed path (markers at the steps) against the ideal line, the band
    ``|y| <= d2``."""
    fig, axes = _figure(3, 4, (13.0, 9.0))
    for ax, row, res in zip(axes.flat, rows, results):
        P, R = res.positions, res.reference
        # view: the followed path plus the reference while it is near (a reference 100 m away would squash it)
        keep = np.abs(R[:, 1]) <= 3 * d2
        pts = np.vstack([P, R[keep]]) if keep.any() else P
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        pad = 0.08 * max(hi[0] - lo[0], hi[1] - lo[1], 0.5)
        ax.axhspan(-d2, d2, color="green", alpha=0.07, linewidth=0)
        ax.axhline(d2, color="green", linewidth=0.6, alpha=0.6)
        ax.axhline(-d2, color="green", linewidth=0.6, alpha=0.6)
        ax.plot(R[:, 0], R[:, 1], linestyle="--", color="black", linewidth=1.0,
                label="ideal line x(q0) + v t")
        ax.plot(P[:, 0], P[:, 1], marker=".", markersize=4, color=_color(0), linewidth=1.3,
                label="tool (open loop)")
        for s in row["singular_steps"][:3]:
            ax.plot(P[s, 0], P[s, 1], marker="o", markersize=8, markerfacecolor="none", color="red")
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)
        v, qi = row["v"], row["q_init"]
        ax.set_title(f"run {row['run']}: v=({v[0]:g}, {v[1]:g}), θ₀={qi[1]:g}°, n={row['n']}, "
                     f"Δ={row['dt']:g}", fontsize=9)
        note = f"final error {row['final_error']:.3g} m"
        if row["leaves_workspace_step"] is not None:
            note += f"\nline leaves |y|≤d₂ at step {row['leaves_workspace_step']}"
        if row["singular_steps"]:
            note += f"\nsingular (σ_min<{SIGMA_THRESHOLD:g}) at step {row['singular_steps'][0]}"
        ax.text(0.02, 0.98, note, transform=ax.transAxes, fontsize=7, va="top",
                bbox=dict(boxstyle="round", facecolor="white", alpha=0.85, linewidth=0.3))
        ax.grid(True, alpha=0.3)
        ax.tick_params(labelsize=7)
    ax = axes.flat[len(rows)]
    ax.axis("off")
    ax.plot([], [], linestyle="--", color="black", label="ideal straight line x(q₀) + v t")
    ax.plot([], [], marker=".", color=_color(0), label="tool, open loop J⁺ v Δ (damped)")
    ax.plot([], [], marker="o", markerfacecolor="none", linestyle="none", color="red",
            label="singularity event (σ_min < 0.05)")
    ax.fill_between([], [], color="green", alpha=0.15, label=f"reachable band |y| ≤ d₂ = {d2:g} m")
    ax.legend(loc="center", fontsize=9)
    fig.suptitle("S5 PR robot: the document's resolved-rate runs (x, y in m)", fontsize=12)
    viz.save_png(fig, path)


def _wrapped_degrees(x, theta) -> tuple[np.ndarray, np.ndarray]:
    """``(x, degrees)`` with the angles wrapped to [-180, 180) and a NaN gap wherever the wrap jumps."""
    a = (np.degrees(theta) + 180.0) % 360.0 - 180.0
    xs, ys = [x[0]], [a[0]]
    for i in range(1, len(a)):
        if abs(a[i] - a[i - 1]) > 180.0:
            xs.append(np.nan)
            ys.append(np.nan)
        xs.append(x[i])
        ys.append(a[i])
    return np.array(xs, dtype=float), np.array(ys)


def runs_joints_figure(rows, results) -> Figure:
    """One small panel per run (all of the table's runs): ``d1`` (m, left axis) and ``theta2``
    (deg, wrapped to +-180, right axis) against the step, with the singular angles +-90 deg."""
    cols = 4
    nrows = -(-(len(rows) + 1) // cols)  # one spare panel holds the legend
    fig, axes = _figure(nrows, cols, (13.0, 3.0 * nrows + 0.6))
    for ax, row, res in zip(axes.flat, rows, results):
        steps = np.arange(len(res.q))
        ax.plot(steps, res.q[:, 0], color=_color(0), linewidth=1.3, marker=".", markersize=3, label="d₁ (m)")
        ax.set_ylabel("d₁ (m)", color=_color(0), fontsize=8)
        tw = ax.twinx()
        tw.plot(*_wrapped_degrees(steps, res.q[:, 1]), color=_color(1), linewidth=0.9, marker="o",
                markersize=2.5, label="θ₂ (deg)")
        for s in (90, -90):
            tw.axhline(s, color="red", linestyle="--", linewidth=0.8)
        tw.set_ylim(-185, 185)
        tw.set_yticks([-180, -90, 0, 90, 180])
        tw.set_ylabel("θ₂ (deg)", color=_color(1), fontsize=8)
        v, qi = row["v"], row["q_init"]
        ax.set_title(f"run {row['run']}: v=({v[0]:g}, {v[1]:g}), θ₀={qi[1]:g}°, n={row['n']}, "
                     f"Δ={row['dt']:g}", fontsize=9)
        ax.set_xlabel("step k", fontsize=8)
        for a in (ax, tw):
            a.tick_params(labelsize=7)
        ax.grid(True, alpha=0.3)
    for ax in list(axes.flat)[len(rows):]:
        ax.axis("off")
    key = axes.flat[len(rows)]
    key.plot([], [], color=_color(0), marker=".", label="d₁ (m), left axis")
    key.plot([], [], color=_color(1), marker="o", label="θ₂ (deg, wrapped to ±180°), right axis")
    key.plot([], [], color="red", linestyle="--", label="singular θ₂ = ±90°")
    key.legend(loc="center", fontsize=9)
    fig.suptitle(f"S5 joint variables over the steps, all {len(rows)} runs (open loop, "
                 "damped J⁺)", fontsize=12)
    return fig


def plot_step_size(study: dict, path: Path) -> None:
    """Write the open- and closed-loop final errors against the step size ``dt`` to ``path`` (PNG)."""
    fig, ((ax,),) = _figure(1, 1, (7.0, 4.4))
    dts = [r["dt"] for r in study["rows"]]
    ax.loglog(dts, [r["open_loop_final_error"] for r in study["rows"]], marker="o", color=_color(0),
              label="open loop (the document's scheme)")
    ax.loglog(dts, [max(r["closed_loop_final_error"], 1e-16) for r in study["rows"]], marker="s",
              color=_color(2), label="closed loop (error feedback)")
    ref = np.array(dts)
    c = study["rows"][-1]["open_loop_final_error"] / dts[-1]
    ax.loglog(ref, c * ref, linestyle=":", color="grey", label="∝ Δ")
    ax.set_xlabel("step Δ (s)")
    ax.set_ylabel("final position error (m)")
    ax.set_title(f"S5 straight line v=({study['v'][0]:g}, {study['v'][1]:g}) from θ₀={study['q_init'][1]:g}° "
                 f"for {study['duration']:.3g} s (inside the workspace)", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    viz.save_png(fig, path)


def plot_circles(rows, runs, d2: float, path: Path) -> None:
    """Write the circle-following runs (open and closed loop, the singular line ``y = d2``) to ``path``."""
    fig, axes = _figure(2, 2, (10.0, 10.0))
    for ax, row, (op, cl) in zip(axes.flat, rows, runs):
        c, r = np.asarray(row["centre"]), row["radius"]
        a = np.linspace(0, 2 * np.pi, 400)
        ax.axhline(d2, color="red", linestyle="--", linewidth=0.9)
        ax.plot(c[0] + r * np.cos(a), c[1] + r * np.sin(a), color="black", linewidth=2.6, alpha=0.25)
        ax.plot(op.positions[:, 0], op.positions[:, 1], color=_color(1), linewidth=1.0)
        ax.plot(cl.positions[:, 0], cl.positions[:, 1], color=_color(0), linewidth=1.0, linestyle="--")
        ax.plot(*op.positions[0], marker="o", color="black", markersize=4)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(f"centre ({c[0]:g}, {c[1]:g}), r = {r:g}, n = {row['n']}, "
                     f"Δ = {row['dt']:g}", fontsize=10)
        ax.text(0.02, 0.9,
                f"max error\nopen {row['open']['max_error']:.2g} m\nclosed "
                f"{row['closed']['max_error']:.2g} m", transform=ax.transAxes, fontsize=8, va="top",
                bbox=dict(boxstyle="round", facecolor="white", alpha=0.85, linewidth=0.3))
        ax.grid(True, alpha=0.3)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
    handles = [
        axes[0, 0].plot([], [], color="black", linewidth=2.6, alpha=0.25,
                        label="reference circle (1 rad/s, start ●)")[0],
        axes[0, 0].plot([], [], color=_color(1), label="open loop: J⁺ ẋ_ref Δ (the document's scheme)")[0],
        axes[0, 0].plot([], [], color=_color(0), linestyle="--",
                        label="closed loop: J⁺ (x_ref(k+1) − x_ref(k) + e_k)")[0],
        axes[0, 0].plot([], [], color="red", linestyle="--",
                        label=f"y = d₂ = {d2:g} m (θ₂ = 90°, singular)")[0],
    ]
    fig.legend(handles=handles, loc="outside lower center", ncol=2, fontsize=9)
    fig.suptitle("S5 circle following: reference vs open loop vs closed loop", fontsize=12)
    viz.save_png(fig, path)


def plot_circle_errors(rows, runs, path: Path) -> None:
    """Write the tracking error over time of every circle run to ``path`` (PNG, log scale)."""
    fig, ((ax,),) = _figure(1, 1, (8.0, 4.8))
    for i, (row, (op, cl)) in enumerate(zip(rows, runs)):
        lab = f"c=({row['centre'][0]:g}, {row['centre'][1]:g}) r={row['radius']:g} Δ={row['dt']:g}"
        ax.semilogy(op.times, np.maximum(op.errors, 1e-16), color=_color(i), linewidth=1.2,
                    label=f"open, {lab}")
        ax.semilogy(cl.times, np.maximum(cl.errors, 1e-16), color=_color(i), linewidth=1.0, linestyle=":",
                    label=f"closed, {lab}")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("tracking error |x_ref − x| (m)")
    ax.set_title("S5 circle tracking errors: open loop (solid) vs closed loop (dotted)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2, loc="lower right")
    viz.save_png(fig, path)


def plot_manipulability(rows, results, circle_rows, circle_runs, path: Path, which=(1, 2, 5, 9, 10)) -> None:
    """``w = |det J|`` along the straight-line runs (singularity events circled) and along the circles' first
    turn."""
    fig, ((a1,), (a2,)) = _figure(2, 1, (8.0, 7.0))
    for i, k in enumerate(which):
        row, res = rows[k - 1], results[k - 1]
        a1.plot(np.arange(len(res.manipulability)), res.manipulability, color=_color(i), marker=".",
                markersize=3,
                label=f"run {k}: v=({row['v'][0]:g}, {row['v'][1]:g}), θ₀={row['q_init'][1]:g}°, "
                      f"Δ={row['dt']:g}")
        for s in row["singular_steps"]:
            a1.plot(s, res.manipulability[s], marker="o", markersize=9, markerfacecolor="none", color="red")
    a1.plot([], [], marker="o", markerfacecolor="none", linestyle="none", color="red",
            label=f"singularity event (σ_min < {SIGMA_THRESHOLD:g})")
    a1.set_xlabel("step k")
    a1.set_ylabel("w = |det J| = d₂|cos θ₂|")
    a1.set_title("S5 manipulability: straight-line runs (open loop, damped J⁺)")
    a1.set_ylim(0, 1.5)
    a1.legend(fontsize=7, loc="upper center", ncol=2)
    for i, (row, (op, cl)) in enumerate(zip(circle_rows, circle_runs)):
        a2.plot(cl.times, cl.manipulability, color=_color(i), linewidth=1.4 if i != 1 else 2.6,
                alpha=1 if i != 1 else 0.6,
                label=f"c=({row['centre'][0]:g}, {row['centre'][1]:g}) r={row['radius']:g} Δ={row['dt']:g}")
    a2.set_xlim(0, 2 * np.pi)
    a2.set_xlabel("time (s) = angle along the circle (rad), first turn")
    a2.set_ylabel("w = |det J|")
    a2.set_title("along the circles (closed loop): w → 0 where the circle touches y = d₂")
    a2.legend(fontsize=7, loc="center right")
    for a in (a1, a2):
        a.grid(True, alpha=0.3)
    a2.set_ylim(bottom=0)
    viz.save_png(fig, path)


# ------------------------------------------------------------------ scenario
def run(out: Path, *, d2: float = 1.0) -> dict:
    """Run S5 into ``out``; returns the key numbers (see the module docstring)."""
    out = Path(out)
    robot = robots.load("pr", d2=d2)

    rng = np.random.default_rng(5)
    checks = [np.array([1.0, math.radians(a)]) for a in (0, 45, 90, -90, 135)] + list(robot.random_q(rng, 20))
    jac_error = max(float(np.abs(robot.jacobian(q)[:2] - position_jacobian(d2, q[1])).max()) for q in checks)
    fk_error = max(float(np.abs(robot.fk(q)[:2, 3] - [q[0] + d2 * math.cos(q[1]), d2 * math.sin(q[1])]).max())
                   for q in checks)

    rows, results = [], []
    for i, (v, qi, n, dt) in enumerate(RUNS, start=1):
        row, res = straight_run(robot, d2, v, qi, n, dt, i)
        rows.append(row)
        results.append(res)
    study = step_study(robot, d2)
    circle_rows, circle_runs = [], []
    for i, (centre, radius, n, dt) in enumerate(CIRCLES, start=1):
        row, op, cl = circle_run(robot, d2, centre, radius, n, dt)
        row["file"] = f"circle{i}.csv"
        np.savetxt(out / row["file"], np.c_[op.times, op.reference, op.q, op.positions, cl.q, cl.positions],
                   delimiter=",", fmt="%.12g", comments="",
                   header="t_s,x_ref_m,y_ref_m,open_d1_m,open_theta2_rad,open_x_m,open_y_m,"
                          "closed_d1_m,closed_theta2_rad,closed_x_m,closed_y_m")
        circle_rows.append(row)
        circle_runs.append((op, cl))

    with open(out / "runs.csv", "w") as f:
        f.write("run,vx,vy,d1_init,theta2_init_deg,n,dt,final_error,max_error,leaves_workspace_step,max_joint_rate,"
                "max_joint_rate_undamped,min_manipulability,first_singular_step,events\n")
        for r in rows:
            ev = " ".join(f"{e['kind']}@{e['step']}" for e in r["events"])
            first = r["singular_steps"][0] if r["singular_steps"] else ""
            leaves = "" if r["leaves_workspace_step"] is None else r["leaves_workspace_step"]
            f.write(f"{r['run']},{r['v'][0]:g},{r['v'][1]:g},{r['q_init'][0]:g},{r['q_init'][1]:g},{r['n']},{r['dt']:g},"
                    f"{r['final_error']:.12g},{r['max_error']:.12g},{leaves},{r['max_joint_rate']:.12g},"
                    f"{r['max_joint_rate_undamped']:.12g},{r['min_manipulability']:.12g},{first},{ev}\n")

    plot_runs_xy(rows, results, d2, out / "runs_xy.png")
    viz.save_png(runs_joints_figure(rows, results), out / "runs_joints.png")
    plot_step_size(study, out / "step_size.png")
    plot_circles(circle_rows, circle_runs, d2, out / "circles.png")
    plot_circle_errors(circle_rows, circle_runs, out / "circle_errors.png")
    plot_manipulability(rows, results, circle_rows, circle_runs, out / "manipulability.png")

    singular_start = next(r for r in rows if abs(r["q_init"][1]) == 90.0)
    first_circle = circle_rows[0]
    return {  # scalars first: `kinserve demo` prints the first few
        "runs": len(rows),
        "runs_with_singularity": sum(r["singular"] for r in rows),
        "singular_start_run": singular_start["run"],
        "singular_start_event_step": (singular_start["singular_steps"][0] if singular_start["singular_steps"]
                                      else None),
        "run1_final_error": rows[0]["final_error"],
        "circle1_max_error_open": first_circle["open"]["max_error"],
        "circle1_max_error_closed": first_circle["closed"]["max_error"],
        "closed_beats_open_on_all_circles": all(c["closed_beats_open"] for c in circle_rows),
        "jacobian_formula_error": jac_error,
        "fk_formula_error": fk_error,
        "d2": d2,
        "sigma_threshold": SIGMA_THRESHOLD,
        "table": rows,
        "step_study": study,
        "circles": circle_rows,
    }
