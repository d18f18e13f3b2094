"""Three-wheel omnidirectional base (SCENARIOS.md S6).

Geometry (body frame, origin at the centre): wheel ``i`` (``i = 0, 1, 2``)
sits at ``p_i = D [cos b_i, sin b_i]``, ``b_i = b_0 + i 2 pi / 3``, with its
axle along the radial direction ``e_i = [cos b_i, sin b_i]`` and its rolling
direction tangential, ``u_i = [-sin b_i, cos b_i]``; its passive rollers let
it slide freely along ``e_i``. Wheel speed ``phi_i`` (rad/s) is positive by
the right-hand rule about the *outward* axle ``e_i``, so a positive
``phi_i`` drives its contact point backwards along ``u_i`` and pushes the hub
along ``-u_i``: rolling without slipping gives ``u_i . v_hub = -R phi_i``.

With the body twist ``(xdot, ydot, thetadot)`` in *world* axes and heading
``theta``, the hub velocity is ``v + thetadot z x (Rot(theta) p_i)``, and

    ``phi_i = -(1/R) [ -sin(theta + b_i) xdot + cos(theta + b_i) ydot + D thetadot ]``

(inverse kinematics, ``phi = H(theta) qdot``). ``H`` depends on the heading
only - the seed document's matrix, which contains the world position
``(x, y)``, is wrong: translating the whole base does not change how its
wheels must turn. Forward kinematics is ``qdot = H(theta)^-1 phi``; ``H`` is
invertible for three wheels at 120 degrees (``det = -3 sqrt(3) D / (2 R^3)``).

Consequences checked by the tests: equal wheel speeds ``phi`` give a pure
rotation ``thetadot = -R phi / D`` (opposite to the wheels' sense), and one
wheel alone gives a constant body twist, i.e. a circle in the world.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.integrate import solve_ivp

from kinserve.kinematics.errors import ShapeError
from kinserve.kinematics.validation import as_numbers, as_positive, as_real, as_vector

from ._checks import simulation_arguments


def _vectors(value: object, name: str) -> np.ndarray:
    """``value`` as a ``(3,)`` or ``(N, 3)`` array of finite numbers with ``|x| <= 1e6``
    (:func:`~kinserve.kinematics.validation.as_numbers`, then the shape)."""
    arr = as_numbers(value, name)
    if arr.ndim not in (1, 2) or arr.shape[-1] != 3:
        raise ShapeError(f"{name} must be 3 numbers or an (N, 3) array, got shape {arr.shape}")
    return arr


@dataclass(frozen=True)
class OmniBase:
    """Three omni wheels of ``wheel_radius`` R at distance ``D`` (``center_distance``), 120 degrees apart.

    ``first_wheel_angle`` is ``b_0`` (rad) in the body frame; the seed's figure
    puts wheel A at 60 degrees, B at 180 degrees and C at 300 degrees (``b_0 = pi/3``).
    Refused: ``wheel_radius`` / ``center_distance`` not in ``(0, 1e6]``; a non-finite angle.
    """

    wheel_radius: float
    center_distance: float
    first_wheel_angle: float = math.pi / 3.0

    def __post_init__(self):
        for name in ("wheel_radius", "center_distance"):
            object.__setattr__(self, name, as_positive(getattr(self, name), name))
        object.__setattr__(self, "first_wheel_angle", as_real(self.first_wheel_angle, "first_wheel_angle"))

    @property
    def wheel_angles(self) -> np.ndarray:
        """Angles (rad) of the wheels around the centre: ``first_wheel_angle + 2 pi k / 3``, k = 0, 1, 2."""
        return self.first_wheel_angle + 2.0 * math.pi / 3.0 * np.arange(3)

    def wheel_positions(self, pose: ArrayLike = (0.0, 0.0, 0.0)) -> np.ndarray:
        """World positions ``(3, 2)`` of the wheel contact points at ``pose = (x, y, theta)`` (3 finite
        numbers with ``|x| <= 1e6``)."""
        x, y, th = as_vector(pose, 3, "pose").tolist()
        a = self.wheel_angles + th
        D = self.center_distance
        return np.stack([x + D * np.cos(a), y + D * np.sin(a)], axis=1)

    def jacobian(self, theta: float) -> np.ndarray:
        """``H(theta)`` (3x3) with ``phi = H(theta) [xdot, ydot, thetadot]`` (world-frame twist); ``theta``
        a finite number with ``|theta| <= 1e6``."""
        return self._jacobian(as_real(theta, "theta"))

    def _jacobian(self, theta: float) -> np.ndarray:
        """:meth:`jacobian` of a checked heading."""
        a = self.wheel_angles + theta
        R, D = self.wheel_radius, self.center_distance
        return -np.stack([-np.sin(a), np.cos(a), np.full(3, D)], axis=1) / R

    def wheel_speeds(self, twist: ArrayLike, theta: float) -> np.ndarray:
        """Inverse kinematics: wheel speeds (rad/s) for the world twist ``(xdot, ydot, thetadot)`` (or
        ``(N, 3)`` twists); refuses other shapes and non-finite or huge (``|x| > 1e6``) values."""
        t = _vectors(twist, "twist (xdot, ydot, thetadot)")
        return t @ self.jacobian(theta).T

    def twist(self, wheel_speeds: ArrayLike, theta: float) -> np.ndarray:
        """Forward kinematics: world twist ``(xdot, ydot, thetadot)`` from the wheel speeds (rad/s; 3 values
        or ``(N, 3)``); refuses other shapes and non-finite or huge (``|x| > 1e6``) values."""
        w = _vectors(wheel_speeds, "wheel_speeds")
        return np.linalg.solve(self.jacobian(theta), w.T).T

    def body_twist(self, wheel_speeds: ArrayLike) -> np.ndarray:
        """Twist in the body frame (heading 0): constant for constant wheel speeds."""
        return self.twist(wheel_speeds, 0.0)

    def simulate(self, wheel_speeds: ArrayLike | Callable[[float], ArrayLike], pose0: ArrayLike,
                 t_span: tuple[float, float], t_eval: ArrayLike | None = None, rtol: float = 1e-10,
                 atol: float = 1e-12) -> tuple[np.ndarray, np.ndarray]:
        """Integrate the pose ``(x, y, theta)`` under wheel speeds (3 values or a function of ``t``).

        Returns ``(t, poses (N, 3))`` from ``scipy.integrate.solve_ivp`` (RK45).

        Refused (:class:`InputError` and subclasses): wheel speeds (or a
        callable's value) not 3 finite numbers with ``|x| <= 1e6``; ``pose0`` not
        3 such numbers ``(x, y, theta)``; ``t_span`` not 2 distinct such times;
        ``t_eval`` not None or a 1-D array of 1 to 10**6 times within
        ``t_span``, strictly increasing (decreasing when ``t_span`` runs
        backwards); ``rtol`` not in ``(0, 1]``; ``atol`` not in ``(0, 1e6]``.
        A callable's own exceptions propagate unchanged.
        """
        f, p0, t_span, t_eval, rtol, atol = simulation_arguments(wheel_speeds, 3, pose0, t_span, t_eval,
                                                                 rtol, atol)

        H0_inv = np.linalg.inv(self._jacobian(0.0))  # H(theta) q = H(0) [Rot(-theta) v, thetadot]

        def rhs(t, s):
            bx, by, bw = (H0_inv @ f(t)).tolist()
            c, sn = math.cos(s[2]), math.sin(s[2])
            return [c * bx - sn * by, sn * bx + c * by, bw]

        sol = solve_ivp(rhs, t_span, p0, t_eval=t_eval, rtol=rtol, atol=atol)
        return sol.t, sol.y.T
