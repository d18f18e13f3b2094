"""A lower priority level whose freedom is a line, solved exactly in closed form (compiled).

When the higher levels leave a line ``dq + z z0`` (``z0`` a unit vector: a 6-D task on a 7-joint arm), the
level's QP of :mod:`~kinserve.ik.qp.hierarchy` is one-dimensional::

    z = argmin 1/2 p z^2 + c z    p = |J_k z0|^2 + eps,  c = (J_k dq + e_k)^T J_k z0
        s.t. lo_i <= v_i + a_i z <= hi_i,  |z| <= limit

(the box ``lb <= dq + z0 z <= ub`` and the rows ``l <= G dq + (G z0) z <= u``). A strictly convex function
of one variable on an interval is minimised by its unconstrained minimiser ``-c / p`` clipped to the
interval. The rows' values at ``z = 0`` are taken as feasible (the step of the levels above keeps them, up to
round-off), so every bound on ``z`` is clamped at 0 and the interval contains 0; a row the line barely moves
(``|a_i| <= LINE_ROW_TOL``) does not restrict ``z``.

Compiled with explicit signatures (loaded when :mod:`~kinserve.ik.qp.hierarchy` is imported), through the
kernel set of :mod:`kinserve.kinematics.kernel_cache`. Arrays of any layout; units are the caller's.
"""

from __future__ import annotations

import numba
import numpy as np

from kinserve.kinematics.kernel_cache import F1_ANY, F2_ANY, compiled, inline

#: Damping ``eps`` of the lower levels (regularises the null-space coordinates).
LOWER_DAMPING = 1e-9

#: Rows whose coefficient along the line is at most this (in magnitude) do not restrict it (round-off of
#: a null-space basis vector: without this, a joint at its bound with a 1e-17 component along the line
#: froze the line - the S9 relax-z centring stopped 5 cm short of the sphere).
LINE_ROW_TOL = 1e-12

_f8 = numba.types.float64


@inline
def _narrow(a, v, lo, hi, zlo, zhi):
    """``(zlo, zhi)`` narrowed by the rows ``lo_i <= v_i + a_i z <= hi_i``, the slacks clamped at 0 (a row at
    its bound by round-off does not push ``z`` away from 0); stops once the interval is ``[0, 0]`` (the
    remaining rows cannot widen it). ``a``, ``v``, ``lo``, ``hi``: one entry per row."""
    for i in range(a.shape[0]):
        ai = a[i]
        if ai > LINE_ROW_TOL:  # lo - v <= a z <= hi - v
            down, up = lo[i] - v[i], hi[i] - v[i]
        elif ai < -LINE_ROW_TOL:  # reversed for a < 0
            down, up = v[i] - hi[i], v[i] - lo[i]
            ai = -ai
        else:
            continue
        if down < 0.0:
            b = down / ai
            if b > zlo:
                zlo = b
        elif zlo < 0.0:
            zlo = 0.0
        if up > 0.0:
            b = up / ai
            if b < zhi:
                zhi = b
        elif zhi > 0.0:
            zhi = 0.0
        if zlo >= 0.0 and zhi <= 0.0:  # collapsed to [0, 0]
            break
    return zlo, zhi


@inline
def _clip_to(z, zlo, zhi):
    """``z`` clipped to ``[zlo, zhi]`` (an interval holding 0); an end at 0 gives exactly ``0.0``."""
    if z < zlo:
        return zlo if zlo < 0.0 else 0.0
    if z > zhi:
        return zhi if zhi > 0.0 else 0.0
    return z


@inline
def _dot(x, y):
    """``x . y`` of two vectors of equal length, summed in index order."""
    s = 0.0
    for i in range(x.shape[0]):
        s += x[i] * y[i]
    return s


@inline
def _rows_times(G, x):
    """``G x``: ``(m, n)`` times ``(n,)``, each entry summed in index order."""
    out = np.empty(G.shape[0])
    for i in range(G.shape[0]):
        out[i] = _dot(G[i], x)
    return out


@compiled(_f8(_f8, _f8, F1_ANY, F1_ANY, F1_ANY, F1_ANY, _f8))
def line_qp(p: float, c: float, a: np.ndarray, v: np.ndarray, lo: np.ndarray, hi: np.ndarray,
            limit: float) -> float:
    """Exact ``argmin 1/2 p z^2 + c z`` over the scalar ``z`` with ``lo_i <= v_i + a_i z <= hi_i`` and
    ``|z| <= limit`` (module docstring; ``p > 0``, ``v`` feasible)."""
    zlo, zhi = _narrow(a, v, lo, hi, -limit, limit)
    return _clip_to(-c / p, zlo, zhi)


@compiled(_f8(F1_ANY, F1_ANY, F2_ANY, F1_ANY, F1_ANY, F1_ANY, F1_ANY, F2_ANY, F1_ANY, F1_ANY, _f8))
def line_level(z0: np.ndarray, jz: np.ndarray, Jk: np.ndarray, ek: np.ndarray, dq: np.ndarray,
               lb: np.ndarray, ub: np.ndarray, G: np.ndarray, l: np.ndarray, u: np.ndarray,  # noqa: E741
               max_step: float) -> float:
    """The coordinate ``z`` of the lower level's step ``z z0`` (module docstring: ``jz = J_k z0``, ``limit =
    max_step``); ``G`` with no rows: the box alone. The same answer as :func:`line_qp` over the box's and the
    rows' entries together: the box narrows the interval first, the rows are evaluated only when the box
    leaves the line some freedom, and the objective only when the rows do too (a blocked line gives
    ``0.0``)."""
    zlo, zhi = _narrow(z0, dq, lb, ub, -max_step, max_step)
    if G.shape[0] > 0 and (zlo < 0.0 or zhi > 0.0):
        zlo, zhi = _narrow(_rows_times(G, z0), _rows_times(G, dq), l, u, zlo, zhi)
    if zlo >= 0.0 and zhi <= 0.0:
        return 0.0
    p = _dot(jz, jz) + LOWER_DAMPING
    c = 0.0  # (J_k dq + e_k) . jz
    for i in range(Jk.shape[0]):
        c += (_dot(Jk[i], dq) + ek[i]) * jz[i]
    return _clip_to(-c / p, zlo, zhi)


__all__ = ["LINE_ROW_TOL", "LOWER_DAMPING", "line_level", "line_qp"]
