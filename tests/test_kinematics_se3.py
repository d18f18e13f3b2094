"""SE(3) helpers against independent formulas (scipy's Rotation, Rodrigues, closed-form inverse)."""

import numpy as np
from scipy.spatial.transform import Rotation

from kinserve.kinematics import se3


def random_pose(rng):
    return se3.pose(Rotation.random(random_state=rng.integers(1 << 31)).as_matrix(), rng.normal(size=3))


def test_exp_log_round_trip(rng):
    for _ in range(50):
        T = random_pose(rng)
        assert np.allclose(se3.exp6(se3.log6(T)), T, atol=1e-10)
        w = rng.normal(size=3)
        w *= min(1.0, 3.0 / np.linalg.norm(w))  # keep the angle below pi
        assert np.allclose(se3.log3(se3.exp3(w)), w, atol=1e-10)


def test_exp3_is_rodrigues(rng):
    w = rng.normal(size=3)
    theta = np.linalg.norm(w)
    k = w / theta
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    assert np.allclose(se3.exp3(w), np.eye(3) + np.sin(theta) * K + (1 - np.cos(theta)) * K @ K)


def test_inverse(rng):
    T = random_pose(rng)
    assert np.allclose(se3.inverse(T), np.linalg.inv(T))


def test_rpy_and_quaternion_match_scipy(rng):
    for _ in range(20):
        rot = Rotation.random(random_state=rng.integers(1 << 31))
        R = rot.as_matrix()
        assert np.allclose(se3.matrix_from_rpy(*se3.rpy_from_matrix(R)), R, atol=1e-10)
        assert np.allclose(se3.rpy_from_matrix(R), rot.as_euler("ZYX")[::-1], atol=1e-9)
        qx = se3.quat_from_matrix(R)
        ref = rot.as_quat()  # scipy is x, y, z, w too
        assert np.allclose(qx, ref, atol=1e-10) or np.allclose(qx, -ref, atol=1e-10)
        assert np.allclose(se3.matrix_from_quat(qx), R, atol=1e-10)


def test_pose_error_and_angle(rng):
    T = random_pose(rng)
    U = T @ se3.pose(se3.rot_x(0.25), [0.3, 0.0, 0.4])
    pos, ang = se3.pose_error(T, U)
    assert np.isclose(pos, 0.5)
    assert np.isclose(ang, 0.25)
    assert np.allclose(se3.rot_y(0.4), Rotation.from_euler("y", 0.4).as_matrix())
