"""Time scalings: boundary conditions, peak rates (the formulas behind minimum_time), trapezoid/triangle."""

import math

import numpy as np
import pytest

from kinserve.kinematics.errors import InputError
from kinserve.planners.time_scaling import (
    cubic_time_scaling,
    minimum_time,
    quintic_time_scaling,
    time_scaling,
    trapezoidal_time_scaling,
)


def _fd(sc, t, h=1e-6):
    return (sc.s(t + h) - sc.s(t - h)) / (2 * h), (sc.ds(t + h) - sc.ds(t - h)) / (2 * h)


@pytest.mark.parametrize("make", [cubic_time_scaling, quintic_time_scaling])
def test_rest_to_rest_polynomials(make):
    T = 2.5
    sc = make(T)
    s, sd, sdd = sc.evaluate(np.array([0.0, T]))
    np.testing.assert_allclose(s, [0.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(sd, [0.0, 0.0], atol=1e-12)
    if make is quintic_time_scaling:
        np.testing.assert_allclose(sdd, [0.0, 0.0], atol=1e-10)
    t = np.linspace(0.2, 2.3, 9)
    v_fd, a_fd = _fd(sc, t)
    np.testing.assert_allclose(sc.ds(t), v_fd, atol=1e-7)
    np.testing.assert_allclose(sc.dds(t), a_fd, atol=1e-5)
    # monotone progress
    assert np.all(np.diff(sc.s(np.linspace(0, T, 200))) >= 0)


def test_closed_forms():
    T = 3.0
    t = np.linspace(0, T, 11)
    tau = t / T
    np.testing.assert_allclose(cubic_time_scaling(T).s(t), 3 * tau**2 - 2 * tau**3, atol=1e-12)
    np.testing.assert_allclose(quintic_time_scaling(T).s(t),
                               10 * tau**3 - 15 * tau**4 + 6 * tau**5, atol=1e-12)


def test_nonzero_boundary_rates():
    sc = quintic_time_scaling(1.5, v0=0.3, v1=-0.2, a0=0.1, a1=0.4)
    s, sd, sdd = sc.evaluate(np.array([0.0, 1.5]))
    np.testing.assert_allclose(s, [0, 1], atol=1e-12)
    np.testing.assert_allclose(sd, [0.3, -0.2], atol=1e-12)
    np.testing.assert_allclose(sdd, [0.1, 0.4], atol=1e-10)


@pytest.mark.parametrize("kind", ["cubic", "quintic", "trapezoidal"])
def test_minimum_time_is_tight(kind):
    D, v, a = 2.0, 1.5, 3.0
    T = minimum_time(kind, D, v, a)
    sc = time_scaling(kind, T) if kind != "trapezoidal" else trapezoidal_time_scaling(v, a, D)
    assert sc.duration == pytest.approx(T)
    t = np.linspace(0, T, 20001)
    _, sd, sdd = sc.evaluate(t)
    vmax, amax = D * np.abs(sd).max(), D * np.abs(sdd).max()
    assert vmax <= v * (1 + 1e-6) and amax <= a * (1 + 1e-6)
    # tight: one of the limits is reached
    assert max(vmax / v, amax / a) == pytest.approx(1.0, rel=1e-3)


def test_trapezoid_and_triangle():
    tr = trapezoidal_time_scaling(2.0, 1.0, distance=10.0)
    assert not tr.triangular
    assert tr.duration == pytest.approx(10 / 2 + 2 / 1)
    s, sd, _ = tr.evaluate(np.array([0.0, tr.duration / 2, tr.duration]))
    np.testing.assert_allclose(s, [0, 0.5, 1], atol=1e-12)
    assert sd[1] * 10 == pytest.approx(2.0)
    tri = trapezoidal_time_scaling(20.0, 1.0, distance=10.0)
    assert tri.triangular
    assert tri.duration == pytest.approx(2 * math.sqrt(10 / 1))
    assert tri.evaluate(tri.duration / 2)[1] * 10 == pytest.approx(math.sqrt(10 * 1))
    # continuity of s and s' everywhere
    t = np.linspace(0, tri.duration, 5001)
    s, sd, _ = tri.evaluate(t)
    assert np.abs(np.diff(s)).max() < 1e-2 and np.abs(np.diff(sd)).max() < 1e-2


def test_minimum_time_per_joint_takes_the_slowest():
    T = minimum_time("quintic", [0.1, 2.0, -1.0], [1.0, 1.0, 0.2], 5.0)
    assert T == pytest.approx(max(minimum_time("quintic", 2.0, 1.0, 5.0),
                                  minimum_time("quintic", 1.0, 0.2, 5.0)))
    assert minimum_time("trapezoidal", 0.0, 1.0, 1.0) == 0.0


def test_bad_inputs():
    with pytest.raises(InputError, match="kind"):
        minimum_time("septic", 1, 1, 1)
    with pytest.raises(InputError, match="v_max"):
        minimum_time("cubic", 1, 0, 1)
    with pytest.raises(InputError, match="T must"):
        cubic_time_scaling(-1)
    with pytest.raises(InputError, match="a_max"):
        trapezoidal_time_scaling(1.0, float("inf"))
    with pytest.raises(InputError, match="needs"):
        time_scaling("trapezoidal")
