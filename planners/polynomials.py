"""Polynomial boundary-value problems: cubic and quintic Hermite segments.

A segment ``x(t)`` on ``[0, T]`` with prescribed position and velocity at both
ends is a cubic; adding the accelerations makes it a quintic. Coefficients are
in the power basis of ``t`` (not normalised), ``x(t) = sum_k c_k t^k``, and may
be vector valued: every boundary argument broadcasts to a common shape ``S``
and the coefficient array has shape ``(n + 1,) + S``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from kinserve.kinematics.errors import InputError, ShapeError
from kinserve.kinematics.validation import as_numbers, as_real

#: Shortest segment duration (s) accepted: ``T**5`` stays far above the smallest float.
MIN_DURATION = 1e-6
#: Longest segment duration (s) accepted.
MAX_DURATION = 1e6


def _duration(T: object) -> float:
    """``T`` as a float in ``[MIN_DURATION, MAX_DURATION]`` (:class:`InputError` naming ``T`` otherwise)."""
    v = as_real(T, "duration T")
    if not MIN_DURATION <= v <= MAX_DURATION:
        raise InputError(f"duration T must be a number of seconds in [{MIN_DURATION:g}, {MAX_DURATION:g}], "
                         f"got {T!r}")
    return v


def _boundary(values: dict[str, object]) -> list[np.ndarray]:
    """The boundary values (finite numbers or arrays, |x| <= 1e6) broadcast to one shape; errors name the
    argument (a NaN, None or text boundary value is refused, never turned into NaN coefficients)."""
    arrays = [as_numbers(v, k) for k, v in values.items()]
    try:
        return np.broadcast_arrays(*arrays)
    except ValueError:
        shapes = ", ".join(f"{k} {a.shape}" for k, a in zip(values, arrays))
        raise ShapeError(f"boundary values must broadcast to one shape, got {shapes}") from None


def cubic_coefficients(T: float, x0: ArrayLike, x1: ArrayLike, v0: ArrayLike = 0.0,
                       v1: ArrayLike = 0.0) -> np.ndarray:
    """Coefficients ``(4, ...)`` of the cubic with ``x(0)=x0, x(T)=x1, x'(0)=v0, x'(T)=v1``.

    ``c0 = x0, c1 = v0``,
    ``c2 = 3 (x1 - x0)/T^2 - (2 v0 + v1)/T``,
    ``c3 = -2 (x1 - x0)/T^3 + (v0 + v1)/T^2``.

    Refused (:class:`InputError` naming the argument): ``T`` outside ``[MIN_DURATION, MAX_DURATION]`` s or
    not a number; boundary values that are None, text, NaN, infinite or above 1e6 in magnitude, or that do
    not broadcast to one shape.
    """
    T = _duration(T)
    x0, x1, v0, v1 = _boundary({"x0": x0, "x1": x1, "v0": v0, "v1": v1})
    dx = x1 - x0
    return np.stack([x0, v0, 3.0 * dx / T**2 - (2.0 * v0 + v1) / T, -2.0 * dx / T**3 + (v0 + v1) / T**2])


def quintic_coefficients(T: float, x0: ArrayLike, x1: ArrayLike, v0: ArrayLike = 0.0, v1: ArrayLike = 0.0,
                         a0: ArrayLike = 0.0, a1: ArrayLike = 0.0) -> np.ndarray:
    """Coefficients ``(6, ...)`` of the quintic meeting position, velocity, acceleration at both ends.

    ``c0 = x0, c1 = v0, c2 = a0/2``; ``c3..c5`` solve the 3x3 end conditions
    (closed form, Lynch & Park eq. 9.9 generalised to non-zero boundary rates):

    ``c3 = (20 dx - (8 v1 + 12 v0) T - (3 a0 - a1) T^2) / (2 T^3)``
    ``c4 = (-30 dx + (14 v1 + 16 v0) T + (3 a0 - 2 a1) T^2) / (2 T^4)``
    ``c5 = (12 dx - 6 (v1 + v0) T - (a0 - a1) T^2) / (2 T^5)``

    Refused as by :func:`cubic_coefficients`.
    """
    T = _duration(T)
    x0, x1, v0, v1, a0, a1 = _boundary({"x0": x0, "x1": x1, "v0": v0, "v1": v1, "a0": a0, "a1": a1})
    dx = x1 - x0
    c3 = (20.0 * dx - (8.0 * v1 + 12.0 * v0) * T - (3.0 * a0 - a1) * T**2) / (2.0 * T**3)
    c4 = (-30.0 * dx + (14.0 * v1 + 16.0 * v0) * T + (3.0 * a0 - 2.0 * a1) * T**2) / (2.0 * T**4)
    c5 = (12.0 * dx - 6.0 * (v1 + v0) * T - (a0 - a1) * T**2) / (2.0 * T**5)
    return np.stack([x0, v0, 0.5 * a0, c3, c4, c5])


def evaluate(coeffs: ArrayLike, t: ArrayLike, order: int = 2) -> list[np.ndarray]:
    """Value and the first ``order`` derivatives of ``sum_k c_k t^k`` at times ``t``.

    ``coeffs`` has shape ``(n + 1,) + S``; ``t`` any shape ``R``. Returns a list of
    ``order + 1`` arrays of shape ``R + S`` (Horner's scheme on each derivative).
    """
    c = np.asarray(coeffs, dtype=float)
    t = np.asarray(t, dtype=float)
    tt = t.reshape(t.shape + (1,) * (c.ndim - 1))
    out = []
    for _ in range(order + 1):
        acc = np.zeros(t.shape + c.shape[1:]) + c[-1]
        for k in range(c.shape[0] - 2, -1, -1):
            acc = acc * tt + c[k]
        out.append(acc)
        n = c.shape[0]
        if n == 1:
            c = np.zeros_like(c)
        else:
            c = c[1:] * np.arange(1, n).reshape((-1,) + (1,) * (c.ndim - 1))
    return out
