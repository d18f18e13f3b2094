"""S4: Franka Panda pick-and-place - SE(3) polynomial trajectories tracked by damped least squares
(SCENARIOS.md S4).

World = the Panda's base frame. A box (open at the top) centred at
``(0.5, 0.5, 0.1)`` and a cylinder standing at ``(0.695, 0.095, 0.025)``.
The document's poses are poses of the **flange** ``panda_link8`` (its
``M`` is the flange at ``q = 0``), and so is the tool here: the gripper acts
at the flange, which at the grasp pose touches the top of the cylinder
(z = 0.05), 45 mm off its axis (the document's numbers). The Panda hand is
therefore not drawn: it would reach 0.1 m below the flange, through the floor.

1. *Model check* - forward kinematics of the URDF (Pinocchio) is the truth.
   ``FK(q = 0)`` equals the document's home pose
   ``[[1,0,0,0.088],[0,-1,0,0],[0,0,-1,0.926]]``. The document's space-frame
   screw axes ``S1..S7`` (product of exponentials ``T = exp([S1]q1)...exp([S7]q7) M``)
   are compared with the axes read off the URDF (columns of the spatial
   Jacobian at ``q = 0``): ``S4`` has ``v = (0.649, 0, -0.088)`` where the
   joint-4 axis passes at ``x = 0.0825`` (0.088 is the flange offset), and
   ``S7`` is the same line as the URDF's but reversed (joint 7 turns about
   ``-z`` at home). ``poe_document_max_*`` are the resulting FK errors of the
   document's PoE along the tracked trajectory; the corrected axes
   (``screw_axes_urdf``) reproduce the URDF to machine precision.
   ``q = 0`` itself is outside the URDF's joint-4 range ``[-3.0718, -0.0698]``
   (the Panda's elbow cannot straighten): the motion starts from ``q_start``,
   an in-limits configuration in the arm's vertical plane with the same flange
   pose (Levenberg-Marquardt IK).
2. *Trajectory* - waypoints home -> pre-grasp -> grasp -> lift -> pre-release
   -> release -> retreat -> home (the pre/post poses sit ``approach`` m back
   along the flange's approach axis; ``approach=0`` gives the document's
   home -> grasp -> release -> home). Each segment is
   :func:`planners.se3_polynomial_trajectory`: ``T(t) = T_s exp(xi(t))``
   with ``xi`` a quintic (zero boundary accelerations; ``order="cubic"``
   also available) meeting the boundary poses *and* body twists exactly.
   The arm passes the pre-/post- poses without stopping, at ``via_speed`` m/s
   along the approach axis (the boundary twists), and rests at home, grasp and
   release. Not the document's cubic in global exponential coordinates
   ``exp(c3 t^3 + ... + c0)``: ``d/dt exp(tau) != [tau'] exp(tau)`` when
   ``tau`` and ``tau'`` do not commute, so that construction misses its
   boundary twists (``document_cubic_twist_error`` measures by how much on
   these segments).
3. *Tracking* - every sample ``T(t_k)`` (``dt`` s apart) is solved by
   damped least squares ``dq = J^T (J J^T + lambda^2 I)^-1 e`` (=
   ``(J^T J + lambda^2 I)^-1 J^T e``) with Pinocchio's analytic Jacobian
   (:func:`ik.solve`, ``method="dls"``), warm started from the previous
   sample's solution, iterated to ``tol_pos``/``tol_rot``. The Panda is
   redundant (7 joints, 6 task rows): with ``centring > 0`` each DLS step also
   moves the joints towards mid-range inside the Jacobian's null space
   (strict priority, the task is unaffected; :mod:`ik.tasks.centring_weights`), which keeps
   them off their limits and brings the arm back to ``q_start`` at the end
   (``final_configuration_drift``; without it the self-motion drifts by
   about 1.8 rad). ``tracking_*`` are the pose errors of ``FK(q_k)`` against
   ``T(t_k)``; ``tracking_failures`` lists samples not reached within
   tolerance (with ``approach=0`` the direct release -> home motion drives
   joint 1 into its limit and is not tracked: reported there).
4. *Events* - ``grasped`` at the first step where the flange is within
   ``grasp_tolerance = (m, rad)`` of the grasp pose: from then on the
   cylinder moves rigidly with the flange,
   ``W_cyl(k) = F(k) F(k_grasp)^-1 W_cyl(0)``; ``released`` at the first
   later step within tolerance of the release pose: the cylinder stays where
   it is. ``cylinder_release_error`` is its distance from where an exact
   release would put it, ``T_release T_grasp^-1 W_cyl(0)``.

5. *Clearance* - the scene is a table top (top face z = 0) and the open box,
   as :class:`kinserve.kinematics.shapes.Box` obstacles; ``min_arm_scene_distance``
   is the smallest signed distance between the arm's collision hulls (links 0-7,
   no hand) and the scene over every step, ``min_cylinder_scene_distance`` that
   of the carried cylinder while it is carried, ``clearance`` the details
   (:mod:`.pick_place_clearance`).

Units: metres, radians, seconds. Artefacts: ``joints.png``,
``tracking_errors.png``, ``manipulability.png``, ``flange_trajectory.png``,
``trajectory.json`` / ``trajectory.csv`` (the joint trajectory),
``scene.html`` (the animated scene).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from kinserve import ik, robots, viz
from kinserve.kinematics import se3
from kinserve.kinematics.errors import InputError
from kinserve.planners import JointTrajectory, se3_polynomial_trajectory

from .pick_place_clearance import TABLE_CENTRE, TABLE_SIZE, motion_clearance

FLANGE = "panda_link8"

#: The document's poses (seed 002), flange frame in the world.
DOC_HOME = np.array([[1, 0, 0, 0.088], [0, -1, 0, 0], [0, 0, -1, 0.926], [0, 0, 0, 1.0]])
DOC_GRASP = np.array([[1, 0, 0, 0.65], [0, -1, 0, 0.095], [0, 0, -1, 0.05], [0, 0, 0, 1.0]])
DOC_RELEASE = np.array([[0, 0, 1, 0.45], [0, -1, 0, 0.5], [1, 0, 0, 0.35], [0, 0, 0, 1.0]])
BOX_CENTRE = np.array([0.5, 0.5, 0.1])
CYLINDER_POSE = se3.pose(p=[0.695, 0.095, 0.025])

#: The document's space-frame screw axes (omega, v) (SCENARIOS.md S4).
DOC_SCREWS = np.array([
    [0, 0, 1, 0, 0, 0],
    [0, 1, 0, -0.333, 0, 0],
    [0, 0, 1, 0, 0, 0],
    [0, -1, 0, 0.649, 0, -0.088],
    [0, 0, 1, 0, 0, 0],
    [0, -1, 0, 1.033, 0, 0],
    [0, 0, 1, 0, -0.088, 0],
], dtype=float)

#: Seed of the start configuration: the arm in its vertical plane, elbow bent (joint 4 < -0.0698).
HOME_SEED = np.array([0.0, -0.5, 0.0, -0.9, 0.0, 0.4, 0.0])

#: Geometry the document does not give (m): open box 0.2 m cube, walls 1 cm; cylinder r 5 cm, 5 cm tall.
BOX_SIZE = 0.2
BOX_WALL = 0.01
CYLINDER_RADIUS = 0.05
CYLINDER_HEIGHT = 0.05


# ------------------------------------------------------------------ model check
def screw_axes_from_model(robot, frame: str = FLANGE) -> np.ndarray:
    """Space-frame screw axes ``(nq, 6)`` as rows ``(omega, v)`` at ``q = 0``.

    Column ``i`` of the spatial Jacobian (Pinocchio's WORLD reference,
    ``[v; w]``) at ``q = 0`` is the twist of joint ``i``'s unit motion seen
    at the world origin: Lynch & Park's ``S_i = (omega_i, -omega_i x p_i)``.
    """
    J0 = robot.jacobian(np.zeros(robot.nq), frame, reference="spatial")
    return np.vstack([J0[3:], J0[:3]]).T.copy()


def poe_fk(screws, M, q) -> np.ndarray:
    """Product of exponentials ``exp([S_1] q_1) ... exp([S_n] q_n) M`` with rows ``S_i = (omega, v)``."""
    T = np.eye(4)
    for S, qi in zip(np.asarray(screws, dtype=float), np.asarray(q, dtype=float)):
        T = T @ se3.exp6(np.r_[S[3:], S[:3]] * qi)
    return T @ M


def _pose_errors(A, B) -> tuple[float, float]:
    return se3.pose_error(A, B)


# ------------------------------------------------------------------ trajectory
@dataclass(frozen=True)
class Waypoint:
    """A named flange pose with the body twist ``[v; w]`` (flange axes, m/s and rad/s) it is passed with."""

    name: str
    pose: np.ndarray
    twist: np.ndarray


def waypoints(approach: float = 0.12, via_speed: float = 0.05) -> list[Waypoint]:
    """The motion's waypoints (see the module docstring).

    Pre-/post- poses are ``T @ Tz(-approach)`` (``approach`` m back along the
    flange's ``z``, the approach axis) and are passed with the body twist
    ``(0, 0, +-via_speed, 0, 0, 0)`` (towards the grasp/release pose on the
    way in, away from it on the way out).
    """
    zero = np.zeros(6)
    if approach < 0 or via_speed < 0:
        raise InputError(f"approach and via_speed must be >= 0, got {approach!r}, {via_speed!r}")
    if approach == 0:
        return [Waypoint("home", DOC_HOME, zero), Waypoint("grasp", DOC_GRASP, zero),
                Waypoint("release", DOC_RELEASE, zero), Waypoint("home", DOC_HOME, zero)]
    back = se3.pose(p=[0.0, 0.0, -float(approach)])
    towards = np.array([0, 0, via_speed, 0, 0, 0], dtype=float)
    away = np.array([0, 0, -via_speed, 0, 0, 0], dtype=float) + 0.0  # + 0.0: no negative zeros
    return [
        Waypoint("home", DOC_HOME, zero),
        Waypoint("pre-grasp", DOC_GRASP @ back, towards),
        Waypoint("grasp", DOC_GRASP, zero),
        Waypoint("lift", DOC_GRASP @ back, away),
        Waypoint("pre-release", DOC_RELEASE @ back, towards),
        Waypoint("release", DOC_RELEASE, zero),
        Waypoint("retreat", DOC_RELEASE @ back, away),
        Waypoint("home", DOC_HOME, zero),
    ]


def segment_durations(wps: list[Waypoint], move: float, approach: float) -> list[float]:
    """``approach`` s for a segment between the grasp/release pose and its pre-/post- pose, else ``move``
    s."""
    out = []
    for a, b in zip(wps[:-1], wps[1:]):
        short = {a.name, b.name} in ({"pre-grasp", "grasp"}, {"grasp", "lift"}, {"pre-release", "release"},
                                     {"release", "retreat"})
        out.append(approach if short else move)
    return out


def plan_segments(wps: list[Waypoint], durations, order: str = "quintic"):
    """One :func:`planners.se3_polynomial_trajectory` per pair of consecutive waypoints."""
    return [se3_polynomial_trajectory(a.pose, b.pose, d, a.twist, b.twist, order=order)
            for a, b, d in zip(wps[:-1], wps[1:], durations)]


def sample_segments(segments, dt: float):
    """Times ``(N,)``, target poses ``(N, 4, 4)``, body twists ``(N, 6)`` and the sample index of each
    waypoint.

    Every segment is sampled at ``t0 + k dt``; its end is the next segment's
    start (one sample); segment durations are rounded to whole steps first.
    """
    times, poses, twists, marks = [0.0], [segments[0].T0], [segments[0].body_twist(0.0)], [0]
    t0 = 0.0
    for seg in segments:
        n = int(round(seg.duration / dt))
        if abs(n * dt - seg.duration) > 1e-9 * max(1.0, seg.duration):
            raise InputError(f"segment duration {seg.duration} s is not a whole number of steps dt={dt} s")
        t = dt * np.arange(1, n + 1)
        times.extend(t0 + t)
        poses.extend(seg.pose(t))
        twists.extend(seg.body_twist(t))
        t0 += n * dt
        marks.append(len(times) - 1)
    return np.array(times), np.array(poses), np.array(twists), marks


def document_cubic_twist_error(T0, T1, V0, V1, tf: float, h: float = 1e-6) -> float:
    """Boundary-twist error of the document's cubic in *global* exponential coordinates.

    The document sets ``T(t) = exp([tau(t)])``, ``tau = c3 t^3 + c2 t^2 + c1 t + c0``
    with ``c0 = log T0``, ``c1 = V0``, ``tau(tf) = log T1``, ``tau'(tf) = V1``,
    assuming ``dT/dt = [tau'] T`` (spatial twist ``= tau'``). ``V0, V1`` here
    are the body twists of the boundary conditions, turned into the spatial
    twists ``Ad(T) V`` the document's formula uses. Returns the largest
    ``|[dT/dt T^-1]^vee - V_spatial|`` at ``t = 0`` and ``t = tf`` (central
    differences of step ``h``); it vanishes only when the twists commute with
    ``tau`` (e.g. both zero).
    """
    t0_, t1_ = se3.log6(T0), se3.log6(T1)
    Vs0 = np.asarray(pin.SE3(T0[:3, :3], T0[:3, 3]).action @ V0)
    Vs1 = np.asarray(pin.SE3(T1[:3, :3], T1[:3, 3]).action @ V1)
    c0, c1 = t0_, Vs0
    c2 = 3 * (t1_ - t0_) / tf**2 - (2 * Vs0 + Vs1) / tf
    c3 = -2 * (t1_ - t0_) / tf**3 + (Vs0 + Vs1) / tf**2

    def T(t):
        return se3.exp6(c3 * t**3 + c2 * t**2 + c1 * t + c0)

    worst = 0.0
    for t, V in ((0.0, Vs0), (tf, Vs1)):
        dT = (T(t + h) - T(t - h)) / (2 * h)
        W = dT @ se3.inverse(T(t))
        twist = np.r_[W[:3, 3], W[2, 1], W[0, 2], W[1, 0]]
        worst = max(worst, float(np.linalg.norm(twist - V)))
    return worst


# ------------------------------------------------------------------ tracking
#: Iterations the solve of the start configuration may take, all its starts together (an iteration budget:
#: the answer depends on the inputs only, not on the machine's speed or load).
START_ITERATION_BUDGET = 2000


def start_configuration(robot) -> tuple[np.ndarray, float, float]:
    """``(q_start, position error, orientation error)``: an in-limits configuration with the home flange pose
    (Levenberg-Marquardt ended by :data:`START_ITERATION_BUDGET` iterations, never by the clock)."""
    res = ik.solve(robot, DOC_HOME, HOME_SEED, frame=FLANGE, method="lm", prefer_q0=True, seed_table=False,
                   tol_pos=1e-9, tol_rot=1e-9, max_iter=200, iteration_budget=START_ITERATION_BUDGET)
    return res.q, res.position_error, res.orientation_error


def track(robot, poses, q_start, *, damping: float, tol_pos: float, tol_rot: float, max_iter: int,
          centring: float = 0.0):
    """DLS IK of every pose, warm started: ``(Q, position errors, orientation errors, iterations, failures)``;
    each pose's run is ended by ``max_iter`` iterations (its iteration budget), never by the clock."""
    n = len(poses)
    Q = np.empty((n, robot.nq))
    pe, re, its = np.empty(n), np.empty(n), np.empty(n, dtype=int)
    failed = []
    q = q_start
    for k, T in enumerate(poses):
        res = ik.solve(robot, T, q, frame=FLANGE, method="dls", damping=damping, tol_pos=tol_pos,
                       tol_rot=tol_rot, max_iter=max_iter, iteration_budget=max_iter, centring=centring)
        q = res.q
        Q[k], pe[k], re[k], its[k] = q, res.position_error, res.orientation_error, res.iterations
        if not res.success:
            failed.append(k)
    return Q, pe, re, its, failed


def first_within(flange, target, tol_pos: float, tol_rot: float, start: int = 0) -> int | None:
    """First step ``k >= start`` whose flange pose is within ``(tol_pos, tol_rot)`` of ``target``."""
    for k in range(start, len(flange)):
        p, r = se3.pose_error(flange[k], target)
        if p <= tol_pos and r <= tol_rot:
            return k
    return None


# ------------------------------------------------------------------ drawing
def arm_without_hand(robot):
    """A copy of the Panda whose visual model lacks the hand and fingers (the document's tool is the
    flange)."""
    arm = robot.copy()
    gm = pin.GeometryModel()
    for g in robot.visual_model.geometryObjects:
        if not g.name.startswith(("panda_hand", "panda_leftfinger", "panda_rightfinger")):
            gm.addGeometryObject(g)
    arm.visual_model = gm
    return arm


def draw_open_box(scene, name: str, centre, size: float, wall: float, color="#b07c4f"):
    """A box open at the top: a floor plate and four walls (outer size ``size``, walls ``wall`` thick)."""
    c = np.asarray(centre, dtype=float)
    h = size
    scene.add_box(f"{name}/bottom", [size, size, wall], c + [0, 0, -h / 2 + wall / 2], color=color)
    for i, (dx, dy) in enumerate(((1, 0), (-1, 0), (0, 1), (0, -1))):
        sx, sy = (wall, size) if dx else (size, wall)
        scene.add_box(f"{name}/wall{i}", [sx, sy, h], c + [dx * (size - wall) / 2, dy * (size - wall) / 2, 0],
                      color=color, opacity=0.85)


def joints_with_events(times, Q, robot, title: str, events: dict, marks_t) -> Figure:
    """The joints plot of S4 (and its planned variant): ``Q`` against ``times`` within ``robot``'s limits, the
    ``events`` ({label: (time, colour)}) as dashed lines and the segment boundaries ``marks_t`` dotted."""
    fig = viz.joints_figure(times, Q, robot.joint_names, limits=(robot.lower, robot.upper), xlabel="time (s)",
                            ylabel="joint angle (rad)", title=title)
    ax = fig.axes[0]
    events_on(ax, events, marks_t)
    ax.set_ylim(-3.3, 4.0)
    ax.legend(loc="upper center", fontsize=7, ncol=5, framealpha=0.9)
    fig.set_size_inches(8.0, 4.6)
    return fig


def events_on(ax, events: dict, marks_t=None):
    """Draw ``events`` ({label: (time or None, colour)}) as dashed vertical lines and the inner ``marks_t``
    (segment boundaries, s) as dotted ones on ``ax``."""
    for label, (t, color) in events.items():
        if t is not None:
            ax.axvline(t, color=color, linestyle="--", linewidth=1.1, label=label)
    if marks_t is not None:
        for t in marks_t[1:-1]:
            ax.axvline(t, color="grey", linestyle=":", linewidth=0.7)


def tracking_errors_figure(times, position_error, orientation_error, *, tol_pos: float, tol_rot: float,
                           events: dict, marks_t=None, damping: float, centring: bool) -> Figure:
    """Position (m) and orientation (rad) tracking errors of the DLS IK against time, log scale, with the
    solver's tolerances, the grasp/release events and the via points; the legend sits below the axes."""
    fig = viz.errors_figure(times, {"position error (m)": position_error,
                                    "orientation error (rad)": orientation_error},
                            xlabel="time (s)", ylabel="|error| (m, rad)", title="")
    fig.set_size_inches(8.0, 5.0)
    ax = fig.axes[0]
    ax.set_title(f"S4 tracking errors of DLS IK\n(λ = {damping:g}, "
                 f"warm started{', null-space centring' if centring else ''}, "
                 f"{len(times)} samples)", fontsize=10)
    ax.axhline(tol_pos, color=viz.colors.to_rgb(viz.colors.cycle(0)), linestyle=":", linewidth=1.0,
               label=f"DLS tol_pos {tol_pos:g} m")
    ax.axhline(tol_rot, color=viz.colors.to_rgb(viz.colors.cycle(1)), linestyle=":", linewidth=1.0,
               label=f"DLS tol_rot {tol_rot:g} rad")
    events_on(ax, events, marks_t)
    if marks_t is not None and len(marks_t) > 2:
        ax.plot([], [], color="grey", linestyle=":", linewidth=0.7, label="via points")
    handles, labels = ax.get_legend_handles_labels()
    ax.get_legend().remove()
    fig.legend(handles, labels, loc="outside lower center", ncol=4, fontsize=7, frameon=False)
    return fig


def _figure(rows: int = 1, size=(8.0, 4.4)):
    fig = Figure(figsize=size, layout="constrained")
    FigureCanvasAgg(fig)
    return fig, [fig.add_subplot(rows, 1, i + 1) for i in range(rows)]


# ------------------------------------------------------------------ scenario
def run(out: Path, *, order: str = "quintic", approach: float = 0.12, via_speed: float = 0.05,
        move_duration: float = 3.0, approach_duration: float = 1.5, dt: float = 0.03, damping: float = 0.05,
        tol_pos: float = 1e-5, tol_rot: float = 1e-4, max_iter: int = 100, centring: float = 1.0,
        grasp_tolerance=(1e-3, 1e-2),
        scene: bool = True) -> dict:
    """Run S4 into ``out``; returns the key numbers (see the module docstring)."""
    out = Path(out)
    panda = robots.load("panda")

    # 1. model check
    home_fk = panda.fk(np.zeros(panda.nq), FLANGE)
    home_fk_error = float(np.abs(home_fk - DOC_HOME).max())
    screws_urdf = screw_axes_from_model(panda)
    differ = [i + 1 for i in range(panda.nq) if not np.allclose(screws_urdf[i], DOC_SCREWS[i], atol=1e-9)]
    q_zero_outside = [panda.joint_names[i] for i in np.flatnonzero((0.0 < panda.lower) | (0.0 > panda.upper))]
    q_start, start_pe, start_re = start_configuration(panda)

    # 2. trajectory
    wps = waypoints(approach, via_speed)
    durations = segment_durations(wps, move_duration, approach_duration)
    segments = plan_segments(wps, durations, order)
    times, targets, twists, marks = sample_segments(segments, dt)
    doc_cubic = max(document_cubic_twist_error(a.pose, b.pose, a.twist, b.twist, d)
                    for a, b, d in zip(wps[:-1], wps[1:], durations))
    boundary = []
    for i, (seg, a, b) in enumerate(zip(segments, wps[:-1], wps[1:])):
        e0 = _pose_errors(seg.pose(0.0), a.pose)
        e1 = _pose_errors(seg.pose(seg.duration), b.pose)
        boundary.append({
            "name": f"{a.name} -> {b.name}", "duration": seg.duration, "t0": float(times[marks[i]]),
            "t1": float(times[marks[i + 1]]), "index0": marks[i], "index1": marks[i + 1],
            "start_twist": a.twist, "end_twist": b.twist,
            "start_pose_error": max(e0), "end_pose_error": max(e1),
            "start_twist_error": float(np.linalg.norm(seg.body_twist(0.0) - a.twist)),
            "end_twist_error": float(np.linalg.norm(seg.body_twist(seg.duration) - b.twist)),
        })

    # 3. tracking
    Q, track_pe, track_re, iterations, failed = track(panda, targets, q_start, damping=damping,
                                                      tol_pos=tol_pos, tol_rot=tol_rot, max_iter=max_iter,
                                                      centring=centring)
    flange = np.array([panda.fk(q, FLANGE) for q in Q])
    manip = np.array([panda.manipulability(q, FLANGE) for q in Q])
    sigma_min = np.array([panda.singular_values(q, FLANGE)[-1] for q in Q])
    poe_doc = [_pose_errors(poe_fk(DOC_SCREWS, DOC_HOME, q), F) for q, F in zip(Q, flange)]
    poe_urdf = [_pose_errors(poe_fk(screws_urdf, DOC_HOME, q), F) for q, F in zip(Q, flange)]

    # 4. events and the cylinder
    tp, tr = (float(v) for v in grasp_tolerance)
    grasp_step = first_within(flange, DOC_GRASP, tp, tr)
    release_step = None if grasp_step is None else first_within(flange, DOC_RELEASE, tp, tr, grasp_step + 1)
    ideal_cylinder = DOC_RELEASE @ se3.inverse(DOC_GRASP) @ CYLINDER_POSE
    if grasp_step is not None:
        offset = se3.inverse(flange[grasp_step]) @ CYLINDER_POSE
        end = release_step if release_step is not None else len(Q) - 1
        cylinder = np.array([CYLINDER_POSE if k < grasp_step else flange[min(k, end)] @ offset
                             for k in range(len(Q))])
    else:
        cylinder = np.repeat(CYLINDER_POSE[None], len(Q), axis=0)
    cyl_final = cylinder[-1]
    cyl_pe, cyl_re = _pose_errors(cyl_final, ideal_cylinder)

    # 5. clearance between the arm (and the carried cylinder) and the scene (table top, open box)
    clearance = motion_clearance(panda, Q, cylinder, grasp_step, release_step, radius=CYLINDER_RADIUS,
                                 height=CYLINDER_HEIGHT, box_centre=BOX_CENTRE, box_size=BOX_SIZE,
                                 box_wall=BOX_WALL)

    traj = JointTrajectory.from_positions(panda.joint_names, Q, dt, zero_end_velocities=True)
    traj.save(out / "trajectory.json")
    traj.save(out / "trajectory.csv")

    # plots
    ev = {f"grasped (step {grasp_step})": (None if grasp_step is None else times[grasp_step], "green"),
          f"released (step {release_step})": (None if release_step is None else times[release_step], "red")}
    marks_t = times[marks]
    fig = joints_with_events(times, Q, panda,
                             "S4 Panda: joints tracking the SE(3) trajectory (dotted: limits)", ev, marks_t)
    viz.save_png(fig, out / "joints.png")

    fig = tracking_errors_figure(times, track_pe, track_re, tol_pos=tol_pos, tol_rot=tol_rot, events=ev,
                                 marks_t=marks_t, damping=damping, centring=bool(centring))
    viz.save_png(fig, out / "tracking_errors.png")

    fig = viz.manipulability_figure(times, {"manipulability w = √det(J Jᵀ)": manip, "σ_min(J)": sigma_min},
                                    title="S4 manipulability of the flange Jacobian (6×7) along the motion")
    ax = fig.axes[0]
    events_on(ax, ev, marks_t)
    ax.set_ylim(bottom=0)
    ax.legend(loc="upper right", fontsize=7, framealpha=0.9)
    viz.save_png(fig, out / "manipulability.png")

    fig, (a1, a2) = _figure(2, (8.0, 6.2))
    for j, lab in enumerate("xyz"):
        c = viz.colors.to_rgb(viz.colors.cycle(j))
        a1.plot(times, targets[:, j, 3], color=c, linewidth=2.4, alpha=0.45, label=f"{lab} planned")
        a1.plot(times, flange[:, j, 3], color=c, linewidth=1.0, linestyle="--", label=f"{lab} tracked")
    top = a1.secondary_xaxis("top")
    top.set_xticks(marks_t, [w.name for w in wps], fontsize=7, rotation=30, ha="left")
    events_on(a1, {}, marks_t)
    a1.set_ylabel("flange position (m)")
    a1.set_ylim(-0.05, 1.2)
    a1.set_title(f"S4 flange trajectory: {order} T(t) = T_s·exp(ξ(t)) per segment, "
                 f"via twists {via_speed:g} m/s", fontsize=10)
    a1.grid(True, alpha=0.3)
    a1.legend(loc="upper center", fontsize=7, ncol=6, framealpha=0.9)
    a2.plot(times, np.linalg.norm(twists[:, :3], axis=1), label="|v| planned (m/s)",
            color=viz.colors.to_rgb("blue"))
    a2.plot(times, np.linalg.norm(twists[:, 3:], axis=1), label="|ω| planned (rad/s)",
            color=viz.colors.to_rgb("red"))
    events_on(a2, ev, marks_t)
    a2.set_xlabel("time (s)")
    a2.set_ylabel("body twist norm")
    a2.grid(True, alpha=0.3)
    a2.legend(loc="upper left", fontsize=7, framealpha=0.9)
    viz.save_png(fig, out / "flange_trajectory.png")

    # scene
    if scene:
        arm = arm_without_hand(panda)
        sc = viz.Scene("kinserve S4 Panda pick and place (grasp -> release)")
        sc.add_robot(arm, Q[0], name="panda")
        draw_open_box(sc, "box", BOX_CENTRE, BOX_SIZE, BOX_WALL)
        sc.add_box("table", TABLE_SIZE, se3.pose(p=TABLE_CENTRE), color="#d9d2c5", opacity=0.6)
        sc.add_cylinder("cylinder", CYLINDER_RADIUS, CYLINDER_HEIGHT, CYLINDER_POSE, color="orange")
        sc.add_path("tool_path", flange[:, :3, 3], color="blue")
        for name, T in (("home", DOC_HOME), ("grasp", DOC_GRASP), ("release", DOC_RELEASE)):
            sc.add_frame(f"targets/{name}", T, length=0.1, radius=0.005)
        sc.add_frame("flange", flange[0], length=0.07, radius=0.004)
        anim = viz.Animation(sc, fps=1.0 / dt)
        anim.robot("panda", Q)
        anim.attach("flange", "panda", 0, None, frame=FLANGE)
        if grasp_step is not None:
            anim.attach("cylinder", "panda", grasp_step, release_step, frame=FLANGE)
        anim.apply()
        sc.set_camera([1.1, -0.65, 1.0], [0.3, 0.15, 0.42])
        viz.export_html(sc, out / "scene.html")

    pos, axis = cyl_final[:3, 3], np.round(cyl_final[:3, 2], 3) + 0.0
    return {  # scalars first: `kinserve demo` prints the first few
        "grasp_step": grasp_step,
        "release_step": release_step,
        "cylinder_final": ("position ({:.4f}, {:.4f}, {:.4f}) m, axis ({:.3f}, {:.3f}, {:.3f})"
                           .format(*pos, *axis)),
        "cylinder_release_error": cyl_pe,
        "min_arm_scene_distance": clearance["min_arm_scene_distance"],
        "min_cylinder_scene_distance": clearance["min_cylinder_scene_distance"],
        "max_tracking_position_error": float(track_pe.max()),
        "max_tracking_orientation_error": float(track_re.max()),
        "grasp_time": None if grasp_step is None else float(times[grasp_step]),
        "release_time": None if release_step is None else float(times[release_step]),
        "cylinder_final_x": float(pos[0]),
        "cylinder_final_y": float(pos[1]),
        "cylinder_final_z": float(pos[2]),
        "cylinder_final_pose": cyl_final,
        "cylinder_ideal_pose": ideal_cylinder,
        "cylinder_release_rotation_error": cyl_re,
        "cylinder_initial_pose": CYLINDER_POSE,
        "grasp_tolerance": [tp, tr],
        "flange_at_grasp": None if grasp_step is None else flange[grasp_step],
        "flange_at_release": None if release_step is None else flange[release_step],
        "events": [{"kind": kind, "step": step, "time": float(times[step])}
                   for kind, step in (("grasped", grasp_step),
                                      ("released", release_step)) if step is not None],
        "home_pose_document": DOC_HOME,
        "home_fk": home_fk,
        "home_fk_error": home_fk_error,
        "q_zero_outside_limits": q_zero_outside,
        "q_start": q_start,
        "q_start_pose_error": [start_pe, start_re],
        "q_final": Q[-1],
        "final_configuration_drift": float(np.linalg.norm(Q[-1] - q_start)),
        "centring": centring,
        "min_limit_margin": float(np.minimum(Q - panda.lower, panda.upper - Q).min()),
        "final_pose_error": list(_pose_errors(flange[-1], DOC_HOME)),
        "screw_axes_document": DOC_SCREWS,
        "screw_axes_urdf": screws_urdf,
        "screw_axes_differ": differ,
        "poe_document_max_position_error": max(p for p, _ in poe_doc),
        "poe_document_max_orientation_error": max(r for _, r in poe_doc),
        "poe_urdf_axes_max_error": max(max(e) for e in poe_urdf),
        "order": order,
        "dt": dt,
        "damping": damping,
        "samples": len(Q),
        "duration": float(times[-1]),
        "waypoints": [{"name": w.name, "pose": w.pose, "twist": w.twist, "index": m, "time": float(times[m])}
                      for w, m in zip(wps, marks)],
        "segments": boundary,
        "document_cubic_twist_error": doc_cubic,
        "tracking_failures": failed,
        "max_dls_iterations": int(iterations.max()),
        "mean_dls_iterations": float(iterations.mean()),
        "min_manipulability": float(manip.min()),
        "min_manipulability_step": int(manip.argmin()),
        "min_sigma": float(sigma_min.min()),
        "within_joint_limits": bool(all(panda.within_limits(q) for q in Q)),
        "clearance": clearance,
    }
