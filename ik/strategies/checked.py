"""Unconstrained first, then constrain: the strategy of every request with obstacles or collision checks.

Obstacles rarely bind. So the request is first solved without them, from the usual starts (``q0``, the seed
table's samples nearest the target, random configurations), and an answer counts when it and every iterate of
its run pass the request's checker (:mod:`kinserve.ik.collision.checkers`: obstacles against the link
capsules,
or the robot's collision model). A converged run whose answer passes while its path does not is the answer
alone (a clear configuration within tolerance: the constrained solve started there would return it at once;
its history is that configuration). At most :data:`~kinserve.ik.options.CHECKED_ATTEMPTS` starts and
:data:`~kinserve.ik.options.CHECKED_BUDGET_SHARE` of the budget go to these attempts:

* ``"lm"``: one LM call whose ``accept`` / ``admit`` tests are the checker's;
* ``"closed_form"``: the best closed-form branch among those the checker passes (LM attempts when none);
* ``"qp"``: the QP (centring, extra constraints) from one start at a time, inadmissible starts skipped.

When no attempt passes, a target the checker calls infeasible (its position inside an obstacle with the
frame's origin on the body) fails at once with the reason. Otherwise the constrained QP imposes the
checker's constraint on every iterate, warm-started from the last clear iterate of the first run that failed.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from itertools import islice
from typing import Any

import numpy as np

from kinserve.ik.collision.checkers import ClearanceChecker, last_clear
from kinserve.ik.collision.collision_checker import CollisionChecker
from kinserve.ik.lm.solver import ADMIT_MISSES
from kinserve.ik.options import CHECKED_ATTEMPTS, CHECKED_BUDGET_SHARE
from kinserve.ik.request import SolveRequest
from kinserve.ik.result import History, Result
from kinserve.ik.starts.multistart import frame_starts
from kinserve.ik.strategies.budget import Budget, request_budget
from kinserve.ik.strategies.closed_form import closed_form
from kinserve.ik.strategies.direct import levenberg_marquardt, target_qp

Checker = ClearanceChecker | CollisionChecker
Admit = Callable[..., bool] | None
_CLEAR = "unconstrained, checked"


def make_checker(req: SolveRequest) -> tuple[Checker, Admit]:
    """The request's checker - the collision model's when it has one bound (made with the binding), else the
    link capsules' - and this solve's admission of starts (None: every start runs)."""
    checker = req.collision_checker
    if checker is None:
        return ClearanceChecker(req.robot, req.avoid, _clipped_q0(req)), None
    chosen = _clipped_q0(req) if req.options and req.options.get("prefer_q0") else None
    return checker, checker.admission(chosen)


def _clipped_q0(req: SolveRequest) -> np.ndarray | None:
    """The request's ``q0`` inside the joint limits (a fresh array), or None."""
    # (np.minimum / np.maximum: a third of np.clip's overhead on a short vector)
    return None if req.q0 is None else np.minimum(np.maximum(req.q0, req.robot.lower), req.robot.upper)


def checked_first(req: SolveRequest, attempts: str) -> Result:
    """Solve ``req`` as the module docstring says; ``attempts``: ``"lm"``, ``"closed_form"`` or ``"qp"``."""
    t0 = time.perf_counter()
    checker, admit = make_checker(req)
    budget = request_budget(req)
    found, failed, used, tried = None, None, 0, 0
    if CHECKED_ATTEMPTS > 0:  # (0: straight to the constrained solve)
        run = _ATTEMPTS[attempts]
        found, failed, used, tried = run(req, checker, admit, budget.share(CHECKED_BUDGET_SHARE))
    if found is not None:
        if checker.name == "obstacles":
            found.message += _q0_note(checker)
        found.elapsed = time.perf_counter() - t0
        return found
    reason = checker.infeasible(req.target)  # (asked only now: no passing answer is its common answer)
    if reason:
        return _infeasible(req, t0, reason, used)
    warm = None if failed is None else last_clear(checker, failed)
    stage = budget.after(t0, used)
    res = _constrained(req, checker, warm, stage, tried)
    res.iterations += used  # the attempts' iterations count: the result reports the whole solve
    if stage.iterations is not None and budget.iterations is not None:
        res.message = res.message.replace(f"iteration budget exhausted ({stage.iterations} iterations)",
                                          f"iteration budget exhausted ({budget.iterations} iterations)")
    res.elapsed = time.perf_counter() - t0
    return res


def _q0_note(checker: Checker) -> str:
    """What the message says of a ``q0`` that violates the checker ("" when there is none)."""
    # (the collision checker's admission judged q0 before its run)
    if checker.name != "obstacles" or not checker.q0_inside():
        return ""
    return "; q0 is inside an obstacle: started from a configuration clear of them"


def _passed(res: Result, checker: Checker, attempt: int, answer_only: bool) -> Result:
    """Mark a result that passed the checker (``answer_only``: its path did not; its history is the
    answer)."""
    collision = checker.name == "collision"
    what = "collision free" if collision else "clear of the obstacles"
    if answer_only:
        res.history = res.history.final()
        res.message = (f"converged: an unconstrained run's answer, {what}, taken as a start of its own "
                       "(the run's path was not; the history is that configuration alone)")
    elif attempt == 1 and res.message == "converged":  # the common answer, written once
        res.message = _PASSED_FIRST[collision]
    else:
        res.message += f"; {what} (unconstrained answer and every iterate checked, attempt {attempt})"
    info = res.info
    info["strategy"] = _CLEAR
    if collision:
        info["collision"] = _CLEAR
        info["collision_attempts"] = attempt
    return res


#: :func:`_passed`'s message of a first attempt's converged run, by ``checker.name == "collision"``.
_PASSED_FIRST = {flag: f"converged; {what} (unconstrained answer and every iterate checked, attempt 1)"
                 for flag, what in ((True, "collision free"), (False, "clear of the obstacles"))}


def _cap(req: SolveRequest) -> int:
    starts = req.options.get("max_starts") if req.options else None
    return 1 + CHECKED_ATTEMPTS if starts is None else min(int(starts), 1 + CHECKED_ATTEMPTS)


def _lm_attempts(req: SolveRequest, checker: Checker, admit: Admit, budget: Budget) -> tuple:
    """One LM call: each converged run accepted when the checker passes its rows (answer first)."""
    rejected: list = []
    verdict: list = []
    skip_start = admit is not None  # the start is admitted apart, before its run (by the screen or admit)
    first_violation = checker.first_violation

    def accept(qs: np.ndarray, row: int | None = None) -> bool:
        rows = qs[:0:-1] if skip_start else qs[::-1]
        # row: the screen's first uncertified row (a screen runs with the collision checker only)
        k = first_violation(rows) if row is None else first_violation(rows, row)
        if k == 0:  # the answer itself violates: the next start
            if not rejected:
                rejected.append(qs)
            return False
        verdict.append(k > 0)  # True: the answer passes, its path does not
        return True

    res = levenberg_marquardt(req, budget, accept=accept, admit=admit, screen=checker.screen,
                              max_starts=_cap(req) if req.options else 1 + CHECKED_ATTEMPTS)
    if res.success:  # (verdict is empty when the screen certified the whole run: accept was not asked)
        return _passed(res, checker, 1 + res.restarts, bool(verdict) and verdict[-1]), None, res.iterations, \
            1 + res.restarts
    failed = rejected[0] if rejected else (res.history.iterates() if res.history is not None else None)
    return None, failed, res.iterations, 1 + res.restarts


def _closed_form_attempt(req: SolveRequest, checker: Checker, admit: Admit, budget: Budget) -> tuple:
    """The chosen closed-form branch among those the checker passes; LM attempts when no branch is usable."""
    res = closed_form(req, fallback=True, admissible=lambda q: checker.first_violation(q[None, :]) < 0)
    if res is not None and res.success:
        return _passed(res, checker, 1, False), None, 0, 1
    if req.method == "analytic":
        return None, None, 0, 1
    return _lm_attempts(req, checker, admit, budget)


def _qp_attempts(req: SolveRequest, checker: Checker, admit: Admit, budget: Budget) -> tuple:
    """The QP from one admissible start at a time, in the usual order, each answer checked."""
    t0 = time.perf_counter()
    failed, used, attempt = None, 0, 0
    skip_start = admit is not None
    for start in islice(_admissible_starts(req, admit), _cap(req)):
        if not _within(budget, t0, used):
            break
        attempt += 1
        res = target_qp(req, req.extra, budget.after(t0, used), start, prefer_q0=True, max_starts=1,
                        seed_table_enabled=False)
        used += res.iterations
        if res.success:
            qs = np.asarray(res.history.iterates()).reshape(-1, req.robot.nq)
            rows = np.concatenate([res.q[None, :], qs[:0:-1] if skip_start else qs[::-1]])
            k = checker.first_violation(rows)
            if k != 0:
                return _passed(res, checker, attempt, k > 0), None, used, attempt
        if failed is None and res.history is not None and len(res.history):
            failed = np.asarray(res.history.iterates())
    return None, failed, used, attempt


#: The attempts of each ``attempts`` argument of :func:`checked_first`.
_ATTEMPTS = {"lm": _lm_attempts, "closed_form": _closed_form_attempt, "qp": _qp_attempts}


def _within(budget: Budget, t0: float, used: int) -> bool:
    """True while ``budget`` (from ``t0``, ``used`` iterations spent) is not spent."""
    if budget.seconds is not None and time.perf_counter() - t0 >= budget.seconds:
        return False
    return budget.iterations is None or used < budget.iterations


def _admissible_starts(req: SolveRequest, admit: Admit) -> Any:
    tgt = req.target
    q0 = _clipped_q0(req)
    seq = frame_starts(req.robot, tgt.frame, tgt.frame_id, tgt.T[:3, :3], tgt.T[:3, 3],
                       len(tgt.rot_rows) == 3, q0, req.seed or 0, bool(req.options.get("seed_table", True)),
                       bool(req.options.get("prefer_q0", False)))
    misses = 0
    for q in seq:
        if admit is None or admit(q):
            misses = 0
            yield q
        else:
            misses += 1
            if misses >= ADMIT_MISSES:  # the scene leaves no room for starts
                return


def _constrained(req: SolveRequest, checker: Checker, warm: np.ndarray | None, budget: Budget,
                 tried: int) -> Result:
    """The QP with the checker's constraint hard on every iterate (warm-started at ``warm``)."""
    extra: dict = {"defer_starts": tried}
    q_start = None
    if warm is not None and "prefer_q0" not in req.options:
        q_start, extra["prefer_q0"] = warm, True
    res = target_qp(req, (checker.constraint,) + req.extra, budget, q_start, **extra)
    res.info["strategy"] = "constrained"
    if checker.name == "collision":
        res.info["collision"] = "constrained"
        if res.message.startswith("no start configuration outside the spheres"):
            res.message = "no collision-free start configuration was found within the time budget"
    return res


def _infeasible(req: SolveRequest, t0: float, reason: str, iterations: int) -> Result:
    """The failed result of a target no configuration clear of the obstacles reaches (``iterations``: the
    unconstrained attempts' iterations; the constrained solve is not run)."""
    robot, tgt = req.robot, req.target
    q = np.clip(robot.neutral() if req.q0 is None else req.q0, robot.lower, robot.upper)
    pe, re = tgt.errors_at(robot, q)  # the start's errors: every number of a result is finite
    return Result(q=q, success=False, position_error=pe, orientation_error=re, iterations=iterations,
                  elapsed=time.perf_counter() - t0, message=reason, method="qp", frame=tgt.frame,
                  history=History.empty(robot.nq, tgt.components), info={"strategy": "infeasible",
                                                                         "collision": "infeasible"})
