"""S1: the redundant planar 4R arm - the one-parameter IK family, both elbow branches, a chooser (SCENARIOS.md
S1).

Arm (``robots.load("planar4r")``): four revolute joints about ``z``, link
lengths ``l1..l4`` (default 1.0, 0.8, 0.6, 0.4 m), joint limits ``+-pi``::

    x = l1 c1 + l2 c12 + l3 c123 + l4 c1234,   y = l1 s1 + ... ,   theta_e = q1 + q2 + q3 + q4.

The task ``(x, y, theta_e)`` has 3 constraints for 4 joints, so its solution
set is a *one-parameter family*, not two configurations (seed 000 claims two;
seed 001 proves infinitely many). Closed form (:mod:`ik.closed_form.planar`):
the wrist point ``w = (x, y) - l4 (cos theta_e, sin theta_e)`` is fixed by the
task; the free parameter is ``q1``, which places the elbow
``c2 = l1 (cos q1, sin q1)``; the remaining 2R problem ``c2 -> w`` (links
``l2, l3``) has the two elbow branches ``q3 = +-acos((|w - c2|^2 - l2^2 - l3^2)
/ (2 l2 l3))`` (``atan2`` everywhere, never ``atan(y/x)``), and
``q4 = theta_e - q1 - q2 - q3``. ``q1`` is feasible when
``|l2 - l3| <= |w - c2(q1)| <= l2 + l3``: one or two intervals of ``q1``.

1. *Family* - :func:`ik.solve_all` samples the family over ``q1`` (``samples``
   values) on both branches; every member is checked here again with the
   robot's forward kinematics (``max_fk_position_residual`` m,
   ``max_fk_orientation_residual`` rad). ``family_q`` / ``family_branch`` /
   ``family_free_parameter`` hold every member.
2. *Chooser* - :func:`ik.choose` picks one member per named criterion:
   ``joint_limit_distance`` (largest normalised distance of the closest joint
   to a limit), ``displacement`` (closest to ``q_current`` in joint space),
   ``manipulability`` (largest ``sqrt(det(J J^T))`` of the ``x, y, yaw`` rows)
   and ``no_self_overlap`` (a filter: links must not cross in the plane) ranked
   by displacement. The default ``q_current`` is folded so that its nearest
   family member has crossing links: the filter changes the pick.
3. *Workspace boundary* - a target at full reach ``|p| = l1 + l2 + l3 + l4``
   with ``theta_e`` pointing outwards: the ``q1`` interval shrinks to a point
   and the two branches coincide (one configuration, the stretched arm).
   Approaching it, the interval width shrinks like ``sqrt(L - |p|)``
   (``boundary_sweep``).

Artefacts: ``family.png`` (the family, both branches, crossing members
apart), ``family_joints.png`` (``q2, q3, q4`` against the free parameter
``q1``), ``chosen.png`` (the pick of each criterion), ``boundary.png`` (the
collapse at the workspace boundary), ``scene.html`` (the picks in 3-D).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Circle as CirclePatch

from kinserve import ik, robots, viz
from kinserve.ik.closed_form.chooser import joint_limit_distance, self_overlap
from kinserve.kinematics import se3

#: Default task (x m, y m, theta_e rad).
TARGET = (1.0, 0.8, math.pi / 2)
#: Default current configuration (rad): folded, its nearest family member has crossing links.
Q_CURRENT = (1.2, -2.0, -2.0, 0.5)
#: Chooser runs: label -> criteria (filters first).
CRITERIA = {
    "joint_limit_distance": ("joint_limit_distance",),
    "displacement": ("displacement",),
    "manipulability": ("manipulability",),
    "no_self_overlap": ("no_self_overlap", "displacement"),
}
#: Two configurations closer than this (rad, max norm) count as one.
SAME_CONFIGURATION = 1e-6


def planar_pose(x: float, y: float, theta: float) -> np.ndarray:
    """4x4 pose of the task ``(x, y, theta_e)`` in the plane ``z = 0``."""
    T = np.eye(4)
    c, s = math.cos(theta), math.sin(theta)
    T[:2, :2] = [[c, -s], [s, c]]
    T[:2, 3] = (x, y)
    return T


def fk_residuals(robot, Q, T_target) -> tuple[np.ndarray, np.ndarray]:
    """Position (m) and orientation (rad) residuals of the tool at every row of ``Q``."""
    pe, re = [], []
    for q in Q:
        a, b = se3.pose_error(robot.fk(q), T_target)
        pe.append(a)
        re.append(b)
    return np.array(pe), np.array(re)


def branch_pairs(family) -> list[tuple[int, int]]:
    """Index pairs (elbow up, elbow down) sharing the same free parameter ``q1``."""
    up = {round(r.info["free_parameter"], 12): i for i, r in enumerate(family)
          if r.info["branch"] == "elbow up"}
    down = {round(r.info["free_parameter"], 12): i for i, r in enumerate(family)
            if r.info["branch"] == "elbow down"}
    return [(up[k], down[k]) for k in sorted(up) if k in down]


def distinct(Q, tol: float = SAME_CONFIGURATION) -> int:
    """Number of distinct rows of ``Q`` (max-norm distance above ``tol``)."""
    kept = []
    for q in np.asarray(Q, dtype=float):
        if all(np.abs(q - k).max() > tol for k in kept):
            kept.append(q)
    return len(kept)


def boundary_sweep(robot, lengths, direction: float, gaps, samples: int) -> dict:
    """Family width and branch separation for targets ``(L - gap)`` from the base along ``direction``.

    The tool points outwards (``theta_e = direction``), so at ``gap = 0`` the
    only solution is the stretched arm ``q = (direction, 0, 0, 0)``.
    """
    L = float(sum(lengths))
    rows = []
    for gap in gaps:
        d = L - gap
        fam = ik.solve_all(robot, planar_pose(d * math.cos(direction), d * math.sin(direction), direction),
                           samples=samples)
        Q = np.array([r.q for r in fam])
        q1 = np.array([r.info["free_parameter"] for r in fam])
        sep = max((float(np.abs(fam[i].q - fam[j].q).max()) for i, j in branch_pairs(fam)), default=0.0)
        pe, _ = fk_residuals(robot, Q, planar_pose(d * math.cos(direction),
                                                   d * math.sin(direction), direction))
        rows.append({"gap": float(gap), "reach": d, "family_size": len(fam), "distinct": distinct(Q),
                     "free_parameter_width": float(q1.max() - q1.min()), "branch_separation": sep,
                     "max_fk_position_residual": float(pe.max())})
    return {"direction": direction, "full_reach": L, "rows": rows}


def _figure(size=(7.0, 4.2), cols: int = 1):
    fig = Figure(figsize=size, layout="constrained")
    FigureCanvasAgg(fig)
    return fig, [fig.add_subplot(1, cols, i + 1) for i in range(cols)]


def _broken(x, y, max_dx: float = 0.2, max_dy: float = 1.0):
    """``(x, y)`` with NaN inserted where the curve jumps (a gap between q1 intervals, a 2 pi wrap)."""
    cut = np.flatnonzero((np.diff(x) > max_dx) | (np.abs(np.diff(y)) > max_dy)) + 1
    return np.insert(x.astype(float), cut, np.nan), np.insert(y.astype(float), cut, np.nan)


def _zoom(ax, points, margin: float = 0.25):
    """Equal-aspect limits around ``points`` (N, 2) with ``margin`` metres."""
    P = np.asarray(points, dtype=float)
    lo, hi = P.min(axis=0) - margin, P.max(axis=0) + margin
    c, h = 0.5 * (lo + hi), 0.5 * float((hi - lo).max())
    ax.set_xlim(c[0] - h, c[0] + h)
    ax.set_ylim(c[1] - h, c[1] + h)


def family_figure(lengths, Q, labels, overlap, target) -> Figure:
    """The family drawn as arms: one colour per elbow branch, members with crossing links apart.

    Every legend count is counted here from the members drawn: ``elbow up: N members`` is the
    branch's size (as ``elbow_up`` in ``result.json``), with how many of them cross.
    """
    labels, overlap = np.asarray(labels), np.asarray(overlap, dtype=bool)
    groups = {}
    for b in ("elbow up", "elbow down"):
        mine = labels == b
        n, n_cross = int(mine.sum()), int((mine & overlap).sum())
        groups[f"{b}: {n} members"
               + (f" ({n_cross} with crossing links, drawn apart)" if n_cross else "")] = \
            Q[mine & ~overlap]
    if overlap.any():
        groups[f"links cross: {int(overlap.sum())} members (rejected by no_self_overlap)"] = Q[overlap]
    fig = viz.planar_arm_figure(lengths, groups, target=target, max_per_branch=24, count_in_label=False,
                                title=f"S1 4R family for (x, y, θe) = ({target[0]:g}, {target[1]:g}, "
                                      f"{target[2]:.3g}): {len(Q)} members")
    ax = fig.axes[0]
    _zoom(ax, np.vstack([viz.planar_chain(lengths, q) for q in Q]))
    handles, names = ax.get_legend_handles_labels()
    ax.get_legend().remove()
    # below the arms, not on them
    fig.legend(handles, names, loc="outside lower center", fontsize=8, frameon=False)
    fig.set_size_inches(6.4, 7.2)
    return fig


def _family_joints_figure(family, overlap, chosen, target):
    fig, axes = _figure(size=(10.0, 3.8), cols=3)
    q1 = np.array([r.info["free_parameter"] for r in family])
    Q = np.array([r.q for r in family])
    labels = np.array([r.info["branch"] for r in family])
    markers = {"elbow up": ("o", "blue"), "elbow down": ("s", "orange")}
    for k, ax in enumerate(axes, start=1):
        for label, (m, c) in markers.items():
            sel = labels == label
            order = np.argsort(q1[sel])
            x, y = _broken(q1[sel][order], Q[sel][order, k])
            ax.plot(x, y, marker=m, markersize=3, linewidth=0.8, linestyle="-",
                    color=viz.colors.to_rgb(c), label=label)
        if overlap.any():
            ax.plot(q1[overlap], Q[overlap, k], "x", color="black", markersize=6, label="links cross")
        for i, (name, idx) in enumerate(chosen.items()):
            ax.plot([q1[idx]], [Q[idx, k]], marker="*", markersize=12, linestyle="none",
                    color=viz.colors.to_rgb(viz.colors.PALETTE[2 + i]), markeredgecolor="black",
                    label=f"pick: {name}")
        ax.set_xlabel("free parameter q1 (rad)")
        ax.set_ylabel(f"q{k + 1} (rad)")
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=7, loc="best")
    fig.suptitle(f"S1 solution family of (x, y, θe) = ({target[0]:g} m, {target[1]:g} m, "
                 f"{target[2]:.3g} rad): q2, q3, q4 as functions of q1", fontsize=10)
    return fig


def _chosen_figure(lengths, family, chosen, q_current, target, scores):
    Q = np.array([r.q for r in family])
    fig = viz.planar_arm_figure(lengths, {"family (all members)": Q}, target=target, max_per_branch=36,
                                title="S1 chooser: one family member per criterion")
    ax = fig.axes[0]
    for line in ax.lines[: min(len(Q), 36)]:  # the family, drawn first: grey background
        line.set_color("lightgrey")
        line.set_alpha(0.7)
    P = viz.planar_chain(lengths, q_current)
    ax.plot(P[:, 0], P[:, 1], "--o", color="black", linewidth=1.4, markersize=4, label="q_current")
    for i, (name, idx) in enumerate(chosen.items()):
        P = viz.planar_chain(lengths, family[idx].q)
        ax.plot(P[:, 0], P[:, 1], "-o", color=viz.colors.to_rgb(viz.colors.PALETTE[2 + i]), linewidth=2.6,
                markersize=5, label=f"{name} ({family[idx].info['branch']}, {scores[name]})")
    _zoom(ax, np.vstack([viz.planar_chain(lengths, q) for q in np.vstack([Q, q_current])]))
    ax.legend(loc="lower left", fontsize=7, framealpha=0.9)
    return fig


def _boundary_figure(sweep, lengths, families):
    fig, (ax, arm) = _figure(size=(11.0, 4.8), cols=2)
    rows = [r for r in sweep["rows"] if r["gap"] > 0]
    gap = np.array([r["gap"] for r in rows])
    width = np.array([r["free_parameter_width"] for r in rows])
    sep = np.array([r["branch_separation"] for r in rows])
    ax.loglog(gap, width, "o-", color=viz.colors.to_rgb("blue"), label="width of the q1 interval (rad)")
    ax.loglog(gap, sep, "s-", color=viz.colors.to_rgb("orange"),
              label="max |q_up − q_down| at equal q1 (rad)")
    ref = width[-1] * np.sqrt(gap / gap[-1])
    ax.loglog(gap, ref, ":", color="grey", label="∝ √gap")
    ax.set_xlabel("gap to full reach  L − |p|  (m)")
    ax.set_ylabel("rad")
    ax.set_title("Approaching the boundary: the family and its branches collapse", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    L = float(sum(lengths))
    for i, (label, Q) in enumerate(families.items()):
        c = viz.colors.to_rgb(viz.colors.PALETTE[i])
        idx = np.unique(np.linspace(0, len(Q) - 1, min(len(Q), 10)).round().astype(int))
        for j, k in enumerate(idx):
            P = viz.planar_chain(lengths, Q[k])
            arm.plot(P[:, 0], P[:, 1], "-o", color=c, markersize=2.5, linewidth=1.1 if len(Q) > 1 else 2.4,
                     alpha=0.8, label=label if j == 0 else None)
    arm.add_patch(CirclePatch((0, 0), L, fill=False, linestyle=":", edgecolor="grey"))
    arm.plot([0], [0], "ks", markersize=7)
    arm.set_aspect("equal")
    arm.set_xlim(-0.4, L + 0.2)
    arm.set_ylim(-0.6, 2.2)
    arm.grid(True, alpha=0.3)
    arm.set_xlabel("x (m)")
    arm.set_ylabel("y (m)")
    arm.set_title("Families for targets at distance |p| (tool pointing outwards)", fontsize=10)
    arm.legend(fontsize=8, loc="upper right")
    return fig


def run(out: Path, *, target=TARGET, q_current=Q_CURRENT, lengths=(1.0, 0.8, 0.6, 0.4), samples: int = 72,
        boundary_direction: float = 0.5, scene: bool = True) -> dict:
    """Run S1 into ``out``; returns the key numbers (see the module docstring)."""
    out = Path(out)
    lengths = tuple(float(v) for v in lengths)
    robot = robots.load("planar4r", l1=lengths[0], l2=lengths[1], l3=lengths[2], l4=lengths[3])
    target = tuple(float(v) for v in target)
    T = planar_pose(*target)
    q_current = robot.check_q(q_current, "q_current")

    # 1. the family, verified with the robot's FK
    family = ik.solve_all(robot, T, samples=samples)
    Q = np.array([r.q for r in family])
    labels = [r.info["branch"] for r in family]
    q1 = np.array([r.info["free_parameter"] for r in family])
    pe, re = fk_residuals(robot, Q, T)
    overlap = np.array([self_overlap(robot, q) for q in Q])
    branch_counts = {b: labels.count(b) for b in ("elbow up", "elbow down")}

    # 2. the chooser
    chosen, picks = {}, {}
    for name, criteria in CRITERIA.items():
        i = ik.choose(robot, family, criteria, q_current=q_current)
        chosen[name] = i
        q = family[i].q
        picks[name] = {
            "criteria": list(criteria), "index": i, "q": q, "branch": labels[i], "free_parameter": q1[i],
            "joint_limit_distance": joint_limit_distance(robot, q),
            "displacement": float(np.linalg.norm(q - q_current)), "manipulability": robot.manipulability(q),
            "self_overlap": bool(overlap[i]), "fk_position_residual": pe[i], "fk_orientation_residual": re[i],
        }
    scores = {
        "joint_limit_distance": f"limit distance {picks['joint_limit_distance']['joint_limit_distance']:.3f}",
        "displacement": f"|Δq| {picks['displacement']['displacement']:.3f} rad"
                        + (", links cross" if picks["displacement"]["self_overlap"] else ""),
        "manipulability": f"w {picks['manipulability']['manipulability']:.3f}",
        "no_self_overlap": f"|Δq| {picks['no_self_overlap']['displacement']:.3f} rad, no crossing",
    }

    # 3. the workspace boundary
    L = float(sum(lengths))
    a = float(boundary_direction)
    gaps = [0.5, 0.2, 0.1, 0.03, 1e-2, 3e-3, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 0.0]
    sweep = boundary_sweep(robot, lengths, a, gaps, samples)
    stretched = ik.solve_all(robot, planar_pose(L * math.cos(a), L * math.sin(a), a), samples=samples)
    Qs = np.array([r.q for r in stretched])
    pe_s, re_s = fk_residuals(robot, Qs, planar_pose(L * math.cos(a), L * math.sin(a), a))
    boundary_families = {}
    for gap in (0.3, 0.08, 0.0):
        d = L - gap
        fam = ik.solve_all(robot, planar_pose(d * math.cos(a), d * math.sin(a), a), samples=samples)
        boundary_families[f"|p| = {d:g} m ({len(fam)} sampled)" if gap
                          else f"|p| = {d:g} m = L: stretched"] = np.array(
            [r.q for r in fam])

    # plots
    viz.save_png(family_figure(lengths, Q, labels, overlap, target), out / "family.png")
    viz.save_png(_family_joints_figure(family, overlap, chosen, target), out / "family_joints.png")
    viz.save_png(_chosen_figure(lengths, family, chosen, q_current, target, scores), out / "chosen.png")
    viz.save_png(_boundary_figure(sweep, lengths, boundary_families), out / "boundary.png")

    if scene:
        sc = viz.Scene("kinserve S1 planar 4R: the chooser's picks and the target")
        for i, (name, idx) in enumerate(chosen.items()):
            sc.add_robot(robot, family[idx].q, name=f"pick_{name}", color=viz.colors.PALETTE[2 + i])
        sc.add_frame("target", T, length=0.3)
        sc.add_path("q_current", np.c_[viz.planar_chain(lengths, q_current), np.zeros(5)], color="black")
        viz.export_html(sc, out / "scene.html")

    return {  # scalars first: `kinserve demo` prints the first few
        "family_size": len(family),
        "elbow_up": branch_counts["elbow up"],
        "elbow_down": branch_counts["elbow down"],
        "max_fk_position_residual": float(pe.max()),
        "max_fk_orientation_residual": float(re.max()),
        "self_overlapping": int(overlap.sum()),
        "boundary_family_size": len(stretched),
        "boundary_distinct": distinct(Qs),
        "target": target,
        "link_lengths": lengths,
        "q_current": q_current,
        "q_current_self_overlap": self_overlap(robot, q_current),
        "branch_counts": branch_counts,
        "free_parameter": "q1",
        "free_parameter_range": [float(q1.min()), float(q1.max())],
        "family_q": Q,
        "family_branch": labels,
        "family_free_parameter": q1,
        "family_self_overlap": overlap,
        "chosen": picks,
        "boundary": {
            "target": (L * math.cos(a), L * math.sin(a), a),
            "family_size": len(stretched),
            "distinct": distinct(Qs),
            "q": Qs,
            "branches": [r.info["branch"] for r in stretched],
            "max_fk_position_residual": float(pe_s.max()),
            "max_fk_orientation_residual": float(re_s.max()),
            "sweep": sweep,
        },
    }
