"""``MotionPlan``: the answer of :func:`~kinserve.planners.motion.plan.plan_motion`.

A failure (start or goal in collision, a goal pose that no collision-free IK solution
reaches, no path within the budget) is a plan with ``success = False`` and the reason in
``message``, never an exception.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from kinserve.planners.joint_trajectory import JointTrajectory


@dataclass(frozen=True)
class MotionPlan:
    """A joint-space motion plan.

    * ``success``, ``message``: whether a path was found, and why not (or how it was timed);
    * ``path`` ``(k, nq)``: simplified waypoints from the start to the goal reached; every segment is
      certified collision free as a continuous motion (``(0, nq)`` on failure);
    * ``raw_path`` ``(m, nq)``: the planner's path before simplification (``(0, nq)`` on failure);
    * ``trajectory``: the time-parameterised path (:class:`~kinserve.planners.JointTrajectory`: times (s),
      positions, velocities, accelerations), at rest at both ends; None on failure;
    * ``goal_index``: index of the goal reached in ``goals`` (0 for a single goal; -1 on failure);
    * ``goals`` ``(n, nq)``: the goal configurations the search aimed at - the goal or goal set given, or,
      for a pose goal, its goal set of collision-free IK solutions (``(0, nq)`` when the IK found none);
    * ``stats``: ``plan_time``, ``simplify_time``, ``parameterize_time``, ``ik_time`` (s; the pose goal's
      IK, 0 for joint goals), ``ik_starts`` and ``ik_iterations`` (its solves and their iterations),
      ``goal_set_size`` (pose goals only), ``checks`` (configuration
      queries of the collision model), ``distance_checks`` (those asking pair distances),
      ``pair_distances`` (coal pair distances computed), ``nodes`` (of
      both trees), ``iterations`` (samples drawn), ``length_before``, ``length_after`` (joint-space path
      length, rad) and ``timing`` (``"toppra"``, ``"rest-to-rest"`` or ``"none"``).
    """

    success: bool
    message: str
    path: np.ndarray
    raw_path: np.ndarray
    trajectory: JointTrajectory | None
    goal_index: int
    stats: dict[str, Any] = field(default_factory=dict)
    goals: np.ndarray | None = None

    def __post_init__(self) -> None:
        for name in ("path", "raw_path", "goals"):
            array = getattr(self, name)
            if array is not None:
                array.flags.writeable = False

    def __repr__(self) -> str:
        state = "success" if self.success else "failure"
        return (f"MotionPlan({state}: {self.message!r}, {len(self.path)} waypoints, "
                f"goal_index={self.goal_index})")


__all__ = ["MotionPlan"]
