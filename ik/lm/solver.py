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
  ``|R^T (p* - p)| = |p* - p|`` and the orientation error ``|e_w|`` is the
  geodesic angle, read off the same quantities at no extra cost.
* Relaxed components: the world- or target-axis error and Jacobian rows of
  :mod:`ik.targets`.

Joint limits (projection with an active set): if ``q + dq`` leaves
``[lower, upper]``, the offending joints are fixed at their bound, their
motion is removed from the residual (``e <- e - J_fixed dq_fixed``) and the
step is re-solved for the remaining joints, at most three times; the final
configuration is clipped into the limits. Plain clipping would stall at a
bound, this keeps descending along the free joints. When a single joint
leaves its range (the common case) the re-solve is one triangular solve with
the Cholesky factor of the free step (:func:`_one_joint_at_bound`).

The success test of a full-pose start is exact but runs only when the merit
``|e|^2`` says success is possible; the errors of the history are computed
from the recorded poses when first read (:func:`_run_full_pose`).

Restarts: a start is abandoned when the error stops decreasing (``|e|^2``
has not fallen below 0.85 of its best value so far for 2 iterations in a
row - this also catches oscillations) or after ``max_iter`` iterations; the
next start comes from :func:`ik.starts.multistart.frame_starts` (``q0`` and the
nearest FK samples by pose distance, then seeded random configurations)
until a start converges or ``max_time`` is spent. When none converges the
answer is the iterate with the least squared position + orientation error
over all starts (the runs are scored only then).

The inner loop calls Pinocchio directly on ``robot.model`` / ``robot.data``
(``computeJointJacobians``, ``updateFramePlacement``, ``getFrameJacobian``,
``SE3.actInv``, ``log6``) and LAPACK's Cholesky solver ``posv`` on the
``nq x nq`` normal equations; nothing is validated inside the loop (inputs
are validated once by :func:`ik.solve`).
"""

from __future__ import annotations

import math
import time
from functools import partial
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin
from scipy.linalg import get_lapack_funcs

from kinserve.ik import numpy_fast
from kinserve.kinematics.serial_chain import serial_chain

from kinserve.ik.result import History, Result, task_evaluator
from kinserve.ik.starts.multistart import frame_starts
from kinserve.ik.starts.seed_table import PerModel

if TYPE_CHECKING:  # annotations only
    from kinserve.kinematics.robot import Robot

    from kinserve.ik.targets import Target

#: Floor ``lambda_0`` of the damping (m^2 / rad^2 units of ``|e|^2``).
DAMPING = 1e-5
#: Gain of the error term of the damping.
DAMPING_GAIN = 0.01
#: A start is abandoned when ``|e|^2`` has not fallen below this fraction of its best value so far ...
STALL_RATIO = 0.85
#: ... this many iterations in a row.
STALL_PATIENCE = 2
#: Iteration cap of one start.
MAX_ITER = 60
#: Default time budget of one solve (s).
MAX_TIME = 0.1
#: The exact success test runs once ``|e|^2 < NEAR tol_pos^2 + tol_rot^2`` (``NEAR >= (pi/2)^2``, see :func:`_run_full_pose`).
NEAR = 2.5
#: Starts on chains of revolute / prismatic joints run in the compiled kernel of :mod:`ik.lm.kernel`, full pose or
#: relaxed (False: always Pinocchio's algorithms from Python, e.g. to compare the two).
COMPILED = True
#: Consecutive starts ``admit`` may refuse before :func:`solve_lm` gives up (the caller's scene leaves little room).
ADMIT_MISSES = 20
#: Failed starts kept unscored (their errors computed only if no start converges) before they are scored.
UNSCORED_RUNS = 16

_posv, _potrs = get_lapack_funcs(("posv", "potrs"), (np.eye(2),))
_dot = np.dot
_add = np.add
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
    """``q + dq`` for the damped step, with the active-set handling of the limits (module docstring).

    Masks are float/bool vectors (``J * free`` rather than fancy indexing) and
    the "did the clip change anything" test compares Python lists: on 7-vectors
    these are the cheapest operations NumPy offers.
    """
    n = q.shape[0]
    A = J.T.dot(J)  # C-ordered and symmetric: A.T is the Fortran-ordered view LAPACK takes without a copy
    A.ravel()[:: n + 1] += lam
    qn = q + _posv(A.T, e.dot(J), 0, 1, 1)[1]  # (a, b, lower, overwrite_a, overwrite_b): positional is cheaper
    qc = _clip(qn, lo, hi)
    if qc.tolist() == qn.tolist():
        return qn
    return _limited_step(J, e, lam, q, lo, hi, qn, qc)


def _limited_step(J, e, lam, q, lo, hi, qn, qc, fixed=None, passes=3):
    """The active-set re-solve of :func:`_bounded_step` once the free step ``qn`` left the limits (``qc`` clipped).

    ``fixed`` (bool mask, default: the joints the clip moved) are held at
    their bound ``qc``; at most ``passes`` re-solves, each adding the joints
    its step pushed out.
    """
    n = q.shape[0]
    if fixed is None:
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


def _one_joint_at_bound(U, J, e, lam, q, lo, hi, qn, qc, qnl, qcl, eye):
    """:func:`_limited_step` for a free step ``qn = q + x`` that left the limits, cheaper when one joint did.

    Fixing joint ``j`` at its bound ``b`` is the equality-constrained problem
    ``min |J dq - e|^2 + lam |dq|^2`` s.t. ``q_j + dq_j = b``; with
    ``A = J^T J + lam I`` its solution is ``x + mu A^-1 u_j`` (``u_j`` the
    unit vector, ``mu`` such that the constraint holds) - the masked re-solve
    over the other joints, from one triangular solve with the Cholesky
    factor ``U`` of ``A`` that the free step left behind. Several joints out
    (or a second one pushed out by this step) go to the masked re-solve.
    ``qnl`` / ``qcl`` are ``qn`` / ``qc`` as lists.
    """
    out = [i for i, (a, b) in enumerate(zip(qnl, qcl)) if a != b]
    if len(out) > 1:
        return _limited_step(J, e, lam, q, lo, hi, qn, qc)
    j = out[0]
    c = _potrs(U, eye[j])[0]  # column j of A^-1
    b = qcl[j]
    qn = qn + ((b - qnl[j]) / c[j]) * c
    qn[j] = b
    qc = _clip(qn, lo, hi)
    if qc.tolist() == qn.tolist():
        return qn
    fixed = qc != qn
    fixed[j] = True
    return _limited_step(J, e, lam, q, lo, hi, qn, qc, fixed, 2)


def _run_full_pose(model, data, fid, Td, q, lo, hi, tp2, tr2, max_iter, lam0, qs, poses):
    """One LM start on a full-pose target (LOCAL log6 error).

    Returns ``(converged, iterations, reason, pe2, re2)``; the squared errors
    are those of the last configuration when it converged (else None). Every
    evaluated ``q`` and its pose error ``oMf^-1 oMd`` are appended to ``qs`` /
    ``poses`` (the errors of the history are read off them lazily, see
    :func:`_squared_errors`).

    The merit is ``E = |e|^2`` with ``e = [v; w] = log6(oMf^-1 oMd)``. The
    exact success test (``|t|^2 < tol_pos^2`` and ``|w|^2 < tol_rot^2``, ``t``
    the translation of ``oMf^-1 oMd``) runs only when ``E`` is below
    ``NEAR * tol_pos^2 + tol_rot^2``: since ``t = V(w) v`` with ``V`` the
    left Jacobian of SO(3), whose singular values lie in ``[2/pi, 1]`` for
    angles up to ``pi``, ``|v| <= (pi/2) |t|``, so every converged
    configuration passes that cheap test.
    """
    best = math.inf
    near = NEAR * tp2 + tr2
    n = q.shape[0]
    A = eye = None
    stalls = 0
    for it in range(max_iter + 1):  # the last pass only evaluates the final configuration
        _cjj(model, data, q)
        iMd = _ufp(model, data, fid).actInv(Td)
        e = _log6(iMd).vector
        E = e.dot(e)
        qs.append(q)
        poses.append(iMd)
        if E < near:
            t = iMd.translation
            pe2 = t.dot(t)
            if pe2 < tp2:
                w = e[3:]
                re2 = w.dot(w)
                if re2 < tr2:
                    return True, it, "converged", pe2, re2
        if it == max_iter:
            break
        if E < STALL_RATIO * best:
            best = E
            stalls = 0
        else:
            stalls += 1
            if stalls >= STALL_PATIENCE:
                return False, it + 1, "stalled", None, None
        # the damped step (_bounded_step inlined; A and its diagonal are buffers reused across iterations)
        J = _gfj(model, data, fid, _LOCAL)
        lam = DAMPING_GAIN * E + lam0
        if A is None:
            A = np.empty((n, n))
            Ad, At = A.reshape(n * n)[:: n + 1], A.T  # At: the Fortran-ordered view LAPACK takes without a copy
        _dot(J.T, J, A)
        _add(Ad, lam, Ad)
        U, x, _ = _posv(At, e.dot(J), 0, 1, 1)  # (a, b, lower, overwrite_a, overwrite_b): U overwrites A
        qn = q + x
        qc = _clip(qn, lo, hi)
        qnl, qcl = qn.tolist(), qc.tolist()
        if qnl == qcl:  # on 7-vectors comparing Python lists is the cheapest test NumPy allows
            q = qn
        else:
            if eye is None:
                eye = np.eye(n)
            q = _one_joint_at_bound(U, J, e, lam, q, lo, hi, qn, qc, qnl, qcl, eye)
    return False, max_iter, "iteration limit", None, None


def _squared_errors(poses) -> tuple[list, list]:
    """``(|t|^2, |w|^2)`` lists of pose errors ``oMf^-1 oMd`` (``t`` its translation, ``w = log6(.)`` angular part)."""
    pos2, rot2 = [], []
    for M in poses:
        t = M.translation
        w = _log6(M).vector[3:]
        pos2.append(t.dot(t))
        rot2.append(w.dot(w))
    return pos2, rot2


def _run_relaxed(model, data, fid, target, q, lo, hi, tp2, tr2, max_iter, lam0, qs, pe2s, re2s):
    """One LM start on the kept rows of a relaxed target (world/target axes)."""
    best = math.inf
    stalls = 0
    kept = target.kept
    it = 0
    while True:
        _cjj(model, data, q)
        M = _ufp(model, data, fid)
        e6 = target.error6(M.rotation, M.translation)
        pe, re = target.errors_from6(e6)
        pe2, re2 = pe * pe, re * re
        qs.append(q)
        pe2s.append(pe2)
        re2s.append(re2)
        if pe2 < tp2 and re2 < tr2:
            return True, it, "converged"
        if it >= max_iter:
            return False, it, "iteration limit"
        E = pe2 + re2
        if E < STALL_RATIO * best:
            best = E
            stalls = 0
        else:
            stalls += 1
            if stalls >= STALL_PATIENCE:
                return False, it + 1, "stalled"
        J = target.jacobian(_gfj(model, data, fid, _LWA))
        q = _bounded_step(J, e6[kept], DAMPING_GAIN * E + lam0, q, lo, hi)
        it += 1


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
    accept: Callable[[Sequence[np.ndarray]], bool] | None = None,
    admit: Callable[[np.ndarray], bool] | None = None,
) -> Result:
    """Levenberg-Marquardt IK of ``target`` (an :class:`ik.targets.Target`) with restarts.

    ``q0`` must already be validated (or None). ``max_time`` (s, default
    :data:`MAX_TIME`) bounds the restarts; ``max_starts`` optionally caps their
    number (deterministic stopping). ``seed_table_enabled=False`` restarts from
    ``q0`` and random configurations only; ``prefer_q0`` makes ``q0`` the first
    start even when a table sample is closer to the target. ``accept``: a test
    of a converged run's configurations (start first, answer last); a run it
    rejects counts as not converged and the next start is tried (e.g. a
    collision check of every iterate, :mod:`ik.collision.solve`). When no run
    is accepted the answer is the best unconverged run's, or the first rejected
    run's when every run converged. ``admit``: a test of a start before its
    run (e.g. a collision check); a start it refuses is skipped without a run
    and without counting as a start (at most :data:`ADMIT_MISSES` in a row).
    """
    fid = target.frame_id
    # before the clock starts: the first call in a process imports the kernel (loaded from Numba's cache or compiled)
    compiled = compiled_chain(robot, fid)
    t0 = _now()
    deadline = t0 + (MAX_TIME if max_time is None else max_time)
    model, data = robot.model, robot.data
    lo, hi = robot.lower, robot.upper
    tp2, tr2 = tol_pos * tol_pos, tol_rot * tol_rot

    starts = None
    if q0 is not None:
        q0 = _clip(q0, lo, hi)  # a fresh array
    if prefer_q0 and q0 is not None:
        q = q0  # the first start of every sequence with prefer_q0: the table is ranked only if a restart needs it
    else:
        starts = _starts(robot, target, q0, seed, seed_table_enabled, prefer_q0)
        q = next(starts)

    best = None  # (k, qs, pos2, rot2, pe2, re2): the run that answers and its best iterate k
    unscored = []  # failed runs (qs, (pos2, rot2) or poses): scored only if no start converges
    rejected = None  # the first converged run ``accept`` rejected
    iterations = 0
    n_starts = 0
    misses = 0
    ok = False
    while True:
        if admit is None or admit(q):
            misses = 0
            n_starts += 1
            if compiled is not None:
                ok, it, run = _compiled_run(compiled, q, lo, hi, target, tp2, tr2, max_iter, damping)
            else:
                ok, it, run = _python_run(model, data, fid, target, q, lo, hi, tp2, tr2, max_iter, damping)
            iterations += it
            if ok:
                if accept is None or accept(run[1][: run[0] + 1]):
                    best = run
                    break
                ok = False
                if rejected is None:
                    rejected = run
            else:
                unscored.append(run)
            if len(unscored) >= UNSCORED_RUNS:
                best = _best_run(unscored, best)
            if _now() > deadline or (max_starts is not None and n_starts >= max_starts):
                break
        else:  # refused: no run, not counted as a start
            misses += 1
            if misses >= ADMIT_MISSES or _now() > deadline:
                break
        if starts is None:
            starts = _starts(robot, target, q0, seed, seed_table_enabled, prefer_q0)
            next(starts)  # q0, already tried
        q = next(starts)
    if not ok:
        best = _best_run(unscored, best) if unscored or best is not None else rejected
    if best is None:  # every start refused: the (clipped) first one, evaluated
        ok, _, run = _python_run(model, data, fid, target, q0 if q0 is not None else q, lo, hi, tp2, tr2, 0, damping)
        best = run if ok else _best_run([run], None)
        ok = False

    k, qs, pos2, rot2, pe2, re2 = best
    pe, re = _sqrt(pe2), _sqrt(re2)
    evaluate = task_evaluator(robot, target)
    if rot2 is None:
        hist = History.from_deferred(qs, pos2, k + 1, target.components, evaluate)
    else:
        hist = History.from_squared(qs, pos2, rot2, k + 1, target.components, evaluate)
    if ok:
        message = "converged"
    elif not n_starts:
        message = f"no start was admitted ({misses} refused in a row by the caller's test)"
    elif best is rejected:
        message = (f"every start that converged ({n_starts} starts, {iterations} iterations) was rejected "
                   "(its answer or path failed the caller's test)")
    else:
        message = (
            f"no start converged to tol_pos={tol_pos:g} m / tol_rot={tol_rot:g} rad in {n_starts} starts "
            f"({iterations} iterations, {'time budget exhausted' if _now() > deadline else 'start limit reached'}); "
            f"best residual {pe:.3g} m / {re:.3g} rad (target may be out of reach)"
        )
    # positional: the fields of Result in order (half the cost of keywords)
    return Result(qs[k].copy(), ok, pe, re, iterations, max(n_starts - 1, 0), _now() - t0, message, hist, "lm",
                  target.frame)


def _python_run(model, data, fid, target, q, lo, hi, tp2, tr2, max_iter, damping) -> tuple[bool, int, tuple]:
    """One start with Pinocchio's algorithms (:func:`_run_full_pose` / :func:`_run_relaxed`).

    Returns ``(converged, iterations, run)``: ``run`` is the answer tuple
    ``(k, qs, pos2, rot2, pe2, re2)`` when converged, else ``(qs, errors)``
    for :func:`_best_run` (``errors`` the recorded poses of a full-pose run,
    scored only if needed, or the ``(pos2, rot2)`` lists of a relaxed one).
    """
    qs = []
    if target.full:
        poses = []
        ok, it, _, pe2, re2 = _run_full_pose(model, data, fid, target.se3, q, lo, hi, tp2, tr2, max_iter, damping,
                                             qs, poses)
        if ok:  # the history's errors are read off ``poses`` only when asked for
            return True, it, (len(qs) - 1, qs, partial(_squared_errors, poses), None, pe2, re2)
        return False, it, (qs, poses)
    pos2, rot2 = [], []
    ok, it, _ = _run_relaxed(model, data, fid, target, q, lo, hi, tp2, tr2, max_iter, damping, qs, pos2, rot2)
    if ok:
        return True, it, (len(qs) - 1, qs, pos2, rot2, pos2[-1], rot2[-1])
    return False, it, (qs, (pos2, rot2))


def _compiled_run(compiled, q, lo, hi, target, tp2, tr2, max_iter, damping) -> tuple[bool, int, tuple]:
    """:func:`_python_run` as one call of :func:`ik.lm.kernel.run_start` (full pose or relaxed).

    The iterates and their exact squared errors come back as arrays (``qs``
    ``(k, nq)``), the same tuples as :func:`_python_run`'s.
    """
    run, geometry, joints = compiled
    rows = max_iter + 1
    qs, errs = np.empty((rows, q.shape[0])), np.empty((rows, 2))
    status, it, k = run(geometry, joints, q, lo, hi, target.T, not target.full, target.A, target.kept, tp2, tr2,
                        float(damping), DAMPING_GAIN, STALL_RATIO, STALL_PATIENCE, int(max_iter), qs, errs)
    qs, pos2, rot2 = qs[:k], errs[:k, 0], errs[:k, 1]
    if status == 0:
        return True, it, (k - 1, qs, pos2, rot2, pos2[k - 1], rot2[k - 1])
    return False, it, (qs, (pos2, rot2))


_chains = PerModel()


def compiled_chain(robot: Robot, fid: int) -> tuple | None:
    """``(kernel, geometry, joints)`` of the chain to frame ``fid`` (cached per model), or None.

    None when :data:`COMPILED` is off, Numba is not installed or the chain has
    joints the kernel does not model
    (:func:`kinserve.kinematics.serial_chain.serial_chain`).
    """
    if not COMPILED:
        return None
    entry = _chains.get(robot.model)
    if entry is not None and fid in entry:
        return entry[fid]
    chain = serial_chain(robot.model, fid)
    value = None
    if chain is not None:
        try:
            from kinserve.ik.lm import kernel as lm_kernel
        except ImportError:  # Numba missing: Pinocchio's algorithms from Python
            pass
        else:
            value = (lm_kernel.run_start, *chain)
    _chains.setdefault(robot.model)[fid] = value
    return value


def _best_run(runs: list, best: tuple | None) -> tuple:
    """``best`` updated with the failed runs ``[(qs, poses or (pos2, rot2)), ...]`` (emptied), in start order.

    A run's best iterate has the least ``|t|^2 + |w|^2``; an earlier run wins ties.
    """
    for qs, errors in runs:
        pos2, rot2 = errors if type(errors) is tuple else _squared_errors(errors)
        k = int(np.argmin(np.add(pos2, rot2)))
        if best is None or pos2[k] + rot2[k] < best[4] + best[5]:
            best = (k, qs, pos2, rot2, pos2[k], rot2[k])
    runs.clear()
    return best


def _starts(robot, target, q0, seed, table_enabled, prefer_q0):
    """The start sequence of :func:`ik.starts.multistart.frame_starts` for ``target``."""
    return frame_starts(robot, target.frame, target.frame_id, target.T[:3, :3], target.T[:3, 3],
                        len(target.rot_rows) == 3, q0, seed, table_enabled, prefer_q0)
