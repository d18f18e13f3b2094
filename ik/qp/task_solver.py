"""Iterated hierarchical IK on tasks and constraints, with restarts (``ik.solve(robot, tasks=...,
constraints=...)``).

Each iteration at ``q``:

1. :meth:`Problem.evaluate` - every task's error and Jacobian, per level.
2. The step of :func:`ik.qp.hierarchy.level_steps`, level by level. **Lazy rows**: the
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
   that is already inside one may only get out. The lower levels' parts of a
   step are scaled down (or corrected to second order) until no goal level
   above them loses more than it may - what it keeps is judged on its own
   residual, and goals already met stay met
   (:class:`~kinserve.ik.qp.level_progress.LowerShares`: the null space is only
   tangent to the set where the higher levels keep their values). A start
   whose goals were not met although the lower levels moved before they were
   is run again with those levels held until the goals are met: from there it
   follows the path of the goal levels alone, so a lower level never keeps a
   start from meeting the goals it meets alone.

Stopping: goals within tolerance (and, with objectives, their merits no longer
improving or the step below :data:`STEP_TOL`:
:class:`~kinserve.ik.qp.level_progress.ObjectiveWatch`); otherwise a stall of
the first unmet goal level (:class:`~kinserve.ik.qp.level_progress.LevelStall`)
or the iteration cap ends the start and
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

import itertools
import math
import time
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from kinserve.ik import numpy_fast
from kinserve.ik import options as _options
from kinserve.ik.problem import Problem
from kinserve.ik.qp.dense_qp import DEFAULT_BACKEND, QPCalls
from kinserve.ik.qp.hierarchy import LevelSteps, level_steps
from kinserve.ik.qp.level_progress import LevelStall, LowerShares, ObjectiveWatch, Trial
from kinserve.ik.result import History, Result
from kinserve.ik.starts.multistart import starts

# the constants of ik.options under the names this module's callers use
DAMPING, DAMPING_GAIN, MAX_STEP = _options.DAMPING, _options.DAMPING_GAIN, _options.MAX_STEP
MAX_ITER, MAX_TIME = _options.MAX_ITER_QP, _options.MAX_TIME_QP
#: Objectives have converged when the step is below this (rad or m).
STEP_TOL = 1e-6
#: Halvings of a step before giving up on it.
MAX_BACKTRACK = 20
#: Iterations with the rows on after a lazy trial failed (an obstacle binds; trials would be wasted).
LAZY_WAIT = 3
STALL_RATIO, STALL_PATIENCE = _options.STALL_RATIO_QP, _options.STALL_PATIENCE
#: Starts already tried by an unconstrained attempt are retried after this many others (``defer_starts``).
#: The constrained runs from the same starts mostly stall in the same local minima (docs/benchmarks.md).
DEFER_BY = 8

_now = time.perf_counter
_clip = numpy_fast.clip


class _Run:
    """Settings of one solve shared by its starts."""

    __slots__ = ("pb", "tp", "tr", "max_iter", "deadline", "budget", "left", "damping", "max_step", "backend",
                 "shortcut", "lazy", "lo", "hi", "gain", "stall_ratio", "stall_patience", "lazy_wait",
                 "calls")

    def __init__(self, pb, tp, tr, max_iter, deadline, damping, max_step, backend, shortcut, lazy,
                 budget=None):
        self.pb, self.tp, self.tr = pb, tp, tr
        # deadline: perf_counter time, None = the clock is not read; budget / left: the iteration budget
        # and what the starts so far left of it (None = no budget)
        self.max_iter, self.deadline = max_iter, deadline
        self.budget = self.left = budget
        self.damping, self.max_step, self.backend = damping, max_step, backend
        self.shortcut, self.lazy = shortcut, lazy
        self.lo, self.hi = pb.robot.lower, pb.robot.upper
        self.gain = pb.gain
        self.lazy_wait = 0
        self.stall_ratio, self.stall_patience = STALL_RATIO, STALL_PATIENCE
        self.calls = QPCalls()  # the QP-solver calls of this solve (Result.info["qp_calls"])


def _step(run: _Run, q, levels, E, m_q) -> tuple[LevelSteps | None, tuple | None]:
    """``(steps, next)``: ``steps`` the step level by level (:func:`level_steps`; None if infeasible),
    ``next = (q + dq, state)`` when the lazy trial was accepted. ``E``: the first level's squared goal
    error (its damping)."""
    pb = run.pb
    lam = DAMPING_GAIN * E + run.damping
    if run.lazy and pb.checked and m_q > 0.0 and run.lazy_wait <= 0:
        lb, ub, G, gl, gu = pb.box_and_rows(q, None, run.max_step, with_checked_rows=False)
        steps = level_steps(levels, lb, ub, G, gl, gu, lam=lam, max_step=run.max_step, backend=run.backend,
                            shortcut=run.shortcut, calls=run.calls)
        if steps is not None:
            qn = _clip(q + steps.total, run.lo, run.hi)
            st = pb.state(qn)
            if st[4] >= (1.0 - run.gain) * m_q:
                return steps, (qn, st)
        run.lazy_wait = LAZY_WAIT  # an obstacle is in the way: take the constrained step for a while
    run.lazy_wait -= 1
    lb, ub, G, gl, gu = pb.box_and_rows(q, None, run.max_step)
    return level_steps(levels, lb, ub, G, gl, gu, lam=lam, max_step=run.max_step, backend=run.backend,
                       shortcut=run.shortcut, calls=run.calls), None


def _corrected(run: _Run, q, m_q, qt, st_t, j):
    """``qt`` (a trial from ``q``) corrected by the step of levels ``0..j`` at ``qt`` (its state ``st_t``),
    as :func:`_accept` takes it from ``q``: the second-order correction of the higher levels' error that
    the lower levels' steps caused (:mod:`ik.qp.level_progress`)."""
    pb = run.pb
    lb, ub, G, gl, gu = pb.box_and_rows(qt, None, run.max_step, with_checked_rows=False)
    lam = DAMPING_GAIN * (st_t[1] ** 2 + st_t[2] ** 2) + run.damping
    steps = level_steps(st_t[0][: j + 1], lb, ub, G, gl, gu, lam=lam, max_step=run.max_step,
                        backend=run.backend, shortcut=run.shortcut, calls=run.calls)
    if steps is None:
        return None, None
    return _accept(run, q, (qt - q) + steps.total, m_q)


def _accept(run: _Run, q, dq, m_q):
    """``(q + alpha dq, state)`` with the largest ``alpha in {1, 1/2, ...}`` keeping the margin
    ``>= min(0, m_q)``."""
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

    Returns (ok, iterations, reason, index of the answer in the record, task errors of it). When the
    goals were not met and the levels below them took part of a step before they were, the start is run
    again with those levels held until the goals are met - from there on the path is the one the goal
    levels take alone - so the lower levels never keep a start from meeting the goals
    (:mod:`ik.qp.level_progress`). ``record`` then holds the second run.
    """
    pb = run.pb
    if st is None:
        st = pb.state(q)
    first = _iterate(run, q, record, st, False, 0)
    if first.ok or not first.lower_before_goals:
        return first[:5]
    for rows in record:
        del rows[:]
    again = _iterate(run, q, record, st, True, first.iterations)
    return again.ok, first.iterations + again.iterations, again.reason, again.answer, again.errors


class _StartEnd(NamedTuple):
    """How one run of a start ended: :func:`_run_start`'s five values, and whether a level below the goals
    took part of a step before the goals were met."""

    ok: bool
    iterations: int
    reason: str
    answer: int | None
    errors: list | None
    lower_before_goals: bool


def _iterate(run: _Run, q, record, st, hold: bool, spent: int) -> _StartEnd:
    """The iterations of one start from ``q`` (its state ``st``); ``hold``: the levels below the last goal
    level are left out until the goals are met; ``spent``: iterations of the budget this start used."""
    pb = run.pb
    stall = LevelStall(len(pb.levels), run.stall_ratio, run.stall_patience)
    objectives = ObjectiveWatch(pb)
    shares = LowerShares(pb, run.tp, run.tr) if len(pb.levels) > 1 else None
    held = len(pb.levels) if not (hold and pb.goal_levels) else pb.goal_levels[-1] + 1
    by_level = len(pb.goal_levels) > 1  # goals on several levels: each judged by its own errors
    own = by_level and pb.goal_levels[0] == 0  # (the first level's damping from its own goals)
    best_ok = best_es = None
    early = False  # a lower level took part of a step before the goals were met
    qs, pes, res = record
    run.lazy_wait = 0
    cap = run.max_iter if run.left is None else max(0, min(run.max_iter, run.left - spent))
    for it in range(cap + 1):
        levels, pe, re, es, m_q = st
        qs.append(q), pes.append(pe), res.append(re)
        within = pe < run.tp and re < run.tr
        if within:
            best_ok, best_es = len(qs) - 1, es
            if not pb.has_objectives:
                return _StartEnd(True, it, "converged", best_ok, es, early)
        if it == cap:
            break
        if within and objectives.stationary(levels):
            return _StartEnd(True, it, "converged (goals within tolerance, objectives stationary)", best_ok,
                             best_es, early)
        level_errors = pb.level_goal_errors(es) if by_level else [(pe, re)]
        if not within and stall.stalled(level_errors, run.tp, run.tr):
            return _StartEnd(best_ok is not None, it, "stalled", best_ok, best_es, early)
        p1, r1 = level_errors[0] if own else (pe, re)
        steps, nxt = _step(run, q, levels if within else levels[:held], p1 * p1 + r1 * r1, m_q)
        if steps is None:
            reason = "the constraints leave no feasible step (QP infeasible)"
            return _StartEnd(best_ok is not None, it, reason, best_ok, best_es, early)
        if within and float(np.abs(steps.total).max()) < STEP_TOL:
            return _StartEnd(True, it, "converged (goals within tolerance, objectives stationary)", best_ok,
                             best_es, early)
        trial = _move(run, q, st, steps, nxt, shares)
        if within and trial.stopped:
            return _StartEnd(True, it, "converged (objectives stopped by the goal tolerance)", best_ok,
                             best_es, early)
        early = early or (trial.taken and not within)
        if trial.q is None:
            return _StartEnd(best_ok is not None, it, "step blocked by a constraint", best_ok, best_es, early)
        q, st = trial.q, trial.state
        if _out_of_time(run):
            return _StartEnd(best_ok is not None, it + 1, "time budget exhausted", best_ok, best_es, early)
    met = best_ok is not None
    return _StartEnd(met, cap, _cap_reason(run, spent + cap, met), best_ok, best_es, early)


def _move(run: _Run, q, st, steps: LevelSteps, nxt, shares: LowerShares | None) -> Trial:
    """The iterate after ``q`` (its state ``st``): the step with the lower levels' shares of
    :class:`LowerShares` (strict priority along the path), or the whole step with one level (``nxt``: the
    lazy trial, when taken)."""
    m_q = st[4]
    if shares is not None and steps.lower:
        return shares.take(q, st, steps, lambda dq: _accept(run, q, dq, m_q), nxt,
                           lambda qt, st_t, j: _corrected(run, q, m_q, qt, st_t, j))
    qn, st_n = nxt if nxt is not None else _accept(run, q, steps.total, m_q)
    return Trial(qn, st_n, (), False, False)


def _out_of_time(run: _Run) -> bool:
    """Whether the solve's deadline has passed (never, without one: the clock is then not read)."""
    return run.deadline is not None and _now() > run.deadline


def _cap_reason(run: _Run, used: int, within: bool) -> str:
    """Why a start that reached its cap ended (``used``: the budget's iterations the start has taken,
    its runs together): the iteration budget, or else the per-start cap."""
    if run.left is not None and used >= run.left:
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
    """Solve a bound :class:`Problem` from the starts of :func:`ik.starts.multistart.starts` (module
    docstring).

    ``evaluate``/``components`` define :attr:`History.task_error` (default:
    the goal tasks' errors, sign ``desired - current``). ``defer_starts``: the first
    so many starts were already tried by the caller (e.g. the unconstrained
    attempts of ``ik.solve``); they come after the next :data:`DEFER_BY`.
    ``iteration_budget``: the iterations of all starts together (None = no
    budget); with it and no ``max_time``, no deadline (an infinite ``max_time``
    is none either) and the clock decides nothing.
    """
    t0 = _now()
    if max_time is None and iteration_budget is None:
        max_time = MAX_TIME
    deadline = t0 + max_time if max_time is not None and math.isfinite(max_time) else None
    run = _Run(pb, tol_pos, tol_rot, int(max_iter), deadline, float(damping), float(max_step), backend,
               bool(shortcut), bool(lazy), None if iteration_budget is None else int(iteration_budget))
    q0, note = _checked_q0(pb, q0)
    sequence = starts(pb.robot, pb.goals, q0, seed, seed_table_enabled, prefer_q0)
    if defer_starts > 0:
        sequence = _deferred(sequence, int(defer_starts), DEFER_BY)
    tried = _run_starts(run, sequence, max_starts)
    report = _Report(method, components, evaluate if evaluate is not None else goal_evaluator(pb),
                     _frame_of(pb), note, t0)
    if tried.best is None:
        return _no_start_result(pb, q0, report)
    return _best_result(run, tried, report)


class _Report(NamedTuple):
    """How a solve reports its answer: the method's name, the history's components (None: the goal tasks',
    :meth:`components_of`) and evaluator (:meth:`History.from_lists`), the goal frames, a note on ``q0``
    ("" = none), the solve's start time."""

    method: str
    components: tuple | None
    evaluate: Callable[[np.ndarray], np.ndarray]
    frame: str
    note: str
    t0: float

    def components_of(self, pb: Problem, es: list) -> tuple:
        """The history's components: the given ones, else :func:`goal_components` of ``pb`` with the task
        errors ``es`` of the answer."""
        return self.components if self.components is not None else goal_components(pb, es)


def _checked_q0(pb: Problem, q0: np.ndarray | None) -> tuple[np.ndarray | None, str]:
    """``(q0 clipped into the limits, note)``; the note says so when ``q0`` violates a checked constraint."""
    if q0 is None:
        return None, ""
    q0 = np.clip(q0, pb.robot.lower, pb.robot.upper)
    if pb.checked and pb.margin(q0) < 0.0:
        return q0, (f"q0 violates a constraint ({pb.describe(q0)}); started from configurations that "
                    "satisfy them")
    return q0, ""


def _no_start_result(pb: Problem, q0: np.ndarray | None, report: _Report) -> Result:
    """The failure of a solve in which no start satisfied the constraints: ``q0`` (or the neutral
    configuration) with its residual."""
    robot = pb.robot
    q = np.clip(robot.neutral() if q0 is None else q0, robot.lower, robot.upper)
    _, pe, re, es = pb.evaluate(q)  # the residual at the returned q: finite, never NaN (no null over HTTP)
    message = "no start configuration satisfying the constraints was found"
    return Result(q=q, success=False, position_error=float(pe), orientation_error=float(re),
                  elapsed=_now() - report.t0, message=f"{message}; {report.note}" if report.note else message,
                  method=report.method, frame=report.frame,
                  history=History.empty(robot.nq, report.components_of(pb, es)))


def _best_result(run: _Run, tried: _Starts, report: _Report) -> Result:
    """The :class:`Result` of the best start (:func:`_run_starts`): its answer, history and message."""
    pb = run.pb
    _, k, (qs, pes, res), reason, ok, es = tried.best
    q = np.array(qs[k])
    if not (ok and es is not None and k == len(qs) - 1 and not pb.has_objectives):
        # (a goals-only start that converged returns right after evaluating its answer: es are its errors)
        _, _, _, es = pb.evaluate(q)
    if ok:
        message = reason
    else:
        message = (f"no start reached tol_pos={run.tp:g} m / tol_rot={run.tr:g} rad in {tried.n_starts} "
                   f"starts ({tried.iterations} iterations; last start: {reason}); best residual "
                   f"{pes[k]:.3g} m / {res[k]:.3g} rad")
    if report.note:
        message = f"{message}; {report.note}"
    hist = History.from_lists(qs[: k + 1], pes[: k + 1], res[: k + 1],
                              components=report.components_of(pb, es), evaluate=report.evaluate)
    return Result(q=q, success=ok, position_error=float(pes[k]), orientation_error=float(res[k]),
                  iterations=tried.iterations, restarts=tried.n_starts - 1, elapsed=_now() - report.t0,
                  message=message, history=hist, method=report.method, frame=report.frame,
                  info={"backend": run.backend, "qp_calls": run.calls.n, "skipped_starts": tried.skipped},
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
        st = pb.state(q)  # (its margin decides whether the start is used; its first iteration reuses it)
        if st[4] < 0.0:
            skipped += 1
            if skipped > 10000 or _out_of_time(run):
                break
            continue
        n_starts += 1
        record = ([], [], [])
        ok, it, reason, k, es = _run_start(run, q, record, st)
        iterations += it
        if run.left is not None:  # a start costs at least one iteration: one ended at once (an infeasible
            run.left -= max(it, 1)  # QP, a blocked step) still bounds the starts an iteration budget allows
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


def goal_components(pb: Problem, es: list) -> tuple:
    """The names of the goal errors' components (:attr:`History.components`): each goal task's own
    ``components``, else its rows' indices, counted from its error in ``es`` (every task's error at one
    configuration, in :meth:`Problem.evaluate`'s order); prefixed with the task's name when there are several
    goals."""
    comps = []
    many = len(pb.goals) > 1
    for t in pb.goals:
        names = getattr(t, "components", None)
        if names is None:
            names = tuple(str(i) for i in range(len(es[pb.error_index(t)])))
        comps.extend(f"{t.name}:{c}" if many else c for c in names)
    return tuple(comps)


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
