"""kinserve.ik.qp_backends: every backend solves the same QPs as a reference solver; workspaces are reused."""

import numpy as np
import pytest
import qpsolvers

from kinserve.ik.qp_backends import available_backends, make_backend
from kinserve.kinematics.errors import InputError


def _problems(rng, n, m, k=6):
    for _ in range(k):
        J = rng.normal(size=(6, n))
        P = J.T @ J + 1e-3 * np.eye(n)
        c = rng.normal(size=n)
        G = rng.normal(size=(m, n))
        l = -rng.random(m) * 0.05
        u = np.full(m, np.inf)
        lb, ub = -rng.random(n) * 0.3, rng.random(n) * 0.3
        yield P, c, G, l, u, lb, ub


@pytest.mark.parametrize("name", available_backends()[:4])
@pytest.mark.parametrize("m", [0, 3])
def test_backend_matches_reference(name, m):
    rng = np.random.default_rng(m)
    backend = make_backend(name, 7, m, role=f"test{m}")
    for P, c, G, l, u, lb, ub in _problems(rng, 7, m):
        x = backend.solve(P, c, G if m else None, l if m else None, u if m else None, lb, ub)
        ref = qpsolvers.solve_qp(P, c, -G if m else None, -l if m else None, lb=lb, ub=ub, solver="quadprog")
        assert x is not None
        assert np.allclose(x, ref, atol=2e-6)
        assert np.all(x >= lb - 1e-6) and np.all(x <= ub + 1e-6)
        if m:
            assert np.all(G @ x >= l - 1e-6)


def test_workspaces_are_cached_and_unknown_names_rejected():
    assert make_backend("osqp", 5, 2) is make_backend("osqp", 5, 2)
    assert make_backend("osqp", 5, 2) is not make_backend("osqp", 5, 3)
    with pytest.raises(InputError, match="not available"):
        make_backend("gurobi-ultra", 5, 2)


def test_infeasible_qp_returns_none():
    backend = make_backend("osqp", 2, 1, role="infeasible")
    P = np.eye(2)
    x = backend.solve(P, np.zeros(2), np.array([[1.0, 1.0]]), np.array([5.0]), np.array([np.inf]), -np.ones(2), np.ones(2))
    assert x is None
