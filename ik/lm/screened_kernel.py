"""One LM start screened by the sphere pre-check, in one compiled call: the start's check, the run, then the
check of its iterates.

The checked LM (:mod:`kinserve.ik.strategies.checked`) keeps a start only when it is clear of collision and
accepts a converged run only when its answer and every iterate are. The sphere pre-check
(:mod:`kinserve.kinematics.precheck_kernels`) certifies most configurations free; :func:`run_screened_start`
asks it of the start before :func:`kinserve.ik.lm.kernel.run_start` (a start it cannot certify is not run:
the caller's own test decides whether it runs at all, so no run is spent on a start that is then refused),
and of a converged run's rows after it (answer first, one pass over the path), so that a run whose start
and rows it certifies costs no call back into Python. What the pre-check cannot certify it reports, and the
caller's own tests decide (skipping a start, or coal): the answers are those of the separate calls.

Returned flag (the fourth entry; the constants of :mod:`kinserve.ik.lm.status`) and row (the fifth):

* ``START_UNCERTIFIED`` - ``check_start`` and the pre-check could not certify the start ``q0``: nothing ran
  (status ``STALLED``, 0 iterations, 0 rows);
* ``ROWS_CERTIFIED`` - the start ran (certified, or admitted by the caller when not ``check_start``) and,
  when it converged, every row from the answer back to the row after the start (``qs[k-1], ..., qs[1]``) is
  certified free;
* ``ROWS_UNCERTIFIED`` - the run converged and one of the rows after the start is not certified: the row is
  the index, in that answer-first order, of the first one (the rows before it are certified; the caller's
  check goes on from it).

The row is -1 with the other flags.
"""

from __future__ import annotations

import numba
import numpy as np

from kinserve.ik.lm.kernel import run_start
from kinserve.ik.lm.status import CONVERGED, ROWS_CERTIFIED, ROWS_UNCERTIFIED, STALLED, START_UNCERTIFIED
from kinserve.kinematics.kernel_cache import F1, F2, I1, I2, compiled
from kinserve.kinematics.precheck_kernels import first_uncertified_in, packed_workspace

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
    ``q0`` before the run (when False the caller admitted it). ``qs[0]`` is ``q0`` after the call."""
    X, W, placed = packed_workspace(ints)  # (one workspace for both checks: stamp 0 the start, 1.. the rows)
    qs[0, :] = q0
    if check_start and first_uncertified_in(floats, ints, qs[:1], 0, tol, X, W, placed, 0) == 0:
        return STALLED, 0, 0, START_UNCERTIFIED, -1
    status, it, k = run_start(geometry, joints, q0, lo, hi, Td, relaxed, Aw, kept, tp2, tr2, lam0, gain,
                              stall_ratio, patience, max_iter, qs, errs)
    if status != CONVERGED:  # no answer: no rows to check
        return status, it, k, ROWS_CERTIFIED, -1
    row = first_uncertified_in(floats, ints, qs[k - 1:0:-1], 0, tol, X, W, placed, 1)
    if row >= k - 1:
        return status, it, k, ROWS_CERTIFIED, -1
    return status, it, k, ROWS_UNCERTIFIED, row


__all__ = ["run_screened_start"]
