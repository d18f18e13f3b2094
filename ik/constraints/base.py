"""The ``Constraint`` protocol: hard limits that hold on every iterate of the IK.

A constraint restricts the joint step ``dq`` taken from a configuration
``q`` in two ways:

* **linear rows** at ``q``:  ``lower <= G dq <= upper`` (``G`` is ``k x nv``;
  entries of ``lower`` / ``upper`` may be ``-inf`` / ``+inf``). The QP of
  every priority level includes them, so a step never asks for more than
  the rows allow. ``G = None`` means the identity: a box ``lower <= dq <= upper``
  (joint and velocity limits). Rows of pairs that are far from binding may be
  left out (their number may change from one ``q`` to the next).
* a **true check** of a configuration: ``margin(robot, data, q)`` is the
  smallest slack (``>= 0`` when ``q`` satisfies the constraint; a distance
  in metres for obstacles). Linear rows are only first-order, so the solver
  evaluates the margin at ``q + dq`` and halves the step until it holds
  (step back-off); an iterate never violates the constraint, and a start
  that already violates it is only allowed to improve (the margin may not
  decrease while it is negative).

For an obstacle at distance ``d(q)`` (margin ``d_min``) the row is the
velocity damper ``g^T dq >= -xi (d - d_min)`` with ``g = dd/dq``: a step may
consume at most the fraction ``xi`` of the current clearance, and when the
clearance is negative the row demands that it grow.

``dt``: :func:`kinserve.ik.step` passes the control period (s) and turns the
step into a velocity ``v = dq / dt``; velocity limits use it
(``|dq| <= v_max dt``). :func:`kinserve.ik.solve` iterates without time and
passes ``dt=None``.

Methods a constraint implements
-------------------------------
``bind(robot) -> Constraint``
    Validate against ``robot`` (frame names, obstacles containing the fixed
    base, vector lengths) and return the constraint to evaluate. Called once
    per solve; raises :class:`kinserve.kinematics.errors.InputError`.
    :func:`kinserve.ik.step` binds the same objects again only when their
    ``_version`` moved: increment it when an input of ``bind`` changes (as
    assigning ``VelocityLimits.v_max`` does).
``rows(robot, data, q, dt=None) -> (G, lower, upper)``
    After ``pinocchio.computeJointJacobians(model, data, q)`` (joint
    placements ``data.oMi``, joint Jacobians ``data.J`` in world axes).
``margin(robot, data, q) -> float``
    After ``pinocchio.forwardKinematics(model, data, q)`` (``data.oMi`` only).
``describe(robot, data, q) -> str``
    The violations at ``q`` in words (after forward kinematics), "" if none.

Example (a user constraint: keep the tool above a table at height ``h``)::

    class AboveTable(ik.Constraint):
        def __init__(self, frame, height):
            super().__init__(name="above table")
            self.frame, self.h = frame, height

        def bind(self, robot):
            self.fid = robot.frame_id(self.frame)
            return self

        def rows(self, robot, data, q, dt=None):
            z = pin.updateFramePlacement(robot.model, data, self.fid).translation[2]
            Jz = pin.getFrameJacobian(robot.model, data, self.fid, pin.LOCAL_WORLD_ALIGNED)[2:3]
            return Jz, np.array([-0.5 * (z - self.h)]), np.array([np.inf])   # velocity damper

        def margin(self, robot, data, q):
            return pin.updateFramePlacement(robot.model, data, self.fid).translation[2] - self.h
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

#: Fraction of the current clearance one step may use up (velocity damper gain ``xi``).
DAMPER_GAIN = 0.5

if TYPE_CHECKING:  # annotations only
    import pinocchio as pin

    from kinserve.kinematics.robot import Robot


class Constraint:
    """Base class of hard IK constraints (the protocol of the module docstring)."""

    #: Bumped by every change that needs a new bind (a subclass's bound inputs, e.g.
    #: ``VelocityLimits.v_max``): :func:`kinserve.ik.step` rebuilds its cached problem when a
    #: constraint's version moved.
    _version: int = 0

    def __init__(self, name: str | None = None):
        self.name = name if name is not None else type(self).__name__

    def bind(self, robot: Robot) -> "Constraint":
        """Validate against ``robot``; return the constraint to evaluate (default ``self``)."""
        return self

    def rows(self, robot: Robot, data: pin.Data, q: np.ndarray,  # pragma: no cover - protocol
             dt: float | None = None) -> tuple[np.ndarray | None, np.ndarray, np.ndarray]:
        """``(G, lower, upper)`` with ``lower <= G dq <= upper`` at ``q`` (``G=None``: identity box)."""
        raise NotImplementedError(f"{type(self).__name__}.rows(robot, data, q, dt) "
                                  "must return (G, lower, upper)")

    def margin(self, robot: Robot, data: pin.Data, q: np.ndarray) -> float:
        """Smallest slack at ``q`` (``>= 0``: satisfied); default ``inf``, nothing to check past the rows."""
        return float("inf")

    def describe(self, robot: Robot, data: pin.Data, q: np.ndarray) -> str:
        """The violations at ``q`` in words ("" when ``q`` satisfies the constraint)."""
        m = self.margin(robot, data, q)
        return "" if m >= 0.0 else f"{self.name} violated by {-m:.4g}"

    def __repr__(self) -> str:
        return f"{type(self).__name__}(name={self.name!r})"
