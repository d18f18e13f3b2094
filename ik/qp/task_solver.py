"""Iterated hierarchical IK on tasks and constraints, with restarts (``ik.solve(robot, tasks=..., constraints=...)``).

Each iteration at ``q``:

1. :meth:`Problem.evaluate` - every task's error and Jacobian, per level.
2. The step of :func:`ik.qp.hierarchy.hierarchical_step`. **Lazy rows**: the
   constraints with a true check (obstacles) are first left out; the trial
   iterate ``q + dq`` is checked, and if every margin still holds
   ``m(q + dq) >= (1 - xi) m(q)`` (what the velocity damper would have asked
   for, measured on the true clearances, ``xi`` the damper gain), the step
   is taken as is - the rows could not have changed it. Otherwise the rows
   at ``q`` are added and the constrained QP is solved. Far from obstacles
   this costs one forward-kinematics pass and one distance evaluation per
   iteration, no gradient and no QP.
3. Step back-off: the step is halved until the true margin at ``q + alpha dq``
   is ``>= min(0, m(q))`` - an iterate never enters an obstacle, and a start
   that is already inside one may only get out. Once the goals are within
   tolerance, the lower-level part of a step is halved until the goals stay
   within tolerance (the null space is only tangent to the self-motion
   manifold).

Stopping: goals within tolerance (and, with objectives, the step below
:data:`STEP_TOL`); otherwise a stall or the iteration cap ends the start and
the next start of :func:`ik.starts.multistart.starts` begins, until ``max_time``
or the ``iteration_budget`` (the iterations of every start together) is spent.
With an ``iteration_budget`` and no ``max_time`` the clock is never read to
decide anything: the answer depends only on the inputs and ``seed``.
Starts whose margin is negative (in collision) are skipped; a ``q0`` in
collision is not an error - the message says the solve began elsewhere.

Determinism: no state survives between solves (the QP solver is called
statelessly, the starts come from a fixed table and ``seed``), so the same
inputs give bit-identical answers unless the time budget cut the solve (it
cannot with an ``iteration_budget`` alone).
"""

from __future__ import annotations

from collections.abc import Callable
import itertools
import math
import time
from typing import NamedTuple

import numpy as np

from kinserve.ik import numpy_fast
from kinserve.ik.qp.dense_qp import DEFAULT_BACKEND, backend_calls
from kinserve.ik.qp.hierarchy import hierarchical_step
from kinserve.ik.starts.multistart import starts
from kinserve.ik.problem import Problem
from kinserve.ik.result import History, Result

#: Floor of the first level's Levenberg-Marquardt damping.
DAMPING = 1e-5
#: Gain of the error term of the damping.
DAMPING_GAIN = 0.01
#: Trust region: largest joint step per iteration (rad or m).
MAX_STEP = 1.0
#: Iteration cap of one start.
MAX_ITER = 200
#: Default time budget (s).
MAX_TIME = 0.5
#: Objectives have converged when the step is below this (rad or m).
STEP_TOL = 1e-6
#: Halvings of a step before giving up on it.
MAX_BACKTRACK = 20
#: Iterations with the rows on after a lazy trial failed (an obstacle binds; trials would be wasted).
LAZY_WAIT = 3
#: Stall detection: best goal error^2 not improved by this factor for STALL_PATIENCE iterations (then the
#: next start). Measured on Panda with spheres and boxes in the way: abandoning early and restarting beats
#: patience (the constrained iterations creep along an obstacle's surface when they stall); on the starts
#: that follow the unconstrained attempts of ik.solve, a ratio of 0.7 took 11 % less time than 0.85.
STALL_RATIO = 0.7
STALL_PATIENCE = 2
#: Starts already tried by an unconstrained attempt are retried after this many others (``defer_starts``).
#: Measured on Panda with spheres and boxes (the targets whose unconstrained attempts all fail): the
#: constrained runs from the same starts mostly stall in the same local minima; deferring them by 8 took
#: 16 % less time on targets not used to choose it.
DEFER_BY = 8

_now = time.perf_counter
_clip = numpy_fast.clip


class _Run:
    """Settings of one solve shared by its starts."""

    __slots__ = ("pb", "tp", "tr", "max_iter", "deadline", "budget", "left", "damping", "max_step", "backend",
                 "shortcut", "lazy", "lo", "hi", "gain", "stall_ratio", "stall_patience", "lazy_wait")

    def __init__(self, pb, tp, tr, max_iter, deadline, damping, max_step, backend, shortcut, lazy, budget=None):
        self.pb, self.tp, self.tr = pb, tp, tr
        # deadline: perf_counter time, None = the clock is not read; budget / left: the iteration budget
        # and what the starts so far left of it (None = no budget)
        self.max_iter, self.deadline = max_iter, deadline
        self.budget = self.left = budget
        self.damping, self.max_step, self.backend, self.shortcut, self.lazy = damping, max_step, backend, shortcut, lazy
        self.lo, self.hi = pb.robot.lower, pb.robot.upper
        self.gain = pb.gain
        self.lazy_wait = 0
        self.stall_ratio, self.stall_patience = STALL_RATIO, STALL_PATIENCE


def _step(run: _Run, q, levels, E, m_q):
    """``(dq, dq_lower, next)`` - ``next = (q + dq, state)`` when the lazy trial was accepted; dq None if infeasible."""
    pb = run.pb
    lam = DAMPING_GAIN * E + run.damping
    if run.lazy and pb.checked and m_q > 0.0 and run.lazy_wait <= 0:
        lb, ub, G, l, u = pb.box_and_rows(q, None, run.max_step, with_checked_rows=False)
        dq, dq2 = hierarchical_step(levels, lb, ub, G, l, u, lam=lam, max_step=run.max_step, backend=run.backend,
                                    shortcut=run.shortcut)
        if dq is not None:
            qn = _clip(q + dq, run.lo, run.hi)
            st = pb.state(qn)
            if st[4] >= (1.0 - run.gain) * m_q:
                return dq, dq2, (qn, st)
        run.lazy_wait = LAZY_WAIT  # an obstacle is in the way: take the constrained step for a while
    run.lazy_wait -= 1
    lb, ub, G, l, u = pb.box_and_rows(q, None, run.max_step)
    dq, dq2 = hierarchical_step(levels, lb, ub, G, l, u, lam=lam, max_step=run.max_step, backend=run.backend,
                                shortcut=run.shortcut)
    return dq, dq2, None


def _accept(run: _Run, q, dq, m_q):
    """``(q + alpha dq, state)`` with the largest ``alpha in {1, 1/2, ...}`` keeping the margin ``>= min(0, m_q)``."""
    pb = run.pb
    floor = min(0.0, m_q)
    alpha = 1.0
    for _ in range(MAX_BACKTRACK):
        qn = _clip(q + alpha * dq, run.lo, run.hi)
        st = pb.state(qn)
        if st[4] >= floor:
            return qn, st
        alpha *= 0.5
    return None, None


def _run_start(run: _Run, q, record, st=None):
    """One start (``st``: its state when already evaluated).

    Returns (ok, iterations, reason, index of the answer in the record, task errors of it).
    """
    pb = run.pb
    best_E = math.inf
    stalls = 0
    best_ok = None
    best_es = None
    beta_prev = 1.0
    qs, pes, res = record
    run.lazy_wait = 0
    if st is None:
        st = pb.state(q)
    cap = run.max_iter if run.left is None else min(run.max_iter, run.left)
    for it in range(cap + 1):
        levels, pe, re, es, m_q = st
        qs.append(q)
        pes.append(pe)
        res.append(re)
        within = pe < run.tp and re < run.tr
        if within:
            best_ok = len(qs) - 1
            best_es = es
            if not pb.has_objectives:
                return True, it, "converged", best_ok, es
        if it == cap:
            break
        E = pe * pe + re * re
        if not within:
            if E < run.stall_ratio * best_E:
                best_E = E
                stalls = 0
            else:
                stalls += 1
                if stalls >= run.stall_patience:
                    return best_ok is not None, it, "stalled", best_ok, best_es
        dq, dq2, nxt = _step(run, q, levels, E, m_q)
        if dq is None:
            return best_ok is not None, it, "the constraints leave no feasible step (QP infeasible)", best_ok, best_es
        if within and float(np.abs(dq).max()) < STEP_TOL:
            return True, it, "converged (goals within tolerance, objectives stationary)", best_ok, best_es
        if within and dq2 is not None:
            # strict priority along the path: a lower-level step may not take the goals out of tolerance
            dq1 = dq - dq2
            beta = min(1.0, 2.0 * beta_prev)
            for _ in range(MAX_BACKTRACK):
                qn, st_n = _accept(run, q, dq1 + beta * dq2, m_q)
                if qn is None or (st_n[1] < run.tp and st_n[2] < run.tr):
                    break
                beta *= 0.5
            else:
                return True, it, "converged (objectives stopped by the goal tolerance)", best_ok, best_es
            beta_prev = beta
        elif nxt is not None:
            qn, st_n = nxt
        else:
            qn, st_n = _accept(run, q, dq, m_q)
        if qn is None:
            return best_ok is not None, it, "step blocked by a constraint", best_ok, best_es
        q, st = qn, st_n
        if _out_of_time(run):
            return best_ok is not None, it + 1, "time budget exhausted", best_ok, best_es
    return best_ok is not None, cap, _cap_reason(run, cap, best_ok is not None), best_ok, best_es


def _out_of_time(run: _Run) -> bool:
    """Whether the solve's deadline has passed (never, without one: the clock is then not read)."""
    return run.deadline is not None and _now() > run.deadline


def _cap_reason(run: _Run, cap: int, within: bool) -> str:
    """Why a start that ran ``cap`` iterations ended: the iteration budget or the per-start cap."""
    if run.left is not None and cap >= run.left:
        return f"iteration budget exhausted ({run.budget} iterations)"
    return "converged (iteration limit reached while improving objectives)" if within else "iteration limit"


def solve_problem(
    pb: Problem,
    q0: np.ndarray | None = None,
    *,
    tol_pos: float = 1e-4,
    tol_rot: float = 1e-3,
    max_time: float | None = None,
    seed: int | None = None,
    max_iter: int = MAX_ITER,
    iteration_budget: int | None = None,
    max_step: float = MAX_STEP,
    damping: float = DAMPING,
    max_starts: int | None = None,
    seed_table_enabled: bool = True,
    prefer_q0: bool = False,
    backend: str = DEFAULT_BACKEND,
    shortcut: bool = True,
    lazy: bool = True,
    method: str = "qp",
    evaluate: Callable[[np.ndarray], np.ndarray] | None = None,
    components: tuple | None = None,
    defer_starts: int = 0,
) -> Result:
    """Solve a bound :class:`Problem` from the starts of :func:`ik.starts.multistart.starts` (module docstring).

    ``evaluate``/``components`` define :attr:`History.task_error` (default:
    the goal tasks' errors, sign ``desired - current``). ``defer_starts``: the first
    so many starts were already tried by the caller (e.g. the unconstrained
    attempts of ``ik.solve``); they come after the next :data:`DEFER_BY`.
    ``iteration_budget``: the iterations of all starts together (None = no
    budget); with it and no ``max_time``, no deadline (an infinite ``max_time``
    is none either) and the clock decides nothing.
    """
    t0 = _now()
    calls0 = backend_calls()
    if max_time is None and iteration_budget is None:
        max_time = MAX_TIME
    deadline = t0 + max_time if max_time is not None and math.isfinite(max_time) else None
    robot = pb.robot
    run = _Run(pb, tol_pos, tol_rot, int(max_iter), deadline, float(damping), float(max_step), backend,
               bool(shortcut), bool(lazy), None if iteration_budget is None else int(iteration_budget))
    lo, hi = robot.lower, robot.upper
    note = ""
    if q0 is not None:
        q0 = np.clip(q0, lo, hi)
        if pb.checked and pb.margin(q0) < 0.0:
            note = f"q0 violates a constraint ({pb.describe(q0)}); started from configurations that satisfy them"
    sequence = starts(robot, pb.goals, q0, seed, seed_table_enabled, prefer_q0)
    if defer_starts > 0:
        sequence = _deferred(sequence, int(defer_starts), DEFER_BY)
    best, iterations, n_starts, skipped = _run_starts(run, sequence, max_starts)
    comps = components if components is not None else _components(pb)
    evaluate = evaluate if evaluate is not None else goal_evaluator(pb)
    frame = _frame_of(pb)
    if best is None:
        q = np.clip(robot.neutral() if q0 is None else q0, lo, hi)
        _, pe, re, _ = pb.evaluate(q)  # the residual at the returned q: finite, never NaN (no null over HTTP)
        return Result(q=q, success=False, position_error=float(pe), orientation_error=float(re), elapsed=_now() - t0,
                      message="no start configuration satisfying the constraints was found" + (f"; {note}" if note else ""),
                      method=method, frame=frame, history=History.empty(robot.nq, comps))
    _, k, (qs, pes, res), reason, ok, es = best
    q = np.array(qs[k])
    if not (ok and es is not None and k == len(qs) - 1 and not pb.has_objectives):
        # (a goals-only start that converged returns right after evaluating its answer: es are its errors)
        _, _, _, es = pb.evaluate(q)
    if ok:
        message = reason
    else:
        message = (f"no start reached tol_pos={tol_pos:g} m / tol_rot={tol_rot:g} rad in {n_starts} starts "
                   f"({iterations} iterations; last start: {reason}); best residual {pes[k]:.3g} m / {res[k]:.3g} rad")
    if note:
        message = f"{message}; {note}"
    hist = History.from_lists(qs[: k + 1], pes[: k + 1], res[: k + 1], components=comps, evaluate=evaluate)
    return Result(q=q, success=ok, position_error=float(pes[k]), orientation_error=float(res[k]),
                  iterations=iterations, restarts=n_starts - 1, elapsed=_now() - t0, message=message, history=hist,
                  method=method, frame=frame, info={"backend": backend, "qp_calls": backend_calls() - calls0, "skipped_starts": skipped},
                  task_errors=pb.task_errors(es))


class _Starts(NamedTuple):
    """What the starts of one solve gave: the best start's ``(score, answer index, record, reason, ok,
    task errors)`` (None when no start was usable), and the counts."""

    best: tuple | None
    iterations: int
    n_starts: int
    skipped: int


def _run_starts(run: _Run, sequence, max_starts: int | None) -> _Starts:
    """Run the starts of ``sequence`` until one succeeds, ``max_starts`` ran, or the time or the iteration
    budget is spent; the best start is a successful one, else the one with the smallest goal error."""
    pb = run.pb
    best = None
    iterations = n_starts = skipped = 0
    for q in sequence:
        st = pb.state(q)  # (its margin decides whether the start is used; the start's first iteration reuses it)
        if st[4] < 0.0:
            skipped += 1
            if skipped > 10000 or _out_of_time(run):
                break
            continue
        n_starts += 1
        record = ([], [], [])
        ok, it, reason, k, es = _run_start(run, q, record, st)
        iterations += it
        if run.left is not None:
            run.left -= it
        qs, pes, res = record
        if k is None:
            k = int(np.argmin(np.square(pes) + np.square(res)))
        score = pes[k] ** 2 + res[k] ** 2
        if best is None or ok or score < best[0]:
            best = (score, k, record, reason, ok, es)
        if ok or _out_of_time(run) or run.left == 0 or (max_starts is not None and n_starts >= max_starts):
            break
    if best is not None and not best[4] and run.left == 0 and "iteration budget" not in best[3]:
        best = (*best[:3], f"{best[3]}; iteration budget exhausted ({run.budget} iterations)", *best[4:])
    return _Starts(best, iterations, n_starts, skipped)


def _deferred(sequence, n: int, by: int):
    """``sequence`` with its first ``n`` items moved after the ``by`` items that follow them."""
    it = iter(sequence)
    first = list(itertools.islice(it, n))
    yield from itertools.islice(it, by)
    yield from first
    yield from it


def _frame_of(pb: Problem) -> str:
    frames = [t.frame_name for t in pb.goals if hasattr(t, "frame_name")]
    return ",".join(frames)


def _components(pb: Problem) -> tuple:
    comps = []
    many = len(pb.goals) > 1
    for t in pb.goals:
        names = getattr(t, "components", None)
        if names is None:
            e, _ = t.compute(pb.robot, _kinematics(pb, pb.robot.neutral()), pb.robot.neutral())
            names = tuple(str(i) for i in range(len(e)))
        comps.extend(f"{t.name}:{c}" if many else c for c in names)
    return tuple(comps)


def _kinematics(pb: Problem, q):
    import pinocchio as pin

    d = pb.check_data
    pin.computeJointJacobians(pb.model, d, q)
    return d


def goal_evaluator(pb: Problem) -> Callable[[np.ndarray], np.ndarray]:
    """``q -> desired - current`` errors of the goal tasks, concatenated (for :attr:`History.task_error`)."""
    holder = {}

    def evaluate(q):
        import pinocchio as pin

        r = holder.get("robot")
        if r is None:
            r = holder["robot"] = pb.robot.copy()
        pin.computeJointJacobians(r.model, r.data, q)
        return -np.concatenate([t.compute(r, r.data, q)[0] for t in pb.goals]) if pb.goals else np.zeros(0)

    return evaluate
