"""Path checkers of the "unconstrained first, then constrain" strategy
(:mod:`kinserve.ik.strategies.checked`).

A checker answers four questions about one request's obstacles:

* ``admission(chosen)``: one solve's ``admit(q)``, may a run start at ``q``? (None: every start runs, its
  run's check includes it);
* ``first_violation(rows)``: the index of the first configuration of ``rows`` that violates the constraint,
  or -1 - the strategy passes a run's rows answer first, so 0 means the answer itself violates it;
* ``infeasible(target)``: a reason when no configuration can reach the target (its position lies inside an
  obstacle and the frame's origin is part of the robot's body), else "";
* ``constraint``: what the constrained solve imposes when no unconstrained run passes.

:class:`ClearanceChecker` keeps obstacles clear of the link capsules (:class:`ik.ObstacleAvoidance`);
:class:`CollisionChecker` uses the robot's collision model (:class:`ik.CollisionConstraint`: the sphere
pre-check certifies most configurations in one compiled call, coal judges the rest).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import coal
import numpy as np

from kinserve.ik.constraints.collision import CollisionConstraint
from kinserve.ik.constraints.obstacles import ObstacleAvoidance
from kinserve.ik.lm.solver import LMScreen
from kinserve.ik.targets import Target
from kinserve.kinematics.robot import Robot

#: Starts the sphere pre-check cannot certify free that one solve skips without asking coal: such a start is
#: within a few centimetres of an obstacle or of the arm (or in collision), a poor start whatever coal says.
UNCERTIFIED_SKIPS = 2


def _position_fixed(target: Target) -> bool:
    return not any(k in target.relaxed for k in (0, 1, 2))


def _inside(obstacles: Any, target: Target, reach: float = 0.0) -> str:
    """The start of the reason when the target position lies inside one of ``obstacles`` grown by ``reach``
    ("the target position [..] lies inside obstacle[k]:kind (d m"), else ""."""
    point = np.array(target.T[:3, 3], dtype=float)
    for k, ob in enumerate(obstacles):
        depth = _depth(ob, point, reach)
        if depth > 0.0:
            return (f"the target position {np.round(point, 4).tolist()} lies inside obstacle[{k}]:{ob.kind} "
                    f"({depth:.4g} m")
    return ""


def _depth(obstacle: Any, point: np.ndarray, reach: float = 0.0) -> float:
    """How deep ``point`` lies inside ``obstacle`` grown by ``reach`` (m; <= 0 when outside): the bounding
    ball answers "outside" at once, the exact signed distance decides the rest."""
    (cx, cy, cz), r = obstacle.bounding_ball()
    if math.hypot(point[0] - cx, point[1] - cy, point[2] - cz) >= r + reach:
        return 0.0
    if obstacle.kind == "box":  # outside the box grown by reach along some axis of its own frame: outside
        T = obstacle.pose
        local = T[:3, :3].T @ (point - T[:3, 3])
        if any(abs(x) >= 0.5 * s + reach for x, s in zip(local.tolist(), obstacle.size)):
            return 0.0
    return reach - float(obstacle.signed_distance(point)[0])


class ClearanceChecker:
    """Obstacles against the robot's link capsules (a bound :class:`ObstacleAvoidance`)."""

    name = "obstacles"
    screen = None  #: no compiled pre-check runs with the LM's starts

    def __init__(self, robot: Robot, avoid: ObstacleAvoidance, q0: np.ndarray | None = None) -> None:
        """``q0``: the request's start (inside the limits), judged with the first rows checked (one call)."""
        self.robot = robot
        self.constraint = avoid
        self.q0 = q0
        self.q0_violates: bool | None = None if q0 is not None else False  # (None: not judged yet)

    def first_violation(self, rows: np.ndarray) -> int:
        """Index of the first row closer than the link radius to an obstacle, or -1."""
        if not len(rows):
            return -1
        judge_q0 = self.q0_violates is None  # q0 rides along with the first rows checked
        checked = np.concatenate((rows, self.q0[None])) if judge_q0 else rows
        bad = np.asarray(self.constraint.violations(self.robot, checked), dtype=bool)
        if judge_q0:
            self.q0_violates, bad = bool(bad[-1]), bad[:-1]
        return int(bad.argmax()) if bad.any() else -1

    def admission(self, chosen: np.ndarray | None = None) -> None:
        """None: every start runs (a run's check includes its start, and ``q0`` rides along with it)."""
        return None

    def q0_inside(self) -> bool:
        """True when the request's ``q0`` violates the obstacles (False without a ``q0``)."""
        if self.q0_violates is None:
            self.first_violation(self.q0[None])
        return bool(self.q0_violates)

    def infeasible(self, target: Target) -> str:
        """A reason when the target position lies inside an obstacle (the tool frame ends a link segment)."""
        if not _position_fixed(target):
            return ""
        inside = _inside(self.constraint.obstacles, target, float(self.constraint.link_radius))
        if not inside:
            return ""
        return (f"{inside} deep, link radius included) and frame {target.frame!r} ends a link segment: no "
                "configuration clear of the obstacles reaches it")


class CollisionChecker:
    """Self-collision and obstacles against the robot's collision model (a bound
    :class:`CollisionConstraint`).

    Made once per bound constraint (by :class:`kinserve.ik.state.BoundConstraints`, with the binding) and
    shared by every solve of that scene in the thread: it holds no state of a solve. A solve's admission of
    starts (:meth:`admission`) is made per solve.
    """

    name = "collision"

    def __init__(self, robot: Robot, constraint: CollisionConstraint) -> None:
        self.robot = robot
        self.constraint = constraint
        pre = constraint.scene.precheck() if constraint.clearance == 0.0 else None
        self.precheck = pre
        #: The pre-check run with each LM start in one compiled call (None without a pre-check).
        self.screen: LMScreen | None = None
        if pre is not None:
            from kinserve.ik.lm.screened_kernel import run_screened_start  # compiled (or loaded) now

            self.screen = LMScreen(run_screened_start, pre.floats, pre.ints, pre.tolerance)

    def admission(self, chosen: np.ndarray | None = None) -> Callable[[np.ndarray], bool]:
        """One solve's ``admit(q)`` (:func:`_admission`); ``chosen``: the caller's ``q0`` when it must run
        first (``prefer_q0``): never skipped without coal's word."""
        return _admission(self.constraint.in_collision, self.precheck, chosen)

    def first_violation(self, rows: np.ndarray) -> int:
        """Index of the first colliding row, or -1: the sphere pre-check certifies rows in one compiled call,
        the scene's coal check decides from the first row it cannot certify."""
        if not len(rows):
            return -1
        pre = self.precheck
        if pre is None:
            return self.constraint.first_collision(rows)
        first_uncertified, floats, ints, tol = pre.first_uncertified, pre.floats, pre.ints, pre.tolerance
        k = first_uncertified(floats, ints, rows, 0, tol)
        if k >= rows.shape[0]:
            return -1
        return self.constraint.scene.first_collision(rows, k)

    def infeasible(self, target: Target) -> str:
        """A reason when the target position lies inside an obstacle and the frame's origin inside the body
        that carries it (then every configuration reaching the target collides)."""
        constraint = self.constraint
        if not constraint.obstacles or not _position_fixed(target):
            return ""
        inside = _inside(constraint.obstacles, target)
        if not inside or not frame_origin_inside_body(self.robot, target.frame):
            return ""
        return (f"{inside} deep) and frame {target.frame!r} has its origin inside the robot's collision "
                "geometry: no collision-free configuration reaches it")


def _admission(in_collision: Callable[[np.ndarray], bool], pre: Any,
               chosen: np.ndarray | None) -> Callable[[np.ndarray], bool]:
    """``admit(q)``: a start the pre-check certifies runs at once; the first :data:`UNCERTIFIED_SKIPS` it
    cannot certify are skipped without coal (except ``chosen``); later ones run when coal finds them free
    (``in_collision``: the constraint's coal check)."""
    if pre is None:
        return lambda q: not in_collision(q)
    certify, floats, ints, tol = pre.certify, pre.floats, pre.ints, pre.tolerance
    chosen_list = None if chosen is None else chosen.tolist()
    skips = [0]

    def admit(q: np.ndarray) -> bool:
        if certify(floats, ints, q, tol):
            return True
        if skips[0] < UNCERTIFIED_SKIPS and (chosen_list is None or q.tolist() != chosen_list):
            skips[0] += 1
            return False
        return not in_collision(q)

    return admit


def frame_origin_inside_body(robot: Robot, frame: str) -> bool:
    """True when the origin of ``frame`` lies inside a collision geometry of the body that carries it."""
    model = robot.model
    fid = robot.frame_id(frame)
    joint = model.frames[fid].parentJoint
    origin = model.frames[fid].placement
    point = coal.Sphere(1e-9)
    req, res = coal.DistanceRequest(), coal.DistanceResult()
    for g in robot.collision.geometry.geometryObjects:
        if g.parentJoint != joint:
            continue
        res.clear()
        d = coal.distance(g.geometry, coal.Transform3s(g.placement.rotation, g.placement.translation),
                          point, coal.Transform3s(np.eye(3), origin.translation), req, res)
        if d < 0.0:
            return True
    return False


def last_clear(checker: ClearanceChecker | CollisionChecker, qs: np.ndarray) -> np.ndarray | None:
    """The configuration of ``qs`` (a run, start first) just before the first violating one; the last if none
    violates; None when the first does."""
    if not len(qs):
        return None
    k = checker.first_violation(np.asarray(qs))
    if k < 0:
        return np.array(qs[-1], dtype=float)
    return np.array(qs[k - 1], dtype=float) if k else None
