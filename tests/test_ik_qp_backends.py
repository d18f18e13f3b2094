"""Every QP backend a user can name (``ik.solve(..., backend=...)``) solves the IK's QPs
(:func:`kinserve.ik.qp.dense_qp.solve_dense`) like an independent reference solver, with and without rows,
with the shortcuts on and off; infeasible problems give None; unknown names are refused."""

import numpy as np
import pytest
import qpsolvers

from kinserve.ik.qp.backends import available_backends
from kinserve.ik.qp.dense_qp import QPCalls, solve_dense
from kinserve.kinematics.errors import InputError


def _problems(rng, n, m, k=6):
    for _ in range(k):
        J = rng.normal(size=(6, n))
        P = J.T @ J + 1e-3 * np.eye(n)
        c = rng.normal(size=n)
        G = rng.normal(size=(m, n))
        gl = -rng.random(m) * 0.05
        gu = np.full(m, np.inf)
        lb, ub = -rng.random(n) * 0.3, rng.random(n) * 0.3
        yield P, c, G, gl, gu, lb, ub


@pytest.mark.parametrize("name", available_backends()[:4])
@pytest.mark.parametrize("m", [0, 3])
@pytest.mark.parametrize("shortcut", [True, False])
def test_backend_matches_reference(name, m, shortcut):
    rng = np.random.default_rng(m)
    for P, c, G, gl, gu, lb, ub in _problems(rng, 7, m):
        x = solve_dense(P, c, lb, ub, G if m else None, gl if m else None, gu if m else None, backend=name,
                        shortcut=shortcut)
        ref = qpsolvers.solve_qp(P, c, -G if m else None, -gl if m else None, lb=lb, ub=ub, solver="quadprog")
        assert x is not None
        assert np.allclose(x, ref, atol=2e-6)
        assert np.all(x >= lb - 1e-6) and np.all(x <= ub + 1e-6)
        if m:
            assert np.all(G @ x >= gl - 1e-6)


@pytest.mark.parametrize("name", available_backends()[:4])
def test_infeasible_qp_returns_none(name):
    P = np.eye(2)
    x = solve_dense(P, np.zeros(2), -np.ones(2), np.ones(2), np.array([[1.0, 1.0]]), np.array([5.0]),
                    np.array([np.inf]), backend=name)
    assert x is None


def test_unknown_backend_is_refused_with_the_installed_names():
    P = np.eye(2)
    with pytest.raises(InputError, match="not available"):
        solve_dense(P, np.ones(2), -np.ones(2), np.ones(2), np.array([[1.0, 1.0]]), np.array([5.0]),
                    np.array([np.inf]), backend="gurobi-ultra")
    from kinserve import ik, robots

    with pytest.raises(InputError, match="backend must be one of the installed QP solvers"):
        ik.solve(robots.load("planar4r"), np.eye(4), backend="gurobi-ultra")


@pytest.mark.parametrize("name", available_backends()[:2])
def test_qp_calls_count_only_the_calls_that_reach_the_solver(name):
    """``calls=`` counts the QPs handed to the solver: the exact shortcuts (a feasible unconstrained
    minimiser, the box active set) are not; each count belongs to the caller that passes it."""
    P, c, lb, ub = np.eye(2), np.array([-0.5, 0.0]), -np.ones(2), np.ones(2)
    a, b = QPCalls(), QPCalls()
    assert np.allclose(solve_dense(P, c, lb, ub, backend=name, calls=a), [0.5, 0.0]) and a.n == 0
    # minimiser (2, 0) outside the box: the box active set gives (1, 0) without the solver
    assert np.allclose(solve_dense(P, np.array([-2.0, 0.0]), lb, ub, backend=name, calls=a), [1.0, 0.0])
    assert a.n == 0
    # x0 + x1 >= 1 cuts the minimiser off: Lagrange gives x = (0.5, 0) + mu (1, 1), mu = 1/4
    row = (np.array([[1.0, 1.0]]), np.array([1.0]), np.array([np.inf]))
    x = solve_dense(P, c, lb, ub, *row, backend=name, calls=a)
    assert np.allclose(x, [0.75, 0.25], atol=1e-6) and (a.n, b.n) == (1, 0)
    solve_dense(P, c, lb, ub, backend=name, shortcut=False, calls=b)  # no shortcut: the solver every time
    assert (a.n, b.n) == (1, 1)
    solve_dense(P, c, lb, ub, *row, backend=name)  # no count kept
    assert (a.n, b.n) == (1, 1)
