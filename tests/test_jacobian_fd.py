"""``Robot.jacobian`` of every registry robot against central finite differences of its FK.

World (default): linear rows = dp/dq, angular rows = w with
``[w]x ~ log(R(q + h e_i) R(q - h e_i)^T) / 2h`` (world axes).
Local: the same twist in the frame's axes: ``R^T dp/dq`` and ``log(R(q-h)^T R(q+h)) / 2h``.
Spatial: the velocity of the body point at the world origin, ``v_O = dp/dq + p x w``, and ``w``.
"""

import zlib

import numpy as np
import pytest

from kinserve import robots

H = 1e-6
TOL = 2e-7  # central differences: O(h^2) truncation + O(eps/h) rounding


def vee_log3(R):
    """Rotation vector of R (independent of Pinocchio): angle * axis from the skew part."""
    cos = np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)
    angle = np.arccos(cos)
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / 2.0
    return w if angle < 1e-12 else w * angle / np.sin(angle)


def fd_jacobians(robot, q, frame=None):
    n = robot.nq
    lin, ang_world, ang_local = np.zeros((3, n)), np.zeros((3, n)), np.zeros((3, n))
    for i in range(n):
        e = np.zeros(n)
        e[i] = H
        Tp, Tm = robot.fk(q + e, frame), robot.fk(q - e, frame)
        lin[:, i] = (Tp[:3, 3] - Tm[:3, 3]) / (2 * H)
        ang_world[:, i] = vee_log3(Tp[:3, :3] @ Tm[:3, :3].T) / (2 * H)
        ang_local[:, i] = vee_log3(Tm[:3, :3].T @ Tp[:3, :3]) / (2 * H)
    return lin, ang_world, ang_local


def interior_samples(robot, n, seed):
    rng = np.random.default_rng(seed)
    margin = np.minimum(1e-3, 0.25 * (robot.upper - robot.lower))
    return rng.uniform(robot.lower + margin, robot.upper - margin, size=(n, robot.nq))


@pytest.mark.parametrize("name", list(robots.available()))
def test_world_jacobian_matches_finite_differences(name):
    robot = robots.load(name, geometry=False)
    for q in interior_samples(robot, 4, seed=zlib.crc32(name.encode())):
        lin, ang, _ = fd_jacobians(robot, q)
        J = robot.jacobian(q)
        assert J.shape == (6, robot.nq)
        np.testing.assert_allclose(J[:3], lin, atol=TOL, err_msg=f"{name} linear")
        np.testing.assert_allclose(J[3:], ang, atol=TOL, err_msg=f"{name} angular")


@pytest.mark.parametrize("name", list(robots.available()))
def test_local_and_spatial_jacobians_match_their_definitions(name):
    robot = robots.load(name, geometry=False)
    for q in interior_samples(robot, 2, seed=1 + zlib.crc32(name.encode())):
        lin, ang_world, ang_local = fd_jacobians(robot, q)
        T = robot.fk(q)
        R, p = T[:3, :3], T[:3, 3]
        J_local = robot.jacobian(q, reference="local")
        np.testing.assert_allclose(J_local[:3], R.T @ lin, atol=TOL, err_msg=f"{name} local linear")
        np.testing.assert_allclose(J_local[3:], ang_local, atol=TOL, err_msg=f"{name} local angular")
        J_spatial = robot.jacobian(q, reference="spatial")
        np.testing.assert_allclose(J_spatial[:3], lin + np.cross(p, ang_world.T).T, atol=TOL,
                                   err_msg=f"{name} spatial linear")
        np.testing.assert_allclose(J_spatial[3:], ang_world, atol=TOL, err_msg=f"{name} spatial angular")


@pytest.mark.parametrize("name,frame", [("panda", "panda_link8"), ("youbot", "link3"), ("scara", "link2")])
def test_jacobian_of_an_intermediate_frame(name, frame):
    robot = robots.load(name, geometry=False)
    q = interior_samples(robot, 1, seed=5)[0]
    lin, ang, _ = fd_jacobians(robot, q, frame)
    J = robot.jacobian(q, frame)
    np.testing.assert_allclose(J, np.vstack([lin, ang]), atol=TOL)
