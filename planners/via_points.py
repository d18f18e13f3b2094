"""Trajectories through via points with continuous velocity and acceleration.

Given via points ``q_0 .. q_{K-1}`` (vectors of any length ``n``: joint
vectors, positions, ...) and times ``t_0 < ... < t_{K-1}``, two constructions:

* ``"cubic_spline"``: the C2 cubic spline through all points with prescribed
  (default zero) boundary velocities (scipy ``CubicSpline`` with clamped ends).
  Position, velocity and acceleration are continuous everywhere; the velocities
  at the interior vias come out of the spline's tridiagonal system.
* ``"quintic"``: one quintic per segment (Lynch & Park ch. 9.4 with
  accelerations). The via velocity of each component is the mean of the two
  adjacent segment slopes when they have the same sign and 0 otherwise (so the
  motion does not overshoot a via that is a local extremum); via
  accelerations are 0. Velocity and acceleration are continuous because both
  segments meeting at a via use the same values there.

When no times are given they are chosen from limits: each segment gets the
rest-to-rest cubic minimum time under ``v_max``/``a_max`` (per component),
a conservative heuristic since the vias are passed with non-zero velocity.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike
from scipy.interpolate import CubicSpline

from kinserve.kinematics.errors import InputError, ShapeError
from kinserve.kinematics.validation import as_choice, as_matrix, as_positive, as_real

from . import polynomials
from .checks import MAX_SAMPLES, as_numbers, as_times, step_count
from .time_scaling import minimum_time

if TYPE_CHECKING:
    from .joint_trajectory import JointTrajectory

METHODS = ("cubic_spline", "quintic")


@dataclass(frozen=True)
class ViaPointTrajectory:
    """A C2 trajectory ``q(t)`` through ``points`` at ``times``.

    ``evaluate(t)`` returns ``(q, qd, qdd)``, each of shape ``(len(t), n)``
    (or ``(n,)`` for a scalar ``t``); times outside ``[t_0, t_end]`` are clamped; NaN,
    infinite or non-numeric times are refused (:class:`InputError`).
    """

    times: np.ndarray
    points: np.ndarray
    method: str
    _spline: CubicSpline | None = None
    _coeffs: np.ndarray | None = None  # (K-1, 6, n) quintic coefficients in local time

    @property
    def duration(self) -> float:
        """``t_end - t_0`` (s)."""
        return float(self.times[-1] - self.times[0])

    @property
    def dim(self) -> int:
        """Dimension ``n`` of the points."""
        return self.points.shape[1]

    def evaluate(self, t: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(q, qd, qdd)`` at times ``t`` (see the class docstring)."""
        scalar = np.ndim(t) == 0
        t = np.clip(np.atleast_1d(as_times(t)).ravel(), self.times[0], self.times[-1])
        if t.size > MAX_SAMPLES:
            raise InputError(f"t holds {t.size:,} times; at most {MAX_SAMPLES:,} are accepted")
        if self._spline is not None:
            out = [self._spline(t, k) for k in range(3)]
        else:
            seg = np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, len(self.times) - 2)
            tau = t - self.times[seg]
            c = self._coeffs[seg]  # (N, 6, n)
            out = [np.zeros((t.size, self.dim)) for _ in range(3)]
            powers = tau[:, None] ** np.arange(6)[None, :]  # (N, 6)
            k = np.arange(6)
            out[0] = np.einsum("nk,nkd->nd", powers, c)
            d1 = np.zeros_like(powers)
            d1[:, 1:] = powers[:, :-1] * k[1:]
            out[1] = np.einsum("nk,nkd->nd", d1, c)
            d2 = np.zeros_like(powers)
            d2[:, 2:] = powers[:, :-2] * (k[2:] * (k[2:] - 1))
            out[2] = np.einsum("nk,nkd->nd", d2, c)
        if scalar:
            return tuple(o[0] for o in out)
        return tuple(out)

    def sample(self, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(t, q, qd, qdd)`` at ``t_0, t_0 + dt, ...`` up to and including the end time.

        ``dt`` (s) must be a finite number in ``(0, 1e6]`` making at most
        :data:`~kinserve.planners.checks.MAX_SAMPLES` steps over the duration (:class:`InputError` naming
        the smallest ``dt`` accepted)."""
        dt = as_positive(dt, "dt")
        step_count(self.duration, dt, "dt", "s", "trajectory")
        n = int(np.floor(self.duration / dt + 1e-9))
        t = self.times[0] + dt * np.arange(n + 1)
        if self.times[-1] - t[-1] > 1e-9 * max(1.0, self.duration):
            t = np.append(t, self.times[-1])
        return (t, *self.evaluate(t))

    def to_joint_trajectory(self, dt: float, joint_names: Iterable[str]) -> JointTrajectory:
        """Sample every ``dt`` into a :class:`planners.joint_trajectory.JointTrajectory`.

        ``dt`` is refused as by :meth:`sample`; ``joint_names`` must be a sequence of :attr:`dim` distinct
        names (:class:`InputError` / :class:`ShapeError` otherwise)."""
        from .joint_trajectory import JointTrajectory, joint_name_list

        names = joint_name_list(joint_names)
        if len(names) != self.dim:
            raise ShapeError(f"joint_names must name the trajectory's {self.dim} components, got "
                             f"{len(names)} names: {names!r:.120}")
        t, q, qd, qdd = self.sample(dt)
        return JointTrajectory(names, t - t[0], q, qd, qdd)


def heuristic_via_velocities(times: np.ndarray, points: np.ndarray, v0: ArrayLike,
                             v1: ArrayLike) -> np.ndarray:
    """Via velocities ``(K, n)``: mean of adjacent slopes when they agree in sign, else 0."""
    slopes = np.diff(points, axis=0) / np.diff(times)[:, None]
    v = np.zeros_like(points)
    v[0], v[-1] = v0, v1
    left, right = slopes[:-1], slopes[1:]
    v[1:-1] = np.where(np.sign(left) * np.sign(right) > 0, 0.5 * (left + right), 0.0)
    return v


def _boundary_velocity(value: ArrayLike, n: int, name: str) -> np.ndarray:
    """A boundary velocity: one finite number for every component, or a finite ``(n,)`` vector."""
    v = as_numbers(value, name)
    if v.shape not in ((), (1,), (n,)):
        raise ShapeError(f"{name} must be one number or a vector of {n} numbers, got shape {v.shape}")
    return np.broadcast_to(v.reshape(-1) if v.ndim else v, (n,)).copy()


def via_point_trajectory(
    points: ArrayLike,
    times: ArrayLike | None = None,
    *,
    method: str = "cubic_spline",
    v_max: ArrayLike | None = None,
    a_max: ArrayLike | None = None,
    v0: ArrayLike = 0.0,
    v1: ArrayLike = 0.0,
    t0: float = 0.0,
) -> ViaPointTrajectory:
    """Trajectory through ``points`` (shape ``(K, n)``, ``K >= 2``) at ``times`` (shape ``(K,)``).

    Without ``times``, ``v_max`` and ``a_max`` (scalars or per-component) set
    each segment's duration (see the module docstring); the trajectory starts
    at ``t0`` (given times are used as they are: ``t0`` is then unused, but checked all the same).
    ``v0``/``v1`` are the boundary velocities (default rest).

    Refused (:class:`InputError` / :class:`ShapeError` naming the argument): an unknown ``method``; points
    or times that are not finite numbers of the right shape; times not strictly increasing or closer than
    1e-6 s; ``v0``, ``v1`` not one finite number or an ``(n,)`` vector of them; ``t0`` not a finite number;
    limits refused by :func:`~kinserve.planners.time_scaling.minimum_time`.
    """
    method = as_choice(method, "method", METHODS)
    t0 = as_real(t0, "t0")
    P = as_numbers(points, "points")
    if P.ndim == 1:
        P = P[:, None]
    P = as_matrix(P, (-1, -1), "points")
    K, n = P.shape
    if K < 2:
        raise ShapeError(f"points must hold at least 2 via points, got {K}")
    if times is None:
        if v_max is None or a_max is None:
            raise InputError("give the via times, or v_max and a_max to choose them")
        seg = [max(minimum_time("cubic", P[k + 1] - P[k], v_max, a_max), polynomials.MIN_DURATION)
               for k in range(K - 1)]
        t = t0 + np.concatenate([[0.0], np.cumsum(seg)])
    else:
        t = as_matrix(times, (K,), "times")
        if np.any(np.diff(t) < polynomials.MIN_DURATION):
            raise InputError(f"times must be strictly increasing, at least {polynomials.MIN_DURATION:g} s "
                             f"apart, got {t.tolist()!r:.200}")
    v0, v1 = _boundary_velocity(v0, n, "v0"), _boundary_velocity(v1, n, "v1")
    if method == "cubic_spline":
        spline = CubicSpline(t, P, axis=0, bc_type=((1, v0), (1, v1)))
        return ViaPointTrajectory(t, P, method, _spline=spline)
    V = heuristic_via_velocities(t, P, v0, v1)
    coeffs = np.stack(
        [
            polynomials.quintic_coefficients(t[k + 1] - t[k], P[k], P[k + 1], V[k], V[k + 1], 0.0, 0.0)
            for k in range(K - 1)
        ]
    )
    return ViaPointTrajectory(t, P, method, _coeffs=coeffs)
