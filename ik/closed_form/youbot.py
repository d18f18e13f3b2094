"""Closed-form IK of the KUKA youBot 5-DOF arm by kinematic decoupling (S2).

Standard DH (``A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``), joint
variable ``theta_i = q_i``::

    a     = [-0.033, 0.155, 0.135, 0.002, 0.0]
    alpha = [pi/2,   0,     0,     pi/2,  pi ]
    d     = [0.145,  0,     0,     0,    -0.185]

Structure. Joint 1 turns the *arm plane* about the vertical: the plane
contains the base ``z`` axis, has the horizontal direction
``x1 = (c1, s1, 0)`` and the vertical ``up``, and normal ``n = z1 = (s1, -c1, 0)``.
Joints 2, 3, 4 turn about ``n``, so in plane coordinates ``(u, v)`` measured
from ``o1 = a1 x1 + d1 up`` and with ``Theta = theta2 + theta3 + theta4``:

    o3 = a2 (c2, s2) + a3 (c23, s23),   o4 = o3 + a4 (cos Theta, sin Theta),
    z5 = (-sin Theta, cos Theta)  (tool approach axis, in the plane),
    p  = o4 - d5 z5              (d5 < 0: the tool sits |d5| beyond the wrist),
    x5 = cos(theta5) x4 + sin(theta5) n.

Inverse (decoupling):

1. ``theta1 = atan2(p_y, p_x)``, and ``theta1 + pi`` ("reach over the back");
   on the base axis ``theta1`` comes from the approach axis instead.
2. A 5-DOF arm reaches only poses whose approach axis ``z5`` lies in the arm
   plane. Off that set the solver projects ``z5`` onto the plane and turns the
   target frame by the smallest rotation taking ``z5`` to its projection (axis
   ``z5 x zp``, angle ``asin |z5 . n|``). Every rotation whose ``z`` axis lies
   in the plane is at least that angle away from the target's, so this is the
   nearest reachable orientation (geodesic distance) at the target position:
   the nearest reachable pose,
   reported in the note and in ``Result.info["reached_pose"]``.
3. ``Theta = atan2(-z5.x1, z5.up)``; wrist point ``W = o4 = P + d5 z5``
   (``P`` the target in plane coordinates), then ``o3 = W - a4 (cos Theta, sin Theta)``.
4. Law of cosines: ``theta3 = +-acos((|o3|^2 - a2^2 - a3^2) / (2 a2 a3))``,
   ``theta2 = atan2(o3_v, o3_u) - atan2(a3 s3, a2 + a3 c3)``, ``theta4 = Theta - theta2 - theta3``.
5. ``theta5 = atan2(x5.n, x5.x4)``.

Up to four branches (front/back x elbow up/down); those inside the joint
limits are returned. The model is checked against the robot's own forward
kinematics (with a constant base transform) before the solver is used.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from kinserve.ik.closed_form.planar import two_link, wrap_into

if TYPE_CHECKING:  # annotations only
    from kinserve.kinematics.robot import Robot
    from kinserve.kinematics.types import VectorLike

#: ``(a, alpha, d)`` of the youBot arm (SCENARIOS.md, S2).
YOUBOT_DH = ((-0.033, math.pi / 2, 0.145), (0.155, 0.0, 0.0), (0.135, 0.0, 0.0), (0.002, math.pi / 2, 0.0),
             (0.0, math.pi, -0.185))


def _dh(a, alpha, d, theta):
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array([[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st], [0.0, sa, ca, d],
                     [0.0, 0.0, 0.0, 1.0]])


def _min_rotation(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Smallest rotation taking unit vector ``a`` to unit vector ``b`` (Rodrigues, axis ``a x b``)."""
    k = np.cross(a, b)
    s2 = float(k @ k)
    c = float(a @ b)
    if s2 < 1e-24:
        return np.eye(3)  # a == b (a == -b cannot occur: b is a's projection onto a plane)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + K + K @ K * ((1.0 - c) / s2)


def _length(d: float) -> str:
    """A distance in metres for a message: millimetres below 1 m."""
    return f"{1000 * d:.3g} mm" if d < 1.0 else f"{d:.3g} m"


class YouBotArm:
    """Closed-form solver of a chain with the youBot's DH structure (module docstring)."""

    name = "youbot"
    finite = True

    def __init__(self, robot: Robot, frame: str, dh: Sequence[Sequence[float]] = YOUBOT_DH) -> None:
        if robot.nq != 5:
            raise ValueError("the youBot solver needs 5 joints")
        self.dh = tuple(tuple(float(v) for v in row) for row in dh)
        (a1, al1, d1), (a2, al2, d2), (a3, al3, d3), (a4, al4, d4), (a5, al5, d5) = self.dh
        if not (abs(al1 - math.pi / 2) < 1e-12 and al2 == 0 and al3 == 0 and abs(al4 - math.pi / 2) < 1e-12
                and abs(al5 - math.pi) < 1e-12 and d2 == 0 and d3 == 0 and d4 == 0 and a5 == 0):
            raise ValueError("DH table does not have the youBot structure")
        self.a1, self.d1, self.a2, self.a3, self.a4, self.d5 = a1, d1, a2, a3, a4, d5
        self.robot = robot
        self.frame = frame
        self.lower, self.upper = robot.lower, robot.upper
        r = robot.copy()
        self.base = r.fk(np.zeros(5), frame) @ np.linalg.inv(self.dh_fk(np.zeros(5)))
        self.base_inv = np.linalg.inv(self.base)
        for q in r.random_q(np.random.default_rng(11), 5):
            if np.abs(r.fk(q, frame) - self.base @ self.dh_fk(q)).max() > 1e-8:
                raise ValueError("the robot does not match the youBot DH model")

    def dh_fk(self, q: VectorLike) -> np.ndarray:
        """``A_1(q_1) ... A_5(q_5)`` (base frame, 4x4)."""
        T = np.eye(4)
        for (a, alpha, d), th in zip(self.dh, q):
            T = T @ _dh(a, alpha, d, th)
        return T

    def fk(self, q: VectorLike) -> np.ndarray:
        """Tool pose in the world: ``base * A_1 ... A_5``."""
        return self.base @ self.dh_fk(q)

    def supports(self, relaxed: Sequence[int]) -> bool:
        """Only full-pose targets have a closed form here (relaxations leave a family of solutions)."""
        return not relaxed

    def solve_all(self, T_target: np.ndarray, relaxed: Sequence[int] = (),
                  samples: int = 0) -> tuple[list[tuple[np.ndarray, str, None, str]], str, dict[str, Any]]:
        """``(branches, note, info)``: every branch ``(q, label, None, note)`` within the limits.

        Each branch carries its own ``note``: empty when it reaches the target
        exactly; otherwise what it is instead - the nearest reachable pose (the
        target's approach axis is out of the arm plane), or, when the target is
        out of reach of that branch's side (front / back), the stretched or
        folded arm pointing at it, with how far short it stays. Branches come
        exact first, then by their residual (position error + orientation
        error of this model's FK, m + rad). ``note`` joins the distinct branch
        notes (for callers that want one line); ``info["reached_pose"]`` is the
        nearest reachable pose when the target is off the 5-DOF reachable set.
        """
        T = self.base_inv @ T_target
        p, R = T[:3, 3], T[:3, :3]
        z5, x5 = R[:, 2], R[:, 0]
        up = np.array([0.0, 0.0, 1.0])
        if math.hypot(p[0], p[1]) > 1e-9:
            t1 = math.atan2(p[1], p[0])
        elif math.hypot(z5[0], z5[1]) > 1e-9:
            t1 = math.atan2(z5[1], z5[0])
        else:
            t1 = 0.0
        out = []
        reached = None
        for side, th1 in (("front", t1), ("back", t1 + math.pi)):
            c1, s1 = math.cos(th1), math.sin(th1)
            x1 = np.array([c1, s1, 0.0])
            n = np.array([s1, -c1, 0.0])
            off = float(z5 @ n)
            zp = z5 - off * n
            nz = np.linalg.norm(zp)
            zp = up if nz < 1e-12 else zp / nz
            xp = _min_rotation(z5, zp) @ x5  # the whole frame turns by the smallest rotation z5 -> zp
            Theta = math.atan2(-float(zp @ x1), float(zp @ up))
            P = np.array([float(p @ x1) - self.a1, p[2] - self.d1])
            W = P + self.d5 * np.array([-math.sin(Theta), math.cos(Theta)])
            o3 = W - self.a4 * np.array([math.cos(Theta), math.sin(Theta)])
            sols, ok = two_link(o3[0], o3[1], self.a2, self.a3)
            note = self._branch_note(side, abs(off), ok, float(np.linalg.norm(o3)))
            x4 = math.cos(Theta) * x1 + math.sin(Theta) * up
            th5 = math.atan2(float(xp @ n), float(xp @ x4))
            if reached is None and side == "front" and abs(off) > 1e-9:
                reached = np.eye(4)
                reached[:3, :3] = np.column_stack([xp, np.cross(zp, xp), zp])
                reached[:3, 3] = p
                reached = self.base @ reached
            for th2, _, th3 in sols:
                th4 = Theta - th2 - th3
                label = f"{side}, elbow {'up' if th3 < 0 else 'down'}"
                out.extend((q, label, None, note) for q in self._in_limits((th1, th2, th3, th4, th5)))
        out.sort(key=lambda b: (bool(b[3]), self._residual(b[0], T)))
        info = {"reached_pose": reached} if reached is not None else {}
        return out, "; ".join(dict.fromkeys(b[3] for b in out if b[3])), info

    def _branch_note(self, side: str, off: float, reach_ok: bool, r: float) -> str:
        """What a ``side`` branch is when it does not reach the target ("" when it does).

        ``off = |z5 . n|``: the approach axis leaves the arm plane by ``asin(off)``;
        ``r``: distance of the wrist point from joint 2, reachable for
        ``|a2 - a3| <= r <= a2 + a3`` (otherwise the arm is stretched or folded
        towards it, and stays ``r - (a2 + a3)`` or ``|a2 - a3| - r`` short).
        """
        if reach_ok:
            short = ""
        elif r > self.a2 + self.a3:
            short = f"stretched arm pointing at it, {_length(r - self.a2 - self.a3)} short"
        else:
            short = f"folded arm pointing at it, {_length(abs(self.a2 - self.a3) - r)} short"
        if off > 1e-9:
            tilt = math.degrees(math.asin(min(1.0, off)))
            plane = (f"target pose is off the 5-DOF reachable set (approach axis {tilt:.3g} deg "
                     "out of the arm plane)")
            if reach_ok:
                return plane + "; this branch reaches the nearest reachable pose"
            return plane + f" and out of reach of the {side} branches: nearest reachable orientation, {short}"
        if not reach_ok:
            return f"target out of reach of the {side} branches: nearest reachable position, {short}"
        return ""

    def _residual(self, q, T_base: np.ndarray) -> float:
        """``|p(q) - p| + |angle of R(q)^T R|`` (m + rad) of this model's FK against base-frame ``T_base``."""
        A = self.dh_fk(q)
        c = (np.trace(A[:3, :3].T @ T_base[:3, :3]) - 1.0) / 2.0
        return float(np.linalg.norm(A[:3, 3] - T_base[:3, 3]) + math.acos(min(1.0, max(-1.0, c))))

    def _in_limits(self, thetas):
        """All joint vectors (2 pi shifts) of the angles inside the limits."""
        sets = []
        for i, th in enumerate(thetas):
            vals = wrap_into(math.remainder(th, 2 * math.pi), self.lower[i], self.upper[i])
            if not vals:
                return []
            sets.append(vals)
        out = [[]]
        for vals in sets:
            out = [o + [v] for o in out for v in vals]
        return [np.array(o) for o in out]
