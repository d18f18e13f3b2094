"""Closed-form IK of planar chains: 2R / 3R / 4R arms (S1) and SCARA-type arms (S9).

Applies to every serial chain whose joints all turn about, or slide along,
the world ``z`` axis (axes parallel to ``+-z``). Such a chain is described
by its geometry at ``q = 0`` (read from the Pinocchio model, then verified
against its forward kinematics at random configurations):

* revolute joints ``i = 1..k`` with axis sign ``s_i`` (``theta_i = s_i q_i``
  is the rotation about ``+z``) and link vectors ``v_i`` (from axis ``i`` to
  axis ``i + 1``, the last one to the tool origin), length ``L_i``, angle
  ``phi_i`` at ``q = 0``;
* at most one prismatic joint along ``+-z`` (sign ``s_p``).

With ``Theta_i = theta_1 + ... + theta_i`` the link angles are
``psi_i = phi_i + Theta_i`` and

    p_xy = c_1 + sum_i L_i (cos psi_i, sin psi_i),   p_z = z_0 + s_p q_p,   R = Rz(Theta_k) R_0.

Revolute joints with ``L_i = 0`` after the last link are *wrist* joints: they
only turn the tool about ``z`` (a SCARA's ``theta4``). Supported shapes, with
``alpha`` the target yaw (``R* R_0^T = Rz(alpha)``):

* 2 links (+ at most one wrist): law of cosines on ``(x, y)`` - elbow
  ``beta = +-acos((|w|^2 - L1^2 - L2^2) / (2 L1 L2))``,
  ``psi_1 = atan2(w_y, w_x) - atan2(L2 sin beta, L1 + L2 cos beta)``; the wrist
  takes ``alpha - Theta_2``. SCARA (S9): ``theta1, theta2`` from the 2R
  solution, ``d3`` from the height, ``theta4`` from ``phi = theta1 + theta2 - theta4``.
* 3 links: the wrist point ``w = p - L3 (cos psi_3, sin psi_3)`` with
  ``psi_3 = phi_3 + alpha``, then 2R.
* 4 links (redundant: 3 task constraints, 4 joints): the solutions form a
  one-parameter family. The free parameter is ``q1``: for each ``q1`` the
  remaining 3R problem from the elbow ``c_2(q1)`` has two branches. ``q1`` is
  feasible when ``|w - c_2(q1)| in [|L2 - L3|, L2 + L3]``, i.e.
  ``cos(psi_1 - gamma) in [c_min, c_max]`` (``gamma = atan2(w)``) - one or two
  intervals computed in closed form; the family is sampled uniformly over
  them (both branches; they coincide at the interval ends, where the arm is
  stretched or folded).

Relaxed ``yaw`` frees the wrist joint (set to mid-range) on a chain with a
wrist; relaxed ``z`` frees the prismatic joint (mid-range). Other
relaxations are not handled in closed form (the solver reports
``supports() == False`` and ``ik.solve`` falls back to a numerical method).
All angles come from ``atan2``; joint values are shifted by multiples of
``2 pi`` into the joint limits, and every combination inside the limits is
returned.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import pinocchio as pin

from kinserve.kinematics import Robot
from kinserve.kinematics.serial_chain import OTHER, REVOLUTE, JointTable, joint_table
from kinserve.kinematics.types import VectorLike

#: One closed-form branch: ``(q, label, free parameter value or None)``.
Branch = tuple[np.ndarray, str, float | None]

_Z = np.array([0.0, 0.0, 1.0])
_TWO_PI = 2.0 * math.pi


def wrap_into(value: float, lower: float, upper: float, tol: float = 1e-9) -> list[float]:
    """Every ``value + 2 pi k`` inside ``[lower, upper]`` (revolute joints)."""
    k_lo = math.ceil((lower - tol - value) / _TWO_PI)
    k_hi = math.floor((upper + tol - value) / _TWO_PI)
    out = []
    for k in range(k_lo, k_hi + 1):
        v = value + k * _TWO_PI
        out.append(min(max(v, lower), upper))
    return out


def two_link(wx: float, wy: float, L1: float, L2: float) -> tuple[list[tuple[float, float, float]], bool]:
    """Both solutions ``(psi_1, psi_2, beta)`` of a 2R arm reaching ``(wx, wy)`` from its base.

    ``beta = psi_2 - psi_1`` is the elbow angle. Returns ``(solutions, reachable)``;
    out of reach, the single stretched / folded configuration pointing at the
    target is returned with ``reachable = False``.
    """
    r2 = wx * wx + wy * wy
    c = (r2 - L1 * L1 - L2 * L2) / (2.0 * L1 * L2)
    reachable = -1.0 - 1e-12 <= c <= 1.0 + 1e-12
    c = min(1.0, max(-1.0, c))
    gamma = math.atan2(wy, wx)
    sols = []
    betas = (math.acos(c), -math.acos(c)) if reachable and abs(c) < 1.0 else (math.acos(c),)
    for beta in betas:
        psi1 = gamma - math.atan2(L2 * math.sin(beta), L1 + L2 * math.cos(beta))
        sols.append((psi1, psi1 + beta, beta))
    return sols, reachable


def _joints_about_z(table: JointTable, data: pin.Data, rows: list[int]) -> tuple[list, list]:
    """``(revolute, prismatic)`` of the joints of ``table``'s ``rows`` (a path, root first) at ``q = 0``
    (``data`` holds its kinematics): ``(q index, sign, axis xy point)`` per revolute joint and ``(q index,
    sign)`` per prismatic joint, the sign that of the world axis along ``+-z``; ValueError when a joint is of
    another type or not along ``z``, or the chain has no revolute joint or more than one prismatic joint."""
    revolute, prismatic = [], []
    for r in rows:
        kind, iq = (int(x) for x in table.joints[r, :2])
        if kind == OTHER:
            raise ValueError("unsupported joint type")
        j = r + 1  # the row's Pinocchio joint
        aw = data.oMi[j].rotation @ table.geometry[r, 12:15]
        if abs(abs(aw[2]) - 1.0) > 1e-9:
            raise ValueError("joint axis not parallel to world z")
        sign = 1.0 if aw[2] > 0 else -1.0
        if kind == REVOLUTE:
            revolute.append((iq, sign, data.oMi[j].translation[:2].copy()))
        else:
            prismatic.append((iq, sign))
    if len(prismatic) > 1 or not revolute:
        raise ValueError("needs revolute joints and at most one prismatic joint")
    return revolute, prismatic


def _links(points: list[np.ndarray]) -> tuple[list[float], list[float]]:
    """``(L, phi)``: length and angle of each link vector between consecutive ``points`` (xy)."""
    L, phi = [], []
    for a, b in zip(points[:-1], points[1:]):
        v = b - a
        L.append(float(math.hypot(v[0], v[1])))
        phi.append(float(math.atan2(v[1], v[0])))
    return L, phi


def _shape(L: list[float], n_revolute: int) -> tuple[int, int]:
    """``(links, wrist joints)`` of a chain with link lengths ``L``; ValueError for a shape without a
    closed form here (module docstring)."""
    nz = [i for i, length in enumerate(L) if length > 1e-9]
    n_links = len(nz)
    if nz != list(range(n_links)):
        raise ValueError("zero-length link before the last link")
    n_wrist = n_revolute - n_links
    if n_links not in (2, 3, 4) or n_wrist > 1 or (n_links > 2 and n_wrist):
        raise ValueError("unsupported planar shape")
    return n_links, n_wrist


def _elbow(beta: float) -> str:
    """The label of a 2R branch of elbow angle ``beta``."""
    return "elbow up" if beta < 0 else "elbow down"


def _psi1_intervals(wp: np.ndarray, L1: float, dmin: float, dmax: float) -> list[tuple[float, float]] | None:
    """The feasible ``psi1`` of a 4-link chain with wrist point ``wp``: the intervals where the elbow
    ``c_2 = L1 (cos psi1, sin psi1)`` is ``[dmin, dmax]`` from ``wp`` (module docstring). None when the wrist
    point is on the first axis and out of reach; ``[]`` when it is out of reach elsewhere."""
    r = math.hypot(wp[0], wp[1])
    if r < 1e-12:
        return [(-math.pi, math.pi)] if dmin - 1e-12 <= L1 <= dmax + 1e-12 else None
    gamma = math.atan2(wp[1], wp[0])
    cmin = (r * r + L1 * L1 - dmax * dmax) / (2 * L1 * r)
    cmax = (r * r + L1 * L1 - dmin * dmin) / (2 * L1 * r)
    if cmin > 1.0 + 1e-12 or cmax < -1.0 - 1e-12:
        return []
    a_in = math.acos(max(-1.0, min(1.0, cmax))) if cmax < 1.0 else 0.0  # |psi1 - gamma| >= a_in
    a_out = math.acos(min(1.0, max(-1.0, cmin))) if cmin > -1.0 else math.pi  # |psi1 - gamma| <= a_out
    intervals = [(-a_out, a_out)] if a_in <= 1e-15 else [(-a_out, -a_in), (a_in, a_out)]
    return [(gamma + a, gamma + b) for a, b in intervals]


def _samples(q_int: list[tuple[float, float]], samples: int) -> list[float]:
    """About ``samples`` values spread uniformly over the intervals (at least both ends of each)."""
    total = sum(b - a for a, b in q_int)
    values = []
    for a, b in q_int:
        m = max(2, int(round(samples * (b - a) / total)) if total > 0 else 1)
        values.extend(np.linspace(a, b, m).tolist())
    return values


class PlanarChain:
    """Geometry of a chain of joints about / along world ``z`` (module docstring) and its closed-form IK."""

    name = "planar"

    def __init__(self, robot: Robot, frame: str) -> None:
        model = robot.model
        fid = robot.frame_id(frame)
        table = joint_table(model)
        rows = table.path_to(fid)
        if len(rows) != robot.nq:
            raise ValueError("frame does not depend on every joint")
        data = model.createData()
        q0 = np.zeros(model.nq)
        pin.forwardKinematics(model, data, q0)
        T0 = pin.updateFramePlacement(model, data, fid)
        self.robot = robot
        self.frame = frame
        self.revolute, self.prismatic = _joints_about_z(table, data, rows)
        self.R0 = T0.rotation.copy()  # any tool tilt is fine: R(q) = Rz(Theta) R0
        self.z0 = float(T0.translation[2])
        self.c1 = self.revolute[0][2]
        self.L, self.phi = _links([r[2] for r in self.revolute] + [T0.translation[:2].copy()])
        self.n_links, self.n_wrist = _shape(self.L, len(self.revolute))
        self.lower, self.upper = robot.lower, robot.upper
        self.finite = self.n_links < 4  #: finitely many branches (False: a one-parameter family)
        self._verify(robot, frame)

    # ------------------------------------------------------------------ model
    def fk(self, q: VectorLike) -> np.ndarray:
        """Tool pose (4x4) from the closed-form planar model (used to verify it against Pinocchio)."""
        Theta = 0.0
        p = self.c1.astype(float).copy()
        for i, (iq, s, _) in enumerate(self.revolute):
            Theta += s * q[iq]
            if i < self.n_links:
                psi = self.phi[i] + Theta
                p = p + self.L[i] * np.array([math.cos(psi), math.sin(psi)])
        z = self.z0 + sum(s * q[iq] for iq, s in self.prismatic)
        T = np.eye(4)
        T[:3, :3] = pin.rpy.rpyToMatrix(0.0, 0.0, Theta) @ self.R0
        T[:3, 3] = (p[0], p[1], z)
        return T

    def _verify(self, robot, frame):
        rng = np.random.default_rng(7)
        r = robot.copy()
        for q in r.random_q(rng, 5):
            if np.abs(r.fk(q, frame) - self.fk(q)).max() > 1e-8:
                raise ValueError("closed-form planar model does not match the robot's forward kinematics")

    # ------------------------------------------------------------------- task
    def supports(self, relaxed: tuple[int, ...]) -> bool:
        """Whether the relaxed components (indices into x y z roll pitch yaw) have a closed form here."""
        rel = set(relaxed)
        if rel - {2, 3, 4, 5}:
            return False  # x / y relaxed: a curve of solutions
        if 5 in rel and self.n_wrist == 0 and self.n_links > 2:
            return False  # 3R/4R with free yaw: a family, leave it to the numerical solvers
        return True

    def solve_all(self, T_target: np.ndarray, relaxed: Sequence[int] = (),
                  samples: int = 24) -> tuple[list[Branch], str, dict[str, Any]]:
        """``(branches, note, info)``: every branch ``(q, label, free_parameter)`` within the joint limits.

        ``note`` is empty when the target is reachable in closed form, else
        says why the returned configurations only approach it (out of reach,
        off the plane). ``free_parameter`` is ``q1`` for the 4-link family.
        """
        rel = set(relaxed)
        p = T_target[:3, 3]
        M = T_target[:3, :3] @ self.R0.T
        alpha = math.atan2(M[1, 0], M[0, 0])
        base = np.zeros(self.robot.nq)
        mid = 0.5 * (self.lower + self.upper)
        notes = self._height(p[2], rel, base, mid)
        w = np.array([p[0] - self.c1[0], p[1] - self.c1[1]])
        branches, reach_ok = self._link_angles(w, alpha, samples)
        if not reach_ok:
            notes.append("target out of reach (the returned configuration points at it, fully stretched or "
                         "folded)")
        out = []
        for psis, label, free in branches:
            for q in self._joint_values(psis, alpha, base, rel, mid):
                out.append((q, label, free))
        return out, "; ".join(notes), {}

    def _height(self, z: float, rel: set, base: np.ndarray, mid: np.ndarray) -> list[str]:
        """Set the prismatic joint of ``base`` for the target height ``z`` (mid-range when ``z`` is relaxed,
        clipped into its limits); the notes on a height it cannot reach (or off a plane without one)."""
        if not self.prismatic:
            if 2 not in rel and abs(z - self.z0) > 1e-9:
                return [f"target height z={z:.6g} is off the arm's plane z={self.z0:.6g}"]
            return []
        iq, s = self.prismatic[0]
        if 2 in rel:
            base[iq] = mid[iq]
            return []
        notes = []
        v = s * (z - self.z0)
        lo, hi = self.lower[iq], self.upper[iq]
        if v < lo - 1e-9 or v > hi + 1e-9:
            notes.append(f"height z={z:.6g} needs joint value {v:.6g} outside [{lo:.6g}, {hi:.6g}]")
        base[iq] = min(max(v, lo), hi)
        return notes

    def _link_angles(self, w: np.ndarray, alpha: float, samples: int) -> tuple[list, bool]:
        """``([(psis, label, free parameter), ...], reachable)``: the absolute link angles of every branch
        reaching ``w`` (relative to the first axis) with tool yaw ``alpha`` (module docstring)."""
        if self.n_links == 4:
            return self._four_link_family(w, alpha, samples)
        if self.n_links == 2:
            sols, reach_ok = two_link(w[0], w[1], self.L[0], self.L[1])
            return [([psi1, psi2], _elbow(beta), None) for psi1, psi2, beta in sols], reach_ok
        psi3 = self.phi[2] + alpha
        w3 = w - self.L[2] * np.array([math.cos(psi3), math.sin(psi3)])
        sols, reach_ok = two_link(w3[0], w3[1], self.L[0], self.L[1])
        return [([psi1, psi2, psi3], _elbow(beta), None) for psi1, psi2, beta in sols], reach_ok

    def _four_link_family(self, w, alpha, samples):
        """Sampled one-parameter family of a 4-link chain: [(psis, label, q1)], reachable."""
        L1, L2, L3, L4 = self.L
        psi4 = self.phi[3] + alpha
        wp = w - L4 * np.array([math.cos(psi4), math.sin(psi4)])  # wrist point relative to c1
        intervals = _psi1_intervals(wp, L1, abs(L2 - L3), L2 + L3)
        if intervals is None:
            return [], False
        if not intervals:
            return self._four_link_nearest(wp, alpha), False
        q_int = self._q1_intervals(intervals)
        if not q_int:
            return [], True
        s1 = self.revolute[0][1]
        out = []
        for q1 in _samples(q_int, samples):
            psi1 = self.phi[0] + s1 * q1
            c2 = L1 * np.array([math.cos(psi1), math.sin(psi1)])
            d = wp - c2
            sols, ok = two_link(d[0], d[1], L2, L3)
            if not ok:
                continue
            for psi2, psi3, beta in sols:
                out.append(([psi1, psi2, psi3, psi4], _elbow(beta), q1))
        return out, True

    def _q1_intervals(self, intervals: list[tuple[float, float]]) -> list[tuple[float, float]]:
        """``psi1`` intervals as ``q1 = s1 (psi1 - phi1)`` intervals, shifted by ``2 pi k`` and cut to the
        limits of ``q1``."""
        iq1, s1, _ = self.revolute[0]
        lo, hi = self.lower[iq1], self.upper[iq1]
        q_int = []
        for a, b in intervals:
            qa, qb = sorted((s1 * (a - self.phi[0]), s1 * (b - self.phi[0])))
            for k in range(-2, 3):
                lo_k, hi_k = max(qa + k * _TWO_PI, lo), min(qb + k * _TWO_PI, hi)
                if hi_k >= lo_k:
                    q_int.append((lo_k, hi_k))
        return q_int

    def _four_link_nearest(self, wp, alpha):
        """Out of reach: all links pointing at the target (psi1 = psi2 = psi3 = gamma)."""
        g = math.atan2(wp[1], wp[0])
        return [([g, g, g, self.phi[3] + alpha], "stretched", None)]

    def _joint_values(self, psis, alpha, base, rel, mid):
        """Joint vectors (all 2 pi shifts inside the limits) from absolute link angles."""
        thetas = []
        prev = 0.0
        for i, psi in enumerate(psis):
            Theta_i = psi - self.phi[i]
            thetas.append(Theta_i - prev)
            prev = Theta_i
        if self.n_wrist:
            thetas.append(None if 5 in rel else alpha - prev)
        choices = []
        for (iq, s, _), th in zip(self.revolute, thetas):
            if th is None:
                choices.append((iq, [mid[iq]]))
                continue
            vals = wrap_into(s * th, self.lower[iq], self.upper[iq])
            if not vals:
                return []
            choices.append((iq, vals))
        out = [base.copy()]
        for iq, vals in choices:
            nxt = []
            for q in out:
                for v in vals:
                    qq = q.copy()
                    qq[iq] = v
                    nxt.append(qq)
            out = nxt
        return out
