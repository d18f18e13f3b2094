"""Time scalings ``s(t)``: progress from ``s(0) = 0`` to ``s(T) = 1`` on ``[0, T]``.

A path ``x(s)`` becomes a trajectory ``x(s(t))`` with velocity ``x'(s) s'(t)``
and acceleration ``x''(s) s'^2 + x'(s) s''``. The scalings here (Lynch & Park,
ch. 9.2):

* cubic, rest to rest: ``s = 3 (t/T)^2 - 2 (t/T)^3``; peak ``s' = 3/(2T)``
  at ``t = T/2``, peak ``|s''| = 6/T^2`` at the ends;
* quintic, rest to rest with zero boundary acceleration:
  ``s = 10 (t/T)^3 - 15 (t/T)^4 + 6 (t/T)^5``; peak ``s' = 15/(8T)``, peak
  ``|s''| = 10 / (sqrt(3) T^2)`` at ``t/T = 1/2 -+ sqrt(3)/6``;
* trapezoidal velocity (bang-coast-bang) with limits ``v`` on ``s'`` and
  ``a`` on ``|s''|``: accelerate for ``v/a``, coast, decelerate; when
  ``v^2/a > 1`` the coast vanishes and the profile is *triangular* with peak
  ``s' = sqrt(a)`` and ``T = 2/sqrt(a)``.

Cubic and quintic scalings may also start and end with non-zero rates
(``v0, v1`` and ``a0, a1`` in units of ``1/s`` and ``1/s^2``), which is what a
segment between two via points needs.

Limits given on a path of length ``L`` (units/s, units/s^2) are limits
``v/L`` and ``a/L`` on ``s``; :func:`minimum_time` does that conversion.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from kinserve.kinematics.errors import InputError, ShapeError
from kinserve.kinematics.validation import as_choice, as_positive, as_real

from . import polynomials
from .checks import as_numbers, as_times, sample_count

_KINDS = ("cubic", "quintic", "trapezoidal")


def _positive(value: object, name: str) -> float:
    """``value`` as a finite float in ``(0, 1e6]`` (:func:`~kinserve.kinematics.validation.as_positive`)."""
    return as_positive(value, name)


class TimeScaling:
    """Base class: a map ``t -> s`` on ``[0, duration]`` with ``s(0) = 0``, ``s(duration) = 1``.

    Times outside ``[0, duration]`` are clamped (the motion is at rest before
    and after, if the boundary rates are zero). Times that are NaN, infinite, above
    1e6 in magnitude or not numbers are refused (:class:`InputError`).
    """

    duration: float

    def evaluate(self, t: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(s, s', s'')`` at times ``t`` (scalars or arrays, seconds)."""
        raise NotImplementedError

    def __call__(self, t: ArrayLike) -> np.ndarray:
        """``s(t)``, the progress at times ``t`` (same as :meth:`s`)."""
        return self.evaluate(t)[0]

    def s(self, t: ArrayLike) -> np.ndarray:
        """Progress ``s(t)`` in ``[0, 1]``."""
        return self.evaluate(t)[0]

    def ds(self, t: ArrayLike) -> np.ndarray:
        """Rate ``s'(t)`` (1/s)."""
        return self.evaluate(t)[1]

    def dds(self, t: ArrayLike) -> np.ndarray:
        """Second derivative ``s''(t)`` (1/s^2)."""
        return self.evaluate(t)[2]

    def sample(self, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(t, s, s', s'')`` at ``n`` evenly spaced times including both ends (``n`` an integer from 2 to
        :data:`~kinserve.planners.checks.MAX_SAMPLES`, else :class:`InputError`)."""
        t = np.linspace(0.0, self.duration, sample_count(n, "n"))
        return (t, *self.evaluate(t))


@dataclass(frozen=True)
class PolynomialTimeScaling(TimeScaling):
    """``s(t) = sum_k c_k t^k`` on ``[0, duration]`` (cubic or quintic)."""

    coefficients: np.ndarray
    duration: float
    kind: str

    def evaluate(self, t: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(s, s', s'')`` of the polynomial at times ``t`` (s), clamped to ``[0, T]``."""
        t = np.clip(as_times(t), 0.0, self.duration)
        return tuple(polynomials.evaluate(self.coefficients, t, 2))


def cubic_time_scaling(T: float, v0: float = 0.0, v1: float = 0.0) -> PolynomialTimeScaling:
    """Cubic ``s(t)`` with ``s(0)=0, s(T)=1, s'(0)=v0, s'(T)=v1`` (rates in 1/s).

    Refused (:class:`InputError` naming the argument): ``T`` not a number in ``[1e-6, 1e6]`` s; ``v0``,
    ``v1`` not single finite numbers with magnitude <= 1e6 (None, NaN, text, arrays)."""
    T = _positive(T, "T")
    v0, v1 = as_real(v0, "v0"), as_real(v1, "v1")
    return PolynomialTimeScaling(polynomials.cubic_coefficients(T, 0.0, 1.0, v0, v1), T, "cubic")


def quintic_time_scaling(T: float, v0: float = 0.0, v1: float = 0.0, a0: float = 0.0,
                         a1: float = 0.0) -> PolynomialTimeScaling:
    """Quintic ``s(t)`` meeting ``s, s', s''`` at both ends (zero rates by default); refused as by
    :func:`cubic_time_scaling` (also ``a0``, ``a1``)."""
    T = _positive(T, "T")
    v0, v1, a0, a1 = (as_real(v, k) for k, v in (("v0", v0), ("v1", v1), ("a0", a0), ("a1", a1)))
    return PolynomialTimeScaling(polynomials.quintic_coefficients(T, 0.0, 1.0, v0, v1, a0, a1), T, "quintic")


@dataclass(frozen=True)
class TrapezoidalTimeScaling(TimeScaling):
    """Bang-coast-bang ``s(t)`` with ``s' <= v_max`` and ``|s''| <= a_max`` (units of ``s``).

    ``t_a`` is the acceleration time, ``v_peak`` the coast rate; ``triangular``
    is True when the distance is too short to reach ``v_max``.
    """

    v_max: float
    a_max: float
    t_a: float
    v_peak: float
    duration: float
    triangular: bool

    @property
    def kind(self) -> str:
        """``"trapezoidal"``."""
        return "trapezoidal"

    def evaluate(self, t: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(s, s', s'')`` at times ``t`` (s), clamped: ``a_max`` up to ``t_a``, cruise, mirror image."""
        t = np.clip(as_times(t), 0.0, self.duration)
        a, ta, vp, T = self.a_max, self.t_a, self.v_peak, self.duration
        td = T - t
        s = np.where(t <= ta, 0.5 * a * t**2,
                     np.where(td <= ta, 1.0 - 0.5 * a * td**2, 0.5 * a * ta**2 + vp * (t - ta)))
        sd = np.where(t <= ta, a * t, np.where(td <= ta, a * td, vp))
        sdd = np.where(t < ta, a, np.where(td < ta, -a, 0.0))
        return s, sd, sdd


def trapezoidal_time_scaling(v_max: float, a_max: float, distance: float = 1.0) -> TrapezoidalTimeScaling:
    """Fastest trapezoidal scaling for a path of length ``distance`` under ``v_max``, ``a_max``.

    The limits are in the path's units (units/s, units/s^2); they act on ``s``
    as ``v_max/distance`` and ``a_max/distance``. Trapezoidal when
    ``v^2/a <= 1`` (in ``s`` units), else triangular. Each of ``v_max``, ``a_max`` and ``distance`` must
    be a finite number in ``(0, 1e6]`` (:class:`InputError` naming it).
    """
    L = _positive(distance, "distance")
    v = _positive(v_max, "v_max") / L
    a = _positive(a_max, "a_max") / L
    if v * v / a >= 1.0:
        ta = math.sqrt(1.0 / a)
        return TrapezoidalTimeScaling(v, a, ta, a * ta, 2.0 * ta, True)
    ta = v / a
    return TrapezoidalTimeScaling(v, a, ta, v, 1.0 / v + ta, False)


#: Peak ``s'`` times ``T`` and peak ``|s''|`` times ``T^2`` of the rest-to-rest polynomials.
PEAK_RATE = {"cubic": 1.5, "quintic": 15.0 / 8.0}
PEAK_ACCELERATION = {"cubic": 6.0, "quintic": 10.0 / math.sqrt(3.0)}


def minimum_time(kind: str, distance: ArrayLike, v_max: ArrayLike, a_max: ArrayLike) -> float:
    """Shortest duration ``T`` of a rest-to-rest scaling moving ``distance`` within the limits.

    ``distance``, ``v_max`` and ``a_max`` may be vectors (one entry per joint):
    the result is the largest of the per-joint minimum times, so a scaling of
    that duration respects every joint's limits. Zero distances need no time.

    * cubic: ``T = max(1.5 D / v, sqrt(6 D / a))``
    * quintic: ``T = max(15 D / (8 v), sqrt(10 D / (sqrt(3) a)))``
    * trapezoidal: ``T = D/v + v/a`` if ``D >= v^2/a``, else ``2 sqrt(D/a)`` (triangular)

    Refused (:class:`InputError` / :class:`ShapeError` naming the argument): an unknown ``kind``; values
    that are not finite numbers with magnitude <= 1e6; limits <= 0; vectors of different lengths (each
    argument is one number or a vector of the common length; none is stretched to another's length).
    """
    kind = as_choice(kind, "kind", _KINDS)
    D = np.abs(as_numbers(distance, "distance"))
    v = as_numbers(v_max, "v_max")
    a = as_numbers(a_max, "a_max")
    shapes = {arr.shape for arr in (D, v, a) if arr.ndim > 0}
    if any(arr.ndim > 1 for arr in (D, v, a)) or len(shapes) > 1:
        raise ShapeError(
            "distance, v_max and a_max must each be one number or a vector of the same length, got shapes "
            f"{D.shape}, {v.shape}, {a.shape}"
        )
    if np.any(v <= 0) or np.any(a <= 0):
        raise InputError(f"v_max and a_max must be > 0, got v_max={v_max!r}, a_max={a_max!r}")
    D, v, a = np.broadcast_arrays(D, v, a)
    if kind == "trapezoidal":
        T = np.where(D >= v * v / a, D / v + v / a, 2.0 * np.sqrt(D / a))
        T = np.where(D == 0.0, 0.0, T)
    else:
        T = np.maximum(PEAK_RATE[kind] * D / v, np.sqrt(PEAK_ACCELERATION[kind] * D / a))
    return float(np.max(T)) if T.size else 0.0


def time_scaling(kind: str, T: float | None = None, *, distance: ArrayLike | None = None,
                 v_max: ArrayLike | None = None, a_max: ArrayLike | None = None) -> TimeScaling:
    """Build a rest-to-rest scaling by name.

    ``time_scaling("quintic", T=2.0)``; or with limits instead of ``T``:
    ``time_scaling("cubic", distance=D, v_max=v, a_max=a)`` uses
    :func:`minimum_time`; ``"trapezoidal"`` always needs the limits (a scalar
    ``distance``, the path length). ``T`` is refused as by :func:`cubic_time_scaling`, the limits as by
    :func:`minimum_time`.
    """
    kind = as_choice(kind, "kind", _KINDS)
    if kind == "trapezoidal":
        if v_max is None or a_max is None:
            raise InputError("a trapezoidal time scaling needs v_max and a_max")
        return trapezoidal_time_scaling(v_max, a_max, 1.0 if distance is None else distance)
    if T is None:
        if distance is None or v_max is None or a_max is None:
            raise InputError(f"a {kind} time scaling needs T, or distance with v_max and a_max")
        T = minimum_time(kind, distance, v_max, a_max)
        if T == 0.0:
            raise InputError("distance is zero: no motion to time-scale")
    return cubic_time_scaling(T) if kind == "cubic" else quintic_time_scaling(T)
