"""kinserve.ik.targets: relax names, task error, task Jacobian rows (finite differences), world vs target
axes."""

import numpy as np
import pinocchio as pin
import pytest

from kinserve import robots
from kinserve.ik.targets import Target, parse_relax
from kinserve.kinematics import se3
from kinserve.kinematics.errors import FrameError, InputError, NonFiniteError, RotationError, ShapeError


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda", geometry=False)


def test_parse_relax_names_aliases_and_strings():
    assert parse_relax(()) == ()
    assert parse_relax(("roll", "pitch", "yaw")) == (3, 4, 5)
    assert parse_relax(("phi",)) == (5,)
    assert parse_relax("z, phi") == (2, 5)
    assert parse_relax(["yaw", "phi", "YAW"]) == (5,)
    with pytest.raises(InputError, match="unknown component 'psi'"):
        parse_relax(("psi",))
    with pytest.raises(InputError):
        parse_relax((1,))
    with pytest.raises(InputError):
        parse_relax(42)


def test_target_validation(panda):
    T = panda.fk(panda.neutral())
    with pytest.raises(FrameError):
        Target(panda, T, frame="no_such_frame")
    with pytest.raises(InputError, match="relax_frame"):
        Target(panda, T, relax=("z",), relax_frame="tool")
    with pytest.raises(InputError, match="nothing left"):
        Target(panda, T, relax=("x", "y", "z", "roll", "pitch", "yaw"))
    bad = T.copy()
    bad[0, 0] = np.nan
    with pytest.raises(NonFiniteError):
        Target(panda, bad)
    skew = T.copy()
    skew[:3, :3] *= 1.01
    with pytest.raises(RotationError):
        Target(panda, skew)
    with pytest.raises(ShapeError):
        Target(panda, T[:3])
    # SE3 accepted, and the target keeps its own copy
    tgt = Target(panda, pin.SE3(T))
    assert np.allclose(tgt.T, T)
    T2 = T.copy()
    tgt2 = Target(panda, T2)
    T2[0, 3] += 1.0
    assert tgt2.T[0, 3] == pytest.approx(T[0, 3])


def test_full_pose_errors_are_distance_and_geodesic_angle(panda, rng):
    qa, qb = panda.random_q(rng), panda.random_q(rng)
    Ta, Tb = panda.fk(qa), panda.fk(qb).copy()
    tgt = Target(panda, Tb)
    pe, re = tgt.errors(Ta[:3, :3], Ta[:3, 3])
    pe_ref, re_ref = se3.pose_error(Ta, Tb)
    assert pe == pytest.approx(pe_ref, abs=1e-12)
    assert re == pytest.approx(re_ref, abs=1e-12)
    assert tgt.full and tgt.components == ("x", "y", "z", "roll", "pitch", "yaw")


def _task_error_at(panda, tgt, q):
    T = panda.fk(q, tgt.frame)
    return tgt.residual(T[:3, :3], T[:3, 3])


@pytest.mark.parametrize("relax,axes",
                         [((), "world"), (("yaw",), "world"), (("z", "roll"), "target"),
                          (("roll", "pitch", "yaw"), "world")])
def test_task_jacobian_is_minus_derivative_of_error_at_the_target(panda, rng, relax, axes):
    # at (and near) the target, d e / d q = -J_task (first order): finite differences
    q = panda.random_q(rng)
    tgt = Target(panda, panda.fk(q).copy(), relax=relax, relax_frame=axes)
    J = tgt.jacobian(panda.jacobian(q))
    h = 1e-6
    fd = np.zeros_like(J)
    for i in range(panda.nq):
        dq = np.zeros(panda.nq)
        dq[i] = h
        fd[:, i] = (_task_error_at(panda, tgt, q + dq) - _task_error_at(panda, tgt, q - dq)) / (2 * h)
    assert np.allclose(fd, -J, atol=1e-6)
    assert J.shape == (6 - len(relax), panda.nq)


def test_relaxed_yaw_zero_set_is_rotation_about_world_z(panda, rng):
    q = panda.random_q(rng)
    T = panda.fk(q).copy()
    tgt = Target(panda, T, relax=("yaw",))
    # a pose rotated about the world z axis (about the frame origin) meets every kept component
    Rz = se3.rot_z(0.7)
    T_rot = T.copy()
    T_rot[:3, :3] = Rz @ T[:3, :3]
    pe, re = tgt.errors(T_rot[:3, :3], T_rot[:3, 3])
    assert pe < 1e-12 and re < 1e-12
    # ... but a rotation about the world x axis does not
    T_x = T.copy()
    T_x[:3, :3] = se3.rot_x(0.3) @ T[:3, :3]
    assert tgt.errors(T_x[:3, :3], T_x[:3, 3])[1] == pytest.approx(0.3, abs=1e-9)


def test_relax_frame_target_uses_the_target_axes(panda, rng):
    q = panda.random_q(rng)
    T = panda.fk(q).copy()
    moved = T.copy()
    moved[:3, 3] += 0.05 * T[:3, 2]  # slide along the target's own z axis
    world = Target(panda, T, relax=("z",), relax_frame="world")
    local = Target(panda, T, relax=("z",), relax_frame="target")
    assert local.errors(moved[:3, :3], moved[:3, 3])[0] < 1e-12
    # in world axes the slide has x/y components unless the target z axis is vertical
    expected = 0.05 * np.linalg.norm(T[:2, 2])
    assert world.errors(moved[:3, :3], moved[:3, 3])[0] == pytest.approx(expected, abs=1e-12)
