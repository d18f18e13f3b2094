"""Levenberg-Marquardt compiled (Numba) for serial chains: one start (:func:`run_start`), many targets
(:func:`run_many`) - the one compiled LM iteration (:func:`_iterate`) of ``ik.solve`` (:mod:`ik.lm.solver`),
``ik.solve_many`` (:mod:`ik.lm.many`) and the service; :func:`ik.lm.solver.python_start` is the same
iteration with Pinocchio's algorithms, for chains this kernel does not model.

* Full pose: the LOCAL error ``e = log6(oMf^-1 oMd)`` and Jacobian; errors ``(|t|^2, |w|^2)`` of
  ``oMf^-1 oMd = (R_e, t)``, ``w = log3(R_e)``. Relaxed: the kept rows of ``e6 = [A^T (p* - p);
  A^T log3(R* R^T)]`` (:mod:`ik.targets`; ``A`` the identity or the target rotation) and of
  ``blockdiag(A^T, A^T) J`` (``J`` world-aligned).
* The damped step ``(J^T J + lambda I) dq = J^T e``, ``lambda = gain |e|^2 + lambda_0`` (Cholesky written out
  for the chain's ``n x n`` matrix); a joint the step takes out of its range is fixed at its bound, its
  motion removed from the residual (``e <- e - J_fixed dq_fixed``) and the step re-solved over the others,
  at most three times, then clipped. A start ends when both squared errors are below their tolerances, when
  ``|e|^2`` has not fallen below ``stall_ratio`` times its best for ``patience`` iterations in a row
  (stalled), or after ``max_iter`` steps.

The chain: :func:`kinserve.kinematics.serial_chain.serial_chain`'s arrays. With ``oMk = oM(k-1) Mk
exp(axis q_k)`` and ``oMf = oMn Mf``, the LOCAL Jacobian column of joint ``k`` is ``R_f^T [z_k x (p_f - o_k);
z_k]`` (revolute) or ``R_f^T [z_k; 0]`` (prismatic), ``z_k`` its world axis, ``o_k`` its world origin. The
SE(3) logarithm: ``w = log3(R) = theta / sin(theta) vee(R - R^T) / 2``, ``v = V(w)^-1 t`` with
``V^-1 = I - [w]x / 2 + (1 - (theta/2) cot(theta/2)) / theta^2 [w]x^2`` (series below ``theta = 1e-4`` and,
for the last coefficient, ``1e-2``; near ``theta = pi`` the axis from ``(R + R^T) / 2 - cos(theta) I =
(1 - cos(theta)) a a^T``).

Joint rotations: :func:`kinserve.kinematics.kernel_primitives.axis_rotation` (inlined); one cache key covers
every kernel file (``jit``/``inline`` of :mod:`kinserve.kinematics.kernel_cache`). Metres, radians."""

from __future__ import annotations

import math

import numba
import numpy as np

from kinserve.ik.lm import status as _status
from kinserve.kinematics.kernel_cache import F1, F2, F3, I1, I2, compiled, inline, jit
from kinserve.kinematics.kernel_primitives import axis_rotation
from kinserve.kinematics.serial_chain import REVOLUTE as _REVOLUTE

#: Entries of :func:`run_many`'s ``params`` (floats) ...
TP2, TR2, LAMBDA0, GAIN, STALL_RATIO, ROTATION_SCALE = range(6)
#: ... and of its ``limits`` (integers; ``MAX_STARTS`` / ``BUDGET`` negative: none). ``Q0_MODE``: 0 no
#: ``q0``, 1 ``q0`` first, 2 ``q0`` ranked among the table's samples by its pose distance.
PATIENCE, MAX_ITER, MAX_STARTS, BUDGET, Q0_MODE, N_TABLE, N_FULL, ROTATION = range(8)

_t = numba.types
_OUT2 = _t.float64[:, ::1]
#: The signatures of :func:`run_start` and :func:`run_many`, compiled (or loaded from the cache) on import.
_RUN_SIGNATURE = _t.UniTuple(_t.int64, 3)(F2, I2, F1, F1, F1, F2, _t.boolean, F2, I1,
                                          *(_t.float64,) * 5, _t.int64, _t.int64, _OUT2, _OUT2)
_MANY_SIGNATURE = _t.void(F2, I2, F1, F1, F3, _t.boolean, _t.boolean, I1, F1, I1,
                          *(F2,) * 6, _OUT2, _OUT2, _t.int64[:, ::1])


@inline
def pose_and_jacobian(geometry: np.ndarray, joints: np.ndarray, q: np.ndarray, R: np.ndarray, p: np.ndarray,
                      J: np.ndarray, local: bool = True) -> None:
    """World pose of the chain's frame into ``R`` (3x3) and ``p`` (3), its Jacobian into ``J`` (6 x n):
    column ``k`` for the chain's joint ``k`` (``q`` index ``joints[k, 1]``), rows linear (m/s per joint unit)
    then angular (rad/s per joint unit) velocity of the frame, in its own axes (LOCAL) or, with
    ``local=False``, in the world's axes at its origin (LOCAL_WORLD_ALIGNED).

    The forward pass: row ``k`` of ``geometry`` places joint ``k`` after the running world placement
    ``(Rw, pw)`` (``pw += Rw t_k``, ``T = Rw R_k``), which the joint then moves by ``Rot(a_k, q)``
    (:func:`kinserve.kinematics.kernel_primitives.axis_rotation`) or ``a_k q``; row ``n`` places the frame.
    Written in one function: an inlined helper taking arrays costs reference counting on every call
    (measured: 5 % of an LM start with the forward pass in a helper)."""
    n = joints.shape[0]
    Rw, pw, T = np.eye(3), np.zeros(3), np.empty((3, 3))
    z, o = np.empty((n, 3)), np.empty((n, 3))  # joint k's world axis and origin
    for k in range(n):
        g = geometry[k]
        for i in range(3):
            pw[i] += Rw[i, 0] * g[9] + Rw[i, 1] * g[10] + Rw[i, 2] * g[11]
            for c in range(3):
                T[i, c] = Rw[i, 0] * g[c] + Rw[i, 1] * g[3 + c] + Rw[i, 2] * g[6 + c]
        ax, ay, az = g[12], g[13], g[14]
        for i in range(3):
            z[k, i] = T[i, 0] * ax + T[i, 1] * ay + T[i, 2] * az
        qk = q[joints[k, 1]]
        if joints[k, 0] == _REVOLUTE:
            r00, r01, r02, r10, r11, r12, r20, r21, r22 = axis_rotation(ax, ay, az, qk)
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
        o[k, 0], o[k, 1], o[k, 2] = pw[0], pw[1], pw[2]
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


@jit
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
        k = 0 if Re[0, 0] >= Re[1, 1] else 1
        k = 2 if Re[2, 2] > Re[k, k] else k
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


@jit
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


@jit
def _solve_damped(J, r, lam, free, x, A):
    """``x = (Jf^T Jf + lam I)^-1 Jf^T r``, ``Jf = J * free`` (fixed joints' columns zeroed); Cholesky."""
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


@jit
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


@inline
def _fix_out(Jt, e, qn, joints, lok, hik, m, free, r, qk, last) -> bool:
    """After a step that left the limits: fixes the free joints now out of range at their bound (the fixed
    ones already are, so every joint is then in range). ``last`` (the third re-solve): returns True, the step
    stays clipped; otherwise sets ``r = e - J dfix`` over every fixed joint and returns False (re-solve)."""
    n = joints.shape[0]
    for k in range(n):
        j = joints[k, 1]
        if free[k] and not lok[k] <= qn[j] <= hik[k]:
            free[k] = False
            qn[j] = min(max(qn[j], lok[k]), hik[k])
    if last:
        return True
    for i in range(m):
        s = e[i]
        for k in range(n):
            if not free[k]:
                s -= Jt[i, k] * (qn[joints[k, 1]] - qk[k])
        r[i] = s
    return False


@inline
def _chain_bounds(joints, lo, hi) -> tuple[np.ndarray, np.ndarray]:
    """The limits of the chain's joints in chain order: ``lo[joints[k, 1]]``, ``hi[joints[k, 1]]``."""
    n = joints.shape[0]
    lok, hik = np.empty(n), np.empty(n)
    for k in range(n):
        lok[k], hik[k] = lo[joints[k, 1]], hi[joints[k, 1]]
    return lok, hik


@inline
def _iterate(geometry, joints, q0, lo, hi, Rd, pd, relaxed, Aw, kept, tp2, tr2, lam0, gain, stall_ratio,
             patience, max_iter, qs, errs) -> tuple[int, int, int]:
    """One start from ``q0`` on the target ``(Rd, pd)`` (module docstring): ``(status, iterations, rows)``;
    ``qs[:rows]`` its configurations (``qs[0] = q0``), ``errs[:rows]`` their squared errors."""
    n = joints.shape[0]
    m = kept.shape[0] if relaxed else 6
    R, p, J, e = np.empty((3, 3)), np.empty(3), np.empty((6, n)), np.empty(6)
    Jt = J if not relaxed else np.empty((m, n))
    r, x, A, free, qk = np.empty(m), np.empty(n), np.empty((n, n)), np.ones(n, dtype=np.bool_), np.empty(n)
    lok, hik = _chain_bounds(joints, lo, hi)
    qs[0, :] = q0
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
            return _status.CONVERGED, it, it + 1
        if it == max_iter:
            break
        stalls = 0 if E < stall_ratio * best else stalls + 1  # (|e|^2 below its best by the ratio: progress)
        best = E if stalls == 0 else best
        if stalls >= patience:
            return _status.STALLED, it + 1, it + 1
        # the damped step within the limits, written here: an inlined helper taking these arrays costs
        # reference counting on every iteration (its fixing of joints out of range, rarely run, is _fix_out)
        lam = gain * E + lam0
        for k in range(n):
            qk[k] = q[joints[k, 1]]
            free[k] = True
        for i in range(m):
            r[i] = e[i]
        qn = qs[it + 1]
        for i in range(q.shape[0]):
            qn[i] = q[i]
        for attempt in range(4):  # the free step, then at most three re-solves
            _solve_damped(Jt, r, lam, free, x, A)
            inside = True
            for k in range(n):
                if free[k]:
                    v = qk[k] + x[k]
                    if not lok[k] <= v <= hik[k]:
                        inside = False
                    qn[joints[k, 1]] = v
            if inside:
                break
            if _fix_out(Jt, e, qn, joints, lok, hik, m, free, r, qk, attempt == 3):
                break
    return _status.ITERATION_LIMIT, max_iter, max_iter + 1


@compiled(_RUN_SIGNATURE)
def run_start(geometry: np.ndarray, joints: np.ndarray, q0: np.ndarray, lo: np.ndarray, hi: np.ndarray,
              Td: np.ndarray, relaxed: bool, Aw: np.ndarray, kept: np.ndarray, tp2: float, tr2: float,
              lam0: float, gain: float, stall_ratio: float, patience: int, max_iter: int, qs: np.ndarray,
              errs: np.ndarray) -> tuple[int, int, int]:
    """One start from ``q0`` on the target pose ``Td`` (4x4): ``(status, iterations, rows)``; ``relaxed``:
    the kept rows ``kept`` in the axes ``Aw`` (module docstring). ``qs[:rows]``: the configurations
    (``qs[0] = q0``), ``errs[:rows]`` their squared errors (``max_iter + 1`` rows each)."""
    return _iterate(geometry, joints, q0, lo, hi, Td[:3, :3], Td[:3, 3], relaxed, Aw, kept, tp2, tr2, lam0,
                    gain, stall_ratio, patience, max_iter, qs, errs)


@jit
def _scores(Gt, f, S) -> None:
    """``S_j = sum_c Gt[c, j] f[c]``: a seed table's ``D_j - |f*|^2`` (``Gt`` its ``G`` transposed)."""
    S[:] = 0.0
    for c in range(Gt.shape[0]):
        fc = f[c]
        for j in range(Gt.shape[1]):
            S[j] += Gt[c, j] * fc


@jit
def _next_start(st, q, q0, D0, f, tables, S, limits) -> bool:
    """The next start of :func:`ik.starts.seed_table.start_sequence` into ``q``; False when none is left.

    ``st = [stage, taken, q0 pending (a Q0_MODE)]``; stages: 0 ``q0`` first, 1 the nearest interior
    samples (``q0`` before the first one farther than its distance ``D0``), 2 ``q0`` if still pending,
    3 the nearest full-range samples, 4 the random configurations, 5 none left. ``tables`` =
    ``(G^T interior, Q interior, G^T full, Q full, random starts)``; ``S`` the two score buffers.
    """
    table_Gt, table_Q, full_Gt, full_Q, randoms = tables
    while True:
        stage = st[0]
        if stage == 0 or stage == 2:
            st[0] += 1
            _scores(table_Gt if stage == 0 else full_Gt, f, S[0] if stage == 0 else S[1])
            if st[2] == 1 or (stage == 2 and st[2] == 2):
                st[2] = 0
                q[:] = q0
                return True
        elif stage == 1 or stage == 3:
            if st[1] < limits[N_TABLE if stage == 1 else N_FULL]:
                Sx = S[0] if stage == 1 else S[1]
                j = np.argmin(Sx)  # the first sample of least score
                if stage == 1 and st[2] == 2 and D0 <= Sx[j] + f[13]:
                    st[2] = 0
                    q[:] = q0
                else:
                    q[:] = (table_Q if stage == 1 else full_Q)[j]
                    Sx[j] = math.inf
                    st[1] += 1
                return True
            st[0] += 1
            st[1] = 0
        elif stage == 4 and st[1] < randoms.shape[0]:
            q[:] = randoms[st[1]]
            st[1] += 1
            return True
        else:
            return False


@jit
def _features(Td, scale, rotation, f) -> None:
    """``f[:13]``: the seed-table feature ``[p, scale vec(R), 1]`` of ``Td`` (rotation part 0 without
    ``rotation``); ``f[13] = |f[:12]|^2``."""
    for i in range(3):
        f[i] = Td[i, 3]
        for c in range(3):
            f[3 + 3 * i + c] = Td[i, c] * scale if rotation else 0.0
    f[12] = 1.0
    f[13] = (f[:12] * f[:12]).sum()


@jit
def _q0_distance(geometry, joints, q0, f, scale) -> float:
    """Pose distance ``D`` (m^2) of the frame at ``q0`` (its full feature) from the target feature ``f``."""
    n = joints.shape[0]
    R, p = np.empty((3, 3)), np.empty(3)
    pose_and_jacobian(geometry, joints, q0, R, p, np.empty((6, n)))  # (the frame's pose only is read)
    D = 0.0
    for i in range(3):
        D += (p[i] - f[i]) ** 2
        for c in range(3):
            D += (R[i, c] * scale - f[3 + 3 * i + c]) ** 2
    return D


@jit
def _solve_target(geometry, joints, lo, hi, Td, relaxed, Aw, kept, params, limits, starts, qs, errs, q_out,
                  err_out) -> tuple[int, int, int]:
    """Starts from ``starts = (st, q, q0, D0, f, tables, S)`` (:func:`_next_start`) until one converges or a
    limit is met: ``(status, iterations, starts)``; the answer (the converged iterate, else the first iterate
    of least ``|t|^2 + |w|^2`` over every start) into ``q_out``, its squared errors into ``err_out``."""
    st, q, q0, D0, f, tables, S = starts
    budget, max_starts, max_iter = limits[BUDGET], limits[MAX_STARTS], limits[MAX_ITER]
    best = math.inf
    used = n = 0
    while _next_start(st, q, q0, D0, f, tables, S, limits):
        cap = max_iter if budget < 0 else min(max_iter, budget - used)
        status, it, k = _iterate(geometry, joints, q, lo, hi, Td[:3, :3], Td[:3, 3], relaxed, Aw, kept,
                                 params[TP2], params[TR2], params[LAMBDA0], params[GAIN], params[STALL_RATIO],
                                 limits[PATIENCE], cap, qs, errs)
        used += it
        n += 1
        for r in range(k - 1 if status == _status.CONVERGED else 0, k):
            if status == _status.CONVERGED or errs[r, 0] + errs[r, 1] < best:
                best = errs[r, 0] + errs[r, 1]
                q_out[:] = qs[r]
                err_out[:] = errs[r]
        if status == _status.CONVERGED:
            return _status.CONVERGED, used, n
        if budget >= 0 and used >= budget:
            return _status.BUDGET_EXHAUSTED, used, n
        if 0 <= max_starts <= n:
            return _status.START_LIMIT, used, n
    return _status.STARTS_EXHAUSTED, used, n


@compiled(_MANY_SIGNATURE)
def run_many(geometry: np.ndarray, joints: np.ndarray, lo: np.ndarray, hi: np.ndarray, targets: np.ndarray,
             relaxed: bool, target_axes: bool, kept: np.ndarray, params: np.ndarray, limits: np.ndarray,
             q0s: np.ndarray, table_Gt: np.ndarray, table_Q: np.ndarray, full_Gt: np.ndarray,
             full_Q: np.ndarray, randoms: np.ndarray, q_out: np.ndarray, err_out: np.ndarray,
             counts: np.ndarray) -> None:
    """Every target pose ``targets[i]`` (4x4) from its own start sequence (that of
    :func:`ik.starts.seed_table.start_sequence`): ``q0s[i]`` (``limits[Q0_MODE]``), the ``limits[N_TABLE]``
    interior samples ``table_Q`` nearest the target (scores from ``table_Gt``, the table's ``G`` transposed),
    the ``limits[N_FULL]`` nearest full-range ones, then ``randoms``. Each start runs :func:`_iterate`
    (``target_axes``: the relaxed rows in the target's axes) with the ``params`` / ``limits`` named by the
    index constants; ``limits[BUDGET]`` caps a target's iterations over all its starts. Writes the answer,
    its squared errors and ``(status, iterations, starts)`` into row ``i`` of ``q_out``, ``err_out``,
    ``counts``.
    """
    qs, errs = np.empty((limits[MAX_ITER] + 1, lo.shape[0])), np.empty((limits[MAX_ITER] + 1, 2))
    S = (np.empty(table_Gt.shape[1]), np.empty(full_Gt.shape[1]))
    tables = (table_Gt, table_Q, full_Gt, full_Q, randoms)
    f, q, st, Aw = np.empty(14), np.empty(lo.shape[0]), np.empty(3, dtype=np.int64), np.eye(3)
    scale = params[ROTATION_SCALE]
    for i in range(targets.shape[0]):
        Td = targets[i]
        _features(Td, scale, limits[ROTATION] != 0, f)
        D0 = _q0_distance(geometry, joints, q0s[i], f, scale) if limits[Q0_MODE] == 2 else 0.0
        if target_axes:
            Aw[:, :] = Td[:3, :3]
        st[0], st[1], st[2] = 0, 0, limits[Q0_MODE]
        status, it, n = _solve_target(geometry, joints, lo, hi, Td, relaxed, Aw, kept, params, limits,
                                      (st, q, q0s[i], D0, f, tables, S), qs, errs, q_out[i], err_out[i])
        counts[i, 0], counts[i, 1], counts[i, 2] = status, it, n
