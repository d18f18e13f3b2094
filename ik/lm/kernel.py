"""One Levenberg-Marquardt start, compiled (Numba) for serial chains.

The same iteration as :func:`ik.lm.solver._run_full_pose` (full pose) and
:func:`ik.lm.solver._run_relaxed` (relaxed components: the kept rows of the
world- or target-axis error of :mod:`ik.targets` with the world-aligned
Jacobian) - the LOCAL ``log6`` error, the damped step ``(J^T J + lambda I) dq = J^T e`` with
``lambda = DAMPING_GAIN |e|^2 + lambda_0``, the active-set projection on the
joint limits, the stall test - run as one compiled call instead of a dozen
Pinocchio / NumPy calls per iteration. The chain comes from
:func:`kinserve.kinematics.serial_chain.serial_chain` (the path of one-DoF
joints from the root to the frame, as arrays). Its pose and LOCAL Jacobian
(:func:`pose_and_jacobian`, checked against Pinocchio in the tests): with
``oMk`` the world placement of joint ``k`` after its motion
(``oMk = oM(k-1) * Mk * exp(axis * q_k)``, a rotation about the axis for a
revolute joint, a translation along it for a prismatic one) and
``oMf = oMn * Mf``, the column of joint ``k`` is

    revolute:   R_f^T [ z_k x (p_f - o_k) ; z_k ]
    prismatic:  R_f^T [ z_k ; 0 ]

with ``z_k`` the joint's world axis, ``o_k`` its world origin, ``p_f`` and
``R_f`` the frame's world position and rotation - Pinocchio's
``getFrameJacobian(..., LOCAL)`` restricted to the chain's columns (the
other columns are zero). The SE(3) logarithm is written out as

    w = log3(R),  theta = |w|:  w = theta / sin(theta) * vee(R - R^T) / 2
    v = V(w)^-1 t,  V^-1 = I - [w]x / 2 + (1 - (theta/2) cot(theta/2)) / theta^2 [w]x^2

(series below ``theta = 1e-4`` and, for the last coefficient, ``1e-2``; near ``theta = pi`` the axis is read off the
symmetric part ``(R + R^T) / 2 - cos(theta) I = (1 - cos(theta)) a a^T``).
The normal equations are solved by a Cholesky factorisation written out for
the chain's ``n x n`` matrix.

Everything the kernel calls is in this file, so that Numba's on-disk cache
(keyed by this file's time stamp) is never stale. This module imports Numba;
:mod:`ik.lm.solver` imports it on the first full-pose solve, not when
:mod:`kinserve.ik` is imported, and keeps its Python iteration when Numba is
missing or the chain has other joints. Units: metres and radians.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from kinserve.kinematics.serial_chain import REVOLUTE as _REVOLUTE

#: Status codes returned by the kernel.
CONVERGED, STALLED, ITERATION_LIMIT = 0, 1, 2
REASONS = ("converged", "stalled", "iteration limit")

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")
_t = numba.types
_IN1, _IN2 = (_t.Array(_t.float64, d, "C", readonly=True) for d in (1, 2))  # inputs: writable arrays convert
#: The one signature of :func:`run_start`, compiled (or loaded from the cache) when this module is imported.
_RUN_SIGNATURE = _t.UniTuple(_t.int64, 3)(
    _IN2, _t.Array(_t.int64, 2, "C", readonly=True), _IN1, _IN1, _IN1, _IN2,
    _t.boolean, _IN2, _t.Array(_t.int64, 1, "C", readonly=True),
    _t.float64, _t.float64, _t.float64, _t.float64, _t.float64, _t.int64, _t.int64,
    _t.float64[:, ::1], _t.float64[:, ::1],
)


@_jit
def pose_and_jacobian(geometry: np.ndarray, joints: np.ndarray, q: np.ndarray, R: np.ndarray, p: np.ndarray,
                      J: np.ndarray, local: bool = True) -> None:
    """World pose of the chain's frame into ``R`` (3x3) and ``p`` (3), its Jacobian into ``J`` (6 x n).

    ``J``'s column ``k`` belongs to the chain's joint ``k`` (``q`` index
    ``joints[k, 1]``); rows are linear (m/s per joint unit) then angular
    (rad/s per joint unit) velocity of the frame, in its own axes (LOCAL) or,
    with ``local=False``, in the world's axes at its origin (LOCAL_WORLD_ALIGNED).
    """
    n = joints.shape[0]
    # running world placement (Rw, pw); joint world axes z and origins o, kept for the Jacobian
    Rw = np.eye(3)
    pw = np.zeros(3)
    z = np.empty((n, 3))
    o = np.empty((n, 3))
    T = np.empty((3, 3))
    for k in range(n):
        g = geometry[k]
        # pw += Rw @ t_k ; Rw = Rw @ R_k
        for i in range(3):
            pw[i] += Rw[i, 0] * g[9] + Rw[i, 1] * g[10] + Rw[i, 2] * g[11]
        for i in range(3):
            for c in range(3):
                T[i, c] = Rw[i, 0] * g[c] + Rw[i, 1] * g[3 + c] + Rw[i, 2] * g[6 + c]
        ax, ay, az = g[12], g[13], g[14]
        for i in range(3):
            z[k, i] = T[i, 0] * ax + T[i, 1] * ay + T[i, 2] * az
        qk = q[joints[k, 1]]
        if joints[k, 0] == _REVOLUTE:
            # Rw = T @ Rot(a, qk), Rodrigues: I + s [a]x + (1 - c) [a]x^2
            s, c = math.sin(qk), math.cos(qk)
            v = 1.0 - c
            r00, r01, r02 = c + v * ax * ax, v * ax * ay - s * az, v * ax * az + s * ay
            r10, r11, r12 = v * ax * ay + s * az, c + v * ay * ay, v * ay * az - s * ax
            r20, r21, r22 = v * ax * az - s * ay, v * ay * az + s * ax, c + v * az * az
            for i in range(3):
                t0, t1, t2 = T[i, 0], T[i, 1], T[i, 2]
                Rw[i, 0] = t0 * r00 + t1 * r10 + t2 * r20
                Rw[i, 1] = t0 * r01 + t1 * r11 + t2 * r21
                Rw[i, 2] = t0 * r02 + t1 * r12 + t2 * r22
        else:
            for i in range(3):
                pw[i] += z[k, i] * qk
                for c in range(3):
                    Rw[i, c] = T[i, c]
        for i in range(3):
            o[k, i] = pw[i]
    g = geometry[n]
    for i in range(3):
        p[i] = pw[i] + Rw[i, 0] * g[9] + Rw[i, 1] * g[10] + Rw[i, 2] * g[11]
        for c in range(3):
            R[i, c] = Rw[i, 0] * g[c] + Rw[i, 1] * g[3 + c] + Rw[i, 2] * g[6 + c]
    for k in range(n):
        zx, zy, zz = z[k, 0], z[k, 1], z[k, 2]
        if joints[k, 0] == _REVOLUTE:
            dx, dy, dz = p[0] - o[k, 0], p[1] - o[k, 1], p[2] - o[k, 2]
            vx, vy, vz = zy * dz - zz * dy, zz * dx - zx * dz, zx * dy - zy * dx
            wx, wy, wz = zx, zy, zz
        else:
            vx, vy, vz = zx, zy, zz
            wx = wy = wz = 0.0
        if local:
            for i in range(3):  # R_f^T applied to both halves
                J[i, k] = R[0, i] * vx + R[1, i] * vy + R[2, i] * vz
                J[3 + i, k] = R[0, i] * wx + R[1, i] * wy + R[2, i] * wz
        else:
            J[0, k], J[1, k], J[2, k], J[3, k], J[4, k], J[5, k] = vx, vy, vz, wx, wy, wz



@_jit
def _log3(Re, w) -> float:
    """``w = log3(Re)`` (rotation vector, module docstring); returns the angle ``|w|``."""
    c = 0.5 * (Re[0, 0] + Re[1, 1] + Re[2, 2] - 1.0)
    c = min(1.0, max(-1.0, c))
    sx, sy, sz = 0.5 * (Re[2, 1] - Re[1, 2]), 0.5 * (Re[0, 2] - Re[2, 0]), 0.5 * (Re[1, 0] - Re[0, 1])
    s = math.sqrt(sx * sx + sy * sy + sz * sz)
    theta = math.atan2(s, c)
    if theta < 1e-4:
        f = 1.0 + theta * theta / 6.0
        wx, wy, wz = f * sx, f * sy, f * sz
    elif theta > math.pi - 1e-3:
        # axis from the symmetric part (1 - c) a a^T, largest diagonal entry first; sign from vee(R - R^T)
        d = 1.0 - c
        k = 0
        if Re[1, 1] > Re[k, k]:
            k = 1
        if Re[2, 2] > Re[k, k]:
            k = 2
        ak = math.sqrt(max((Re[k, k] - c) / d, 0.0))
        a = np.empty(3)
        for i in range(3):
            a[i] = 0.5 * (Re[i, k] + Re[k, i]) / (d * ak) if i != k else ak
        if a[0] * sx + a[1] * sy + a[2] * sz < 0.0:
            a = -a
        wx, wy, wz = theta * a[0], theta * a[1], theta * a[2]
    else:
        f = theta / s
        wx, wy, wz = f * sx, f * sy, f * sz
    w[0], w[1], w[2] = wx, wy, wz
    return theta


@_jit
def _log6(Rf, pf, Rd, pd, e):
    """``e = [v; w] = log6(oMf^-1 oMd)``; returns ``|t|^2`` (``t = R_f^T (p_d - p_f)``)."""
    Re = np.empty((3, 3))
    for i in range(3):
        for c in range(3):
            Re[i, c] = Rf[0, i] * Rd[0, c] + Rf[1, i] * Rd[1, c] + Rf[2, i] * Rd[2, c]
    dx, dy, dz = pd[0] - pf[0], pd[1] - pf[1], pd[2] - pf[2]
    tx = Rf[0, 0] * dx + Rf[1, 0] * dy + Rf[2, 0] * dz
    ty = Rf[0, 1] * dx + Rf[1, 1] * dy + Rf[2, 1] * dz
    tz = Rf[0, 2] * dx + Rf[1, 2] * dy + Rf[2, 2] * dz
    w = np.empty(3)
    theta = _log3(Re, w)
    wx, wy, wz = w[0], w[1], w[2]
    t2 = theta * theta
    if theta < 1e-2:  # series of (1 - x cot x) / theta^2, x = theta / 2: no cancellation
        b = 1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0
    else:
        h = 0.5 * theta
        b = (1.0 - h * math.cos(h) / math.sin(h)) / t2
    # v = t - [w]x t / 2 + b [w]x^2 t ; [w]x t = w x t, [w]x^2 t = w x (w x t)
    cx, cy, cz = wy * tz - wz * ty, wz * tx - wx * tz, wx * ty - wy * tx
    ccx, ccy, ccz = wy * cz - wz * cy, wz * cx - wx * cz, wx * cy - wy * cx
    e[0] = tx - 0.5 * cx + b * ccx
    e[1] = ty - 0.5 * cy + b * ccy
    e[2] = tz - 0.5 * cz + b * ccz
    e[3], e[4], e[5] = wx, wy, wz
    return tx * tx + ty * ty + tz * tz


@_jit
def _solve_damped(J, r, lam, free, x, A):
    """``x = (Jf^T Jf + lam I)^-1 Jf^T r`` with ``Jf = J * free`` (columns of fixed joints zeroed); Cholesky."""
    n = J.shape[1]
    for a in range(n):
        for b in range(a + 1):
            s = 0.0
            if free[a] and free[b]:
                for i in range(J.shape[0]):
                    s += J[i, a] * J[i, b]
            A[a, b] = s
        A[a, a] += lam
        s = 0.0
        if free[a]:
            for i in range(J.shape[0]):
                s += J[i, a] * r[i]
        x[a] = s
    for a in range(n):  # A = L L^T in the lower triangle
        for b in range(a):
            s = A[a, b]
            for c in range(b):
                s -= A[a, c] * A[b, c]
            A[a, b] = s / A[b, b]
        s = A[a, a]
        for c in range(a):
            s -= A[a, c] * A[a, c]
        A[a, a] = math.sqrt(s)
    for a in range(n):  # L y = b
        s = x[a]
        for c in range(a):
            s -= A[a, c] * x[c]
        x[a] = s / A[a, a]
    for a in range(n - 1, -1, -1):  # L^T x = y
        s = x[a]
        for c in range(a + 1, n):
            s -= A[c, a] * x[c]
        x[a] = s / A[a, a]


@_jit
def _relaxed_error(R, p, Rd, pd, Aw, kept, J, Jt, e) -> tuple[float, float]:
    """The kept rows of ``e6 = [A^T (p* - p); A^T log3(R* R^T)]`` into ``e`` and of ``blockdiag(A^T, A^T) J``
    (``J`` world-aligned) into ``Jt``; returns the squared position and orientation errors (kept rows)."""
    M = np.empty((3, 3))
    for a in range(3):
        for b in range(3):
            M[a, b] = Rd[a, 0] * R[b, 0] + Rd[a, 1] * R[b, 1] + Rd[a, 2] * R[b, 2]
    w = np.empty(3)
    _log3(M, w)
    e6 = np.empty(6)
    for a in range(3):
        e6[a] = Aw[0, a] * (pd[0] - p[0]) + Aw[1, a] * (pd[1] - p[1]) + Aw[2, a] * (pd[2] - p[2])
        e6[3 + a] = Aw[0, a] * w[0] + Aw[1, a] * w[1] + Aw[2, a] * w[2]
    pe2 = re2 = 0.0
    n = J.shape[1]
    for r in range(kept.shape[0]):
        i = kept[r]
        e[r] = e6[i]
        if i < 3:
            pe2 += e6[i] * e6[i]
        else:
            re2 += e6[i] * e6[i]
        base, a = (0, i) if i < 3 else (3, i - 3)
        for k in range(n):
            Jt[r, k] = Aw[0, a] * J[base, k] + Aw[1, a] * J[base + 1, k] + Aw[2, a] * J[base + 2, k]
    return pe2, re2


@numba.njit(_RUN_SIGNATURE, cache=True, nogil=True, error_model="numpy")
def run_start(geometry: np.ndarray, joints: np.ndarray, q0: np.ndarray, lo: np.ndarray, hi: np.ndarray,
              Td: np.ndarray, relaxed: bool, Aw: np.ndarray, kept: np.ndarray, tp2: float, tr2: float, lam0: float,
              gain: float, stall_ratio: float, patience: int, max_iter: int, qs: np.ndarray,
              errs: np.ndarray) -> tuple[int, int, int]:
    """One start from ``q0`` on the target pose ``Td`` (4x4): returns ``(status, iterations, rows)``.

    Full pose (``relaxed`` False): the LOCAL ``log6`` error and Jacobian, errors ``(|t|^2, |w|^2)`` of
    ``oMf^-1 oMd``. Relaxed: the kept rows ``kept`` of the world- or target-axis error of
    :mod:`ik.targets` (axes ``Aw``: the identity or the target rotation) and of the world-aligned
    Jacobian, errors the squared norms of the kept position and rotation rows.
    ``qs[:rows]`` are the evaluated configurations (``qs[0] = q0``), ``errs[:rows]`` their squared errors.
    """
    n = joints.shape[0]
    nq = q0.shape[0]
    m = kept.shape[0] if relaxed else 6
    Rd = Td[:3, :3]
    pd = Td[:3, 3]
    R = np.empty((3, 3))
    p = np.empty(3)
    J = np.empty((6, n))
    Jt = J if not relaxed else np.empty((m, n))
    e = np.empty(6)
    r = np.empty(m)
    x = np.empty(n)
    A = np.empty((n, n))
    free = np.ones(n, dtype=np.bool_)
    qk = np.empty(n)
    lok = np.empty(n)
    hik = np.empty(n)
    for k in range(n):
        j = joints[k, 1]
        lok[k] = lo[j]
        hik[k] = hi[j]
    q = qs[0]
    for i in range(nq):
        q[i] = q0[i]
    best = math.inf
    stalls = 0
    for it in range(max_iter + 1):  # the last pass only evaluates the final configuration
        q = qs[it]
        pose_and_jacobian(geometry, joints, q, R, p, J, not relaxed)
        if relaxed:
            pe2, re2 = _relaxed_error(R, p, Rd, pd, Aw, kept, J, Jt, e)
            E = pe2 + re2
        else:
            pe2 = _log6(R, p, Rd, pd, e)
            re2 = e[3] * e[3] + e[4] * e[4] + e[5] * e[5]
            E = e[0] * e[0] + e[1] * e[1] + e[2] * e[2] + re2
        errs[it, 0] = pe2
        errs[it, 1] = re2
        if pe2 < tp2 and re2 < tr2:
            return CONVERGED, it, it + 1
        if it == max_iter:
            break
        if E < stall_ratio * best:
            best = E
            stalls = 0
        else:
            stalls += 1
            if stalls >= patience:
                return STALLED, it + 1, it + 1
        lam = gain * E + lam0
        for k in range(n):
            qk[k] = q[joints[k, 1]]
            free[k] = True
        # free step, then at most three re-solves with the joints that left their range fixed at the bound
        for i in range(m):
            r[i] = e[i]
        qn = qs[it + 1]
        for i in range(nq):
            qn[i] = q[i]
        for attempt in range(4):
            _solve_damped(Jt, r, lam, free, x, A)
            inside = True
            for k in range(n):
                if free[k]:
                    v = qk[k] + x[k]
                    if v < lok[k] or v > hik[k]:
                        inside = False
                    qn[joints[k, 1]] = v
            if inside:
                break
            if attempt == 3:  # still out after three re-solves: clip
                for k in range(n):
                    j = joints[k, 1]
                    qn[j] = min(max(qn[j], lok[k]), hik[k])
                break
            # fix the joints now out at their bound; r = e - J dfix over all fixed joints
            for k in range(n):
                j = joints[k, 1]
                if free[k] and (qn[j] < lok[k] or qn[j] > hik[k]):
                    free[k] = False
                    qn[j] = min(max(qn[j], lok[k]), hik[k])
            for i in range(m):
                s = e[i]
                for k in range(n):
                    if not free[k]:
                        s -= Jt[i, k] * (qn[joints[k, 1]] - qk[k])
                r[i] = s
    return ITERATION_LIMIT, max_iter, max_iter + 1
