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
