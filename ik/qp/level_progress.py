"""Strict priorities along the iterations: every goal level is judged by its own residual.

The step of :func:`~kinserve.ik.qp.hierarchy.level_steps` is exact for the
linearised levels: level ``k``'s contribution ``d_k`` lies in the null space of
every Jacobian above it, so ``J_j dq`` is what level ``j < k`` asked for. But the
null space is only tangent to the set where the higher levels keep their
values: ``e_j(q + d_1 + d_k) - e_j(q + d_1)`` is of second order in the step, and
a large ``d_k`` (a posture a radian away from its reference) can undo what level
``j`` gained in the same step - iterated, it keeps level ``j`` from converging.
So an iteration takes

    q' = q + d_1 + sum_k beta_k d_k,       1 >= beta_2 >= ... >= beta_K >= 0

(a convex combination of the step's feasible partial sums ``d_1 + ... + d_k``,
so every bound and row of the step still holds) with the largest shares
``beta_k`` that every goal level above them lets pass. A goal level ``j`` (one
holding a goal task) passes at the trial ``q'`` when

(a) its goal tasks are within tolerance at ``q'``, or
(b) its merit ``f_j = |e_j|^2`` (the stacked, weighted error the level
    minimises) decreased enough:
    ``f_j(q') <= m_j + (1 - SUFFICIENT_DECREASE) max(f_j(q) - m_j, 0)``, with
    ``m_j = |e_j(q) + J_j dq|^2`` its linear model's prediction for the step
    ``dq = q' - q`` (before a correction, below): the levels below may cost it
    at most ``1 - SUFFICIENT_DECREASE`` of the decrease its own model predicts,
    or
(c) ``f_j(q')`` is no larger than at the trial without the levels below ``j``
    (``beta_k = 0`` for ``k > j``: what it reaches without them; evaluated only
    when (a) and (b) fail);

and a goal level met at ``q`` passes by (a) only (goals met stay met). A
failing trial is first **corrected** to second order, as SQP methods do for
curved constraints: the step of levels ``1..j`` at the trial, taken from there
(``correct``; it removes most of what the curvature cost them, so a lower level
can keep a large share). If the corrected trial fails too, the shares of every
level below ``j`` are halved, at most :data:`LOWER_BACKTRACK` times, then set to
0 (the trial is then the one of (c), which passes). Objective levels (no goal task: posture, centring) are not
judged: they have no tolerance to keep, and a stationary objective would freeze
every level below it; the levels below still move only in their first-order
null space. A start remembers its shares: the next iteration tries twice them
(at most 1, at least :data:`MIN_SHARE`).

Once the goals are within tolerance, the objectives have **converged** when no
level holding an objective task has lowered its merit ``f_j`` below
``(1 - OBJECTIVE_RTOL)`` times its best (less ``OBJECTIVE_ATOL``) for
:data:`OBJECTIVE_PATIENCE` iterations (:class:`ObjectiveWatch`): each objective
is judged by its own residual in the freedom left, not by the size of the step - near the
goal tolerance the step rarely vanishes (the first level corrects what the
curvature of the lower levels' steps costs it, and the lower levels undo that
correction's effect on them), while their merits no longer improve.

A start has **stalled** when the first goal level that is not within tolerance
has not improved its error ``pe^2 + re^2`` (the largest position (m) /
orientation (rad) error of its goal tasks) by the factor ``ratio`` for
``patience`` iterations (:class:`LevelStall`): a met level above does not hide
the one still moving, and an unmet level below cannot make a converging one
look stalled.

These tests bound what a lower level may cost a higher one in each iteration;
they do not make the path that of the higher levels alone.
:mod:`kinserve.ik.qp.task_solver` adds the guarantee: a start whose goals were
not met although a lower level took part of a step before they were is run
again with the lower levels held until the goals are met.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

if TYPE_CHECKING:  # annotations only
    from kinserve.ik.problem import Problem
    from kinserve.ik.qp.hierarchy import LevelSteps

#: Fraction of a goal level's predicted decrease of ``|e_j|^2`` that the levels below it must leave it (b).
SUFFICIENT_DECREASE = 0.5
#: Halvings of the lower levels' shares before they are set to 0.
LOWER_BACKTRACK = 10
#: The smallest share an iteration starts from (after a share of 0).
MIN_SHARE = 0.5 ** LOWER_BACKTRACK

#: An objective level improves when its merit falls below ``(1 - OBJECTIVE_RTOL) best - OBJECTIVE_ATOL``.
OBJECTIVE_RTOL = 1e-4
OBJECTIVE_ATOL = 1e-12
#: Iterations within tolerance without such an improvement before the objectives count as converged.
OBJECTIVE_PATIENCE = 3

#: ``correct(q', state, j) -> (q'', state)``: ``q'`` corrected by the step of levels ``0..j`` at ``q'``.
Correct = Callable[[np.ndarray, tuple, int], tuple]
#: ``accept(dq) -> (q', state at q')``, ``(None, None)`` when no multiple of ``dq`` keeps the constraints.
Accept = Callable[[np.ndarray], tuple]


class Trial(NamedTuple):
    """The iterate an iteration moves to: ``q`` and its ``state`` (:meth:`Problem.state`; both None when the
    constraints block the step), the lower levels' ``shares``, ``stopped``: a lower level had a step and
    none of it was taken, ``taken``: some of a lower level's step was taken."""

    q: np.ndarray | None
    state: tuple | None
    shares: tuple
    stopped: bool
    taken: bool


class _Iteration(NamedTuple):
    """What the tests of one iteration read: the iterate ``q``, its ``(J, e)`` per level, the step level by
    level, how a trial step is taken (``accept``, ``correct``), each level's goals met at ``q`` (``met``),
    and the trials made so far by their shares (``refs``)."""

    q: np.ndarray
    levels: list
    steps: LevelSteps
    accept: Accept
    correct: Correct | None
    met: list
    refs: dict


class LowerShares:
    """The shares of the lower levels' steps that the iterations of one start take (module docstring)."""

    __slots__ = ("pb", "tp", "tr", "shares", "judged")

    def __init__(self, pb: Problem, tol_pos: float, tol_rot: float) -> None:
        self.pb, self.tp, self.tr = pb, tol_pos, tol_rot
        self.shares = [1.0] * (len(pb.levels) - 1)  # shares[i - 1]: level i's (levels numbered from 0)
        self.judged = [j for j in pb.goal_levels if j < len(pb.levels) - 1]  # goal levels with levels below

    def take(self, q: np.ndarray, state: tuple, steps: LevelSteps, accept: Accept,
             first: tuple | None = None, correct: Correct | None = None) -> Trial:
        """The trial ``q + d_1 + sum beta_k d_k`` with the largest shares the goal levels let pass.

        ``state`` is :meth:`Problem.state` at ``q``; ``first``: ``accept(steps.total)``
        when already known (used when every starting share is 1); ``correct``:
        the second-order correction of a trial (see :data:`Correct`), tried on a
        failing trial before its shares are halved.
        """
        moved = [d is not None for d in steps.lower]
        n = len(moved)  # (the levels of this step: the highest n + 1 of the problem's)
        if not any(moved) or not self.judged:
            trial = first if first is not None else accept(steps.total)
            return Trial(trial[0], trial[1], tuple(self.shares[:n]), False, any(moved))
        met = [p < self.tp and r < self.tr for p, r in self.pb.level_goal_errors(state[3])]
        now = _Iteration(q, state[0], steps, accept, correct, met, {})
        shares = self._starting_shares()[:n]
        trial = first if first is not None and min(shares) == 1.0 else accept(_combined(steps, shares))
        halvings = [0] * (n + 1)
        for _ in range((LOWER_BACKTRACK + 1) * (n + 1)):
            j, trial = self._passing(now, trial, shares)
            if j is None:
                break
            if halvings[j] < LOWER_BACKTRACK:
                halvings[j] += 1
                shares = shares[:j] + [s * 0.5 for s in shares[j:]]
            else:
                shares = shares[:j] + [0.0] * (n - j)
            trial = now.refs.get(tuple(shares)) or accept(_combined(steps, shares))
        # (the loop always ends on a pass: a level fails at most LOWER_BACKTRACK + 1 times, the last time
        # with nothing below it left to move)
        self.shares = shares + self.shares[n:]
        taken = any(s > 0.0 for s, m in zip(shares, moved) if m)
        return Trial(trial[0], trial[1], tuple(shares), not taken, taken)

    def _starting_shares(self) -> list:
        """Twice the last iteration's shares, in ``[MIN_SHARE, 1]``, non-increasing down the levels."""
        out, cap = [], 1.0
        for s in self.shares:
            cap = min(cap, max(2.0 * s, MIN_SHARE))
            out.append(cap)
        return out

    def _passing(self, now: _Iteration, trial: tuple, shares: list) -> tuple[int | None, tuple]:
        """``(None, trial)`` when ``trial`` or its correction passes, else ``(j, trial)``: ``j`` the first
        goal level that fails at ``trial``."""
        dq = _combined(now.steps, shares)
        j = self._blocked(now, trial, shares, dq)
        if j is None or now.correct is None or trial[0] is None:
            return j, trial
        fixed = now.correct(trial[0], trial[1], j)
        if fixed[0] is not None and self._blocked(now, fixed, shares, dq) is None:
            return None, fixed
        return j, trial

    def _blocked(self, now: _Iteration, trial: tuple, shares: list, dq: np.ndarray) -> int | None:
        """The first goal level that fails at ``trial`` (module docstring; ``dq`` the uncorrected step of
        these shares, for the levels' linear models), or None when all pass."""
        qn, st = trial
        errors = None
        for j in self.judged:
            if not any(s > 0.0 and d is not None for s, d in zip(shares[j:], now.steps.lower[j:])):
                continue  # nothing below j moves: the trial is the one without them
            if qn is None:
                return j
            if errors is None:
                errors = self.pb.level_goal_errors(st[3])
            pe, re = errors[j]
            if pe < self.tp and re < self.tr:
                continue  # (a)
            if now.met[j]:
                return j  # (goals met at q stay met)
            J, e = now.levels[j]
            e_new = st[0][j][1]
            f_new = float(e_new.dot(e_new))
            r = e + J.dot(dq)
            m, f = float(r.dot(r)), float(e.dot(e))
            if f_new <= m + (1.0 - SUFFICIENT_DECREASE) * max(f - m, 0.0):
                continue  # (b)
            if f_new <= self._reference(now, shares, j):
                continue  # (c)
            return j
        return None

    def _reference(self, now: _Iteration, shares: list, j: int) -> float:
        """``f_j`` at the trial without the levels below ``j`` (``inf`` when the constraints block it)."""
        key = tuple(shares[:j] + [0.0] * (len(shares) - j))
        ref = now.refs.get(key)
        if ref is None:
            ref = now.refs[key] = now.accept(_combined(now.steps, list(key)))
        if ref[0] is None:
            return np.inf
        e_ref = ref[1][0][j][1]
        return float(e_ref.dot(e_ref))


def _combined(steps: LevelSteps, shares: list) -> np.ndarray:
    """``d_1 + sum_k shares[k - 2] d_k`` over the lower levels that moved."""
    dq = steps.first
    for s, d in zip(shares, steps.lower):
        if d is not None and s > 0.0:
            dq = dq + (d if s == 1.0 else s * d)
    return dq


class LevelStall:
    """The stall test of one start, judged on the first goal level not within tolerance (module docstring)."""

    __slots__ = ("best", "count", "ratio", "patience")

    def __init__(self, n_levels: int, ratio: float, patience: int) -> None:
        self.best = [np.inf] * n_levels
        self.count = 0
        self.ratio, self.patience = ratio, patience

    def stalled(self, level_errors: list, tol_pos: float, tol_rot: float) -> bool:
        """Record one iterate's :meth:`Problem.level_goal_errors`; True once the start has stalled.

        Levels whose goals are within tolerance (levels without goals too:
        their errors are 0) are passed over; with every level within, nothing
        is recorded.
        """
        for j, (pe, re) in enumerate(level_errors):
            if pe < tol_pos and re < tol_rot:
                continue
            E = pe * pe + re * re
            if E < self.ratio * self.best[j]:
                self.best[j] = E
                self.count = 0
                return False
            self.count += 1
            return self.count >= self.patience
        return False


class ObjectiveWatch:
    """Whether the objective levels of one start still improve once its goals are met (module docstring)."""

    __slots__ = ("levels", "best", "count", "patience")

    def __init__(self, pb: Problem, patience: int = OBJECTIVE_PATIENCE) -> None:
        self.levels = [j for j, lvl in enumerate(pb.levels) if any(not t.goal for t in lvl)]
        self.best = [np.inf] * len(self.levels)
        self.count = 0
        self.patience = patience

    def stationary(self, levels: list) -> bool:
        """Record the merits ``|e_j|^2`` of one iterate whose goals are within tolerance (``levels``: its
        ``(J, e)`` per level); True once no objective level improved for ``patience`` such iterates."""
        improved = False
        for i, j in enumerate(self.levels):
            e = levels[j][1]
            f = float(e.dot(e))
            if f < (1.0 - OBJECTIVE_RTOL) * self.best[i] - OBJECTIVE_ATOL:
                improved = True
            if f < self.best[i]:
                self.best[i] = f
        self.count = 0 if improved else self.count + 1
        return self.count >= self.patience
