"""One LM start screened by the sphere pre-check, in one compiled call: the start's admission, the run and the
check of its iterates.

The checked LM (:mod:`kinserve.ik.strategies.checked`) admits a start only when it is clear of collision and
accepts a converged run only when its answer and every iterate are. The sphere pre-check
(:mod:`kinserve.kinematics.precheck_kernels`) certifies most configurations free; :func:`run_screened_start`
asks it before and after :func:`kinserve.ik.lm.kernel.run_start`, so that a start it certifies and a run whose
rows it certifies cost no call back into Python. What it cannot certify it reports, and the caller's own tests
decide (skipping a start, or coal): the answers are those of the separate calls.

Returned flag (the fourth entry; the constants of :mod:`kinserve.ik.lm.status`) and row (the fifth):

* ``START_UNCERTIFIED`` - ``admit_start`` and the pre-check could not certify ``q0``: nothing ran;
* ``ROWS_CERTIFIED`` - the run converged and every row from the answer back to the row after the start
  (``qs[k-1], ..., qs[1]``) is certified free; also when the run did not converge (nothing to check);
* ``ROWS_UNCERTIFIED`` - the run converged and one of those rows is not certified: the row is the index, in
  that answer-first order, of the first one (the rows before it are certified; the caller's check goes on
  from it). The row is -1 with the other flags.

The start row itself is never checked after the run: it was admitted before it (here, or by the caller when
``admit_start`` is False).
"""

from __future__ import annotations

import numba
import numpy as np

from kinserve.ik.lm.kernel import run_start
from kinserve.ik.lm.status import CONVERGED, ROWS_CERTIFIED, ROWS_UNCERTIFIED, START_UNCERTIFIED
from kinserve.kinematics.kernel_cache import F1, F2, I1, I2, compiled
from kinserve.kinematics.precheck_kernels import certify_configuration, first_uncertified

_t = numba.types
_OUT2 = _t.float64[:, ::1]
_SIGNATURE = _t.UniTuple(_t.int64, 5)(F2, I2, F1, F1, F1, F2, _t.boolean, F2, I1, *(_t.float64,) * 5,
                                      _t.int64, _t.int64, _OUT2, _OUT2, F1, I1, _t.float64, _t.boolean)


@compiled(_SIGNATURE)
def run_screened_start(geometry: np.ndarray, joints: np.ndarray, q0: np.ndarray, lo: np.ndarray,
                       hi: np.ndarray, Td: np.ndarray, relaxed: bool, Aw: np.ndarray, kept: np.ndarray,
                       tp2: float, tr2: float, lam0: float, gain: float, stall_ratio: float, patience: int,
                       max_iter: int, qs: np.ndarray, errs: np.ndarray, floats: np.ndarray, ints: np.ndarray,
                       tol: float, admit_start: bool) -> tuple[int, int, int, int, int]:
    """``(status, iterations, rows, flag, row)``: :func:`~kinserve.ik.lm.kernel.run_start`'s answer (its
    arguments first), the flag and the row of the module docstring. ``floats, ints, tol``: the scene's
    pre-check (:class:`~kinserve.kinematics.scene_precheck.PrecheckArguments`); ``admit_start``: certify
    ``q0`` before the run (when False the caller admitted it)."""
    if admit_start and not certify_configuration(floats, ints, q0, tol):
        return CONVERGED, 0, 0, START_UNCERTIFIED, -1
    status, it, k = run_start(geometry, joints, q0, lo, hi, Td, relaxed, Aw, kept, tp2, tr2, lam0, gain,
                              stall_ratio, patience, max_iter, qs, errs)
    if status != CONVERGED or k < 2:  # (k == 1: the start is the answer, admitted already)
        return status, it, k, ROWS_CERTIFIED, -1
    row = first_uncertified(floats, ints, qs[k - 1:0:-1], 0, tol)
    if row >= k - 1:
        return status, it, k, ROWS_CERTIFIED, -1
    return status, it, k, ROWS_UNCERTIFIED, row


__all__ = ["run_screened_start"]
