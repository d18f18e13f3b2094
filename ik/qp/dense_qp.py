"""Small dense QPs of the differential IK, solved exactly and deterministically.

    minimise   1/2 x^T P x + c^T x          (P positive definite)
    subject to lb <= x <= ub,   l <= A x <= u

1. The unconstrained minimiser ``x = -P^-1 c`` (one Cholesky solve, LAPACK
   ``posv``): the problem is convex, so if ``x`` satisfies every bound and row
   it *is* the solution.
2. Box only: a few primal active-set rounds (:func:`box_active_set`),
   accepted only when the KKT conditions hold.
3. Otherwise a dense active-set solver: DAQP (default; no state is kept
   between calls, so the same problem always gives the same bytes) or any
   solver known to ``qpsolvers`` by name (called statelessly as well).

Returns None when the problem is infeasible or the solver fails.
"""

from __future__ import annotations

import math
import threading
import warnings

import numpy as np
from scipy.linalg import get_lapack_funcs

from kinserve.kinematics.errors import InputError

from kinserve.ik import numpy_fast

_posv = get_lapack_funcs(("posv",), (np.eye(2),))[0]
_clip = numpy_fast.clip

#: Stand-in for an infinite bound in the solvers' arrays.
BIG = 1e20

#: The default backend: DAQP when installed, else OSQP through qpsolvers.
try:  # pragma: no cover - depends on the environment
    import daqp as _daqp

    DEFAULT_BACKEND = "daqp"
except ImportError:  # pragma: no cover
    _daqp = None
    DEFAULT_BACKEND = "osqp"


_counter = threading.local()


def backend_calls() -> int:
    """Number of QP-solver calls made so far by this thread (the shortcuts do not count)."""
    return getattr(_counter, "n", 0)


def box_active_set(P: np.ndarray, c: np.ndarray, lb: np.ndarray, ub: np.ndarray, x: np.ndarray,
                   rounds: int = 3) -> np.ndarray | None:
    """Exact solution of ``min 1/2 x^T P x + c^T x, lb <= x <= ub`` by a few primal active-set rounds, or None.

    Starting from the unconstrained minimiser ``x``, the coordinates outside
    the box are fixed at their bound and the reduced problem is solved for
    the others; the answer is returned only if it satisfies the KKT
    conditions - feasible, and the gradient ``g = P x + c`` has the sign of a
    non-negative multiplier on every fixed coordinate (``g_i <= 0`` at an upper
    bound, ``g_i >= 0`` at a lower bound) - so it *is* the QP's solution.
    Otherwise None (the caller asks the QP solver).
    """
    n = x.shape[0]
    at_hi = x > ub
    at_lo = x < lb
    for _ in range(rounds):
        fixed = at_hi | at_lo
        free = 1.0 - fixed
        xs = np.where(at_hi, ub, np.where(at_lo, lb, 0.0))
        Pm = P * free[:, None] * free[None, :]
        Pm.flat[:: n + 1] += fixed
        rhs = free * -(c + P.dot(xs)) + xs
        xs = _posv(Pm, rhs)[1]
        if _clip(xs, lb, ub).tolist() != xs.tolist():
            at_hi = at_hi | (xs > ub)
            at_lo = at_lo | (xs < lb)
            continue
        grad = P.dot(xs) + c
        tol = 1e-12 * (1.0 + np.abs(grad).max())
        if (grad[at_hi] <= tol).all() and (grad[at_lo] >= -tol).all():
            return xs
        return None
    return None


def solve_dense(P: np.ndarray, c: np.ndarray, lb: np.ndarray, ub: np.ndarray, A: np.ndarray | None = None,
                l: np.ndarray | None = None, u: np.ndarray | None = None, backend: str = DEFAULT_BACKEND,
                shortcut: bool = True) -> np.ndarray | None:
    """Solve the QP of the module docstring; None when infeasible. ``A`` may be None or have 0 rows."""
    has_rows = A is not None and A.shape[0] > 0
    if shortcut:
        x = _posv(P, -c)[1]
        if _clip(x, lb, ub).tolist() == x.tolist():
            if not has_rows:
                return x
            Ax = A.dot(x)
            if (Ax >= l).all() and (Ax <= u).all():
                return x
        elif not has_rows:
            xs = box_active_set(P, c, lb, ub, x)
            if xs is not None:
                return xs
    return _backend_solve(P, c, lb, ub, A if has_rows else None, l, u, backend)


_concat = np.concatenate
_add_reduce = np.add.reduce
_NO_ROWS: dict = {}
_SENSE: dict = {}


def _no_rows(n: int) -> np.ndarray:
    """An empty ``(0, n)`` row matrix (cached; it has no entries to write)."""
    a = _NO_ROWS.get(n)
    if a is None:
        a = _NO_ROWS[n] = np.zeros((0, n))
    return a


def _sense(k: int) -> np.ndarray:
    """DAQP's constraint kinds: ``k`` zeros (plain inequalities; DAQP reads them and does not write them)."""
    a = _SENSE.get(k)
    if a is None:
        a = _SENSE[k] = np.zeros(k, dtype=np.int32)
    return a


#: Tolerances of the iterative solvers reached through qpsolvers: their defaults (1e-5 for proxqp) leave
#: steps microradians off the QP's solution, which the active-set solvers (daqp, quadprog) solve exactly.
_TIGHT = {"osqp": {"eps_abs": 1e-9, "eps_rel": 1e-9, "max_iter": 20000, "polishing": True},
          "proxqp": {"eps_abs": 1e-9, "eps_rel": 0.0}}


def _backend_solve(P, c, lb, ub, A, l, u, backend):
    _counter.n = getattr(_counter, "n", 0) + 1
    n = c.shape[0]
    if backend == "daqp" and _daqp is not None:
        if A is None:
            bu, bl, Am = ub.copy(), lb.copy(), _no_rows(n)  # writable copies (DAQP takes writable buffers)
        else:
            bu, bl, Am = _concat((ub, u)), _concat((lb, l)), A
        # infinite bounds are passed as they are: DAQP treats bounds beyond its DAQP_INF (1e30) as absent
        x, _, exitflag, _ = _daqp.solve(P if P.flags.c_contiguous else np.ascontiguousarray(P),
                                        c if c.flags.c_contiguous else np.ascontiguousarray(c),
                                        Am if Am.flags.c_contiguous else np.ascontiguousarray(Am), bu, bl,
                                        _sense(bu.shape[0]))
        if exitflag < 1:
            return None
        # a finite sum: every entry finite (a step of more than 1e300 rad counts as a failure too)
        return x if math.isfinite(_add_reduce(x)) else None
    import qpsolvers

    if backend not in qpsolvers.available_solvers:
        raise InputError(f"backend {backend!r} is not available; installed QP solvers: {qpsolvers.available_solvers}")
    Gi, h = None, None
    if A is not None:
        fu, fl = u < BIG, l > -BIG
        Gi = np.vstack([A[fu], -A[fl]])
        h = np.concatenate([u[fu], -l[fl]])
        if Gi.shape[0] == 0:
            Gi = h = None
    lbf = np.maximum(lb, -BIG)
    ubf = np.minimum(ub, BIG)
    opts = _TIGHT.get(backend, {})
    try:
        with warnings.catch_warnings():  # solver chatter (osqp's pending API change, qpsolvers' sparse hints)
            warnings.simplefilter("ignore", PendingDeprecationWarning)
            warnings.filterwarnings("ignore", message="Converted matrix", module="qpsolvers")
            x = qpsolvers.solve_qp(P, c, Gi, h, lb=lbf, ub=ubf, solver=backend, **opts)
    except Exception:  # noqa: BLE001 - solver-specific failures ("constraints are inconsistent")
        return None
    if x is None:
        return None
    x = np.asarray(x, dtype=float)
    return x if np.isfinite(x).all() else None
