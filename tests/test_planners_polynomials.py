"""Cubic/quintic boundary-value polynomials: end conditions and derivatives by finite differences."""

import numpy as np
import pytest

from kinserve.kinematics.errors import InputError
from kinserve.planners import polynomials as P


@pytest.mark.parametrize("seed", range(5))
def test_quintic_meets_all_six_conditions(seed):
    rng = np.random.default_rng(seed)
    T = rng.uniform(0.3, 4.0)
    b = rng.normal(size=(6, 3))
    c = P.quintic_coefficients(T, *b)
    x, v, a = P.evaluate(c, np.array([0.0, T]))
    np.testing.assert_allclose(x, b[[0, 1]], atol=1e-10)
    np.testing.assert_allclose(v, b[[2, 3]], atol=1e-10)
    np.testing.assert_allclose(a, b[[4, 5]], atol=1e-9)


@pytest.mark.parametrize("seed", range(5))
def test_cubic_meets_four_conditions(seed):
    rng = np.random.default_rng(seed)
    T = rng.uniform(0.3, 4.0)
    x0, x1, v0, v1 = rng.normal(size=(4, 2))
    x, v, _ = P.evaluate(P.cubic_coefficients(T, x0, x1, v0, v1), np.array([0.0, T]))
    np.testing.assert_allclose(x, [x0, x1], atol=1e-12)
    np.testing.assert_allclose(v, [v0, v1], atol=1e-10)


def test_derivatives_match_finite_differences():
    c = P.quintic_coefficients(2.0, 0.1, 1.3, -0.4, 0.7, 0.2, -1.0)
    t = np.linspace(0.1, 1.9, 7)
    h = 1e-5
    x, v, a = P.evaluate(c, t)
    xp, vp, _ = P.evaluate(c, t + h)
    xm, vm, _ = P.evaluate(c, t - h)
    np.testing.assert_allclose(v, (xp - xm) / (2 * h), atol=1e-7)
    np.testing.assert_allclose(a, (vp - vm) / (2 * h), atol=1e-6)


def test_bad_duration_raises():
    with pytest.raises(InputError, match="duration T"):
        P.cubic_coefficients(0.0, 0.0, 1.0)
    with pytest.raises(InputError, match="duration T"):
        P.quintic_coefficients(float("nan"), 0.0, 1.0)
