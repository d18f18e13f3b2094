"""Differential drive: wheel speeds <-> (v, omega) round trip, straight line, spin, circle radius."""

import math

import numpy as np
import pytest

from kinserve.kinematics.errors import InputError
from kinserve.planners.mobile.diff_drive import DiffDrive


def test_round_trip(rng):
    dd = DiffDrive(0.05, 0.3)
    vw = rng.normal(size=(50, 2))
    wheels = dd.wheel_speeds(vw[:, 0], vw[:, 1])
    np.testing.assert_allclose(dd.body_velocity(wheels[:, 0], wheels[:, 1]), vw, atol=1e-12)


def test_special_motions():
    dd = DiffDrive(0.1, 0.4)
    np.testing.assert_allclose(dd.wheel_speeds(1.0, 0.0), [10.0, 10.0])  # straight: equal wheels
    np.testing.assert_allclose(dd.wheel_speeds(0.0, 1.0), [-2.0, 2.0])  # spin: opposite wheels
    # rim speeds differ by omega * track
    L, R = dd.wheel_speeds(0.5, 0.8)
    assert (R - L) * 0.1 == pytest.approx(0.8 * 0.4)


def test_simulated_circle_radius_is_v_over_omega():
    dd = DiffDrive(0.05, 0.3)
    L, R = dd.wheel_speeds(0.4, 0.5)
    t, P = dd.simulate([L, R], [0, 0, 0], (0, 2 * math.pi / 0.5), t_eval=np.linspace(0, 4 * math.pi, 100))
    centre = np.array([0.0, 0.4 / 0.5])
    np.testing.assert_allclose(np.hypot(P[:, 0] - centre[0], P[:, 1] - centre[1]), 0.8, atol=1e-6)
    np.testing.assert_allclose(P[-1], [0, 0, 2 * math.pi], atol=1e-6)


def test_bad_parameters():
    with pytest.raises(InputError, match="track"):
        DiffDrive(0.1, 0.0)
