"""Three-wheel omni base (S6): heading-only Jacobian, equal wheels rotate in place, one wheel draws a
circle."""

import math

import numpy as np
import pytest

from kinserve.kinematics.errors import InputError
from kinserve.planners.mobile.omni import OmniBase

BASE = OmniBase(wheel_radius=0.05, center_distance=0.2)


def _rim_speeds_from_rigid_motion(base, pose, twist):
    """Independent: velocity of each wheel centre from the rigid-body motion, projected on its rolling
    direction."""
    x, y, th = pose
    xd, yd, thd = twist
    out = []
    for b in base.wheel_angles:
        p = np.array([x + base.center_distance * math.cos(th + b),
                      y + base.center_distance * math.sin(th + b)])
        v = np.array([xd, yd]) + thd * np.array([-(p[1] - y), p[0] - x])  # v_c + omega z x (p - c)
        u = np.array([-math.sin(th + b), math.cos(th + b)])  # rolling direction
        out.append(-(u @ v) / base.wheel_radius)  # positive about the outward axle drives the hub along -u
    return np.array(out)


@pytest.mark.parametrize("pose", [(0, 0, 0.0), (3.0, -7.0, 0.0), (3.0, -7.0, 1.1), (-50, 20, -2.5)])
def test_wheel_speeds_depend_on_heading_not_position(pose, rng):
    tw = rng.normal(size=3)
    np.testing.assert_allclose(BASE.wheel_speeds(tw, pose[2]),
                               _rim_speeds_from_rigid_motion(BASE, pose, tw), atol=1e-12)


def test_forward_is_inverse_of_inverse(rng):
    for _ in range(10):
        th = rng.uniform(-math.pi, math.pi)
        tw = rng.normal(size=3)
        np.testing.assert_allclose(BASE.twist(BASE.wheel_speeds(tw, th), th), tw, atol=1e-12)
    det = np.linalg.det(BASE.jacobian(0.4))
    assert det == pytest.approx(-3 * math.sqrt(3) * 0.2 / (2 * 0.05**3))


@pytest.mark.parametrize("w", [0.1, -0.1])
def test_equal_wheel_speeds_rotate_in_place(w):
    t, P = BASE.simulate([w, w, w], [0.0, 0.0, 0.0], (0, 10))
    np.testing.assert_allclose(P[:, :2], 0.0, atol=1e-12)
    # opposite to the wheels' sense: thetadot = -R w / D
    assert P[-1, 2] == pytest.approx(-0.05 * w / 0.2 * 10, rel=1e-9)


def test_one_wheel_only_draws_a_circle():
    w = np.array([math.pi / 2, 0.0, 0.0])
    t, P = BASE.simulate(w, [0.0, 0.0, math.radians(30)], (0, 30), t_eval=np.linspace(0, 30, 300))
    A = np.c_[2 * P[:, 0], 2 * P[:, 1], np.ones(len(P))]
    cx, cy, c = np.linalg.lstsq(A, (P[:, :2] ** 2).sum(1), rcond=None)[0]
    r = math.sqrt(c + cx**2 + cy**2)
    np.testing.assert_allclose(np.hypot(P[:, 0] - cx, P[:, 1] - cy), r, atol=1e-7)
    vb = BASE.body_twist(w)
    assert r == pytest.approx(math.hypot(vb[0], vb[1]) / abs(vb[2]), rel=1e-7)
    assert r > 0.01 and np.ptp(P[:, 0]) > r  # it really moves around


def test_bad_inputs():
    with pytest.raises(InputError, match="wheel_radius"):
        OmniBase(0.0, 0.2)
    with pytest.raises(InputError, match="twist"):
        BASE.wheel_speeds([1, 2], 0.0)
    with pytest.raises(InputError, match="pose0"):
        BASE.simulate([1, 1, 1], [0, 0], (0, 1))
