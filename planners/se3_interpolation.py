"""Interpolation between poses in SE(3), and SE(3) polynomial trajectories.

Poses are 4x4 homogeneous arrays (``pinocchio.SE3`` accepted); twists are
6-vectors ``[v; w]`` (linear first, as Pinocchio's ``Motion``).

Geometric interpolation for a progress ``s in [0, 1]``:

* decoupled: ``p(s) = p0 + s (p1 - p0)`` and
  ``R(s) = R0 exp(s log(R0^T R1))`` (spherical linear interpolation, the
  shortest rotation; the tool point moves on a straight line);
* screw: ``T(s) = T0 exp(s log(T0^-1 T1))`` (constant body twist; the tool
  point moves on a helix about the screw axis).

Both start exactly at ``T0`` and end exactly at ``T1``.

SE(3) polynomial trajectory with boundary *body* twists ``V0, V1``
(``V = [T^-1 dT/dt]^vee``): the document this replaces fits a polynomial to
global exponential coordinates ``exp(c3 t^3 + ... + c0)``, which does not
compose with the boundary poses. Here the polynomial lives in local
coordinates at the start pose,

    ``T(t) = T0 exp(xi(t))``,  ``xi(0) = 0``,  ``xi(tf) = X = log(T0^-1 T1)``,

so ``T(0) = T0`` and ``T(tf) = T1`` exactly. The body twist is
``V(t) = Jr(xi) xi'(t)`` with ``Jr`` the right Jacobian of ``exp`` on SE(3)
(``pinocchio.Jexp6``), hence the boundary rates are

    ``xi'(0) = V0``  (``Jr(0) = I``),  ``xi'(tf) = Jr(X)^-1 V1``  (exact).

The body acceleration is ``dV/dt = Jr(xi) xi'' + (dJr/dt) xi'``; at ``xi = 0``
the second term is ``-1/2 ad(xi') xi' = 0``, so ``xi''(0) = A0`` is exact.
At the goal ``xi''(tf) = Jr(X)^-1 (A1 - (dJr/dt) xi'(tf))`` where
``dJr/dt`` is the directional derivative of ``Jexp6`` at ``X`` along
``xi'(tf)``, taken by a central finite difference (step ``1e-5`` in ``xi``):
the goal acceleration is met to about ``1e-9`` (relative), not exactly.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from scipy.spatial.transform import Rotation

from kinserve.kinematics import se3
from kinserve.kinematics.errors import InputError
from kinserve.kinematics.types import ArrayLike, PoseLike, VectorLike
from kinserve.kinematics.validation import as_choice, as_count, as_flag, as_pose, as_positive, as_vector

from . import polynomials
from .checks import MAX_SAMPLES, as_times, sample_count

METHODS = ("decoupled", "screw")
#: The polynomial orders of :func:`se3_polynomial_trajectory`.
ORDERS = ("cubic", "quintic")


def _progress(s):
    """``s`` as finite numbers (progress, normally in ``[0, 1]``), at most :data:`MAX_SAMPLES` of them."""
    s = as_times(s, "s (progress, normally in [0, 1])")
    if s.size > MAX_SAMPLES:
        raise InputError(f"s holds {s.size:,} progress values; at most {MAX_SAMPLES:,} are accepted")
    return s


def decoupled_interpolation(T0: PoseLike, T1: PoseLike, s: ArrayLike) -> np.ndarray:
    """Straight-line translation + slerp rotation; ``(4, 4)`` for a scalar ``s``, else ``(N, 4, 4)``."""
    A, B = as_pose(T0, "T0"), as_pose(T1, "T1")
    s = _progress(s)
    ss = np.atleast_1d(s).ravel()
    w = se3.log3(A[:3, :3].T @ B[:3, :3])
    out = np.zeros((ss.size, 4, 4))
    out[:, 3, 3] = 1.0
    out[:, :3, :3] = A[:3, :3] @ Rotation.from_rotvec(ss[:, None] * w[None, :]).as_matrix()
    out[:, :3, 3] = A[:3, 3] + ss[:, None] * (B[:3, 3] - A[:3, 3])
    return out[0] if s.ndim == 0 else out


def screw_interpolation(T0: PoseLike, T1: PoseLike, s: ArrayLike) -> np.ndarray:
    """``T0 exp(s log(T0^-1 T1))``; ``(4, 4)`` for a scalar ``s``, else ``(N, 4, 4)``."""
    A, B = as_pose(T0, "T0"), as_pose(T1, "T1")
    s = _progress(s)
    ss = np.atleast_1d(s).ravel()
    X = pin.log6(se3.to_se3(A).actInv(se3.to_se3(B))).vector
    A_se3 = se3.to_se3(A)
    out = np.array([(A_se3 * pin.exp6(pin.Motion(si * X))).homogeneous for si in ss])
    return out[0] if s.ndim == 0 else out


def interpolate(T0: PoseLike, T1: PoseLike, s: ArrayLike, method: str = "decoupled") -> np.ndarray:
    """Dispatch to :func:`decoupled_interpolation` or :func:`screw_interpolation` by ``method``, one of
    :data:`METHODS` (:class:`InputError` otherwise)."""
    if as_choice(method, "method", METHODS) == "decoupled":
        return decoupled_interpolation(T0, T1, s)
    return screw_interpolation(T0, T1, s)


def intermediate_poses(T0: PoseLike, T1: PoseLike, n: int, method: str = "decoupled",
                       include_ends: bool = False) -> np.ndarray:
    """``n`` poses strictly between ``T0`` and ``T1`` at ``s = k/(n+1)``, ``k = 1..n``.

    With ``include_ends`` the result also starts with ``T0`` and ends with ``T1``
    (``n + 2`` poses). ``n`` must be an integer from 0 to ``MAX_SAMPLES - 2``
    (:data:`~kinserve.planners.checks.MAX_SAMPLES`) and ``method`` one of :data:`METHODS`, else
    :class:`InputError`.
    """
    n = as_count(n, "n", 0, MAX_SAMPLES - 2)
    as_choice(method, "method", METHODS)
    s = np.linspace(0.0, 1.0, n + 2)
    if not as_flag(include_ends, "include_ends"):
        s = s[1:-1]
    if s.size == 0:
        return np.zeros((0, 4, 4))
    return interpolate(T0, T1, s, method)


def interpolate_checkpoints(poses: Sequence[PoseLike], n: int, method: str = "decoupled") -> np.ndarray:
    """Poses through consecutive checkpoints: ``P0, n poses, P1, n poses, ..., P_last``.

    Returns ``((K - 1)(n + 1) + 1, 4, 4)`` for ``K`` checkpoints; every
    checkpoint appears exactly once, at index ``k (n + 1)``. Refused (:class:`InputError`): no poses, or
    ``n`` not an integer >= 0, or a total above :data:`~kinserve.planners.checks.MAX_SAMPLES` poses.
    """
    if poses is None or isinstance(poses, (str, bytes, dict)) or not hasattr(poses, "__len__"):
        raise InputError(f"poses must be a sequence of poses, got {poses!r:.80}")
    if len(poses) < 1:
        raise InputError("poses must hold at least one pose")
    n = as_count(n, "n", 0, MAX_SAMPLES - 2)
    if (len(poses) - 1) * (n + 1) + 1 > MAX_SAMPLES:
        raise InputError(f"n = {n} poses per segment over {len(poses) - 1} segments make "
                         f"{(len(poses) - 1) * (n + 1) + 1:,} poses; at most {MAX_SAMPLES:,} are accepted "
                         f"(n <= {(MAX_SAMPLES - 1) // max(1, len(poses) - 1) - 1})")
    P = [as_pose(p, f"poses[{i}]") for i, p in enumerate(poses)]
    out = [P[0][None]]
    for a, b in zip(P[:-1], P[1:]):
        out.append(intermediate_poses(a, b, n, method, include_ends=True)[1:])
    return np.concatenate(out)


@dataclass(frozen=True)
class SE3PolynomialTrajectory:
    """``T(t) = T0 exp(xi(t))`` with ``xi`` a cubic or quintic (see the module docstring)."""

    T0: np.ndarray
    T1: np.ndarray
    duration: float
    coefficients: np.ndarray  # (4 or 6, 6) power basis of xi(t)
    order: str

    def _xi(self, t):
        t = np.clip(np.atleast_1d(as_times(t)), 0.0, self.duration)
        if t.size > MAX_SAMPLES:
            raise InputError(f"t holds {t.size:,} times; at most {MAX_SAMPLES:,} are accepted")
        return polynomials.evaluate(self.coefficients, t, 1)

    def pose(self, t: ArrayLike) -> np.ndarray:
        """Pose(s) at time(s) ``t``: ``(4, 4)`` or ``(N, 4, 4)``; NaN, infinite or non-numeric times are
        refused (:class:`InputError`), times outside ``[0, duration]`` clamped."""
        xi, _ = self._xi(t)
        A = se3.to_se3(self.T0)
        out = np.array([(A * pin.exp6(pin.Motion(x))).homogeneous for x in xi])
        return out[0] if np.ndim(t) == 0 else out

    def body_twist(self, t: ArrayLike) -> np.ndarray:
        """Body twist ``V = Jr(xi) xi'`` (``[v; w]`` in the moving frame) at time(s) ``t``; times refused as
        by :meth:`pose`."""
        xi, dxi = self._xi(t)
        out = np.array([pin.Jexp6(pin.Motion(x)) @ d for x, d in zip(xi, dxi)])
        return out[0] if np.ndim(t) == 0 else out

    def sample(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        """``(t, poses)`` at ``n`` evenly spaced times including both ends (``n`` an integer from 2 to
        :data:`~kinserve.planners.checks.MAX_SAMPLES`, else :class:`InputError`)."""
        t = np.linspace(0.0, self.duration, sample_count(n, "n"))
        return t, self.pose(t)


def _jr_derivative(X: np.ndarray, direction: np.ndarray, h: float = 1e-5) -> np.ndarray:
    """Directional derivative of ``Jexp6`` at ``X`` along ``direction`` (central difference)."""
    norm = float(np.linalg.norm(direction))
    if norm == 0.0:
        return np.zeros((6, 6))
    d = direction / norm
    Jp = pin.Jexp6(pin.Motion(X + h * d))
    Jm = pin.Jexp6(pin.Motion(X - h * d))
    return (Jp - Jm) / (2.0 * h) * norm


def se3_polynomial_trajectory(
    T0: PoseLike,
    T1: PoseLike,
    duration: float,
    twist0: VectorLike | None = None,
    twist1: VectorLike | None = None,
    *,
    order: str = "quintic",
    acceleration0: VectorLike | None = None,
    acceleration1: VectorLike | None = None,
) -> SE3PolynomialTrajectory:
    """SE(3) trajectory from ``T0`` to ``T1`` in ``duration`` seconds with boundary body twists.

    ``twist0``/``twist1`` are body twists ``[v; w]`` (m/s, rad/s) at the start
    and goal (default rest); ``order="quintic"`` also meets the body
    accelerations ``acceleration0/1`` (default zero), ``"cubic"`` only the
    twists. See the module docstring for the construction and for the one
    approximation (the goal acceleration of the quintic). ``duration`` must be a number of seconds in
    ``[1e-6, 1e6]`` and ``order`` one of :data:`ORDERS` (:class:`InputError` otherwise).
    """
    order = as_choice(order, "order", ORDERS)
    A, B = as_pose(T0, "T0"), as_pose(T1, "T1")
    tf = as_positive(duration, "duration")
    if tf < polynomials.MIN_DURATION:
        raise InputError(f"duration must be at least {polynomials.MIN_DURATION:g} s, got {duration!r}")
    V0 = np.zeros(6) if twist0 is None else as_vector(twist0, 6, "twist0")
    V1 = np.zeros(6) if twist1 is None else as_vector(twist1, 6, "twist1")
    X = np.array(pin.log6(se3.to_se3(A).actInv(se3.to_se3(B))).vector)
    Jr_X = pin.Jexp6(pin.Motion(X))
    dxi1 = np.linalg.solve(Jr_X, V1)
    if order == "cubic":
        c = polynomials.cubic_coefficients(tf, np.zeros(6), X, V0, dxi1)
    else:
        A0 = np.zeros(6) if acceleration0 is None else as_vector(acceleration0, 6, "acceleration0")
        A1 = np.zeros(6) if acceleration1 is None else as_vector(acceleration1, 6, "acceleration1")
        ddxi1 = np.linalg.solve(Jr_X, A1 - _jr_derivative(X, dxi1) @ dxi1)
        c = polynomials.quintic_coefficients(tf, np.zeros(6), X, V0, dxi1, A0, ddxi1)
    return SE3PolynomialTrajectory(A, B, tf, c, order)


def poses_along(T0: PoseLike, T1: PoseLike, scaling: Callable[[np.ndarray], ArrayLike], times: ArrayLike,
                method: str = "screw") -> np.ndarray:
    """Poses ``interpolate(T0, T1, s(t))`` at ``times`` for a time scaling ``s`` (``(N, 4, 4)``).

    E.g. ``poses_along(Ts, Tg, quintic_time_scaling(5.0), t)`` is Lynch & Park's
    ``ScrewTrajectory`` (``method="screw"``) or ``CartesianTrajectory``
    (``method="decoupled"``).
    """
    if not callable(scaling):
        raise InputError(f"scaling must be a time scaling t -> s(t) (e.g. quintic_time_scaling(T)), got "
                         f"{scaling!r:.60}")
    s = np.atleast_1d(scaling(as_times(times, "times")))
    return interpolate(T0, T1, s, method)
