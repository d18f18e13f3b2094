"""Differential-drive kinematics: wheel speeds <-> body velocity (v, omega).

Two wheels of radius ``r`` on a common axle, ``track`` (distance between the
wheel contact points) apart; the reference point is the axle's midpoint and
the heading ``theta`` points forwards. With wheel angular speeds
``phi_L, phi_R`` (rad/s, positive = rolling forwards):

    ``v = r (phi_R + phi_L) / 2``,   ``omega = r (phi_R - phi_L) / track``
    ``phi_R = (v + omega track / 2) / r``,   ``phi_L = (v - omega track / 2) / r``

and the pose moves as the unicycle ``xdot = v cos theta, ydot = v sin theta,
thetadot = omega``. The robot cannot move sideways (non-holonomic).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.integrate import solve_ivp

from kinserve.kinematics.errors import InputError
from kinserve.kinematics.validation import as_numbers, as_positive

from ._checks import simulation_arguments


def _pair(a: np.ndarray, b: np.ndarray, names: str) -> tuple[np.ndarray, np.ndarray]:
    """``a, b`` broadcast together (:class:`InputError` naming ``names`` when they cannot be)."""
    try:
        return np.broadcast_arrays(a, b)
    except ValueError:
        raise InputError(f"{names} must have broadcastable shapes, got {a.shape} and {b.shape}") from None


@dataclass(frozen=True)
class DiffDrive:
    """A differential-drive base: ``wheel_radius`` and ``track`` (same length unit, e.g. m), each in
    ``(0, 1e6]`` (else :class:`InputError`)."""

    wheel_radius: float
    track: float

    def __post_init__(self):
        for name in ("wheel_radius", "track"):
            object.__setattr__(self, name, as_positive(getattr(self, name), name))

    def wheel_speeds(self, v: ArrayLike, omega: ArrayLike) -> np.ndarray:
        """``[phi_L, phi_R]`` (rad/s) for forward speed ``v`` and turn rate ``omega``; broadcasts
        (``(..., 2)``). Refuses non-numeric, non-finite or huge (``|x| > 1e6``) values and shapes that do
        not broadcast."""
        v, w = _pair(as_numbers(v, "v"), as_numbers(omega, "omega"), "v and omega")
        half = 0.5 * self.track
        return np.stack([(v - w * half) / self.wheel_radius, (v + w * half) / self.wheel_radius], axis=-1)

    def body_velocity(self, phi_left: ArrayLike, phi_right: ArrayLike) -> np.ndarray:
        """``[v, omega]`` from the wheel speeds (rad/s); broadcasts (``(..., 2)``). Refuses non-numeric,
        non-finite or huge (``|x| > 1e6``) values and shapes that do not broadcast."""
        L, R = _pair(as_numbers(phi_left, "phi_left"), as_numbers(phi_right, "phi_right"),
                     "phi_left and phi_right")
        r = self.wheel_radius
        return np.stack([0.5 * r * (R + L), r * (R - L) / self.track], axis=-1)

    def simulate(self, wheel_speeds: ArrayLike | Callable[[float], ArrayLike], pose0: ArrayLike,
                 t_span: tuple[float, float], t_eval: ArrayLike | None = None, rtol: float = 1e-10,
                 atol: float = 1e-12) -> tuple[np.ndarray, np.ndarray]:
        """Integrate the pose ``(x, y, theta)`` under wheel speeds (``[phi_L, phi_R]`` or a function of
        ``t``).

        Returns ``(t, poses (N, 3))`` from ``scipy.integrate.solve_ivp``.

        Refused (:class:`InputError` and subclasses): wheel speeds (or a
        callable's value) not 2 finite numbers with ``|x| <= 1e6``; ``pose0`` not
        3 such numbers; ``t_span`` not 2 distinct such times; ``t_eval`` not None
        or a 1-D array of 1 to 10**6 times within ``t_span``, strictly
        increasing (decreasing when ``t_span`` runs backwards); ``rtol`` not
        in ``(0, 1]``; ``atol`` not in ``(0, 1e6]``. A callable's own
        exceptions propagate unchanged.
        """
        f, p0, t_span, t_eval, rtol, atol = simulation_arguments(wheel_speeds, 2, pose0, t_span, t_eval,
                                                                 rtol, atol)

        r, track = self.wheel_radius, self.track

        def rhs(t, s):
            phi_l, phi_r = f(t).tolist()  # checked by f
            v, w = 0.5 * r * (phi_r + phi_l), r * (phi_r - phi_l) / track
            return [v * math.cos(s[2]), v * math.sin(s[2]), w]

        sol = solve_ivp(rhs, t_span, p0, t_eval=t_eval, rtol=rtol, atol=atol)
        return sol.t, sol.y.T
