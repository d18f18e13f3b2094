"""One LM start screened by the sphere pre-check, in one compiled call: the run, then the check of its
iterates and of its start.

The checked LM (:mod:`kinserve.ik.strategies.checked`) keeps a start only when it is clear of collision and
accepts a converged run only when its answer and every iterate are. The sphere pre-check
(:mod:`kinserve.kinematics.precheck_kernels`) certifies most configurations free; :func:`run_screened_start`
asks it after :func:`kinserve.ik.lm.kernel.run_start`, so that a run whose rows and start it certifies costs
no call back into Python. A converged run's start is checked as the last of its rows (answer first, start
last: one pass of the pre-check over the whole path, right after the run); a run that did not converge has
its start alone checked. A run whose start the caller then refuses is discarded, as the start would have
been refused before it. What the pre-check cannot certify it reports, and the caller's own tests decide
(skipping a start, or coal): the answers are those of the separate calls.

Returned flag (the fourth entry; the constants of :mod:`kinserve.ik.lm.status`) and row (the fifth):

* ``START_UNCERTIFIED`` - ``check_start`` and the pre-check could not certify the start ``q0``; when the run
  converged, every other row of it is certified;
* ``ROWS_CERTIFIED`` - every row the flag speaks for is certified free: when the run converged, the rows
  from the answer back to the row after the start (``qs[k-1], ..., qs[1]``) and the start when
  ``check_start``; when it did not, the start when ``check_start`` (no answer: its other rows are not
  checked);
* ``ROWS_UNCERTIFIED`` - the run converged and one of the rows after the start is not certified: the row is
  the index, in that answer-first order, of the first one (the rows before it are certified; the caller's
  check goes on from it). The start is then not checked here (the caller's own test decides it).

The row is -1 with the other flags. With ``check_start`` False the caller has admitted the start itself.
"""

from __future__ import annotations

import numba
import numpy as np

from kinserve.ik.lm.kernel import run_start
from kinserve.ik.lm.status import CONVERGED, ROWS_CERTIFIED, ROWS_UNCERTIFIED, START_UNCERTIFIED
from kinserve.kinematics.kernel_cache import F1, F2, I1, I2, compiled
from kinserve.kinematics.precheck_kernels import first_uncertified

_t = numba.types
_OUT2 = _t.float64[:, ::1]
_SIGNATURE = _t.UniTuple(_t.int64, 5)(F2, I2, F1, F1, F1, F2, _t.boolean, F2, I1, *(_t.float64,) * 5,
                                      _t.int64, _t.int64, _OUT2, _OUT2, F1, I1, _t.float64, _t.boolean)


@compiled(_SIGNATURE)
def run_screened_start(geometry: np.ndarray, joints: np.ndarray, q0: np.ndarray, lo: np.ndarray,
                       hi: np.ndarray, Td: np.ndarray, relaxed: bool, Aw: np.ndarray, kept: np.ndarray,
                       tp2: float, tr2: float, lam0: float, gain: float, stall_ratio: float, patience: int,
                       max_iter: int, qs: np.ndarray, errs: np.ndarray, floats: np.ndarray, ints: np.ndarray,
                       tol: float, check_start: bool) -> tuple[int, int, int, int, int]:
    """``(status, iterations, rows, flag, row)``: :func:`~kinserve.ik.lm.kernel.run_start`'s answer (its
    arguments first), the flag and the row of the module docstring. ``floats, ints, tol``: the scene's
    pre-check (:class:`~kinserve.kinematics.scene_precheck.PrecheckArguments`); ``check_start``: certify
    ``q0`` too (when False the caller admitted it). ``qs[0]`` is ``q0`` after the run."""
    status, it, k = run_start(geometry, joints, q0, lo, hi, Td, relaxed, Aw, kept, tp2, tr2, lam0, gain,
                              stall_ratio, patience, max_iter, qs, errs)
    if status != CONVERGED:  # no answer: only the start may need its certificate
        if check_start and first_uncertified(floats, ints, qs[:1], 0, tol) == 0:
            return status, it, k, START_UNCERTIFIED, -1
        return status, it, k, ROWS_CERTIFIED, -1
    last = k - 1 if check_start else k - 2  # the last row to check, in answer-first order
    row = first_uncertified(floats, ints, qs[k - 1::-1] if check_start else qs[k - 1:0:-1], 0, tol)
    if row > last:
        return status, it, k, ROWS_CERTIFIED, -1
    if row == k - 1:  # (check_start: every row before the start is certified)
        return status, it, k, START_UNCERTIFIED, -1
    return status, it, k, ROWS_UNCERTIFIED, row


__all__ = ["run_screened_start"]
