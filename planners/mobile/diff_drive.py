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


@dataclass(frozen=True)
class DiffDrive:
    """A differential-drive base: ``wheel_radius`` and ``track`` (same length unit, e.g. m)."""

    wheel_radius: float
    track: float

    def __post_init__(self):
        for name in ("wheel_radius", "track"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise InputError(f"{name} must be a finite number > 0, got {v!r}")

    def wheel_speeds(self, v: ArrayLike, omega: ArrayLike) -> np.ndarray:
        """``[phi_L, phi_R]`` (rad/s) for forward speed ``v`` and turn rate ``omega``; broadcasts
        (``(..., 2)``)."""
        v = np.asarray(v, dtype=float)
        w = np.asarray(omega, dtype=float)
        half = 0.5 * self.track
        return np.stack([(v - w * half) / self.wheel_radius, (v + w * half) / self.wheel_radius], axis=-1)

    def body_velocity(self, phi_left: ArrayLike, phi_right: ArrayLike) -> np.ndarray:
        """``[v, omega]`` from the wheel speeds (rad/s); broadcasts (``(..., 2)``)."""
        L = np.asarray(phi_left, dtype=float)
        R = np.asarray(phi_right, dtype=float)
        r = self.wheel_radius
        return np.stack([0.5 * r * (R + L), r * (R - L) / self.track], axis=-1)

    def simulate(self, wheel_speeds: ArrayLike | Callable[[float], ArrayLike], pose0: ArrayLike,
                 t_span: tuple[float, float], t_eval: ArrayLike | None = None, rtol: float = 1e-10,
                 atol: float = 1e-12) -> tuple[np.ndarray, np.ndarray]:
        """Integrate the pose ``(x, y, theta)`` under wheel speeds (``[phi_L, phi_R]`` or a function of
        ``t``).

        Returns ``(t, poses (N, 3))`` from ``scipy.integrate.solve_ivp``.
        """
        f = (wheel_speeds if callable(wheel_speeds)
             else (lambda t, _w=np.asarray(wheel_speeds, dtype=float): _w))

        def rhs(t, s):
            v, w = self.body_velocity(*np.asarray(f(t), dtype=float))
            return [v * math.cos(s[2]), v * math.sin(s[2]), w]

        sol = solve_ivp(rhs, t_span, np.asarray(pose0, dtype=float), t_eval=t_eval, rtol=rtol, atol=atol)
        return sol.t, sol.y.T
