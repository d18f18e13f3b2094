"""QP backends for the iterated differential IK: set up once per solve, updated and warm-started per step.

Every backend solves

    minimise  1/2 x^T P x + c^T x
    subject to  lb <= x <= ub,   l <= G x <= u

with a fixed size ``(n, m)`` for the whole solve: the matrices change values
each iteration, never shape or sparsity, so a solver's workspace is built
once and only updated.

* ``"osqp"`` (default): one ``osqp.OSQP`` object; the constraint matrix
  ``[I; G]`` and ``P`` (upper triangle) keep a dense sparsity pattern, each
  step calls ``update(Px=, Ax=, q=, l=, u=)`` and the previous primal/dual
  solution warm-starts ADMM (tight ``eps`` instead of polishing, which
  prints to stdout from C).
* ``"daqp"``: one ``daqp.Model`` (dense active-set), updated in place.
* ``"proxqp"``: one ``proxsuite.proxqp.dense.QP`` with box constraints,
  ``update`` + warm start from the previous result.
* ``"quadprog"`` and any other name known to ``qpsolvers``: the stateless
  ``qpsolvers.solve_qp`` on preallocated matrices (these solvers have no
  workspace to keep).

``qpsolvers.solve_qp`` rebuilds the solver at every call, which is why the
first three are driven through their native persistent interfaces.
"""

from __future__ import annotations

import threading

import numpy as np

from kinserve.kinematics.errors import InputError

INF = 1e20


def available_backends() -> list[str]:
    """Backend names usable on this machine."""
    import qpsolvers

    names = []
    for name in ("osqp", "daqp", "proxqp", "quadprog"):
        if name in qpsolvers.available_solvers:
            names.append(name)
    names += [s for s in qpsolvers.available_solvers if s not in names]
    return names


class QPBackend:
    """Interface: ``solve(P, c, G, l, u, lb, ub) -> x`` or None when the QP failed."""

    name = "?"

    def __init__(self, n: int, m: int) -> None:
        self.n, self.m = n, m
        self.status = ""

    def solve(self, P: np.ndarray, c: np.ndarray, G: np.ndarray, l: np.ndarray, u: np.ndarray,
              lb: np.ndarray, ub: np.ndarray) -> np.ndarray | None:  # pragma: no cover - interface
        raise NotImplementedError


class OSQPBackend(QPBackend):
    name = "osqp"

    def __init__(self, n: int, m: int, eps: float = 1e-7, max_iter: int = 4000) -> None:
        super().__init__(n, m)
        import osqp
        import scipy.sparse as sp

        self._osqp = osqp
        P = sp.csc_matrix(np.triu(np.ones((n, n))))
        A = sp.csc_matrix(np.vstack([np.eye(n), np.ones((m, n))]) if m else np.eye(n))
        # CSC data order of a dense upper triangle: column by column, rows 0..j
        self._p_rows, self._p_cols = [], []
        for j in range(n):
            for i in range(j + 1):
                self._p_rows.append(i)
                self._p_cols.append(j)
        self._p_rows = np.array(self._p_rows)
        self._p_cols = np.array(self._p_cols)
        # A = [I; G] in CSC: column j holds row j (the identity) then rows n..n+m-1
        self._Ax = np.ones(A.nnz)
        self._gidx = np.array([j * (m + 1) + 1 + i for j in range(n) for i in range(m)], dtype=int) if m else None
        self._l = np.empty(n + m)
        self._u = np.empty(n + m)
        self._prob = osqp.OSQP()
        self._prob.setup(
            P, np.zeros(n), A, -np.ones(n + m), np.ones(n + m),
            verbose=False, eps_abs=eps, eps_rel=eps, polishing=False, max_iter=max_iter, warm_starting=True,
        )
        self._solver = self._prob._solver

    def solve(self, P: np.ndarray, c: np.ndarray, G: np.ndarray, l: np.ndarray, u: np.ndarray,
              lb: np.ndarray, ub: np.ndarray) -> np.ndarray | None:
        # the extension object directly: osqp.OSQP.solve() builds a namespace of
        # every info field on each call, which costs more than the solve itself
        solver = self._solver
        self._l[: self.n] = lb
        self._u[: self.n] = ub
        if self.m:
            self._Ax[self._gidx] = G.T.reshape(-1)
            np.maximum(l, -INF, out=self._l[self.n:])
            np.minimum(u, INF, out=self._u[self.n:])
            solver.update_data_mat(P_x=P[self._p_rows, self._p_cols], P_i=None, A_x=self._Ax, A_i=None)
        else:
            solver.update_data_mat(P_x=P[self._p_rows, self._p_cols], P_i=None, A_x=None, A_i=None)
        solver.update_data_vec(q=c, l=self._l, u=self._u)
        solver.solve()
        status = solver.info.status_val
        if status not in (1, 2):  # solved, solved inaccurate
            self.status = str(solver.info.status)
            return None
        self.status = "solved"
        x = np.array(solver.solution.x, dtype=float)
        return x if np.all(np.isfinite(x)) else None


class DAQPBackend(QPBackend):
    name = "daqp"

    def __init__(self, n: int, m: int) -> None:
        super().__init__(n, m)
        import daqp

        self._model = daqp.Model()
        self._A = np.zeros((m, n)) if m else np.zeros((0, n))
        self._bu = np.empty(n + m)
        self._bl = np.empty(n + m)
        self._sense = np.zeros(n + m, dtype=np.int32)
        self._setup = False

    def solve(self, P: np.ndarray, c: np.ndarray, G: np.ndarray, l: np.ndarray, u: np.ndarray,
              lb: np.ndarray, ub: np.ndarray) -> np.ndarray | None:
        n = self.n
        self._bl[:n], self._bu[:n] = lb, ub
        if self.m:
            self._A[:] = G
            self._bl[n:] = np.maximum(l, -INF)
            self._bu[n:] = np.minimum(u, INF)
        H = np.ascontiguousarray(P)
        f = np.ascontiguousarray(c, dtype=float)
        if not self._setup:
            self._model.setup(H, f, self._A, self._bu, self._bl, self._sense)
            self._setup = True
        elif self.m:
            self._model.update(H=H, f=f, A=self._A, bupper=self._bu, blower=self._bl)
        else:
            self._model.update(H=H, f=f, bupper=self._bu, blower=self._bl)
        x, _, exitflag, _ = self._model.solve()
        self.status = f"exitflag {exitflag}"
        if exitflag < 1:
            return None
        x = np.asarray(x, dtype=float)
        return x if np.all(np.isfinite(x)) else None


class ProxQPBackend(QPBackend):
    name = "proxqp"

    def __init__(self, n: int, m: int) -> None:
        super().__init__(n, m)
        from proxsuite import proxqp

        self._qp = proxqp.dense.QP(n, 0, m, True)
        self._qp.settings.eps_abs = 1e-9
        self._qp.settings.verbose = False
        self._qp.settings.initial_guess = proxqp.InitialGuess.WARM_START_WITH_PREVIOUS_RESULT
        self._init = False
        self._ok = proxqp.QPSolverOutput.PROXQP_SOLVED

    def solve(self, P: np.ndarray, c: np.ndarray, G: np.ndarray, l: np.ndarray, u: np.ndarray,
              lb: np.ndarray, ub: np.ndarray) -> np.ndarray | None:
        C = G if self.m else None
        lo = np.maximum(l, -INF) if self.m else None
        up = np.minimum(u, INF) if self.m else None
        if not self._init:
            self._qp.init(P, c, None, None, C, lo, up, lb, ub)
            self._init = True
        else:
            self._qp.update(P, c, None, None, C, lo, up, lb, ub)
        self._qp.solve()
        self.status = str(self._qp.results.info.status)
        if self._qp.results.info.status != self._ok:
            return None
        x = np.array(self._qp.results.x, dtype=float)
        return x if np.all(np.isfinite(x)) else None


class QPSolversBackend(QPBackend):
    """Any ``qpsolvers`` solver, called statelessly (``G x <= h`` form, infinite rows dropped)."""

    def __init__(self, n: int, m: int, solver: str) -> None:
        super().__init__(n, m)
        import qpsolvers

        self._solve_qp = qpsolvers.solve_qp
        self.name = solver
        self._x = None

    def solve(self, P: np.ndarray, c: np.ndarray, G: np.ndarray, l: np.ndarray, u: np.ndarray,
              lb: np.ndarray, ub: np.ndarray) -> np.ndarray | None:
        rows, rhs = [], []
        if self.m:
            fin_u = np.isfinite(u) & (u < INF)
            fin_l = np.isfinite(l) & (l > -INF)
            if fin_u.any():
                rows.append(G[fin_u])
                rhs.append(u[fin_u])
            if fin_l.any():
                rows.append(-G[fin_l])
                rhs.append(-l[fin_l])
        Gm = np.vstack(rows) if rows else None
        h = np.concatenate(rhs) if rhs else None
        try:
            x = self._solve_qp(P, c, Gm, h, lb=lb, ub=ub, solver=self.name, initvals=self._x)
        except Exception as exc:  # solver-specific failures (e.g. quadprog's "constraints are inconsistent")
            self.status = f"{type(exc).__name__}: {exc}"
            return None
        if x is None or not np.all(np.isfinite(x)):
            self.status = "no solution"
            return None
        self.status = "solved"
        self._x = x
        return np.asarray(x, dtype=float)


_cache = threading.local()


def make_backend(name: str, n: int, m: int, role: str = "primary") -> QPBackend:
    """The backend for an ``n``-variable problem with ``m`` general constraint rows.

    Workspaces are cached per thread, keyed by ``(name, n, m, role)``: setting
    up OSQP costs about half a millisecond (sparse matrices + factorisation),
    far more than a whole solve, so a solve reuses the workspace of the
    previous solve of the same size and only updates its numbers.
    """
    key = (name.lower() if isinstance(name, str) else name, n, m, role)
    cache = getattr(_cache, "backends", None)
    if cache is None:
        cache = _cache.backends = {}
    backend = cache.get(key)
    if backend is None:
        backend = cache[key] = _new_backend(name, n, m)
    return backend


def _new_backend(name: str, n: int, m: int) -> QPBackend:
    import qpsolvers

    if not isinstance(name, str):
        raise InputError(f"backend must be a solver name, got {name!r}")
    key = name.lower()
    if key not in qpsolvers.available_solvers:
        raise InputError(
            f"backend {name!r} is not available; installed QP solvers: {', '.join(available_backends())}"
        )
    if key == "osqp":
        return OSQPBackend(n, m)
    if key == "daqp":
        return DAQPBackend(n, m)
    if key == "proxqp":
        return ProxQPBackend(n, m)
    return QPSolversBackend(n, m, key)
