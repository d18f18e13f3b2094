"""SE(3) interpolation and polynomial trajectories: exact ends, on SO(3), boundary twists by finite
differences."""

import numpy as np
import pinocchio as pin
import pytest

from kinserve.kinematics import se3
from kinserve.kinematics.errors import InputError, RotationError
from kinserve.planners.se3_interpolation import (
    decoupled_interpolation,
    intermediate_poses,
    interpolate_checkpoints,
    poses_along,
    screw_interpolation,
    se3_polynomial_trajectory,
)
from kinserve.planners.time_scaling import quintic_time_scaling


def _random_pose(rng):
    R = se3.matrix_from_quat(rng.normal(size=4))
    return se3.pose(R, rng.uniform(-1, 1, 3))


def _on_so3(T):
    R = T[..., :3, :3]
    eye = np.broadcast_to(np.eye(3), R.shape)
    return (np.abs(np.swapaxes(R, -1, -2) @ R - eye).max() < 1e-10
            and np.all(np.abs(np.linalg.det(R) - 1) < 1e-10))


@pytest.mark.parametrize("fn", [decoupled_interpolation, screw_interpolation])
def test_ends_exact_and_rotations_valid(fn, rng):
    A, B = _random_pose(rng), _random_pose(rng)
    np.testing.assert_allclose(fn(A, B, 0.0), A, atol=1e-12)
    np.testing.assert_allclose(fn(A, B, 1.0), B, atol=1e-10)
    Ts = fn(A, B, np.linspace(0, 1, 17))
    assert Ts.shape == (17, 4, 4) and _on_so3(Ts)
    np.testing.assert_allclose(Ts[:, 3], np.tile([0, 0, 0, 1.0], (17, 1)))


def test_decoupled_is_straight_line_and_slerp(rng):
    A, B = _random_pose(rng), _random_pose(rng)
    s = np.linspace(0, 1, 9)
    Ts = decoupled_interpolation(A, B, s)
    np.testing.assert_allclose(Ts[:, :3, 3], A[:3, 3] + s[:, None] * (B[:3, 3] - A[:3, 3]), atol=1e-12)
    # slerp: constant angular rate, the angle to A grows linearly
    total = se3.rotation_angle(A[:3, :3], B[:3, :3])
    ang = [se3.rotation_angle(A[:3, :3], T[:3, :3]) for T in Ts]
    np.testing.assert_allclose(ang, s * total, atol=1e-9)


def test_screw_has_constant_body_twist(rng):
    A, B = _random_pose(rng), _random_pose(rng)
    Ts = screw_interpolation(A, B, np.linspace(0, 1, 11))
    steps = [se3.log6(se3.inverse(a) @ b) for a, b in zip(Ts[:-1], Ts[1:])]
    np.testing.assert_allclose(steps, np.tile(se3.log6(se3.inverse(A) @ B) / 10, (10, 1)), atol=1e-9)


def test_intermediate_poses_and_checkpoints(rng):
    P = [_random_pose(rng) for _ in range(4)]
    mid = intermediate_poses(P[0], P[1], 3)
    assert mid.shape == (3, 4, 4)
    np.testing.assert_allclose(mid[1], decoupled_interpolation(P[0], P[1], 0.5), atol=1e-12)
    allp = interpolate_checkpoints(P, 3, method="screw")
    assert allp.shape == (3 * 4 + 1, 4, 4)
    for k in range(4):
        np.testing.assert_allclose(allp[4 * k], P[k], atol=1e-10)
    assert intermediate_poses(P[0], P[1], 0).shape == (0, 4, 4)


def _twist_fd(tr, t, h=1e-6):
    if t + h <= tr.duration:
        return se3.log6(se3.inverse(tr.pose(t)) @ tr.pose(t + h)) / h
    return se3.log6(se3.inverse(tr.pose(t - h)) @ tr.pose(t)) / h


@pytest.mark.parametrize("order", ["cubic", "quintic"])
def test_polynomial_trajectory_meets_poses_and_twists(order, rng):
    A, B = _random_pose(rng), _random_pose(rng)
    V0, V1 = rng.normal(size=6), rng.normal(size=6)
    tf = 2.0
    tr = se3_polynomial_trajectory(A, B, tf, V0, V1, order=order)
    np.testing.assert_allclose(tr.pose(0.0), A, atol=1e-12)
    np.testing.assert_allclose(tr.pose(tf), B, atol=1e-9)
    assert _on_so3(tr.sample(15)[1])
    np.testing.assert_allclose(_twist_fd(tr, 0.0), V0, atol=2e-5)
    np.testing.assert_allclose(_twist_fd(tr, tf), V1, atol=2e-5)
    # body_twist() is the derivative of pose() everywhere
    for t in (0.3, 1.1, 1.7):
        np.testing.assert_allclose(tr.body_twist(t),
                                   (_twist_fd(tr, t, 1e-6) + _twist_fd(tr, t - 1e-6, 1e-6)) / 2, atol=1e-4)


def test_quintic_boundary_accelerations(rng):
    A, B = _random_pose(rng), _random_pose(rng)
    V0, V1, A1 = rng.normal(size=6), rng.normal(size=6), rng.normal(size=6)
    tf, h = 1.5, 1e-4
    tr = se3_polynomial_trajectory(A, B, tf, V0, V1, acceleration1=A1)
    V = tr.body_twist(np.array([0.0, h, 2 * h]))
    np.testing.assert_allclose((-3 * V[0] + 4 * V[1] - V[2]) / (2 * h), 0.0, atol=1e-5)
    V = tr.body_twist(np.array([tf - 2 * h, tf - h, tf]))
    np.testing.assert_allclose((3 * V[2] - 4 * V[1] + V[0]) / (2 * h), A1, atol=1e-5)


def test_rest_to_rest_polynomial_equals_screw_with_time_scaling(rng):
    A, B = _random_pose(rng), _random_pose(rng)
    tr = se3_polynomial_trajectory(A, B, 3.0, order="quintic")
    t = np.linspace(0, 3, 7)
    np.testing.assert_allclose(tr.pose(t),
                               poses_along(A, B, quintic_time_scaling(3.0), t, "screw"), atol=1e-10)


def test_bad_inputs(rng):
    A = _random_pose(rng)
    bad = A.copy()
    bad[:3, :3] *= 2
    with pytest.raises(RotationError, match="T1"):
        decoupled_interpolation(A, bad, 0.5)
    with pytest.raises(InputError, match="method"):
        intermediate_poses(A, A, 2, method="linear")
    with pytest.raises(InputError, match="duration"):
        se3_polynomial_trajectory(A, A, 0.0)
    with pytest.raises(InputError, match="twist0"):
        se3_polynomial_trajectory(A, A, 1.0, twist0=[1, 2, 3])
    # pinocchio.SE3 accepted at the boundary
    np.testing.assert_allclose(screw_interpolation(pin.SE3(A[:3, :3], A[:3, 3]), A, 0.5), A, atol=1e-12)
