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
import warnings
from types import MappingProxyType

import numpy as np
from scipy.linalg import get_lapack_funcs

from kinserve.ik import numpy_fast
from kinserve.kinematics.errors import InputError

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


class QPCalls:
    """A count of QP-solver calls (the exact shortcuts do not count), owned by the solve that passes it to
    :func:`solve_dense` as ``calls=`` (the task solver reports it as ``Result.info["qp_calls"]``)."""

    __slots__ = ("n",)

    def __init__(self) -> None:
        self.n = 0


def box_active_set(P: np.ndarray, c: np.ndarray, lb: np.ndarray, ub: np.ndarray, x: np.ndarray,
                   rounds: int = 3) -> np.ndarray | None:
    """Exact solution of ``min 1/2 x^T P x + c^T x, lb <= x <= ub`` by a few primal active-set rounds, or
    None.

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
                row_lo: np.ndarray | None = None, row_hi: np.ndarray | None = None,
                backend: str = DEFAULT_BACKEND, shortcut: bool = True,
                calls: QPCalls | None = None) -> np.ndarray | None:
    """Solve the QP of the module docstring (``row_lo``, ``row_hi``: its ``l``, ``u``); None when infeasible.

    ``A`` may be None or have 0 rows; ``calls``, when given, counts the calls that reach the QP solver.
    """
    has_rows = A is not None and A.shape[0] > 0
    if shortcut:
        x = _posv(P, -c)[1]
        if _clip(x, lb, ub).tolist() == x.tolist():
            if not has_rows:
                return x
            Ax = A.dot(x)
            if (Ax >= row_lo).all() and (Ax <= row_hi).all():
                return x
        elif not has_rows:
            xs = box_active_set(P, c, lb, ub, x)
            if xs is not None:
                return xs
    if calls is not None:
        calls.n += 1
    if backend == "daqp" and _daqp is not None:
        return _daqp_solve(P, c, lb, ub, A if has_rows else None, row_lo, row_hi)
    return _qpsolvers_solve(P, c, lb, ub, A if has_rows else None, row_lo, row_hi, backend)


_concat = np.concatenate
_add_reduce = np.add.reduce

#: Tolerances of the iterative solvers reached through qpsolvers: their defaults (1e-5 for proxqp) leave
#: steps microradians off the QP's solution, which the active-set solvers (daqp, quadprog) solve exactly.
#: A read-only table (built here, never written).
_TIGHT = MappingProxyType({
    "osqp": MappingProxyType({"eps_abs": 1e-9, "eps_rel": 1e-9, "max_iter": 20000, "polishing": True}),
    "proxqp": MappingProxyType({"eps_abs": 1e-9, "eps_rel": 0.0}),
})
_NO_OPTIONS = MappingProxyType({})


def _daqp_solve(P, c, lb, ub, A, row_lo, row_hi):
    """The QP through DAQP (stateless); None when infeasible or not finite."""
    if A is None:  # writable arrays (DAQP takes writable buffers): copies of the box, an empty row matrix
        bu, bl, Am = ub.copy(), lb.copy(), np.zeros((0, c.shape[0]))
    else:
        bu, bl, Am = _concat((ub, row_hi)), _concat((lb, row_lo)), A
    # infinite bounds are passed as they are: DAQP treats bounds beyond its DAQP_INF (1e30) as absent;
    # the constraint kinds are all 0 (plain inequalities)
    x, _, exitflag, _ = _daqp.solve(P if P.flags.c_contiguous else np.ascontiguousarray(P),
                                    c if c.flags.c_contiguous else np.ascontiguousarray(c),
                                    Am if Am.flags.c_contiguous else np.ascontiguousarray(Am), bu, bl,
                                    np.zeros(bu.shape[0], dtype=np.int32))
    if exitflag < 1:
        return None
    # a finite sum: every entry finite (a step of more than 1e300 rad counts as a failure too)
    return x if math.isfinite(_add_reduce(x)) else None


def _qpsolvers_solve(P, c, lb, ub, A, row_lo, row_hi, backend):
    """The QP through ``qpsolvers`` with the solver named ``backend``; None when it fails."""
    import qpsolvers

    if backend not in qpsolvers.available_solvers:
        raise InputError(f"backend {backend!r} is not available; installed QP solvers: "
                         f"{qpsolvers.available_solvers}")
    Gi, h = None, None
    if A is not None:
        fu, fl = row_hi < BIG, row_lo > -BIG
        Gi = np.vstack([A[fu], -A[fl]])
        h = np.concatenate([row_hi[fu], -row_lo[fl]])
        if Gi.shape[0] == 0:
            Gi = h = None
    lbf = np.maximum(lb, -BIG)
    ubf = np.minimum(ub, BIG)
    opts = _TIGHT.get(backend, _NO_OPTIONS)
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
