"""Levenberg-Marquardt inverse kinematics with joint limits (method ``"lm"``).

For problems whose only inequalities are the joint limits. Each iteration
linearises the task at ``q`` and takes the damped Gauss-Newton step

    (J^T J + lambda I) dq = J^T e,      lambda = 0.01 |e|^2 + lambda_0

(an error-dependent damping in the spirit of Sugihara's: larger far from
the target, where the linearisation is poor; ``lambda_0`` keeps the system
positive definite at singular configurations, so the step never explodes).

* Full pose (nothing relaxed): ``e = log6(oMf^-1 oMd)`` is the twist that
  takes the frame to the target, in the frame's own axes, and ``J`` is the
  frame Jacobian in the same (LOCAL) axes. The position error is
  ``|R^T (p* - p)| = |p* - p|`` and the orientation error ``|e_w|`` the
  geodesic angle.
* Relaxed components: the world- or target-axis error and Jacobian rows of
  :mod:`ik.targets`.

Joint limits (projection with an active set): if ``q + dq`` leaves
``[lower, upper]``, the offending joints are fixed at their bound, their
motion is removed from the residual (``e <- e - J_fixed dq_fixed``) and the
step is re-solved for the remaining joints, at most three times; the final
configuration is clipped into the limits. Plain clipping would stall at a
bound, this keeps descending along the free joints.

One iteration, two implementations: the compiled kernel of :mod:`ik.lm.kernel`
for chains of one-DoF revolute / prismatic joints (every robot kinserve loads),
and :func:`python_start` with Pinocchio's algorithms for any other chain (the
same steps, the same iterates to rounding).

Restarts: a start is abandoned when the error stops decreasing (``|e|^2``
has not fallen below 0.85 of its best value so far for 2 iterations in a
row - this also catches oscillations) or after ``max_iter`` iterations; the
next start comes from :func:`ik.starts.multistart.frame_starts` (``q0`` and the
nearest FK samples by pose distance, then seeded random configurations)
until a start converges or a limit is met: ``max_time`` (s), ``max_starts``,
or ``iteration_budget`` (iterations over all starts together; with it and no
``max_time`` the clock is never read, so the answer depends only on the
inputs and the seed). When none converges the answer is the iterate with the
least squared position + orientation error over all starts.

Nothing is validated inside the loop (inputs are validated once by the request
of :func:`ik.solve`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from functools import partial
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin
from scipy.linalg import get_lapack_funcs

from kinserve.ik import numpy_fast
from kinserve.ik import options as _options
from kinserve.ik.lm.chains import compiled_chain, compiled_chains
from kinserve.ik.lm.screen import LMScreen
from kinserve.ik.lm.status import CONVERGED, ITERATION_LIMIT, ROWS_UNCERTIFIED, STALLED, START_UNCERTIFIED
from kinserve.ik.result import History, Result, task_evaluator
from kinserve.ik.starts.multistart import frame_starts

if TYPE_CHECKING:  # annotations only
    from collections.abc import Iterator

    from kinserve.ik.targets import Target
    from kinserve.kinematics.robot import Robot

__all__ = ["solve_lm", "python_start", "compiled_chain", "failure_message"]

# the constants of ik.options under the names this module's callers and kernels use
DAMPING, DAMPING_GAIN, STALL_PATIENCE = _options.DAMPING, _options.DAMPING_GAIN, _options.STALL_PATIENCE
STALL_RATIO, MAX_ITER, MAX_TIME = _options.STALL_RATIO_LM, _options.MAX_ITER_LM, _options.MAX_TIME_LM
#: Consecutive starts ``admit`` may refuse before :func:`solve_lm` gives up (the caller's scene leaves little
#: room).
ADMIT_MISSES = 20
#: Failed starts kept unscored (their best iterate found only if no start converges) before they are scored.
UNSCORED_RUNS = 16

_posv = get_lapack_funcs(("posv",), (np.eye(2),))[0]
_cjj = pin.computeJointJacobians
_ufp = pin.updateFramePlacement
_gfj = pin.getFrameJacobian
_log6 = pin.log6
_LOCAL = pin.LOCAL
_LWA = pin.LOCAL_WORLD_ALIGNED
_now = time.perf_counter
_sqrt = math.sqrt
_clip = numpy_fast.clip


def _bounded_step(J, e, lam, q, lo, hi):
    """``q + dq`` for the damped step, with the active-set handling of the limits (module docstring)."""
    n = q.shape[0]
    A = J.T.dot(J)  # C-ordered and symmetric: A.T is the Fortran-ordered view LAPACK takes without a copy
    A.ravel()[:: n + 1] += lam
    qn = q + _posv(A.T, e.dot(J), 0, 1, 1)[1]  # (a, b, lower, overwrite_a, overwrite_b): positional, cheaper
    qc = _clip(qn, lo, hi)
    if qc.tolist() == qn.tolist():
        return qn
    return _limited_step(J, e, lam, q, lo, hi, qn, qc)


def _limited_step(J, e, lam, q, lo, hi, qn, qc, passes=3):
    """The active-set re-solve of :func:`_bounded_step` once the free step ``qn`` left the limits (``qc``:
    clipped).

    The joints the clip moved are held at their bound ``qc``; at most
    ``passes`` re-solves, each adding the joints its step pushed out.
    """
    n = q.shape[0]
    fixed = qc != qn
    for _ in range(passes):
        free = 1.0 - fixed
        dfix = (qc - q) * fixed
        Jf = J * free
        A = Jf.T.dot(Jf)
        A.ravel()[:: n + 1] += lam
        dq = _posv(A.T, (e - J.dot(dfix)).dot(Jf), 0, 1, 1)[1]
        qn = q + dq * free + dfix
        qc = _clip(qn, lo, hi)
        if qc.tolist() == qn.tolist():
            return qn
        fixed = fixed | (qc != qn)
    return qc


def _linearise(model, data, fid: int, target: Target, goal: pin.SE3 | None, q: np.ndarray) -> tuple:
    """``(e, J, |t|^2, |w|^2, |e|^2)`` at ``q``: the error and Jacobian rows of the step, the squared errors.

    Full pose (``goal``: the target as an SE3): ``e = log6(oMf^-1 oMd)`` and the LOCAL Jacobian (errors of
    ``oMf^-1 oMd``); relaxed: the kept rows of :meth:`ik.targets.Target.error6` and of the world-aligned
    Jacobian in the target's axes.
    """
    _cjj(model, data, q)
    M = _ufp(model, data, fid)
    if target.full:
        iMd = M.actInv(goal)
        e = _log6(iMd).vector
        t, w = iMd.translation, e[3:]
        return e, _gfj(model, data, fid, _LOCAL), t.dot(t), w.dot(w), e.dot(e)
    e6 = target.error6(M.rotation, M.translation)
    ep, ew = e6[:3][target.pos_rows], e6[3:][target.rot_rows]
    pe2, re2 = ep.dot(ep), ew.dot(ew)
    return e6[target.kept], target.jacobian(_gfj(model, data, fid, _LWA)), pe2, re2, pe2 + re2


def python_start(model: pin.Model, data: pin.Data, target: Target, q0: np.ndarray, lo: np.ndarray,
                 hi: np.ndarray, tp2: float, tr2: float, lam0: float, max_iter: int, qs: np.ndarray,
                 errs: np.ndarray) -> tuple[int, int, int]:
    """One start from ``q0`` with Pinocchio's algorithms: the iteration of :func:`ik.lm.kernel.run_start`, for
    any chain, with its contract: ``(status, iterations, rows)`` (:mod:`ik.lm.status`), ``qs[:rows]`` the
    evaluated configurations (``qs[0] = q0``) and ``errs[:rows]`` their squared position / orientation
    errors (both need ``max_iter + 1`` rows); converged when ``|t|^2 < tp2`` and ``|w|^2 < tr2``."""
    fid = target.frame_id
    goal = target.se3 if target.full else None
    qs[0] = q0
    best = math.inf
    stalls = 0
    for it in range(max_iter + 1):  # the last pass only evaluates the final configuration
        q = qs[it]
        e, J, pe2, re2, E = _linearise(model, data, fid, target, goal, q)
        errs[it, 0], errs[it, 1] = pe2, re2
        if pe2 < tp2 and re2 < tr2:
            return CONVERGED, it, it + 1
        if it == max_iter:
            break
        if E < STALL_RATIO * best:
            best = E
            stalls = 0
        else:
            stalls += 1
            if stalls >= STALL_PATIENCE:
                return STALLED, it + 1, it + 1
        qs[it + 1] = _bounded_step(J, e, DAMPING_GAIN * E + lam0, q, lo, hi)
    return ITERATION_LIMIT, max_iter, max_iter + 1


def _run_start(problem: tuple, q: np.ndarray, max_iter: int) -> tuple[bool, int, tuple]:
    """One start: ``(converged, iterations, run)``; ``run`` is ``(k, qs, pos2, rot2, pe2, re2)`` (the answer
    row ``k``) when converged, else ``(qs, pos2, rot2)`` for :func:`_best_run`."""
    robot, target, chain, tp2, tr2, damping = problem[:6]
    rows = max_iter + 1
    qs, errs = np.empty((rows, q.shape[0])), np.empty((rows, 2))
    if chain is not None:
        status, it, k = chain.kernel.run_start(chain.geometry, chain.joints, q, robot.lower, robot.upper,
                                               target.T, not target.full, target.A, target.kept, tp2, tr2,
                                               damping, DAMPING_GAIN, STALL_RATIO, STALL_PATIENCE, max_iter,
                                               qs, errs)
    else:
        status, it, k = python_start(robot.model, robot.data, target, q, robot.lower, robot.upper, tp2, tr2,
                                     damping, max_iter, qs, errs)
    return _run(status, it, k, qs, errs)


def _run(status: int, it: int, k: int, qs: np.ndarray, errs: np.ndarray) -> tuple[bool, int, tuple]:
    """:func:`_run_start`'s answer from a kernel's ``(status, iterations, rows)`` and its buffers."""
    qs, pos2, rot2 = qs[:k], errs[:k, 0], errs[:k, 1]
    if status == CONVERGED:
        return True, it, (k - 1, qs, pos2, rot2, pos2[k - 1], rot2[k - 1])
    return False, it, (qs, pos2, rot2)


def _run_screened(problem: tuple, q: np.ndarray, max_iter: int, check_start: bool) -> tuple:
    """One start through the screen's compiled call (:mod:`ik.lm.screened_kernel`): :func:`_run_start`'s
    answer, the screen's flag and its first uncertified row (answer first; -1: none). ``check_start``: the
    screen certifies the start first (not certified: nothing runs, the answer is None)."""
    robot, target, chain, tp2, tr2, damping = problem[:6]
    screen = problem[8]
    rows = max_iter + 1
    qs, errs = np.empty((rows, q.shape[0])), np.empty((rows, 2))
    status, it, k, flag, row = screen.run(chain.geometry, chain.joints, q, robot.lower, robot.upper, target.T,
                                          not target.full, target.A, target.kept, tp2, tr2, damping,
                                          DAMPING_GAIN, STALL_RATIO, STALL_PATIENCE, max_iter, qs, errs,
                                          screen.floats, screen.ints, screen.tolerance, check_start)
    if flag == START_UNCERTIFIED:
        return False, 0, None, flag, row
    return (*_run(status, it, k, qs, errs), flag, row)


#: What became of one start (:func:`_try_start`).
REFUSED, FAILED, REJECTED, ACCEPTED = range(4)


def _try_start(problem: tuple, q: np.ndarray, cap: int, accept, admit) -> tuple[int, int, tuple | None]:
    """One start of :func:`_search`: ``(outcome, iterations, run)``, outcome :data:`REFUSED` (``admit`` said
    no: the start does not run), :data:`FAILED` (no convergence), :data:`REJECTED` (converged, ``accept``
    said no) or :data:`ACCEPTED`. Without a screen ``admit`` is asked before the run. With a screen
    (``problem[8]``) the compiled call certifies the start before its run and the run's rows after it;
    ``admit`` is asked only of a start it could not certify (admitted: the start runs in a second call that
    does not check it) and ``accept`` only of a converged run whose rows it could not all certify, with the
    index of the first of those (answer first: ``accept(qs, row)``)."""
    if problem[8] is None or problem[2] is None:
        if admit is not None and not admit(q):
            return REFUSED, 0, None
        ok, it, run = _run_start(problem, q, cap)
        row = None
    else:
        ok, it, run, flag, row = _run_screened(problem, q, cap, admit is not None)
        if flag == START_UNCERTIFIED:
            if not admit(q, False):  # (the screen has already failed to certify it)
                return REFUSED, 0, None
            ok, it, run, flag, row = _run_screened(problem, q, cap, False)
        if flag != ROWS_UNCERTIFIED:
            return (ACCEPTED if ok else FAILED), it, run
    if not ok:
        return FAILED, it, run
    if accept is None or (accept(run[1][: run[0] + 1]) if row is None else accept(run[1][: run[0] + 1], row)):
        return ACCEPTED, it, run
    return REJECTED, it, run


def _best_run(runs: list, best: tuple | None) -> tuple:
    """``best`` updated with the failed runs ``[(qs, pos2, rot2), ...]`` (emptied), in start order.

    A run's best iterate has the least ``|t|^2 + |w|^2`` (its first such row); an earlier run wins ties.
    """
    for qs, pos2, rot2 in runs:
        k = int(np.argmin(pos2 + rot2))
        if best is None or pos2[k] + rot2[k] < best[4] + best[5]:
            best = (k, qs, pos2, rot2, pos2[k], rot2[k])
    runs.clear()
    return best


def _stop_reason(deadline: float | None, n_starts: int, max_starts: int | None, iterations: int,
                 budget: int | None) -> str:
    """Why the search stops after a failed start ("" when it goes on); reads the clock for a deadline only."""
    if budget is not None and iterations >= budget:
        return f"iteration budget exhausted ({iterations} iterations)"
    if max_starts is not None and n_starts >= max_starts:
        return "start limit reached"
    if deadline is not None and _now() > deadline:
        return "time budget exhausted"
    return ""


def _search(problem: tuple, first: np.ndarray | None, starts: Callable[[], Iterator[np.ndarray]],
            limits: tuple, accept, admit) -> tuple:
    """Starts until one converges (and ``accept`` takes it) or a limit is met (see :func:`solve_lm`).

    ``first``: the first start when the sequence need not be built for it (``prefer_q0``); ``limits`` =
    ``(deadline or None, max_starts, iteration_budget, max_iter)``. Returns ``(converged, best run, first
    rejected run, starts, iterations, refused in a row, stop reason, last start offered)``.
    """
    deadline, max_starts, budget, max_iter = limits
    sequence = None
    q = first
    if q is None:
        sequence = starts()
        q = next(sequence)
    best = rejected = None
    unscored: list = []  # failed runs: scored only if no start converges (or when many have piled up)
    iterations = n_starts = misses = 0
    while True:
        cap = max_iter if budget is None else min(max_iter, budget - iterations)
        outcome, it, run = _try_start(problem, q, cap, accept, admit)
        if outcome == ACCEPTED:
            return True, run, rejected, n_starts + 1, iterations + it, 0, "converged", q
        if outcome != REFUSED:
            misses = 0
            n_starts += 1
            iterations += it
            if outcome == REJECTED:
                rejected = run if rejected is None else rejected
            else:
                unscored.append(run)
            if len(unscored) >= UNSCORED_RUNS:
                best = _best_run(unscored, best)
            stop = _stop_reason(deadline, n_starts, max_starts, iterations, budget)
        else:  # refused: nothing ran, not counted as a start
            misses += 1
            stop = _refusal_stop(deadline, misses, iterations, budget)
        if stop:
            best = _best_run(unscored, best) if unscored or best is not None else None
            return False, best, rejected, n_starts, iterations, misses, stop, q
        if sequence is None:
            sequence = starts()
            next(sequence)  # q0, already tried
        q = next(sequence)


def _refusal_stop(deadline: float | None, misses: int, iterations: int, budget: int | None) -> str:
    """Why the search stops after a refused start ("" when it goes on)."""
    if budget is not None and iterations >= budget:
        return f"iteration budget exhausted ({iterations} iterations)"
    if deadline is not None and _now() > deadline:
        return "time budget exhausted"
    return f"{misses} starts refused in a row by the caller's test" if misses >= ADMIT_MISSES else ""


def failure_message(tol_pos: float, tol_rot: float, n_starts: int, iterations: int, stop: str, pe: float,
                    re: float) -> str:
    """The message of an LM solve in which no start converged (``stop``: why the search stopped)."""
    where = (f"in {n_starts} starts: {stop}" if stop.startswith("iteration budget")
             else f"in {n_starts} starts ({iterations} iterations, {stop})")
    return (f"no start converged to tol_pos={tol_pos:g} m / tol_rot={tol_rot:g} rad {where}; "
            f"best residual {pe:.3g} m / {re:.3g} rad (target may be out of reach)")


def solve_lm(
    robot: Robot,
    target: Target,
    q0: np.ndarray | None = None,
    *,
    tol_pos: float = 1e-4,
    tol_rot: float = 1e-3,
    max_time: float | None = None,
    seed: int | None = None,
    max_iter: int = MAX_ITER,
    damping: float = DAMPING,
    max_starts: int | None = None,
    seed_table_enabled: bool = True,
    prefer_q0: bool = False,
    iteration_budget: int | None = None,
    accept: Callable[..., bool] | None = None,
    admit: Callable[..., bool] | None = None,
    screen: LMScreen | None = None,
) -> Result:
    """Levenberg-Marquardt IK of ``target`` (an :class:`ik.targets.Target`) with restarts.

    ``q0`` must already be validated (or None). Limits: ``max_time`` (s, default :data:`MAX_TIME`; with
    ``iteration_budget`` and no ``max_time`` there is no time limit and the clock is never read),
    ``max_starts`` (starts), ``iteration_budget`` (iterations over all starts; message "iteration budget
    exhausted (N iterations)"). ``seed_table_enabled=False`` restarts from ``q0`` and random configurations
    only; ``prefer_q0`` makes ``q0`` the first start even when a table sample is closer to the target.
    ``accept``: a test of a converged run's configurations (start first, answer last); a run it rejects
    counts as not converged and the next start is tried (e.g. a collision check of every iterate). When no
    run is accepted the answer is the best unconverged run's, or the first rejected run's when every run
    converged. ``admit``: a test of a start before its run (e.g. a collision check); a start it refuses is
    skipped without a run and without counting as a start (at most :data:`ADMIT_MISSES` in a row).
    ``screen``: a pre-check run in the same compiled call as each start, before and after the run
    (:class:`LMScreen`, compiled chains only): ``admit`` is then asked only of the starts it cannot certify
    (before their run, as ``admit(q, False)``: the screen has not certified ``q``), and ``accept`` only of
    the converged runs whose rows it cannot all certify, as ``accept(qs, row)``: ``row`` is the first row
    the screen could not certify, counted from the answer back (the start left out), so the rows after the
    answer and before it are certified (the screen's "certified" must imply both tests' yes).
    """
    chains = robot.lm_chains  # (compiled_chain inlined: warmed before the clock starts)
    chain = (chains if chains is not None else compiled_chains(robot)).chains[target.frame_id]
    t0 = _now()
    clocked = max_time is not None or iteration_budget is None
    deadline = t0 + (MAX_TIME if max_time is None else max_time) if clocked else None
    if q0 is not None:
        q0 = _clip(q0, robot.lower, robot.upper)  # a fresh array
    problem = (robot, target, chain, tol_pos * tol_pos, tol_rot * tol_rot, float(damping), tol_pos, tol_rot,
               screen)
    starts = partial(_starts, robot, target, q0, seed, seed_table_enabled, prefer_q0)
    outcome = _search(problem, q0 if prefer_q0 else None, starts,
                      (deadline, max_starts, iteration_budget, int(max_iter)), accept, admit)
    return _result(problem, outcome, q0, t0)


def _result(problem: tuple, outcome: tuple, q0: np.ndarray | None, t0: float) -> Result:
    """The :class:`Result` of a search (:func:`_search`): its answer, history and message."""
    robot, target, tol_pos, tol_rot = problem[0], problem[1], problem[6], problem[7]
    ok, best, rejected, n_starts, iterations, misses, stop, q_last = outcome
    if best is None:
        best = rejected
    if best is None:  # every start refused: the (clipped) q0 or the last start offered, evaluated
        done, _, run = _run_start(problem, q0 if q0 is not None else q_last, 0)
        best = run if done else _best_run([run], None)
    k, qs, pos2, rot2, pe2, re2 = best
    pe, re = _sqrt(pe2), _sqrt(re2)
    hist = History.from_squared(qs, pos2, rot2, k + 1, target.components, task_evaluator(robot, target))
    if ok:
        message = "converged"
    elif not n_starts:
        message = f"no start was admitted ({misses} refused in a row by the caller's test)"
    elif best is rejected:
        message = (f"every start that converged ({n_starts} starts, {iterations} iterations) was rejected "
                   "(its answer or path failed the caller's test)")
    else:
        message = failure_message(tol_pos, tol_rot, n_starts, iterations, stop, pe, re)
    # positional: the fields of Result in order (half the cost of keywords)
    return Result(qs[k].copy(), ok, pe, re, iterations, max(n_starts - 1, 0), _now() - t0, message, hist,
                  "lm", target.frame)


def _starts(robot, target, q0, seed, table_enabled, prefer_q0):
    """The start sequence of :func:`ik.starts.multistart.frame_starts` for ``target``."""
    return frame_starts(robot, target.frame, target.frame_id, target.T[:3, :3], target.T[:3, 3],
                        len(target.rot_rows) == 3, q0, seed, table_enabled, prefer_q0)

