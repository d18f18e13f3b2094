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

import numpy as np

from kinserve.ik.collision.collision_checker import CollisionChecker
from kinserve.ik.collision.target_inside import inside, position_fixed
from kinserve.ik.constraints.obstacles import ObstacleAvoidance
from kinserve.ik.targets import Target
from kinserve.kinematics.robot import Robot


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
        bad = self.constraint.violations(self.robot, checked).tolist()  # (a short list: no NumPy reductions)
        if judge_q0:
            self.q0_violates = bad.pop()
        return bad.index(True) if True in bad else -1

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
        if not position_fixed(target):
            return ""
        inside_at = inside(self.constraint.obstacles, target, float(self.constraint.link_radius))
        if not inside_at:
            return ""
        return (f"{inside_at} deep, link radius included) and frame {target.frame!r} ends a link segment: no "
                "configuration clear of the obstacles reaches it")


def last_clear(checker: ClearanceChecker | CollisionChecker, qs: np.ndarray) -> np.ndarray | None:
    """The configuration of ``qs`` (a run, start first) just before the first violating one; the last if none
    violates; None when the first does."""
    if not len(qs):
        return None
    k = checker.first_violation(np.asarray(qs))
    if k < 0:
        return np.array(qs[-1], dtype=float)
    return np.array(qs[k - 1], dtype=float) if k else None
