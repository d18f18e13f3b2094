"""S4, planned: the Panda's pick-and-place with a carried cylinder, a planned transfer around the open box and
straight-line approach and retreat moves (``kinserve demo pick-place --planned``).

The scene and the document's numbers are those of :mod:`.pick_place` (world = the Panda's base frame): a
table top (top face ``z = 0``), the open box (0.2 m cube, 1 cm walls, centred at ``(0.5, 0.5, 0.1)``) as
its five plates, so the hole is real (:func:`.pick_place_clearance.box_plates`), and a cylinder (r 5 cm,
5 cm tall) standing at ``(0.695, 0.095, 0.025)``. The tool is the flange ``panda_link8``; the hand and the
fingers are left out of the robot (collision and visual models), as in S4: at the document's grasp pose
the flange touches the top of the cylinder, where the hand would reach 0.1 m below it, through the table.

**Sequence** (every stage from where the one before ended; each pose's IK, each plan and each
straight line on iteration budgets and seeds, never on the clock, so the same inputs give the same
answer on a busy machine):

1. ``q_start``: the in-limits configuration of the document's home pose
   (:func:`.pick_place.start_configuration`);
2. *pre-grasp IK*: the grasp pose ``approach`` m back along the flange's approach axis ``z`` (above the
   cylinder), solved collision free (:func:`ik.solve`, warm started at the current configuration);
3. *to pre-grasp*: :func:`planners.plan_motion` around the table, the box and the standing cylinder;
4. *approach*: :func:`planners.plan_cartesian` straight down to the document's grasp pose ``DOC_GRASP``,
   checked against the same obstacles (the flange's link ends 0.16 mm above the cylinder's top there);
5. *grasp*: the cylinder is attached to the flange (``robot.attach``, an :class:`ik.Cylinder` at its
   pose in the flange frame ``F(q_grasp)^-1 W_cyl``, touch link ``panda_link7``, the flange's link); it
   is carried - checked against the obstacles and the arm's other links - until the release;
6. *lift*: straight up ``approach`` m, checked against the box only: the cylinder starts standing on
   the table (contact, 0 m) and the line moves everything away from it; the clearance below covers
   the table along this move too;
7. *pre-release IK* and *transfer*: :func:`planners.plan_motion` carrying the cylinder, around the box,
   to ``approach`` m above the release pose;
8. *lower*: straight down into the box to the release pose :func:`release_pose`, the cylinder upright
   with its axis at ``release_xy`` and its bottom ``release_height`` m above the box's floor: the
   cylinder is released there, wholly inside the box (it would drop the rest of the way);
9. *release*: detached; from now on it is an obstacle at that pose;
10. *retreat*: straight up ``approach`` m; *home*: :func:`planners.plan_motion` back to ``q_start``.

Every :func:`~planners.plan_motion` and :func:`~planners.plan_cartesian` result is certified collision
free as a continuous motion (with the robot's self-collision checked). The stages' trajectories (at rest
at both ends) are joined into one, with a ``dwell`` s hold at the grasp and at the release.

**Why not the document's release pose**: ``DOC_RELEASE`` turns the flange's approach axis horizontal and
holds the cylinder on its side with its centre at ``z = 0.395`` m, 0.195 m above the box's rim; with
that orientation link 6 hangs 0.137 m below the flange, so no pose of it puts the cylinder inside a
0.2 m box. The planned variant keeps the grasp orientation (approach axis down) for the release;
``cylinder_document_release_error`` is the distance (m, rad) of the final cylinder pose from the
document's ideal ``DOC_RELEASE DOC_GRASP^-1 W_cyl``.

**Clearance**, computed afterwards and independently of the planners' certificates, on every sample of
the joined trajectory and on linear interpolation between them (no joint moves more than
``max_joint_step`` rad between checks): coal's signed distances (m) of the arm's link hulls
(``panda_link0..7``, :meth:`Robot.min_distance`) to the box's plates and to the table, and of the carried
cylinder (a coal cylinder at ``F(q) F(q_grasp)^-1 W_cyl``) to the box's plates over the carried samples
and to the table over the carried samples after the lift (before, it stands on the table). Each minimum is
then looked for again on a sixteen times finer sampling of the two intervals beside the smallest sample.

Units: metres, radians, seconds. Artefacts: ``trajectory.json`` / ``trajectory.csv`` (the joined joint
trajectory), ``joints.png``, ``clearance.png``, ``scene.html`` (the arm animated, the box, the table, the
cylinder carried between the grasp and the release, the flange's path).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from kinserve import ik, robots, viz
from kinserve.kinematics import se3
from kinserve.kinematics.errors import InputError
from kinserve.kinematics.robot import Extensions, Robot
from kinserve.kinematics.shapes import Box, Cylinder, Shape
from kinserve.planners import JointTrajectory, plan_cartesian, plan_motion

from .pick_place import (
    BOX_CENTRE,
    BOX_SIZE,
    BOX_WALL,
    CYLINDER_HEIGHT,
    CYLINDER_POSE,
    CYLINDER_RADIUS,
    DOC_GRASP,
    DOC_RELEASE,
    FLANGE,
    arm_without_hand,
    draw_open_box,
    events_on,
    joints_with_events,
    start_configuration,
)
from .pick_place_clearance import TABLE_CENTRE, TABLE_SIZE, arm_only, box_plates, cylinder_distance

#: The collision link the cylinder touches at the grasp (the flange's own link; link 8 has no geometry).
TOUCH_LINKS = ("panda_link7",)
#: IK of the pre-grasp and pre-release poses: tolerances (m, rad) and the iteration budget of all starts.
IK_TOL = (1e-7, 1e-6)
IK_BUDGET = 2000
#: The straight lines' IK tolerances (m, rad): tight, so the grasp pose is met to well under the 0.16 mm
#: between the flange's link and the cylinder's top there.
LINE_TOL = (1e-6, 1e-5)


# ------------------------------------------------------------------ scene
def release_pose(release_xy: tuple[float, float] = (0.52, 0.52), release_height: float = 0.10
                 ) -> tuple[np.ndarray, np.ndarray]:
    """``(flange pose, cylinder pose)`` of the release: the cylinder upright with its axis at
    ``release_xy`` (m) and its bottom ``release_height`` m above the top of the box's floor plate, held as
    at the grasp (``flange = W_cyl_release W_cyl^-1 DOC_GRASP``)."""
    xy = np.asarray(release_xy, dtype=float)
    if xy.shape != (2,) or not np.all(np.isfinite(xy)):
        raise InputError(f"release_xy must be two finite numbers (m), got {release_xy!r}")
    if not (isinstance(release_height, (int, float)) and np.isfinite(release_height) and release_height >= 0):
        raise InputError(f"release_height must be a number >= 0 (m), got {release_height!r}")
    floor_top = BOX_CENTRE[2] - BOX_SIZE / 2 + BOX_WALL
    cylinder = se3.pose(p=[xy[0], xy[1], floor_top + release_height + CYLINDER_HEIGHT / 2])
    return cylinder @ se3.inverse(CYLINDER_POSE) @ DOC_GRASP, cylinder


def planning_arm(panda: Robot) -> Robot:
    """A copy of the Panda without the hand and fingers in its collision and visual models, with its own IK
    state (the IK's bound collision constraints belong to one collision model)."""
    arm = arm_without_hand(arm_only(panda))
    arm.extensions = Extensions()
    return arm


def table_box() -> tuple[Box, list[Box]]:
    """The table top and the five plates of the open box."""
    return Box(se3.pose(p=TABLE_CENTRE), TABLE_SIZE), box_plates(BOX_CENTRE, BOX_SIZE, BOX_WALL)


# ------------------------------------------------------------------ the stages
@dataclass(frozen=True)
class Stage:
    """One stage: ``name``, ``kind`` (``"ik"``, ``"plan_motion"`` or ``"plan_cartesian"``), ``success``,
    ``message``, ``trajectory`` (None for IK or on failure), ``carrying`` (the cylinder is carried),
    ``checked`` (names of the obstacles it was checked against) and ``stats`` (iterations, fraction, ...)."""

    name: str
    kind: str
    success: bool
    message: str
    trajectory: JointTrajectory | None = None
    carrying: bool = False
    checked: tuple[str, ...] = ()
    stats: dict = field(default_factory=dict)


class Sequencer:
    """Runs the stages in order from ``q`` (module docstring); ``stages`` records each one. Each method
    returns whether its stage succeeded and, if so, moves ``q`` to where it ended."""

    def __init__(self, arm: Robot, q: np.ndarray, *, seed: int, max_iterations: int, ik_budget: int):
        self.arm, self.robot, self.q = arm, arm, np.asarray(q, dtype=float)
        self.seed, self.max_iterations, self.ik_budget = seed, max_iterations, ik_budget
        self.stages: list[Stage] = []
        self.goal: np.ndarray | None = None
        self.placement: np.ndarray | None = None  # the cylinder's pose in the flange frame, once grasped

    def _add(self, stage: Stage) -> bool:
        self.stages.append(stage)
        return stage.success

    def ik(self, name: str, pose: np.ndarray, obstacles: dict[str, Shape]) -> bool:
        """Collision-free IK of the flange ``pose``, warm started at ``q``: the next :meth:`motion`'s goal."""
        res = ik.solve(self.robot, pose, self.q, frame=FLANGE, method="lm", prefer_q0=True,
                       tol_pos=IK_TOL[0], tol_rot=IK_TOL[1], obstacles=list(obstacles.values()),
                       self_collision=True, iteration_budget=self.ik_budget, seed=self.seed)
        self.goal = res.q if res.success else None
        return self._add(Stage(name, "ik", bool(res.success), res.message, None, bool(self.robot.attached),
                               tuple(obstacles), {"iterations": int(res.iterations),
                                                  "position_error": float(res.position_error),
                                                  "orientation_error": float(res.orientation_error)}))

    def motion(self, name: str, goal: np.ndarray | None, obstacles: dict[str, Shape]) -> bool:
        """:func:`planners.plan_motion` from ``q`` to ``goal`` (default: the last IK's answer)."""
        goal = self.goal if goal is None else goal
        plan = plan_motion(self.robot, self.q, goal, obstacles=list(obstacles.values()), self_collision=True,
                           max_time=None, max_iterations=self.max_iterations, seed=self.seed)
        if plan.success:
            self.q = plan.path[-1].copy()
        stats = {k: plan.stats.get(k) for k in ("iterations", "nodes", "length_before", "length_after")}
        return self._add(Stage(name, "plan_motion", bool(plan.success), plan.message, plan.trajectory,
                               bool(self.robot.attached), tuple(obstacles), stats))

    def line(self, name: str, pose: np.ndarray, obstacles: dict[str, Shape]) -> bool:
        """:func:`planners.plan_cartesian`: the flange on the straight line from its pose at ``q`` to
        ``pose``."""
        move = plan_cartesian(self.robot, self.q, pose, frame=FLANGE, obstacles=list(obstacles.values()),
                              self_collision=True, tol_pos=LINE_TOL[0], tol_rot=LINE_TOL[1], seed=self.seed)
        if move.success:
            self.q = move.path[-1].copy()
        return self._add(Stage(name, "plan_cartesian", bool(move.success), move.message, move.trajectory,
                               bool(self.robot.attached), tuple(obstacles),
                               {"fraction": float(move.fraction), "waypoints": len(move.path),
                                "stop": move.stop}))

    def grasp(self) -> None:
        """Attach the cylinder (standing at ``CYLINDER_POSE``) to the flange where it is now."""
        self.placement = se3.inverse(self.arm.fk(self.q, FLANGE)) @ CYLINDER_POSE
        self.robot = self.arm.copy().attach("cylinder", carried_cylinder(), FLANGE, self.placement,
                                            touch_links=TOUCH_LINKS)

    def release(self) -> Cylinder:
        """Detach the cylinder; returns it as an obstacle at its pose now."""
        pose = self.robot.attached_poses(self.q)["cylinder"]
        self.robot.detach("cylinder")
        self.robot = self.arm
        return Cylinder(pose, CYLINDER_RADIUS, CYLINDER_HEIGHT)


def carried_cylinder() -> Cylinder:
    """The cylinder as a shape at its own frame's origin (its pose in the flange goes to ``attach``)."""
    return Cylinder(np.eye(4), CYLINDER_RADIUS, CYLINDER_HEIGHT)


def plan_sequence(arm: Robot, q_start: np.ndarray, release: np.ndarray, *, approach: float, seed: int,
                  max_iterations: int, ik_budget: int) -> tuple[Sequencer, Cylinder | None]:
    """Run the stages of the module docstring (stopping at the first that fails): the :class:`Sequencer`
    with the stages, and the released cylinder (None when the sequence stopped before the release)."""
    table, plates = table_box()
    scene = {"table": table, **{f"box/plate{i}": p for i, p in enumerate(plates)}}
    box = {k: v for k, v in scene.items() if k.startswith("box/")}
    standing = {**scene, "cylinder (standing)": Cylinder(CYLINDER_POSE, CYLINDER_RADIUS, CYLINDER_HEIGHT)}
    back = se3.pose(p=[0.0, 0.0, -float(approach)])
    seq = Sequencer(arm, q_start, seed=seed, max_iterations=max_iterations, ik_budget=ik_budget)
    ok = (seq.ik("pre-grasp IK", DOC_GRASP @ back, standing) and seq.motion("to pre-grasp", None, standing)
          and seq.line("approach", DOC_GRASP, standing))
    if not ok:
        return seq, None
    seq.grasp()
    ok = (seq.line("lift", DOC_GRASP @ back, box) and seq.ik("pre-release IK", release @ back, scene)
          and seq.motion("transfer", None, scene) and seq.line("lower", release, scene))
    if not ok:
        return seq, None
    placed = seq.release()
    after = {**scene, "cylinder (placed)": placed}
    _ = seq.line("retreat", release @ back, after) and seq.motion("home", q_start, after)
    return seq, placed


# ------------------------------------------------------------------ the joined trajectory
Span = tuple[float, float]


def join_stages(stages: list[Stage], joint_names: list[str], dwell: float,
                hold_after: tuple[str, ...] = ("approach", "lower")) -> tuple[JointTrajectory, list[Span]]:
    """The stages' trajectories one after the other: ``(trajectory, [(t0, t1) of each stage])`` (``(t, t)``
    for a stage without motion). Each stage starts where the one before ended, at rest; the shared point is
    kept once, except after the stages in ``hold_after``, where the arm holds still ``dwell`` s (the
    gripper closing or opening)."""
    if not (isinstance(dwell, (int, float)) and np.isfinite(dwell) and dwell >= 0):
        raise InputError(f"dwell must be a number >= 0 (s), got {dwell!r}")
    times, Q, V, A, spans = [], [], [], [], []
    t_end, hold = 0.0, 0.0
    for st in stages:
        tr = st.trajectory
        if tr is None:
            spans.append((t_end, t_end))
            continue
        skip = 1 if times and hold == 0 else 0
        t0 = t_end + hold
        times.append(t0 + tr.times[skip:] - tr.times[0])
        Q.append(tr.positions[skip:])
        V.append(np.zeros_like(tr.positions[skip:]) if tr.velocities is None else tr.velocities[skip:])
        A.append(np.zeros_like(tr.positions[skip:]) if tr.accelerations is None else tr.accelerations[skip:])
        t_end = t0 + tr.duration - tr.times[0]
        spans.append((t0, t_end))
        hold = dwell if st.name in hold_after else 0.0
    return (JointTrajectory(joint_names, np.concatenate(times), np.concatenate(Q), np.concatenate(V),
                            np.concatenate(A)), spans)


def dense_samples(traj: JointTrajectory, max_joint_step: float) -> tuple[np.ndarray, np.ndarray]:
    """``(t, Q)``: every point of ``traj`` and linear interpolation between consecutive points, so that no
    joint moves more than ``max_joint_step`` (rad) between two samples."""
    if not (isinstance(max_joint_step, (int, float)) and np.isfinite(max_joint_step) and max_joint_step > 0):
        raise InputError(f"max_joint_step must be a number > 0 (rad), got {max_joint_step!r}")
    t_out, q_out = [traj.times[:1]], [traj.positions[:1]]
    for k in range(traj.n_points - 1):
        a, b = traj.positions[k], traj.positions[k + 1]
        n = max(1, int(np.ceil(np.max(np.abs(b - a)) / max_joint_step)))
        s = np.linspace(0.0, 1.0, n + 1)[1:]
        t_out.append(traj.times[k] + s * (traj.times[k + 1] - traj.times[k]))
        q_out.append(a + s[:, None] * (b - a))
    return np.concatenate(t_out), np.concatenate(q_out)


# ------------------------------------------------------------------ clearance
#: Points per sample interval on each side of a sampled minimum where :func:`trajectory_clearance` looks
#: for it again (the reported minima are those of this finer sampling).
REFINE_POINTS = 16


def _minimum(values: np.ndarray, t: np.ndarray, Q: np.ndarray, distance, mask: np.ndarray | None = None
             ) -> tuple[float | None, float | None]:
    """The smallest of ``values`` (over ``mask``) and its time, refined: ``distance(q)`` on
    :data:`REFINE_POINTS` points of each interpolation interval beside the smallest sample (within
    ``mask``) too, so that the minimum reported lies within ``1 / REFINE_POINTS`` of a sample interval of the
    motion's closest approach there."""
    idx = np.flatnonzero(np.ones(len(values), bool) if mask is None else mask)
    if len(idx) == 0:
        return None, None
    k = idx[int(np.argmin(values[idx]))]
    best, when = float(values[k]), float(t[k])
    for j in (k - 1, k + 1):
        if not (0 <= j < len(values) and (mask is None or mask[j])):
            continue
        for f in np.linspace(0.0, 1.0, REFINE_POINTS + 1)[1:-1]:
            d = float(distance(Q[k] + f * (Q[j] - Q[k])))
            if d < best:
                best, when = d, float(t[k] + f * (t[j] - t[k]))
    return best, when


def trajectory_clearance(arm: Robot, t: np.ndarray, Q: np.ndarray, placement: np.ndarray,
                         carried: np.ndarray, lifted: np.ndarray) -> dict:
    """Clearance of the dense samples ``(t, Q)`` (module docstring): ``carried`` / ``lifted`` mark the
    samples where the cylinder moves with the flange / has left the table (its distance to the table is
    computed on every carried sample, its minimum taken over the lifted ones); ``placement`` is its pose in
    the flange frame. Returns the minima (m) with their times (s), each refined between the samples beside
    it (:func:`_minimum`), and the per-sample arrays (NaN where the cylinder is not carried)."""
    table, plates = table_box()
    tables = [table]

    def arm_to(shapes: list) -> Callable[[np.ndarray], float]:
        return lambda q: arm.min_distance(q, shapes, self_collision=False)

    def cylinder_to(shapes: list) -> Callable[[np.ndarray], float]:
        return lambda q: cylinder_distance(arm.fk(q, FLANGE) @ placement, CYLINDER_RADIUS, CYLINDER_HEIGHT,
                                           shapes)

    every = np.ones(len(Q), dtype=bool)
    # per measure: its distance, the samples it is computed on, the samples its minimum is taken over
    measures = {"arm_box": (arm_to(plates), every, None), "arm_table": (arm_to(tables), every, None),
                "cylinder_box": (cylinder_to(plates), carried, carried),
                "cylinder_table": (cylinder_to(tables), carried, lifted)}
    arrays = {}
    for key, (distance, computed, _) in measures.items():
        rows = np.flatnonzero(computed)
        values = np.full(len(Q), np.nan)
        values[rows] = [distance(Q[k]) for k in rows]
        arrays[key] = values
    out = {"samples": len(Q)}
    for key, (distance, _, mask) in measures.items():
        minimum = _minimum(arrays[key], t, Q, distance, mask)
        out[f"min_{key}_distance"], out[f"min_{key}_distance_time"] = minimum
    arm_box = arrays["arm_box"]
    k = int(np.argmin(arm_box))
    out["min_arm_box_distance_pair"] = list(min(arm.distances(Q[k], plates, self_collision=False).items(),
                                                key=lambda kv: kv[1].distance)[0])
    out.update(t=t, **arrays)
    return out


# ------------------------------------------------------------------ artefacts
def clearance_figure(clearance: dict, events: dict, marks_t) -> Figure:
    """Clearance (m) of the arm and the carried cylinder to the box and the table against time."""
    fig = Figure(figsize=(8.0, 4.4), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    t = clearance["t"]
    for key, label in (("arm_box", "arm - box"), ("arm_table", "arm - table"),
                       ("cylinder_box", "cylinder - box (carried)"),
                       ("cylinder_table", "cylinder - table (carried; 0 while it stands on it)")):
        ax.plot(t, clearance[key], label=label, linewidth=1.2)
    events_on(ax, events, marks_t)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("signed distance (m)")
    ax.set_ylim(bottom=0)
    ax.set_title(f"S4 planned: clearance on {clearance['samples']} dense samples (coal, link hulls)",
                 fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper right", fontsize=7, framealpha=0.9)
    return fig


def write_scene(out: Path, arm: Robot, traj: JointTrajectory, grasp_t: float, release_t: float,
                release: np.ndarray, fps: float) -> int:
    """``scene.html``: the arm along ``traj`` resampled at ``fps``, the box, the table, the cylinder carried
    from ``grasp_t`` to ``release_t`` (s), the flange's path and the grasp / release targets. Returns the
    number of frames."""
    t = np.arange(0.0, traj.duration + 0.5 / fps, 1.0 / fps)
    Q = traj.position_at(np.minimum(t, traj.duration))
    sc = viz.Scene("kinserve S4 planned: Panda pick and place around the open box")
    sc.add_robot(arm, Q[0], name="panda")
    draw_open_box(sc, "box", BOX_CENTRE, BOX_SIZE, BOX_WALL)
    sc.add_box("table", TABLE_SIZE, se3.pose(p=TABLE_CENTRE), color="#d9d2c5", opacity=0.6)
    sc.add_cylinder("cylinder", CYLINDER_RADIUS, CYLINDER_HEIGHT, CYLINDER_POSE, color="orange")
    sc.add_path("tool_path", np.array([arm.fk(q, FLANGE)[:3, 3] for q in Q]), color="blue")
    for name, T in (("grasp", DOC_GRASP), ("release", release)):
        sc.add_frame(f"targets/{name}", T, length=0.1, radius=0.005)
    anim = viz.Animation(sc, fps=fps)
    anim.robot("panda", Q)
    grasp_k = int(np.searchsorted(t, grasp_t - 1e-9))
    release_k = int(np.searchsorted(t, release_t - 1e-9))
    anim.attach("cylinder", "panda", grasp_k, min(release_k, len(t) - 1), frame=FLANGE)
    anim.apply()
    sc.set_camera([1.1, -0.65, 1.0], [0.3, 0.15, 0.42])
    viz.export_html(sc, out / "scene.html")
    return len(t)


def _stage_dict(stage: Stage, span: tuple[float, float], line_deviation: float | None) -> dict:
    return {"name": stage.name, "kind": stage.kind, "success": stage.success, "message": stage.message,
            "carrying": stage.carrying, "checked": list(stage.checked), "t0": span[0], "t1": span[1],
            "duration": span[1] - span[0], "line_deviation": line_deviation, **stage.stats}


def line_deviation(arm: Robot, t: np.ndarray, Q: np.ndarray, span: tuple[float, float]) -> float:
    """Largest distance (m) of the flange's origin, at the dense samples inside ``span`` (s), from the
    segment between its positions at the span's first and last samples."""
    idx = np.flatnonzero((t >= span[0] - 1e-9) & (t <= span[1] + 1e-9))
    P = np.array([arm.fk(Q[k], FLANGE)[:3, 3] for k in idx])
    a, d = P[0], P[-1] - P[0]
    s = np.clip((P - a) @ d / max(float(d @ d), 1e-300), 0.0, 1.0)
    return float(np.linalg.norm(P - (a + s[:, None] * d), axis=1).max())


def cylinder_in_box(pose: np.ndarray) -> dict:
    """Where the released cylinder (upright or not) sits in the box: its axis, how far its bottom rim is
    above the floor plate's top (m), how far its top rim is below the walls' top (m), and the smallest gap
    (m) between it and the walls' inner faces (an upright cylinder's disc in the inner square)."""
    axis = pose[:3, 2]
    c = pose[:3, 3] - BOX_CENTRE
    inner = BOX_SIZE / 2 - BOX_WALL
    # half extents of the cylinder along the world axes (exact for any orientation)
    half = CYLINDER_RADIUS * np.sqrt(np.clip(1.0 - axis**2, 0.0, 1.0)) + CYLINDER_HEIGHT / 2 * np.abs(axis)
    return {"axis": axis, "above_floor": float(c[2] - half[2] - (-BOX_SIZE / 2 + BOX_WALL)),
            "below_rim": float(BOX_SIZE / 2 - (c[2] + half[2])),
            "wall_gap": float(min(inner - abs(c[0]) - half[0], inner - abs(c[1]) - half[1]))}


def _plots(out: Path, arm: Robot, traj: JointTrajectory, clearance: dict, spans: dict, grasp_t: float,
           release_t: float) -> None:
    ev = {f"grasp ({grasp_t:.2f} s)": (grasp_t, "green"), f"release ({release_t:.2f} s)": (release_t, "red")}
    marks_t = np.array([0.0, *sorted({s[1] for s in spans.values()})])
    title = "S4 planned: joints (planned transfers, straight-line approach / retreat)"
    fig = joints_with_events(traj.times, traj.positions, arm, title, ev, marks_t)
    viz.save_png(fig, out / "joints.png")
    viz.save_png(clearance_figure(clearance, ev, marks_t), out / "clearance.png")


def _report(arm: Robot, seq: Sequencer, placed: Cylinder, traj: JointTrajectory, spans: dict[str, Span],
            t: np.ndarray, Q: np.ndarray, clearance: dict, cylinder_target: np.ndarray) -> dict:
    """The result of a complete run (every stage succeeded), JSON-ready; scalars first: ``kinserve demo``
    prints the first few."""
    final = placed.pose
    doc_ideal = DOC_RELEASE @ se3.inverse(DOC_GRASP) @ CYLINDER_POSE
    stages = [_stage_dict(s, spans[s.name], line_deviation(arm, t, Q, spans[s.name])
                          if s.kind == "plan_cartesian" else None) for s in seq.stages]
    minima = {k: v for k, v in clearance.items() if k.startswith("min_")}
    grasp_t, release_t = spans["approach"][1], spans["lower"][1]
    return {
        "success": True,
        "duration": traj.duration,
        **{k: minima[k] for k in ("min_arm_box_distance", "min_cylinder_box_distance",
                                  "min_arm_table_distance", "min_cylinder_table_distance")},
        "grasp_time": grasp_t,
        "release_time": release_t,
        "grasp_step": int(np.argmin(np.abs(traj.times - grasp_t))),
        "release_step": int(np.argmin(np.abs(traj.times - release_t))),
        "cylinder_release_error": list(se3.pose_error(final, cylinder_target)),
        "cylinder_document_release_error": list(se3.pose_error(final, doc_ideal)),
        "cylinder_in_box": cylinder_in_box(final),
        "max_line_deviation": max(s["line_deviation"] for s in stages if s["line_deviation"] is not None),
        "stages": stages,
        "clearance": minima,
        "dense_samples": len(t),
        "trajectory_points": traj.n_points,
        "q_final": traj.positions[-1],
        "cylinder_initial_pose": CYLINDER_POSE,
        "cylinder_final_pose": final,
        "cylinder_release_target": cylinder_target,
        "cylinder_document_ideal_pose": doc_ideal,
        "cylinder_pose_in_flange": seq.placement,
        "grasp_pose": DOC_GRASP,
        "touch_links": list(TOUCH_LINKS),
    }


def run(out: Path, *, approach: float = 0.12, release_xy: tuple[float, float] = (0.52, 0.52),
        release_height: float = 0.10, seed: int = 0, max_iterations: int = 2000, ik_budget: int = IK_BUDGET,
        dwell: float = 0.5, max_joint_step: float = 0.01, fps: float = 30.0, scene: bool = True) -> dict:
    """Run the planned S4 into ``out``; returns the key numbers (module docstring). ``max_iterations``: each
    :func:`planners.plan_motion`'s RRT-Connect samples; ``ik_budget``: each pose IK's iterations; ``seed``:
    every plan's, line's and IK's seed. A stage that fails ends the sequence: ``success`` is False,
    ``failed_stage`` names it and no artefact but the result is written."""
    out = Path(out)
    panda = robots.load("panda")
    arm = planning_arm(panda)
    q_start = start_configuration(panda)[0]
    release, cylinder_target = release_pose(release_xy, release_height)
    seq, placed = plan_sequence(arm, q_start, release, approach=approach, seed=seed,
                                max_iterations=max_iterations, ik_budget=ik_budget)
    settings = {"q_start": q_start, "release_pose": release, "approach": approach, "dwell": dwell,
                "seed": seed, "max_iterations": max_iterations, "ik_budget": ik_budget,
                "max_joint_step": max_joint_step}
    if placed is None or seq.stages[-1].name != "home" or not seq.stages[-1].success:
        failed = next(s for s in seq.stages if not s.success)
        return {"success": False, "failed_stage": failed.name, "message": failed.message,
                "stages": [_stage_dict(s, (0.0, 0.0), None) for s in seq.stages], **settings}
    traj, span_list = join_stages(seq.stages, arm.joint_names, dwell)
    spans = {s.name: sp for s, sp in zip(seq.stages, span_list)}
    traj.save(out / "trajectory.json")
    traj.save(out / "trajectory.csv")
    grasp_t, release_t, lifted_t = spans["approach"][1], spans["lower"][1], spans["lift"][1]
    t, Q = dense_samples(traj, max_joint_step)
    carried = (t >= grasp_t - 1e-9) & (t <= release_t + 1e-9)
    clearance = trajectory_clearance(arm, t, Q, seq.placement, carried, carried & (t >= lifted_t - 1e-9))
    _plots(out, arm, traj, clearance, spans, grasp_t, release_t)
    frames = write_scene(out, arm, traj, grasp_t, release_t, release, fps) if scene else 0
    return {**_report(arm, seq, placed, traj, spans, t, Q, clearance, cylinder_target),
            "animation_frames": frames, **settings}
