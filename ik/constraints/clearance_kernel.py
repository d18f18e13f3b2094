"""Which configurations put a link segment inside an obstacle: sphere, capsule and box pairs, compiled.

:meth:`kinserve.ik.constraints.obstacles.ObstacleAvoidance.violations` checks the
iterates of a run: for ``K`` configurations and every (segment, obstacle)
pair whether the segment comes closer than the obstacle's size plus the
offset ``off`` (link radius + required margin). :func:`violations` takes the
segments' end points of all configurations at once (``P``, ``(K, points, 3)``,
world, m) and the pair tables of the bound constraint
(:mod:`..obstacle_tables`), and decides each configuration in one compiled call,
stopping at its first violated pair:

* sphere (centre ``c``, radius ``r``): the point-segment distance
  ``|a + s (b - a) - c|``, ``s = clamp((c - a).(b - a) / |b - a|^2, 0, 1)``,
  violated when its square is below ``(r + off)^2``;
* capsule (core ``[p, q]``, radius ``r``): the segment-segment distance
  (Ericson, *Real-Time Collision Detection*, 5.1.9, as
  :func:`..segment_distance.segment_segment`), violated below ``r + off``;
* box (pose ``R, t``, half extents ``h``): the segment in the box frame
  ``R^T (x - t)``; the separating-axis test against the box grown by ``off``
  (:func:`separated`, also called from Python by the base check of
  :mod:`..obstacle_base`) clears most pairs; the others get the exact
  segment-box distance of :func:`..segment_distance.segment_box_distance`
  (violated below ``off``, or at 0: the segment meets the box).

The same formulas as the NumPy code of :mod:`..segment_distance` (checked
against it and against sampled distances in the tests).

:func:`skeleton_points` computes those end points from the configurations
(forward kinematics of the whole tree packed by
:func:`kinserve.kinematics.serial_chain.kinematic_tree`: ``oMj = oM(parent) Mj
exp(a_j q_j)``; a point ``l`` fixed to joint ``j`` is at ``R_j l + p_j``), so a
check of a run's iterates is two compiled calls and no Pinocchio call per
configuration. For the QP steps with spheres only, :func:`sphere_geometry`
gives the clearances, unit normals and near pairs at one configuration and
:func:`sphere_rows` the velocity-damper rows ``n^T J_v + (o x n)^T J_w`` from
Pinocchio's joint Jacobians (see :mod:`..sphere_rows`). The tree FK is
:func:`kinserve.kinematics.kernel_primitives.tree_placements_into` (inlined); the cache key of these
kernels covers every kernel file (:mod:`kinserve.kinematics.kernel_cache`).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from kinserve.kinematics.kernel_cache import B1, F1, F1_ANY, F2, F2_ANY, F3, I1, I2, compiled, jit, leaf
from kinserve.kinematics.kernel_primitives import tree_placements_into

_t = numba.types
_SIGNATURE = _t.void(F3, I1, I1, F2, F1, I1, I1, F2, F2, F1, I1, I1, F3, F2, F2, _t.float64,
                     _t.boolean[::1])
_POINTS_SIGNATURE = _t.void(F2, I2, I1, F2, F2, _t.float64[:, :, ::1])
_SPHERES_SIGNATURE = _t.float64(F2, I2, I1, F2, F1_ANY, I1, I1, F2, F1, F1, _t.float64,
                                _t.float64[::1], _t.float64[:, ::1], _t.boolean[::1])
_ROWS_SIGNATURE = _t.int64(F2, F2, F2_ANY, F2, B1, _t.float64[:, ::1])
_SEPARATED_SIGNATURE = _t.boolean(F1_ANY, F1_ANY, F1_ANY, _t.float64)
_jit = jit  # (kernel_cache's: one cache key over every kernel source)


@leaf
def _points_at(tree, joints, point_joint, point_local, q, X, out):
    """``out[i] = R_j l_i + p_j`` at configuration ``q`` (``X`` ``(J + 1, 12)``: the joints' world placements,
    filled here by :func:`kinserve.kinematics.kernel_primitives.tree_placements_into`)."""
    tree_placements_into(tree, joints, q, X)
    for i in range(point_joint.shape[0]):
        Xj = X[point_joint[i]]
        l0, l1, l2 = point_local[i, 0], point_local[i, 1], point_local[i, 2]
        for r in range(3):
            out[i, r] = Xj[9 + r] + Xj[3 * r] * l0 + Xj[3 * r + 1] * l1 + Xj[3 * r + 2] * l2


@compiled(_POINTS_SIGNATURE)
def skeleton_points(tree: np.ndarray, joints: np.ndarray, point_joint: np.ndarray, point_local: np.ndarray,
                    Q: np.ndarray, P: np.ndarray) -> None:
    """World points ``P[k, i] = R_j l_i + p_j`` (``j = point_joint[i]``, ``l_i = point_local[i]``; joint 0 is
    the world) of every configuration ``Q[k]``, by forward kinematics of the packed tree (module
    docstring)."""
    X = np.empty((joints.shape[0] + 1, 12))
    for k in range(Q.shape[0]):
        _points_at(tree, joints, point_joint, point_local, Q[k], X, P[k])


@compiled(_SPHERES_SIGNATURE)
def sphere_geometry(tree: np.ndarray, joints: np.ndarray, point_joint: np.ndarray, point_local: np.ndarray,
                    q: np.ndarray, ia: np.ndarray, ib: np.ndarray, centers: np.ndarray, inv_len2: np.ndarray,
                    r_off: np.ndarray, influence: float, c: np.ndarray, V: np.ndarray,
                    near: np.ndarray) -> float:
    """Clearances ``c = |x - o| - (r + off)`` of the sphere pairs at ``q`` (rigid segments: ``1 / |b - a|^2``
    given), the unit normals ``V`` (witness point ``x`` minus centre ``o``, rows) and the pairs within
    ``influence`` with a defined normal (``near``); returns the smallest clearance (m)."""
    X = np.empty((joints.shape[0] + 1, 12))
    P = np.empty((point_joint.shape[0], 3))
    _points_at(tree, joints, point_joint, point_local, q, X, P)
    lowest = np.inf
    for p in range(ia.shape[0]):
        A, B, o = P[ia[p]], P[ib[p]], centers[p]
        ux, uy, uz = B[0] - A[0], B[1] - A[1], B[2] - A[2]
        wx, wy, wz = o[0] - A[0], o[1] - A[1], o[2] - A[2]
        s = min(max((wx * ux + wy * uy + wz * uz) * inv_len2[p], 0.0), 1.0)
        vx, vy, vz = s * ux - wx, s * uy - wy, s * uz - wz  # x - o
        d = math.sqrt(vx * vx + vy * vy + vz * vz)
        c[p] = d - r_off[p]
        lowest = min(lowest, c[p])
        near[p] = c[p] < influence and d > 1e-12
        f = 1.0 / max(d, 1e-12)
        V[p, 0], V[p, 1], V[p, 2] = vx * f, vy * f, vz * f
    return lowest


@compiled(_ROWS_SIGNATURE)
def sphere_rows(V: np.ndarray, centers: np.ndarray, J: np.ndarray, support: np.ndarray, near: np.ndarray,
                G: np.ndarray) -> int:
    """Rows ``n^T J_v + (o x n)^T J_w`` (masked by the support of the pair's segment) of the ``near`` pairs
    into the first rows of ``G``; returns their number. ``J``: Pinocchio's WORLD joint Jacobians ``(6, nv)``
    (``data.J``); the moment arm of a sphere row is its centre ``o`` (the witness point is ``o + d n``)."""
    k = 0
    nv = J.shape[1]
    for p in range(V.shape[0]):
        if not near[p]:
            continue
        n0, n1, n2 = V[p, 0], V[p, 1], V[p, 2]
        o = centers[p]
        m0, m1, m2 = o[1] * n2 - o[2] * n1, o[2] * n0 - o[0] * n2, o[0] * n1 - o[1] * n0
        for j in range(nv):
            G[k, j] = (n0 * J[0, j] + n1 * J[1, j] + n2 * J[2, j] + m0 * J[3, j] + m1 * J[4, j]
                       + m2 * J[5, j]) * support[p, j]
        k += 1
    return k


@leaf
def point_to_segment2(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> float:
    """Squared distance from point ``c`` to the segment ``[a, b]`` (3-vectors)."""
    ux, uy, uz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    wx, wy, wz = c[0] - a[0], c[1] - a[1], c[2] - a[2]
    L2 = ux * ux + uy * uy + uz * uz
    s = 0.0
    if L2 > 1e-18:
        s = min(max((wx * ux + wy * uy + wz * uz) / L2, 0.0), 1.0)
    vx, vy, vz = wx - s * ux, wy - s * uy, wz - s * uz
    return vx * vx + vy * vy + vz * vz


@leaf
def segment_to_segment(p1: np.ndarray, q1: np.ndarray, p2: np.ndarray, q2: np.ndarray) -> float:
    """Distance between the segments ``[p1, q1]`` and ``[p2, q2]`` (module docstring)."""
    d1x, d1y, d1z = q1[0] - p1[0], q1[1] - p1[1], q1[2] - p1[2]
    d2x, d2y, d2z = q2[0] - p2[0], q2[1] - p2[1], q2[2] - p2[2]
    rx, ry, rz = p1[0] - p2[0], p1[1] - p2[1], p1[2] - p2[2]
    a = d1x * d1x + d1y * d1y + d1z * d1z
    e = d2x * d2x + d2y * d2y + d2z * d2z
    f = d2x * rx + d2y * ry + d2z * rz
    b = d1x * d2x + d1y * d2y + d1z * d2z
    c = d1x * rx + d1y * ry + d1z * rz
    if e <= 1e-18:  # the second segment is a point
        s = min(max(-c / a, 0.0), 1.0) if a > 1e-18 else 0.0
        t = 0.0
    else:
        den = a * e - b * b
        s = min(max((b * f - c * e) / den, 0.0), 1.0) if den > 1e-18 * max(a * e, 1.0) else 0.0
        t = (b * s + f) / e
        if t < 0.0 or t > 1.0:
            t = min(max(t, 0.0), 1.0)
            s = min(max((b * t - c) / a, 0.0), 1.0) if a > 1e-18 else 0.0
    vx = p1[0] + s * d1x - p2[0] - t * d2x
    vy = p1[1] + s * d1y - p2[1] - t * d2y
    vz = p1[2] + s * d1z - p2[2] - t * d2z
    return math.sqrt(vx * vx + vy * vy + vz * vz)


@_jit
def _phi(x: float, h: float) -> float:
    """``x - clamp(x, -h, h)``."""
    return x - h if x > h else x + h if x < -h else 0.0


@_jit
def segment_to_box(a: np.ndarray, b: np.ndarray, h: np.ndarray) -> float:
    """Distance from the segment ``[a, b]`` to the box ``|y| <= h`` (its frame; 0 when they meet)."""
    u0, u1, u2 = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    cands = np.empty(8)
    n = 0
    cands[n] = 0.0
    n += 1
    for i in range(3):
        ui = b[i] - a[i]
        if ui != 0.0:
            for e in (h[i], -h[i]):
                t = (e - a[i]) / ui
                if 0.0 < t < 1.0:
                    cands[n] = t
                    n += 1
    cands[n] = 1.0
    n += 1
    cands[:n].sort()
    s = 1.0
    t0 = 0.0
    f0 = u0 * _phi(a[0], h[0]) + u1 * _phi(a[1], h[1]) + u2 * _phi(a[2], h[2])
    if f0 > 0.0:
        s = 0.0
    else:
        for k in range(1, n):
            t1 = cands[k]
            f1 = (u0 * _phi(a[0] + t1 * u0, h[0]) + u1 * _phi(a[1] + t1 * u1, h[1])
                  + u2 * _phi(a[2] + t1 * u2, h[2]))
            if f1 > 0.0:
                s = min(max(t0 - f0 * (t1 - t0) / (f1 - f0), 0.0), 1.0)
                break
            t0, f0 = t1, f1
    v0 = _phi(a[0] + s * u0, h[0])
    v1 = _phi(a[1] + s * u1, h[1])
    v2 = _phi(a[2] + s * u2, h[2])
    return math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)


@compiled(_SEPARATED_SIGNATURE)
def separated(a: np.ndarray, b: np.ndarray, h: np.ndarray, off: float) -> bool:
    """True when the segment ``[a, b]`` is separated from the box ``|y| <= h + off`` (its frame) by an axis.

    The separating-axis test of a segment and a box (Ericson, *Real-Time
    Collision Detection*, 5.3.3): with the midpoint ``c``, the half-extent
    ``w = (b - a) / 2`` and ``|w|`` padded by 1e-12 (parallel cases), the axes
    are the box's (``|c_i| > e_i + |w_i|``) and their cross products with ``w``.
    Separated from the box grown by ``off`` on every side implies a distance
    ``>= off`` from the box (the grown box contains all points within ``off``).
    ``a``, ``b``, ``h``: 3-vectors (float64 arrays). Compiled, callable from Python as well.
    """
    e0, e1, e2 = h[0] + off, h[1] + off, h[2] + off
    c0, c1, c2 = 0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2])
    w0, w1, w2 = 0.5 * (b[0] - a[0]), 0.5 * (b[1] - a[1]), 0.5 * (b[2] - a[2])
    v0, v1, v2 = abs(w0) + 1e-12, abs(w1) + 1e-12, abs(w2) + 1e-12
    return (abs(c0) > e0 + v0 or abs(c1) > e1 + v1 or abs(c2) > e2 + v2
            or abs(c1 * w2 - c2 * w1) > e1 * v2 + e2 * v1
            or abs(c2 * w0 - c0 * w2) > e0 * v2 + e2 * v0
            or abs(c0 * w1 - c1 * w0) > e0 * v1 + e1 * v0)


@compiled(_SIGNATURE)
def violations(P: np.ndarray, sph_ia: np.ndarray, sph_ib: np.ndarray, sph_c: np.ndarray,
               sph_r_off2: np.ndarray, cap_ia: np.ndarray, cap_ib: np.ndarray, cap_a: np.ndarray,
               cap_b: np.ndarray, cap_r_off: np.ndarray, box_ia: np.ndarray, box_ib: np.ndarray,
               box_R: np.ndarray, box_t: np.ndarray, box_h: np.ndarray, off: float, bad: np.ndarray) -> None:
    """``bad[k] |= True`` where configuration ``k`` violates a sphere, capsule or box pair (module docstring).

    ``P`` ``(K, points, 3)``: segment end points per configuration; pair
    ``i`` of a kind joins the points ``ia[i]`` and ``ib[i]``. Spheres: centres
    ``(n, 3)`` and ``(r + off)^2``; capsules: cores ``[a, b]`` and ``r + off``;
    boxes: rotations ``(n, 3, 3)``, centres and half extents ``(n, 3)``.
    """
    la = np.empty(3)
    lb = np.empty(3)
    for k in range(P.shape[0]):
        if bad[k]:
            continue
        X = P[k]
        hit = False
        for i in range(sph_ia.shape[0]):
            if point_to_segment2(X[sph_ia[i]], X[sph_ib[i]], sph_c[i]) < sph_r_off2[i]:
                hit = True
                break
        if not hit:
            for i in range(cap_ia.shape[0]):
                if segment_to_segment(X[cap_ia[i]], X[cap_ib[i]], cap_a[i], cap_b[i]) < cap_r_off[i]:
                    hit = True
                    break
        if not hit:
            for i in range(box_ia.shape[0]):
                R, t = box_R[i], box_t[i]
                A, B = X[box_ia[i]], X[box_ib[i]]
                for c in range(3):  # R^T (x - t)
                    la[c] = R[0, c] * (A[0] - t[0]) + R[1, c] * (A[1] - t[1]) + R[2, c] * (A[2] - t[2])
                    lb[c] = R[0, c] * (B[0] - t[0]) + R[1, c] * (B[1] - t[1]) + R[2, c] * (B[2] - t[2])
                if separated(la, lb, box_h[i], off):
                    continue
                d = segment_to_box(la, lb, box_h[i])
                if d < off or d <= 0.0:
                    hit = True
                    break
        bad[k] = hit
