"""Robot: FK, batch FK, Jacobians against finite differences and their definitions, copies."""

import numpy as np
import pinocchio as pin
import pytest

from kinserve.kinematics import ModelError, Robot, se3
from kinserve.kinematics.errors import SingularityError

# A chain exercising every joint kind batch FK supports: RX, RY, RZ, unaligned revolute,
# PX and unaligned prismatic, with non-trivial fixed placements and a tool frame behind a fixed joint.
MIXED_URDF = """<?xml version="1.0"?>
<robot name="mixed">
  <link name="base"/><link name="l1"/><link name="l2"/><link name="l3"/><link name="l4"/>
  <link name="l5"/><link name="l6"/><link name="tool"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0.1 0 0.3" rpy="0 0 0.2"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0 0.05 0.2" rpy="0.3 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="j3" type="prismatic"><parent link="l2"/><child link="l3"/><origin xyz="0.2 0 0" rpy="0 0.1 0"/>
    <axis xyz="1 0 0"/><limit lower="0" upper="0.5" effort="1" velocity="1"/></joint>
  <joint name="j4" type="revolute"><parent link="l3"/><child link="l4"/><origin xyz="0 0 0.1" rpy="0 0 0"/>
    <axis xyz="0.6 0 0.8"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="j5" type="prismatic"><parent link="l4"/><child link="l5"/>
    <origin xyz="0 0.1 0" rpy="0.2 0.1 0"/><axis xyz="0 0.6 0.8"/>
    <limit lower="-0.2" upper="0.2" effort="1" velocity="1"/></joint>
  <joint name="j6" type="revolute"><parent link="l5"/><child link="l6"/>
    <origin xyz="0.05 0 0.05" rpy="0 0 0"/><axis xyz="1 0 0"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="jt" type="fixed"><parent link="l6"/><child link="tool"/>
    <origin xyz="0 0 0.12" rpy="0.1 0.2 0.3"/></joint>
</robot>"""


@pytest.fixture
def mixed():
    return Robot(pin.buildModelFromXML(MIXED_URDF), tip="tool", name="mixed")


def numeric_jacobian(robot, q, frame=None, h=1e-6):
    """Central differences of FK: linear rows from positions, angular rows from log(R+ R-^T)/2h."""
    J = np.zeros((6, robot.nq))
    for i in range(robot.nq):
        dq = np.zeros(robot.nq)
        dq[i] = h
        Tp, Tm = robot.fk(q + dq, frame).copy(), robot.fk(q - dq, frame).copy()
        J[:3, i] = (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)
        J[3:, i] = se3.log3(Tp[:3, :3] @ Tm[:3, :3].T) / (2 * h)
    return J


def test_fk_matches_pinocchio_frames_forward_kinematics(panda, rng):
    data = panda.model.createData()
    for _ in range(20):
        q = panda.random_q(rng)
        pin.framesForwardKinematics(panda.model, data, q)
        for frame in ("panda_link8", "panda_hand", "panda_link3"):
            ref = data.oMf[panda.model.getFrameId(frame)].homogeneous
            assert np.allclose(panda.fk(q, frame), ref, atol=1e-12)


def test_fk_all_agrees_with_fk(mixed, rng):
    q = mixed.random_q(rng)
    poses = mixed.fk_all(q)
    assert set(poses) == set(mixed.frame_names)
    for name in ("tool", "l3", "l5"):
        assert np.allclose(poses[name], mixed.fk(q, name), atol=1e-12)


@pytest.mark.parametrize("robot_fixture", ["panda", "mixed"])
def test_fk_batch_matches_fk(robot_fixture, request, rng):
    robot = request.getfixturevalue(robot_fixture)
    Q = robot.random_q(rng, n=200)
    for frame in (None, robot.frame_names[len(robot.frame_names) // 2]):
        T = robot.fk_batch(Q, frame)
        assert T.shape == (200, 4, 4)
        for i in range(0, 200, 7):
            assert np.allclose(T[i], robot.fk(Q[i], frame), atol=1e-12)


def test_fk_batch_validates(panda):
    from kinserve.kinematics import NonFiniteError, ShapeError

    with pytest.raises(ShapeError, match=r"Q must have shape \(N, 7\)"):
        panda.fk_batch(np.zeros((3, 6)))
    bad = np.zeros((3, 7))
    bad[1, 2] = np.nan
    with pytest.raises(NonFiniteError, match="Q"):
        panda.fk_batch(bad)


@pytest.mark.parametrize("robot_fixture", ["panda", "mixed"])
def test_world_jacobian_matches_finite_differences(robot_fixture, request, rng):
    robot = request.getfixturevalue(robot_fixture)
    for _ in range(5):
        q = robot.random_q(rng)
        assert np.allclose(robot.jacobian(q), numeric_jacobian(robot, q), atol=1e-6)


def test_local_and_spatial_jacobians_follow_their_definitions(mixed, rng):
    q = mixed.random_q(rng)
    T = mixed.fk(q).copy()
    R, p = T[:3, :3], T[:3, 3]
    Jw = mixed.jacobian(q).copy()
    Jl = mixed.jacobian(q, reference="local").copy()
    Js = mixed.jacobian(q, reference="spatial").copy()
    # local: same twist expressed in the tool axes
    assert np.allclose(Jl[:3], R.T @ Jw[:3], atol=1e-12)
    assert np.allclose(Jl[3:], R.T @ Jw[3:], atol=1e-12)
    # spatial: velocity of the body point at the world origin, v0 = v_p + w x (0 - p) = v_p + p x w
    P = np.array([[0, -p[2], p[1]], [p[2], 0, -p[0]], [-p[1], p[0], 0]])
    assert np.allclose(Js[3:], Jw[3:], atol=1e-12)
    assert np.allclose(Js[:3], Jw[:3] + P @ Jw[3:], atol=1e-12)
    assert np.allclose(mixed.jacobian(q, reference="body"), Jl)


def test_analytic_jacobian_is_derivative_of_position_and_rpy(panda, rng):
    h = 1e-6
    for _ in range(5):
        q = panda.random_q(rng)
        JA = panda.analytic_jacobian(q)
        num = np.zeros((6, 7))
        for i in range(7):
            dq = np.zeros(7)
            dq[i] = h
            Tp, Tm = panda.fk(q + dq).copy(), panda.fk(q - dq).copy()
            num[:3, i] = (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)
            drpy = se3.rpy_from_matrix(Tp[:3, :3]) - se3.rpy_from_matrix(Tm[:3, :3])
            num[3:, i] = (drpy + np.pi) % (2 * np.pi) - np.pi
            num[3:, i] /= 2 * h
        assert np.allclose(JA, num, atol=1e-5)


def test_analytic_jacobian_reports_gimbal_lock():
    # One revolute joint about y: at q = pi/2 the tool pitch is exactly pi/2.
    urdf = """<robot name="p"><link name="a"/><link name="b"/>
      <joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 1 0"/>
      <limit lower="-3" upper="3" effort="1" velocity="1"/></joint></robot>"""
    robot = Robot(pin.buildModelFromXML(urdf), tip="b")
    robot.analytic_jacobian(np.array([0.3]))
    with pytest.raises(SingularityError, match="pitch"):
        robot.analytic_jacobian(np.array([np.pi / 2]))


def test_singularity_measures(panda):
    # q = 0: joints 1, 3, 5 and 7 of the Panda are coaxial in pairs -> rank loss.
    q0 = np.zeros(7)
    assert panda.is_singular(q0)
    assert panda.manipulability(q0) < 1e-9
    assert panda.condition_number(q0) > 1e8
    q = np.array([0.1, -0.5, 0.2, -2.0, 0.3, 1.6, 0.4])
    J = panda.jacobian(q)
    assert not panda.is_singular(q)
    assert np.isclose(panda.manipulability(q), np.sqrt(np.linalg.det(J @ J.T)), rtol=1e-9)
    s = panda.singular_values(q)
    assert np.isclose(panda.condition_number(q), s[0] / s[-1])
    # position rows only: a 3x7 Jacobian has 3 singular values
    assert panda.singular_values(q, axes=("x", "y", "z")).shape == (3,)


def test_planar_task_axes_make_planar_arms_non_singular():
    urdf = """<robot name="p2"><link name="a"/><link name="b"/><link name="c"/><link name="t"/>
      <joint name="j1" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>
      <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
      <joint name="j2" type="revolute"><parent link="b"/><child link="c"/><origin xyz="1 0 0"/>
      <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
      <joint name="jt" type="fixed"><parent link="c"/><child link="t"/><origin xyz="1 0 0"/></joint>
    </robot>"""
    arm = Robot(pin.buildModelFromXML(urdf), tip="t", task_axes=("x", "y"))
    q = np.array([0.3, 0.9])
    assert not arm.is_singular(q)
    # 2R arm: det of the position Jacobian is l1 l2 sin(q2)
    assert np.isclose(arm.manipulability(q), abs(np.sin(0.9)), rtol=1e-9)
    assert arm.is_singular(np.array([0.3, 0.0]))  # stretched out


def test_copy_has_independent_data(panda, rng):
    other = panda.copy()
    assert other.model is panda.model and other.data is not panda.data
    q1, q2 = panda.random_q(rng), panda.random_q(rng)
    T1 = panda.fk(q1)
    other.fk(q2)
    assert np.allclose(panda.data.oMf[panda.frame_id("panda_link8")].homogeneous, T1)


def test_random_q_within_limits_and_deterministic(panda):
    Q = panda.random_q(7, n=500)
    assert np.all(Q >= panda.lower) and np.all(Q <= panda.upper)
    assert np.array_equal(panda.random_q(7), panda.random_q(7))
    # the same numbers as numpy's uniform draw within the limits, bit for bit (one and many)
    a, b = np.random.default_rng(11), np.random.default_rng(11)
    assert np.array_equal(panda.random_q(a), b.uniform(panda.lower, panda.upper))
    assert np.array_equal(panda.random_q(a, n=50), b.uniform(panda.lower, panda.upper, size=(50, panda.nq)))
    assert panda.within_limits(panda.middle())


def test_continuous_joints_are_rejected_with_a_clear_message():
    urdf = """<robot name="c"><link name="a"/><link name="b"/>
      <joint name="j" type="continuous"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/></joint>
    </robot>"""
    with pytest.raises(ModelError, match="nq == nv"):
        Robot(pin.buildModelFromXML(urdf))


def test_limits_are_read_only_so_copies_cannot_corrupt_each_other(panda):
    other = panda.copy()
    with pytest.raises(ValueError):
        other.lower[0] = 0.0
    assert panda.lower[0] < 0


def test_pickle_carries_kinematics_not_workspace(panda, rng):
    import pickle

    q = panda.random_q(rng)
    clone = pickle.loads(pickle.dumps(panda))
    assert clone.data is not panda.data and clone.visual_model is None
    assert np.allclose(clone.fk(q), panda.fk(q)) and np.allclose(clone.jacobian(q), panda.jacobian(q))
    assert clone.joint_names == panda.joint_names and clone.tip == panda.tip
