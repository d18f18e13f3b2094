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
(:func:`~kinserve.ik.qp.line_kernel.line_qp`, compiled: the unconstrained minimiser clipped to the
feasible interval).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from kinserve.ik.qp.dense_qp import DEFAULT_BACKEND, QPCalls, solve_dense
from kinserve.ik.qp.line_kernel import LOWER_DAMPING, line_level
from kinserve.ik.tasks.centring_weights import null_space_basis

_concat = np.concatenate

#: Solve a lower level whose freedom is a line in closed form (:mod:`~kinserve.ik.qp.line_kernel`) instead
#: of with the QP solver.
LINE_LEVEL = True

#: The rows of a step without constraint rows, as the line kernel takes them (constants: never written).
_NO_ROWS = np.zeros((0, 0))
_NO_ROWS.setflags(write=False)
_NO_BOUNDS = np.zeros(0)
_NO_BOUNDS.setflags(write=False)


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


def _line_level(z0: np.ndarray, jz: np.ndarray, Jk: np.ndarray, ek: np.ndarray, dq: np.ndarray,
                lb: np.ndarray, ub: np.ndarray, G: np.ndarray | None, l: np.ndarray | None,  # noqa: E741
                u: np.ndarray | None, max_step: float) -> float:
    """The coordinate ``z`` of the lower level's step ``z z0`` when its freedom is the line along the unit
    vector ``z0``: :func:`~kinserve.ik.qp.line_kernel.line_level` (``G`` None: no rows)."""
    if G is None:
        return line_level(z0, jz, Jk, ek, dq, lb, ub, _NO_ROWS, _NO_BOUNDS, _NO_BOUNDS, max_step)
    return line_level(z0, jz, Jk, ek, dq, lb, ub, G, l, u, max_step)
