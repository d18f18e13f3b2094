"""One differential-IK step with strict priorities between levels and hard constraints at every level.

Tasks are grouped by priority (1 = highest). Inside a level the rows of its
tasks are stacked, each scaled by ``sqrt(weight)``: ``J_k``, ``e_k``. With the
box ``lb <= dq <= ub`` (joint limits, trust region, velocity limits) and the
constraint rows ``l <= G dq <= u``:

Level 1 - a Levenberg-Marquardt step with hard inequalities::

    dq_1 = argmin 1/2 |J_1 dq + e_1|^2 + 1/2 lambda |dq|^2      lambda = gain |e_1|^2 + lambda_0
           s.t. lb <= dq <= ub,  l <= G dq <= u

Level k > 1 - in the null space of every higher level: with ``Z`` an
orthonormal basis of the null space of ``[J_1; ...; J_{k-1}]`` (rank-revealing,
built level by level: :func:`~kinserve.ik.tasks.centring_weights.null_space_basis`),
``dq = dq_{k-1} + Z z`` and::

    z = argmin 1/2 |J_k (dq_{k-1} + Z z) + e_k|^2 + 1/2 eps |z|^2
        s.t. lb <= dq_{k-1} + Z z <= ub,  l <= G (dq_{k-1} + Z z) <= u,  |z| <= max_step

so ``J_j dq`` is unchanged for every higher level ``j`` (the higher levels'
first-order progress is kept exactly) and the constraints hold at every
level. When the first level is infeasible because rows demand that violated
constraints recover (``l > 0``, a start in collision), those rows are relaxed
to ``l = 0`` (get no worse) and the level is solved again. A level whose QP
is infeasible (the higher levels leave it no feasible freedom) contributes
nothing (:func:`level_steps` gives each level's part). This is the nullspace form of a
hierarchical QP; it needs no more than one small QP per level. When the
freedom left is a line (``Z`` has one column: a 6-D task on a 7-joint arm)
the level's QP is one-dimensional and is solved exactly in closed form
(:func:`line_qp`: the unconstrained minimiser clipped to the feasible
interval).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from kinserve.ik.qp.dense_qp import DEFAULT_BACKEND, QPCalls, solve_dense
from kinserve.ik.tasks.centring_weights import null_space_basis

_concat = np.concatenate

#: Damping of the lower levels (regularises the null-space coordinates).
LOWER_DAMPING = 1e-9

#: Solve a lower level whose freedom is a line with :func:`line_qp` instead of the QP solver.
LINE_LEVEL = True

#: Rows whose coefficient along the line is at most this (in magnitude) do not restrict it (round-off of
#: a null-space basis vector: without this, a joint at its bound with a 1e-17 component along the line
#: froze the line - the S9 relax-z centring stopped 5 cm short of the sphere).
LINE_ROW_TOL = 1e-12


def stack_level(pairs: list, sqrt_weights: list) -> tuple[np.ndarray, np.ndarray]:
    """``(J, e)`` of one level: the tasks' ``(e, J)`` rows stacked, each scaled by its ``sqrt(weight)``
    (``sqrt_weights``: a number, a vector, or None for weight 1)."""
    if len(pairs) == 1 and (sqrt_weights[0] is None):
        return pairs[0][1], pairs[0][0]
    Js, es = [], []
    for (e, J), sw in zip(pairs, sqrt_weights):
        if sw is None:
            Js.append(J), es.append(e)
        else:
            if np.ndim(sw):
                Js.append(J * sw[:, None]), es.append(e * sw)
            else:
                Js.append(J * sw), es.append(e * sw)
    return _concat(Js), _concat(es)


class LevelSteps(NamedTuple):
    """The step of :func:`level_steps`, level by level.

    ``total = first + sum(d for d in lower if d is not None)``: ``first`` is
    level 1's step, ``lower[k - 2]`` level ``k``'s contribution ``Z z`` (None
    when the level added nothing: no freedom left, an infeasible level QP, a
    line blocked by the bounds).
    """

    total: np.ndarray
    first: np.ndarray
    lower: list


def hierarchical_step(levels: list, lb: np.ndarray, ub: np.ndarray, G: np.ndarray | None = None,
                      l: np.ndarray | None = None, u: np.ndarray | None = None, *,  # noqa: E741
                      lam: float, max_step: float = 1.0, backend: str = DEFAULT_BACKEND,
                      shortcut: bool = True,
                      calls: QPCalls | None = None) -> tuple[np.ndarray | None, np.ndarray | None]:
    """``(dq, dq_lower)``: the step and the part of it contributed by levels below the first; ``(None, None)``
    when the first level's QP is infeasible (``dq_lower`` is None with one level).

    ``levels`` is a list of ``(J, e)`` ordered by priority; ``lam`` the
    first level's damping. The parts summed of :func:`level_steps`. ``calls`` counts the QP-solver calls.
    """
    out = _solve_levels(levels, lb, ub, G, l, u, lam, max_step, backend, shortcut, calls)
    if out is None:
        return None, None
    dq, first, lower = out
    if not lower:
        return dq, None
    if len(lower) == 1:  # (two levels: the second's part as it is)
        return dq, (lower[0] if lower[0] is not None else np.zeros(dq.shape[0]))
    return dq, dq - first


def level_steps(levels: list, lb: np.ndarray, ub: np.ndarray, G: np.ndarray | None = None,
                l: np.ndarray | None = None, u: np.ndarray | None = None, *, lam: float,  # noqa: E741
                max_step: float = 1.0, backend: str = DEFAULT_BACKEND,
                shortcut: bool = True, calls: QPCalls | None = None) -> LevelSteps | None:
    """The step of the module docstring, level by level (:class:`LevelSteps`); None when the first level's QP
    is infeasible.

    ``levels`` is a list of ``(J, e)`` ordered by priority; ``lam`` the
    first level's damping; ``max_step`` bounds ``|z|`` of the lower levels; ``calls`` counts the QP-solver
    calls.
    """
    out = _solve_levels(levels, lb, ub, G, l, u, lam, max_step, backend, shortcut, calls)
    return None if out is None else LevelSteps(*out)


def _solve_levels(levels, lb, ub, G, l, u, lam, max_step, backend, shortcut, calls):  # noqa: E741
    """``(total, first, lower)`` of :class:`LevelSteps`, or None (:func:`level_steps`)."""
    J1, e1 = levels[0]
    n = J1.shape[1]
    P = J1.T.dot(J1)
    P.ravel()[:: n + 1] += lam  # (a view: P is fresh and contiguous)
    dq = solve_dense(P, e1.dot(J1), lb, ub, G, l, u, backend, shortcut, calls)
    if dq is None and G is not None and (l > 0.0).any():
        # rows that demand a violated constraint recover (l > 0) may conflict: ask only that it gets no worse
        l = np.minimum(l, 0.0)  # noqa: E741
        dq = solve_dense(P, e1.dot(J1), lb, ub, G, l, u, backend, shortcut, calls)
    if dq is None:
        return None
    first = dq
    lower = []
    if len(levels) == 1:
        return dq, first, lower
    Z = null_space_basis(J1)
    last = len(levels) - 1
    if G is not None and G.shape[0] == 0:
        G = None
    for k in range(1, last + 1):
        Jk, ek = levels[k]
        if Z.shape[1] == 0:
            lower.extend([None] * (last + 1 - k))
            break
        JZ = Jk.dot(Z)
        step = _lower_level(Z, JZ, Jk, ek, dq, lb, ub, G, l, u, max_step, backend, shortcut, calls)
        lower.append(step)
        if step is not None:
            dq = dq + step
        if k < last:  # the next level moves in the null space of this one too (none after the last)
            Z = Z.dot(null_space_basis(JZ))
    return dq, first, lower


def _lower_level(Z, JZ, Jk, ek, dq, lb, ub, G, l, u, max_step, backend, shortcut, calls):  # noqa: E741
    """Level ``k``'s contribution ``Z z`` (module docstring) on top of the step ``dq`` of the levels above
    (``G`` None without rows); None when it adds nothing (its QP infeasible, or a line blocked by the
    bounds)."""
    dim = Z.shape[1]
    if LINE_LEVEL and dim == 1 and shortcut:  # one free direction: the QP on a line, in closed form
        z0 = Z[:, 0]
        z = _line_level(z0, JZ[:, 0], Jk, ek, dq, lb, ub, G, l, u, max_step)
        return z0 * z if z != 0.0 else None
    Pz = JZ.T.dot(JZ)
    Pz.flat[:: dim + 1] += LOWER_DAMPING
    cz = (Jk.dot(dq) + ek).dot(JZ)
    if G is not None:
        Gd = G.dot(dq)
        A = np.concatenate((Z, G.dot(Z)))
        lo = np.concatenate((lb - dq, l - Gd))
        hi = np.concatenate((ub - dq, u - Gd))
    else:
        A, lo, hi = Z, lb - dq, ub - dq
    zlim = np.full(dim, max_step)
    z = solve_dense(Pz, cz, -zlim, zlim, A, lo, hi, backend, shortcut, calls)
    return None if z is None else Z.dot(z)


def line_qp(p: float, c: float, a: list, v: list, lo: list, hi: list, limit: float) -> float:
    """Exact ``argmin 1/2 p z^2 + c z`` over the scalar ``z`` with ``lo_i <= v_i + a_i z <= hi_i`` and
    ``|z| <= limit``.

    ``p > 0``; ``v`` are the rows' values at ``z = 0``, taken as feasible
    (``lo_i <= v_i <= hi_i``: the rows at a feasible step, round-off included),
    so every bound on ``z`` is clamped at 0 and the interval ``[z_lo, z_hi]`` of
    feasible ``z`` contains 0. A strictly convex function of one variable on an
    interval is minimised by its unconstrained minimiser ``-c / p`` clipped to
    the interval. Rows with ``a_i = 0`` do not restrict ``z``.
    """
    zlo, zhi = _line_interval(a, v, lo, hi, -limit, limit)
    return _clip_to(-c / p, zlo, zhi)


def _clip_to(z: float, zlo: float, zhi: float) -> float:
    """``z`` clipped to ``[zlo, zhi]`` (an interval holding 0); an end at 0 gives exactly ``0.0``."""
    if z < zlo:
        return zlo if zlo < 0.0 else 0.0
    if z > zhi:
        return zhi if zhi > 0.0 else 0.0
    return z


def _line_interval(a: list, v: list, lo: list, hi: list, zlo: float, zhi: float) -> tuple[float, float]:
    """``[zlo, zhi]`` narrowed by the rows ``lo_i <= v_i + a_i z <= hi_i`` (slacks clamped at 0, see
    :func:`line_qp`).

    Stops as soon as the interval is ``[0, 0]`` (the remaining rows cannot widen it).
    """
    for ai, vi, li, hi_ in zip(a, v, lo, hi):
        # slacks clamped at 0 (a row at its bound by round-off does not push z away from 0), and a row the
        # line barely moves (|a_i| <= LINE_ROW_TOL, e.g. 1e-17 of a basis vector) does not restrict z: a
        # bound of (1e-16 / 1e-17) would be noise, as the QP solver's feasibility tolerance also treats it.
        # For a_i > 0 the bounds are (lo_i - v_i) / a_i <= z <= (hi_i - v_i) / a_i, reversed for a_i < 0;
        # written with conditionals, not min/max (this loop runs for every row of every line level)
        if ai > LINE_ROW_TOL:
            down, up = li - vi, hi_ - vi
        elif ai < -LINE_ROW_TOL:
            down, up = vi - hi_, vi - li
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


def _line_level(z0: np.ndarray, jz: np.ndarray, Jk: np.ndarray, ek: np.ndarray, dq: np.ndarray,
                lb: np.ndarray, ub: np.ndarray, G: np.ndarray | None, l: np.ndarray | None,  # noqa: E741
                u: np.ndarray | None, max_step: float) -> float:
    """The coordinate ``z`` of the lower level's step ``z z0`` when its freedom is the line along the unit
    vector ``z0``.

    The level's QP (module docstring) with ``Z = z0``: ``Pz = |J_k z0|^2 + eps``,
    ``cz = (J_k dq + e_k)^T J_k z0`` (``jz = J_k z0``), the box
    ``lb <= dq + z0 z <= ub`` and the rows ``l <= G dq + (G z0) z <= u``,
    solved exactly as :func:`line_qp` does: the box narrows the interval first, the
    rows are evaluated only when the box leaves the line some freedom, and the
    objective only when the rows do too (a line blocked at ``[0, 0]`` gives ``0.0``).
    """
    zlo, zhi = _line_interval(z0.tolist(), dq.tolist(), lb.tolist(), ub.tolist(), -max_step, max_step)
    if G is not None and (zlo < 0.0 or zhi > 0.0):
        zlo, zhi = _line_interval(G.dot(z0).tolist(), G.dot(dq).tolist(), l.tolist(), u.tolist(), zlo, zhi)
    if zlo >= 0.0 and zhi <= 0.0:
        return 0.0
    p = float(jz.dot(jz)) + LOWER_DAMPING
    c = float((Jk.dot(dq) + ek).dot(jz))
    return _clip_to(-c / p, zlo, zhi)
