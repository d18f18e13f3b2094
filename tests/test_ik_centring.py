"""kinserve.ik.tasks.centring_weights: weights, null-space basis, strict priority of the secondary step."""

import numpy as np
import pytest

from kinserve import robots
from kinserve.ik.tasks.centring_weights import (
    centring_objective,
    centring_weights,
    null_space_basis,
    null_space_correction,
)
from kinserve.kinematics.errors import InputError, NonFiniteError


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda", geometry=False)


def test_weights_validation(panda):
    assert centring_weights(panda, 0.0) is None
    assert centring_weights(panda, None) is None
    w = centring_weights(panda, 2.0)
    assert np.allclose(w, 2.0 / (panda.upper - panda.lower) ** 2)
    per = centring_weights(panda, [0, 0, 0, 1, 0, 0, 0])
    assert np.count_nonzero(per) == 1
    with pytest.raises(InputError):
        centring_weights(panda, -1.0)
    with pytest.raises(InputError):
        centring_weights(panda, [1.0, 2.0])
    with pytest.raises(NonFiniteError):
        centring_weights(panda, np.nan)
    assert centring_objective(panda, panda.middle(), w) == 0.0
    assert centring_objective(panda, panda.upper, w) == pytest.approx(0.5 * 2.0 * 7 * 0.25)


def test_null_space_basis_is_orthonormal_and_rank_revealing(panda, rng):
    q = panda.random_q(rng)
    J = panda.jacobian(q)
    Z = null_space_basis(J)
    assert Z.shape == (7, 1)
    assert np.allclose(J @ Z, 0.0, atol=1e-10)
    assert np.allclose(Z.T @ Z, np.eye(1))
    # zero rows do not use up freedom
    Jz = np.vstack([J[:3], np.zeros((2, 7))])
    assert null_space_basis(Jz).shape == (7, 4)


def test_null_space_correction_keeps_the_task_and_reduces_the_objective(panda, rng):
    q = panda.random_q(rng)
    J = panda.jacobian(q)
    e = rng.normal(size=6) * 1e-2
    dq1 = np.linalg.pinv(J) @ e
    w = centring_weights(panda, 1.0)
    target = panda.middle() - q
    dq = dq1 + null_space_correction(null_space_basis(J), w, target - dq1)
    assert np.allclose(J @ dq, J @ dq1, atol=1e-10)  # strict priority: same task velocity
    assert centring_objective(panda, q + dq, w) <= centring_objective(panda, q + dq1, w) + 1e-15


def test_compiled_null_space_spans_scipys_null_space_and_refuses_what_it_cannot_certify():
    """The compiled Householder QR (null_space_kernel) against SciPy's SVD-based null space: the same
    projector ``Z Z^T``, an orthonormal ``Z``, ``J Z = 0``, on random wide matrices in C, Fortran and
    transposed-view layouts (the input left untouched); refused (the caller's SVD decides) on a zero matrix,
    a repeated row and a NaN."""
    from scipy.linalg import null_space

    from kinserve.ik.tasks.null_space_kernel import certified_null_space

    rng = np.random.default_rng(11)
    for t in range(300):
        m = int(rng.integers(1, 7))
        n = int(rng.integers(m + 1, 10))
        J = [rng.normal(size=(m, n)), np.asfortranarray(rng.normal(size=(m, n))),
             rng.normal(size=(n, m)).T][t % 3]
        before = J.copy()
        ok, Z = certified_null_space(J, 1e-6)
        assert ok and Z.shape == (n, n - m)
        assert np.array_equal(J, before)
        assert np.allclose(J @ Z, 0.0, atol=1e-12) and np.allclose(Z.T @ Z, np.eye(n - m), atol=1e-12)
        N = null_space(J)
        assert np.allclose(Z @ Z.T, N @ N.T, atol=1e-12)
    J = rng.normal(size=(2, 5))
    repeated = np.vstack([J[0], J[0]])
    with_nan = J.copy()
    with_nan[0, 0] = np.nan
    for refused in (np.zeros((2, 5)), repeated, with_nan, rng.normal(size=(5, 5)), np.zeros((0, 4))):
        assert not certified_null_space(refused, 1e-6)[0]
    assert null_space_basis(repeated).shape == (5, 4)  # the SVD path finds rank 1
