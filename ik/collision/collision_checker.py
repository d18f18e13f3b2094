"""The checker of the "unconstrained first, then constrain" strategy against the robot's collision model
(:mod:`kinserve.ik.strategies.checked`; the protocol: :mod:`kinserve.ik.collision.checkers`).

:class:`CollisionChecker` uses a bound :class:`ik.CollisionConstraint`: the sphere pre-check certifies most
configurations in one compiled call (with each LM start: :class:`~kinserve.ik.lm.screen.LMScreen`), coal
judges the rest. It is made once per bound constraint, with the binding
(:class:`kinserve.ik.state.BoundConstraints`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import coal
import numpy as np

from kinserve.ik.collision.target_inside import inside, position_fixed
from kinserve.ik.constraints.collision import CollisionConstraint
from kinserve.ik.lm.screen import LMScreen
from kinserve.ik.targets import Target
from kinserve.kinematics.robot import Robot

#: Starts the sphere pre-check cannot certify free that one solve skips without asking coal: such a start is
#: within a few centimetres of an obstacle or of the arm (or in collision), a poor start whatever coal says.
UNCERTIFIED_SKIPS = 2


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

    def admission(self, chosen: np.ndarray | None = None) -> Callable[..., bool]:
        """One solve's ``admit(q)`` (:func:`_admission`); ``chosen``: the caller's ``q0`` when it must run
        first (``prefer_q0``): never skipped without coal's word."""
        return _admission(self.constraint.in_collision, self.precheck, chosen)

    def first_violation(self, rows: np.ndarray, uncertified: int | None = None) -> int:
        """Index of the first colliding row, or -1: the sphere pre-check certifies rows in one compiled call,
        the scene's coal check decides from the first row it cannot certify. ``uncertified``: that row when
        the caller's pre-check found it already (the rows before it certified: the screen of the LM's run)."""
        if not len(rows):
            return -1
        pre = self.precheck
        if pre is None:
            return self.constraint.first_collision(rows)
        k = uncertified
        if k is None:
            k = pre.first_uncertified(pre.floats, pre.ints, rows, 0, pre.tolerance)
            if k >= rows.shape[0]:
                return -1
        return self.constraint.scene.first_collision(rows, k)

    def infeasible(self, target: Target) -> str:
        """A reason when the target position lies inside an obstacle and the frame's origin inside the body
        that carries it (then every configuration reaching the target collides)."""
        constraint = self.constraint
        if not constraint.obstacles or not position_fixed(target):
            return ""
        inside_at = inside(constraint.obstacles, target)
        if not inside_at or not frame_origin_inside_body(self.robot, target.frame):
            return ""
        return (f"{inside_at} deep) and frame {target.frame!r} has its origin inside the robot's collision "
                "geometry: no collision-free configuration reaches it")


def _admission(in_collision: Callable[[np.ndarray], bool], pre: Any,
               chosen: np.ndarray | None) -> Callable[..., bool]:
    """``admit(q, certify_first=True)``: a start the pre-check certifies runs at once; the first
    :data:`UNCERTIFIED_SKIPS` it cannot certify are skipped without coal (except ``chosen``); later ones run
    when coal finds them free (``in_collision``: the constraint's coal check). ``certify_first=False``: the
    caller's pre-check (the LM's screen) has already failed to certify ``q``."""
    if pre is None:
        return lambda q, certify_first=True: not in_collision(q)
    certify, floats, ints, tol = pre.certify, pre.floats, pre.ints, pre.tolerance
    chosen_list = None if chosen is None else chosen.tolist()
    skips = [0]

    def admit(q: np.ndarray, certify_first: bool = True) -> bool:
        if certify_first and certify(floats, ints, q, tol):
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


__all__ = ["UNCERTIFIED_SKIPS", "CollisionChecker", "frame_origin_inside_body"]
