"""Resolved-rate motion control: joint rates from Cartesian velocities, ``qdot = J^+ xdot``.

For a robot whose task coordinates ``x(q)`` are the rows ``axes`` of its tool
frame (``robot.task_axes`` by default, e.g. ``("x", "y")`` for the planar PR
robot), the Jacobian rows ``J = dx/dq`` map joint rates to task rates.
Euler integration with step ``dt``:

* open loop (the seed document's scheme), along a commanded task velocity
  ``xdot(t)``: ``q_{k+1} = q_k + J(q_k)^+ xdot(t_k) dt``. Errors from the
  linearisation accumulate (a commanded circle spirals outwards);
* closed loop (error feedback, CLIK): with the reference ``x_ref(t)``,
  ``q_{k+1} = q_k + J^+ [x_ref(t_{k+1}) - x_ref(t_k) + K e_k]``,
  ``e_k = x_ref(t_k) - x(q_k)``, gain ``K in (0, 1]`` per step (``K = 1``:
  aim at the next reference point). The error stays bounded by the one-step
  linearisation error instead of accumulating.

``J^+`` is the damped least-squares inverse
``J^T (J J^T + lambda^2 I)^-1 = V diag(sigma / (sigma^2 + lambda^2)) U^T``
with the adaptive damping of Nakamura / Maciejewski: ``lambda = 0`` while the
smallest singular value ``sigma_min >= sigma_threshold`` and
``lambda^2 = (1 - (sigma_min / sigma_threshold)^2) lambda_max^2`` below it,
so joint rates stay bounded at a singularity instead of exploding: with
``lambda_max >= sigma_threshold`` (the defaults, 0.1 and 0.05) the gain
``sigma / (sigma^2 + lambda^2)`` of every singular direction is at most
``1 / sigma_threshold``, hence ``|qdot| <= |xdot| / sigma_threshold`` at any
configuration (an undamped inverse gives ``|xdot| / sigma_min -> inf``); a
fixed damping ``lambda`` bounds it by ``|xdot| / (2 lambda)``.
``damping=0`` gives the plain pseudo-inverse.

Singularities are *reported*, not hidden: the result lists an event (with
the step index) each time ``sigma_min`` drops below ``sigma_threshold``
(the Jacobian nearly loses rank; for a square ``J`` the manipulability
``w = prod sigma_i`` goes to 0 with it) and each time the joint-rate norm
exceeds ``max_joint_rate`` (default ``|xdot_k| / sigma_threshold``, the rate an
undamped inverse needs at the threshold). A step so large that the Jacobian's
prediction is wrong, ``|x(q_{k+1}) - x(q_k) - J qdot dt| > max_step_error
|J qdot dt|``, is reported as a ``"large_step"`` event: Euler steps that jump
across a singularity (or past the workspace boundary) in one go would
otherwise go unnoticed between two samples. Leaving the joint limits (which
resolved-rate control does not enforce) is reported as ``"joint_limit"``.

Task coordinates supported: ``x, y, z`` (tool position, m) and ``yaw``
(``atan2(R10, R00)``, rad; meaningful for planar mechanisms, whose angular
velocity row is ``d yaw/dt``). ``roll``/``pitch`` have no such integrable
coordinate and are rejected.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from kinserve.kinematics import Robot, axis_rows
from kinserve.kinematics.errors import InputError, ShapeError
from kinserve.kinematics.robot import as_robot
from kinserve.kinematics.types import VectorLike
from kinserve.kinematics.validation import (
    as_count,
    as_flag,
    as_matrix,
    as_nonnegative,
    as_positive,
    as_real,
    as_vector,
    describe,
)

from .checks import MAX_SAMPLES

#: A reference trajectory: ``t -> (x_ref(t), xdot_ref(t))`` in the task axes.
Reference = Callable[[float], tuple[np.ndarray, np.ndarray]]

_POSITION_AXES = {"x": 0, "y": 1, "z": 2}


@dataclass(frozen=True)
class SingularityEvent:
    """One episode of near-singularity starting at ``step`` (index into the result's arrays).

    ``kind`` is ``"low_manipulability"`` (``value`` = sigma_min),
    ``"joint_rate"`` (``value`` = joint-rate norm), ``"large_step"``
    (``value`` = relative linearisation error of that step) or
    ``"joint_limit"`` (a joint left its limits; ``value`` = ``|q|``).
    """

    step: int
    time: float
    kind: str
    value: float
    message: str


@dataclass
class ResolvedRateResult:
    """History of a resolved-rate run: ``n + 1`` states for ``n`` steps (fewer if stopped early).

    ``positions``/``reference`` are task coordinates ``(n + 1, m)``;
    ``errors[k] = |reference[k] - positions[k]|``; ``joint_rates`` and
    ``damping`` are per step ``(n, nq)``, ``(n,)``; ``manipulability`` and
    ``sigma_min`` are evaluated at every state.
    """

    axes: tuple[str, ...]
    times: np.ndarray
    q: np.ndarray
    positions: np.ndarray
    reference: np.ndarray
    errors: np.ndarray
    manipulability: np.ndarray
    sigma_min: np.ndarray
    joint_rates: np.ndarray
    damping: np.ndarray
    events: list[SingularityEvent] = field(default_factory=list)
    closed_loop: bool = False
    stopped_early: bool = False

    @property
    def singular(self) -> bool:
        """True if any singularity event was reported."""
        return bool(self.events)

    @property
    def first_event_step(self) -> int | None:
        """Step of the first singularity event, or None when there was none."""
        return self.events[0].step if self.events else None

    @property
    def max_error(self) -> float:
        """Largest task error over the steps (task units: m, rad for yaw)."""
        return float(self.errors.max())

    @property
    def final_error(self) -> float:
        """Task error at the last step."""
        return float(self.errors[-1])

    @property
    def rms_error(self) -> float:
        """Root mean square of the task errors over the steps."""
        return float(np.sqrt(np.mean(self.errors**2)))

    def summary(self) -> dict:
        """Steps, loop kind, error figures and events as a JSON-ready dict."""
        return {
            "steps": int(len(self.times) - 1),
            "closed_loop": self.closed_loop,
            "max_error": self.max_error,
            "rms_error": self.rms_error,
            "final_error": self.final_error,
            "min_manipulability": float(self.manipulability.min()),
            "events": [(e.step, e.kind, e.value) for e in self.events],
        }


def _check_axes(robot: Robot, axes) -> tuple[str, ...]:
    """The task axes (``robot.task_axes`` for None), ``phi`` read as ``yaw``: names among x, y, z, yaw, each
    once (:class:`InputError` / :class:`ShapeError` otherwise)."""
    raw = robot.task_axes if axes is None else axes
    axis_rows(raw)  # a sequence of known names, each once (a bare string or an unknown name is refused)
    axes = tuple("yaw" if a == "phi" else a for a in raw)
    bad = [a for a in axes if a in ("roll", "pitch")]
    if bad:
        raise InputError(
            f"resolved-rate task axes must be among x, y, z, yaw; got {axes} ({bad} have no integrable "
            "coordinate)"
        )
    if not axes:
        raise InputError("axes must name at least one task component")
    return axes


def task_coordinates(robot: Robot, q: VectorLike, axes: Sequence[str],
                     frame: str | None = None) -> np.ndarray:
    """Task coordinates ``x(q)``: tool position components and/or yaw (see module docstring).

    ``axes``: names among ``x``, ``y``, ``z``, ``yaw`` (``phi``), each once; an unknown name, ``roll`` /
    ``pitch`` or an empty list is refused (:class:`InputError`), never read as yaw; so is a ``robot`` that
    is not a :class:`~kinserve.kinematics.Robot`.
    """
    axes = _check_axes(as_robot(robot), axes)
    T = robot.fk(q, frame)
    out = np.empty(len(axes))
    for i, a in enumerate(axes):
        out[i] = T[_POSITION_AXES[a], 3] if a in _POSITION_AXES else math.atan2(T[1, 0], T[0, 0])
    return out


def _wrap_task_error(e: np.ndarray, yaw_index: list[int]) -> np.ndarray:
    for i in yaw_index:
        e[i] = (e[i] + math.pi) % (2.0 * math.pi) - math.pi
    return e


def damped_pseudo_inverse(J: np.ndarray, damping: float = 0.0,
                          rcond: float = 1e-12) -> tuple[np.ndarray, np.ndarray]:
    """``(J^+, sigma)``: ``V diag(sigma/(sigma^2 + damping^2)) U^T`` and the singular values.

    With ``damping = 0`` singular values below ``rcond * sigma_max`` are
    dropped (Moore-Penrose pseudo-inverse).

    Refused (:class:`InputError` / :class:`ShapeError`): ``J`` not a non-empty 2-D array of finite
    numbers; ``damping`` not a finite number in ``[0, 1e6]``; ``rcond`` not in ``[0, 1]``.
    """
    J = as_matrix(J, (-1, -1), "J")
    if J.size == 0:
        raise ShapeError(f"J must have at least one row and one column, got shape {J.shape}")
    damping = as_nonnegative(damping, "damping")
    rcond = as_nonnegative(rcond, "rcond", maximum=1.0)
    U, s, Vt = np.linalg.svd(J, full_matrices=False)
    return _pinv_from_svd(U, s, Vt, damping, rcond), s


def _pinv_from_svd(U, s, Vt, damping: float, rcond: float = 1e-12) -> np.ndarray:
    if damping > 0.0:
        inv = s / (s * s + damping * damping)
    else:
        cut = rcond * (s[0] if s.size else 0.0)
        inv = np.where(s > cut, 1.0 / np.where(s > cut, s, 1.0), 0.0)
    return (Vt.T * inv) @ U.T


def adaptive_damping(sigma_min: float, sigma_threshold: float, lambda_max: float) -> float:
    """``lambda`` with ``lambda^2 = (1 - (sigma_min/sigma_threshold)^2) lambda_max^2`` below the threshold,
    else 0."""
    if sigma_min >= sigma_threshold:
        return 0.0
    r = sigma_min / sigma_threshold
    return lambda_max * math.sqrt(max(0.0, 1.0 - r * r))


def _checked_run_arguments(n, dt, gain, damping) -> int:
    """The step count ``n`` as an int, after checking :func:`track_reference`'s ``n``, ``dt``, ``gain``
    and ``damping`` (:class:`InputError` naming the argument): ``n`` an integer from 0 to
    :data:`~kinserve.planners.checks.MAX_SAMPLES`, ``dt`` in ``(0, 1e6]``, ``gain`` in ``(0, 1]``, ``damping``
    ``"adaptive"`` or a number in ``[0, 1e6]``."""
    n = as_count(n, "n (number of steps)", 0, MAX_SAMPLES)
    as_positive(dt, "dt")
    as_positive(gain, "gain", maximum=1.0)
    if not (isinstance(damping, str) and damping == "adaptive"):
        if isinstance(damping, str):
            raise InputError(f"damping must be 'adaptive' or a number >= 0, got {damping!r}")
        as_nonnegative(damping, "damping")
    return n


def track_reference(
    robot: Robot,
    reference: Reference,
    q0: VectorLike,
    n: int,
    dt: float,
    *,
    closed_loop: bool = True,
    gain: float = 1.0,
    axes: Sequence[str] | None = None,
    frame: str | None = None,
    damping: float | str = "adaptive",
    sigma_threshold: float = 0.05,
    lambda_max: float = 0.1,
    max_joint_rate: float | None = None,
    max_step_error: float = 0.1,
    stop_on_singularity: bool = False,
) -> ResolvedRateResult:
    """Follow ``reference(t) -> (x_ref, xdot_ref)`` for ``n`` steps of ``dt`` seconds from ``q0``.

    Open loop integrates ``J^+ xdot_ref(t_k)``; closed loop uses the next
    reference point and the feedback ``gain`` (see the module docstring).
    ``damping``: ``"adaptive"`` (default), a fixed ``lambda >= 0``, or 0.
    With ``stop_on_singularity`` the run ends at the first event.

    Refused (:class:`InputError` naming the argument, before any step): ``robot`` not a
    :class:`~kinserve.kinematics.Robot`; ``n``, ``dt``, ``gain`` and ``damping`` as
    :func:`_checked_run_arguments` says; ``sigma_threshold``, ``max_step_error`` and ``max_joint_rate`` (when
    given) not in ``(0, 1e6]``; ``lambda_max`` not in ``[0, 1e6]``; ``reference`` not callable;
    ``closed_loop`` or ``stop_on_singularity`` not True or False. ``reference(t)`` must return a pair
    ``(x_ref, xdot_ref)`` of vectors of one finite number per task axis (:class:`InputError` /
    :class:`ShapeError` at the step that gets anything else); an exception raised by ``reference`` itself
    propagates unchanged (it is the caller's code, not a refusal of an argument).
    """
    robot = as_robot(robot)
    if not callable(reference):
        raise InputError("reference must be a function t -> (x_ref, xdot_ref), got "
                         f"{type(reference).__name__}")
    closed_loop = as_flag(closed_loop, "closed_loop")
    stop_on_singularity = as_flag(stop_on_singularity, "stop_on_singularity")
    axes = _check_axes(robot, axes)
    rows = axis_rows(axes)
    yaw_index = [i for i, a in enumerate(axes) if a == "yaw"]
    q = robot.check_q(q0, "q0").astype(float).copy()
    n = _checked_run_arguments(n, dt, gain, damping)
    sigma_threshold = as_positive(sigma_threshold, "sigma_threshold")
    lambda_max = as_nonnegative(lambda_max, "lambda_max")
    max_step_error = as_positive(max_step_error, "max_step_error")
    if max_joint_rate is not None:
        max_joint_rate = as_positive(max_joint_rate, "max_joint_rate")
    m = len(axes)

    def ref(t):
        pair = reference(t)
        if not (isinstance(pair, (tuple, list)) and len(pair) == 2):
            raise InputError(f"reference(t) must return a pair (x_ref, xdot_ref) of {m} numbers each (one "
                             f"per axis of {axes}), got {describe(pair)} at t = {t:g}")
        return as_vector(pair[0], m, "reference position"), as_vector(pair[1], m, "reference velocity")

    times = dt * np.arange(n + 1)
    Q = np.empty((n + 1, robot.nq))
    X = np.empty((n + 1, m))
    R = np.empty((n + 1, m))
    manip = np.empty(n + 1)
    smin = np.empty(n + 1)
    rates = np.zeros((n, robot.nq))
    lams = np.zeros(n)
    events: list[SingularityEvent] = []
    low_prev = rate_prev = big_prev = limit_prev = False
    predicted = None
    stopped = False
    x_ref, xd_ref = ref(0.0)
    last = n
    for k in range(n + 1):
        Q[k] = q
        X[k] = task_coordinates(robot, q, axes, frame)
        R[k] = x_ref
        if predicted is not None:
            moved = float(np.linalg.norm(predicted - X[k - 1]))
            miss = float(np.linalg.norm(_wrap_task_error(X[k] - predicted, yaw_index)))
            big = moved > 0.0 and miss > max_step_error * moved
            if big and not big_prev:
                events.append(SingularityEvent(k - 1, float(times[k - 1]), "large_step", miss / moved,
                                               f"step {k - 1} (t={times[k - 1]:.4g}s): "
                                               f"the task moved {miss:.3g} away from the Jacobian's "
                                               f"prediction ({miss / moved:.0%} of the step); "
                                               "the step crosses a singularity or is too large for "
                                               f"dt={dt:g}"))
            big_prev = big
        J = robot.jacobian(q, frame)[rows]
        U, s, Vt = np.linalg.svd(J, full_matrices=False)
        sig = float(s[-1]) if len(s) >= m else 0.0  # fewer joints than task rows: rank-deficient
        lam = adaptive_damping(sig, sigma_threshold, lambda_max) if damping == "adaptive" else float(damping)
        Jp = _pinv_from_svd(U, s, Vt, lam)
        smin[k] = sig
        manip[k] = float(np.prod(s)) if len(s) >= m else 0.0
        low = sig < sigma_threshold
        if low and not low_prev:
            events.append(SingularityEvent(k, float(times[k]), "low_manipulability", sig,
                                           f"step {k} (t={times[k]:.4g}s): smallest singular value of the "
                                           f"task Jacobian {sig:.3g} < {sigma_threshold:g}; "
                                           f"manipulability {manip[k]:.3g}"))
        low_prev = low
        if k == n:
            break
        if stop_on_singularity and events:
            last, stopped = k, True
            break
        x_next, xd_next = ref(times[k + 1])
        if closed_loop:
            e = _wrap_task_error(x_ref - X[k], yaw_index)
            step = _wrap_task_error(x_next - x_ref, yaw_index) + gain * e
            xdot_cmd = step / dt
        else:
            xdot_cmd = xd_ref
        qdot = Jp @ xdot_cmd
        rate = float(np.linalg.norm(qdot))
        limit = (max_joint_rate if max_joint_rate is not None
                 else float(np.linalg.norm(xdot_cmd)) / sigma_threshold)
        high = rate > limit and rate > 0.0
        if high and not rate_prev:
            events.append(SingularityEvent(k, float(times[k]), "joint_rate", rate,
                                           f"step {k} (t={times[k]:.4g}s): "
                                           f"joint-rate norm {rate:.3g} exceeds {limit:.3g}"))
        rate_prev = high
        rates[k] = qdot
        lams[k] = lam
        predicted = X[k] + (J @ qdot) * dt
        q = q + qdot * dt
        outside = not robot.within_limits(q)
        if outside and not limit_prev:
            bad = [robot.joint_names[i] for i in np.flatnonzero((q < robot.lower) | (q > robot.upper))]
            events.append(SingularityEvent(k + 1, float(times[k + 1]), "joint_limit",
                                           float(np.linalg.norm(q)),
                                           f"step {k + 1} (t={times[k + 1]:.4g}s): "
                                           f"joint(s) {', '.join(bad)} left their limits (not enforced by "
                                           "resolved-rate control)"))
        limit_prev = outside
        if not np.all(np.isfinite(q)):
            events.append(SingularityEvent(k, float(times[k]), "joint_rate", math.inf,
                                           f"step {k}: joint values became non-finite; run stopped"))
            last, stopped = k, True
            break
        x_ref, xd_ref = x_next, xd_next
    events.sort(key=lambda e: e.step)
    sl = slice(0, last + 1)
    errors = np.linalg.norm(np.array([_wrap_task_error(r - x, yaw_index)
                                      for r, x in zip(R[sl], X[sl])]), axis=1)
    return ResolvedRateResult(axes, times[sl], Q[sl], X[sl], R[sl], errors, manip[sl], smin[sl],
                              rates[:last], lams[:last], events, closed_loop, stopped)


def resolved_rate(robot: Robot, velocity: VectorLike, q0: VectorLike, n: int, dt: float, *,
                  closed_loop: bool = False, **kwargs: Any) -> ResolvedRateResult:
    """Move the tool along the constant task velocity ``velocity`` for ``n`` steps of ``dt``.

    Open loop by default (``q_{k+1} = q_k + J^+ v dt``, the seed's scheme);
    the reference is the straight line ``x(q0) + v t``. Keyword arguments as
    :func:`track_reference` (``robot`` not a :class:`~kinserve.kinematics.Robot` is refused, as there).
    """
    robot = as_robot(robot)
    axes = _check_axes(robot, kwargs.pop("axes", None))
    frame = kwargs.get("frame")
    v = as_vector(velocity, len(axes), "velocity")
    x0 = task_coordinates(robot, robot.check_q(q0, "q0"), axes, frame)
    return track_reference(robot, lambda t: (x0 + v * t, v), q0, n, dt, closed_loop=closed_loop,
                           axes=axes, **kwargs)


def circle_reference(centre: VectorLike, radius: float, period: float, phase: float = 0.0) -> Reference:
    """``t -> (c + r [cos(w t + phase), sin(w t + phase)], r w [-sin, cos])`` with ``w = 2 pi / period``."""
    c = as_vector(centre, 2, "centre")
    if not (math.isfinite(radius) and radius > 0):
        raise InputError(f"radius must be a finite number > 0, got {radius!r}")
    w = 2.0 * math.pi / period

    def ref(t):
        a = w * t + phase
        ca, sa = math.cos(a), math.sin(a)
        return c + radius * np.array([ca, sa]), radius * w * np.array([-sa, ca])

    return ref


def follow_circle(
    robot: Robot,
    centre: VectorLike,
    radius: float,
    q0: VectorLike,
    n: int,
    dt: float,
    *,
    closed_loop: bool = True,
    angular_velocity: float = 1.0,
    **kwargs: Any,
) -> ResolvedRateResult:
    """Follow a circle (centre, radius) in the two task axes at ``angular_velocity`` rad/s for ``n`` steps.

    The reference is ``c + r [cos(w t + phase), sin(w t + phase)]`` with
    ``w = angular_velocity`` (the seed's circle runs at 1 rad/s, so a larger
    ``dt`` means a larger angle per step and a larger error).

    The circle starts at the point nearest the tool's initial position
    (phase ``atan2(y0 - cy, x0 - cx)``), counter-clockwise for ``w > 0``; the
    initial error is the tool's distance from the circle. Open loop is the
    seed document's scheme (commanded tangent velocity only). ``radius`` must be in ``(0, 1e6]`` and
    ``angular_velocity`` a non-zero number of magnitude at most 1e6 and ``robot`` a
    :class:`~kinserve.kinematics.Robot` (:class:`InputError` otherwise).
    """
    robot = as_robot(robot)
    axes = _check_axes(robot, kwargs.pop("axes", None))
    if len(axes) != 2:
        raise InputError(f"circle following needs exactly two task axes, got {axes}")
    as_count(n, "n (number of steps)", 1, MAX_SAMPLES)
    x0 = task_coordinates(robot, robot.check_q(q0, "q0"), axes, kwargs.get("frame"))
    c = as_vector(centre, 2, "centre")
    radius = as_positive(radius, "radius")
    phase = math.atan2(x0[1] - c[1], x0[0] - c[0])
    if as_real(angular_velocity, "angular_velocity") == 0:
        raise InputError("angular_velocity must be a finite non-zero number (rad/s), "
                         f"got {angular_velocity!r}")
    ref = circle_reference(c, radius, 2.0 * math.pi / angular_velocity, phase)
    return track_reference(robot, ref, q0, n, dt, closed_loop=closed_loop, axes=axes, **kwargs)
