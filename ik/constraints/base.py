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

The outputs of a user's ``rows`` and ``margin`` (written outside kinserve) are
checked on every call (:func:`checked_rows`, :func:`checked_margin`): wrong
shapes, NaN or entries of magnitude above
:data:`~kinserve.kinematics.validation.MAX_ABS` (``lower`` / ``upper`` may be
infinite) raise an error naming the constraint's class.

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

import math
from typing import TYPE_CHECKING

import numpy as np

from kinserve.ik.tasks.base import check_name
from kinserve.kinematics.errors import InputError, NonFiniteError, ShapeError
from kinserve.kinematics.validation import MAX_ABS, is_bounded

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
        """``name``: the label in messages, a non-empty str or None for the class name
        (:func:`~kinserve.ik.tasks.base.check_name`; :class:`InputError` otherwise)."""
        self.name = check_name(name, type(self).__name__)

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


def is_users_constraint(constraint: Constraint) -> bool:
    """Whether ``constraint``'s ``rows`` or ``margin`` is written outside kinserve (a user's constraint, or a
    user's subclass overriding either): its outputs are checked on every call; kinserve's own are not."""
    return not all(getattr(getattr(type(constraint), method), "__module__", "").startswith("kinserve.")
                   for method in ("rows", "margin"))


def _bounds_ok(values: np.ndarray) -> bool:
    """No NaN, and every finite entry of magnitude at most ``MAX_ABS`` (infinities allowed)."""
    return bool(np.all((np.abs(values) <= MAX_ABS) | np.isinf(values)))


def checked_rows(constraint: Constraint, output: object, nv: int) -> tuple:
    """``(G, lower, upper)`` of a user constraint's ``rows`` ``output`` as float arrays (``G`` None: a box),
    after checking the protocol: a triple; ``G`` ``k x nv`` of numbers of magnitude at most ``MAX_ABS`` and
    ``lower`` / ``upper`` of ``k`` entries, or ``G`` None and ``nv`` entries each; no NaN in the bounds
    (infinities allowed). :class:`InputError`, :class:`ShapeError` or :class:`NonFiniteError`, naming the
    constraint's class."""
    name = type(constraint).__name__
    try:
        G, lower, upper = output  # type: ignore[misc]
    except (TypeError, ValueError):
        raise InputError(f"{name}.rows(robot, data, q, dt) must return a triple (G, lower, upper), got "
                         f"{type(output).__name__}") from None
    try:
        lower, upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
        G = None if G is None else np.asarray(G, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name}.rows must return numbers: G (or None), lower and upper") from None
    if G is not None and (G.ndim != 2 or G.shape[1] != nv):
        raise ShapeError(f"{name}.rows: G must be k x {nv} (one column per joint velocity) or None (a box), "
                         f"got shape {G.shape}")
    k = nv if G is None else G.shape[0]
    if lower.shape != (k,) or upper.shape != (k,):
        raise ShapeError(f"{name}.rows: lower and upper must hold {k} numbers each ("
                         f"{'one per joint velocity: G is None' if G is None else 'one per row of G'}), got "
                         f"shapes {lower.shape} and {upper.shape}")
    if G is not None and not is_bounded(G):
        raise NonFiniteError(f"{name}.rows: G must hold finite numbers with magnitude <= {MAX_ABS:g}")
    if not (_bounds_ok(lower) and _bounds_ok(upper)):
        raise NonFiniteError(f"{name}.rows: lower and upper must be numbers (infinite allowed, no NaN) with "
                             f"finite magnitude <= {MAX_ABS:g}, got {lower.tolist()} and {upper.tolist()}")
    return G, lower, upper


def checked_margin(constraint: Constraint, value: object) -> float:
    """A user constraint's ``margin`` ``value`` as a float, after checking it is one number, not NaN
    (infinite allowed). :class:`InputError` or :class:`NonFiniteError`, naming the constraint's class."""
    name = type(constraint).__name__
    if isinstance(value, (bool, np.bool_, str, bytes)) or np.ndim(value) != 0:
        raise InputError(f"{name}.margin(robot, data, q) must return one number (>= 0: satisfied), got "
                         f"{type(value).__name__}")
    try:
        m = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise InputError(f"{name}.margin(robot, data, q) must return one number (>= 0: satisfied), got "
                         f"{type(value).__name__}") from None
    if math.isnan(m):
        raise NonFiniteError(f"{name}.margin(robot, data, q) returned NaN; it must be a number (>= 0: "
                             f"satisfied; infinite allowed)")
    return m
