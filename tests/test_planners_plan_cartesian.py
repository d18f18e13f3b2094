"""``planners.plan_cartesian``: the SE(3) line followed, the trajectory's limits, every stop with its reason.

The line is checked against independent formulas (linear interpolation and scipy's ``Slerp`` for the
decoupled line, scipy's matrix ``expm`` / ``logm`` for the screw), collisions against an independent coal
model (the URDF's meshes, :class:`motion_scenes.IndependentCheck`) on dense samples, singular values against
numpy's SVD of Pinocchio's Jacobian. Each pose's IK runs on an iteration budget and the moves have no clock
(``max_time=None``): no answer depends on the machine's speed.
"""

import numpy as np
import pinocchio as pin
import pytest
from fake_clock import stepping_clock
from scipy.linalg import expm, logm
from scipy.spatial.transform import Rotation, Slerp

from kinserve import ik, robots
from kinserve.kinematics import FrameError, InputError, ShapeError, se3
from kinserve.planners import CartesianMove, cartesian_to_joint, plan_cartesian
from kinserve.planners.cartesian_move import line_steps
from kinserve.planners.motion.request import velocity_limits

from motion_scenes import IndependentCheck, dense

Q0 = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8])
HAND = "panda_hand"
#: A UR5 configuration with its wrist bent by 0.3 rad (q5); WRIST_BACK bends it the other way.
UR5_Q = np.array([0.3, -1.2, 1.5, -1.0, 0.3, 0.5])
WRIST_BACK = np.array([0.3, -1.2, 1.5, -1.0, -0.3, 0.5])


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda")


@pytest.fixture(scope="module")
def ur5():
    return robots.load("ur5")


def moved(panda, delta, rot=None):
    T0 = panda.fk(Q0, HAND)
    T1 = T0.copy()
    T1[:3, 3] += delta
    if rot is not None:
        T1[:3, :3] = T1[:3, :3] @ rot
    return T0, T1


def box(size, xyz):
    T = np.eye(4)
    T[:3, 3] = xyz
    return ik.Box(size=size, pose=T)


def reference_line(T0, T1, s, interpolation):
    """The line's poses at progress ``s``, from scipy alone."""
    if interpolation == "screw":
        X = np.real(logm(np.linalg.inv(T0) @ T1))
        return np.array([T0 @ expm(si * X) for si in s])
    out = np.tile(np.eye(4), (len(s), 1, 1))
    out[:, :3, 3] = T0[:3, 3] + np.outer(s, T1[:3, 3] - T0[:3, 3])
    out[:, :3, :3] = Slerp([0, 1], Rotation.from_matrix([T0[:3, :3], T1[:3, :3]]))(s).as_matrix()
    return out


def sigma_min(robot, q, frame):
    """Smallest singular value of the 6 x nq world-aligned Jacobian of ``frame`` (Pinocchio + numpy)."""
    data = robot.model.createData()
    J = pin.computeFrameJacobian(robot.model, data, q, robot.model.getFrameId(frame),
                                 pin.LOCAL_WORLD_ALIGNED)
    return np.linalg.svd(J, compute_uv=False)[-1]


@pytest.fixture(scope="module", params=["decoupled", "screw"])
def straight(panda, request):
    T0, T1 = moved(panda, [0.1, 0.15, -0.1], se3.rot_z(0.4))
    return request.param, T0, T1, plan_cartesian(panda, Q0, T1, interpolation=request.param)


def test_a_straight_move_follows_the_se3_line(panda, straight):
    interpolation, T0, T1, move = straight
    assert isinstance(move, CartesianMove)
    assert move.success and move.stop == "completed" and move.fraction == 1.0 and move.stop_q is None
    n = len(move.poses) - 1
    assert np.allclose(move.s, np.arange(n + 1) / n) and len(move.path) == n + 1
    assert np.array_equal(move.path[0], Q0)
    reference = reference_line(T0, T1, move.s, interpolation)
    for q, T in zip(move.path, reference):
        p_err, r_err = se3.pose_error(panda.fk(q, HAND), T)
        assert p_err < 1e-4 and r_err < 1e-3
        assert panda.within_limits(q)
    assert np.all(move.position_errors < 1e-4) and np.all(move.orientation_errors < 1e-3)
    # the steps: none moves the hand's origin by more than max_step or turns it by more than
    # max_rotation_step, and one step fewer could not keep both
    fine = reference_line(T0, T1, np.linspace(0, 1, 2001), interpolation)
    length = np.linalg.norm(np.diff(fine[:, :3, 3], axis=0), axis=1).sum()
    angle = np.linalg.norm(Rotation.from_matrix(T0[:3, :3].T @ T1[:3, :3]).as_rotvec())
    assert n == int(np.ceil(max(length / 0.01, angle / 0.05) - 1e-6))
    P = np.array([panda.fk(q, HAND)[:3, 3] for q in move.path])
    assert np.linalg.norm(np.diff(P, axis=0), axis=1).max() <= 0.01 + 1e-4


def test_the_trajectory_keeps_the_limits_and_starts_and_ends_at_rest(panda, straight):
    interpolation, T0, T1, move = straight
    traj = move.trajectory
    assert move.timing == "toppra"
    v, a = velocity_limits(panda), 2.0 * velocity_limits(panda)
    assert np.max(np.abs(traj.velocities) / v) <= 1.0 + 1e-6
    assert np.max(np.abs(traj.accelerations) / a) <= 1.0 + 1e-6
    assert np.max(np.abs(traj.velocities) / v) > 0.5 or np.max(np.abs(traj.accelerations) / a) > 0.5
    assert np.array_equal(traj.positions[0], move.path[0])
    assert np.array_equal(traj.positions[-1], move.path[-1])
    assert not np.any(traj.velocities[0]) and not np.any(traj.velocities[-1])
    # velocities agree with the positions (central differences, samples about 10 ms apart)
    t, Q = traj.times, traj.positions
    fd = (Q[2:] - Q[:-2]) / (t[2:] - t[:-2])[:, None]
    assert np.max(np.abs(fd - traj.velocities[1:-1])) < 0.05 * np.max(np.abs(traj.velocities))
    # the corners of the joint path are rounded far below the step: every sample keeps the hand on the line
    line = reference_line(T0, T1, np.linspace(0, 1, 4001), interpolation)[:, :3, 3]
    P = panda.fk_batch(Q, HAND)[:, :3, 3]
    gap = np.linalg.norm(P[:, None, :] - line[None, :, :], axis=2).min(axis=1)
    assert gap.max() < 1e-3


def test_acceleration_limits_are_used(panda):
    _, T1 = moved(panda, [0.0, 0.2, 0.0])
    slow = plan_cartesian(panda, Q0, T1, self_collision=False, acceleration_limits=0.5)
    fast = plan_cartesian(panda, Q0, T1, self_collision=False)
    assert np.array_equal(slow.path, fast.path)
    assert np.max(np.abs(slow.trajectory.accelerations)) <= 0.5 * (1 + 1e-6)
    assert slow.trajectory.times[-1] > fast.trajectory.times[-1]


def test_the_move_and_cartesian_to_joint_are_one_engine(panda):
    """The same line through cartesian_to_joint: the same joint path, bit for bit."""
    T0, T1 = moved(panda, [0.1, 0.15, -0.1], se3.rot_z(0.4))
    move = plan_cartesian(panda, Q0, T1, self_collision=False)
    plan = cartesian_to_joint(panda, [T0, T1], Q0, frame=HAND, steps=len(move.poses) - 2, max_time=None,
                              iteration_budget=300)
    assert plan.success
    assert np.array_equal(plan.trajectory.positions, move.path)


def test_a_line_through_a_box_stops_at_the_collision(panda):
    T0, T1 = moved(panda, [0.0, 0.4, 0.0])
    obstacle = box((0.1, 0.05, 0.1), T0[:3, 3] + [0.0, 0.25, 0.0])
    move = plan_cartesian(panda, Q0, T1, obstacles=[obstacle])
    assert not move.success and move.stop == "collision"
    assert move.stop_detail["where"] == "waypoint"
    assert ("panda_hand", "obstacle[0]:box") in move.stop_detail["pairs"]
    assert "panda_hand with obstacle[0]:box" in move.message
    # the hand's origin enters the box at s = 0.225 / 0.4: the move stops before
    assert 0.0 < move.fraction < 0.225 / 0.4
    assert move.fraction == pytest.approx(len(move.path[1:]) / (len(move.poses) - 1))
    check = IndependentCheck(panda, [obstacle])
    assert check.first_collision(dense(move.path)) == -1  # the path before the box is free
    assert check.first_collision(move.trajectory.positions) == -1
    assert check.colliding(move.stop_q)  # the solution it stopped at is in the box


def test_a_segment_between_free_waypoints_is_a_collision(panda):
    """A 1 cm ball halfway between two waypoints 10 cm apart: the waypoints are free, the motion is not."""
    T0, T1 = moved(panda, [0.3, 0.0, 0.0])
    ball = ik.Sphere(T0[:3, 3] + [0.15, 0.0, 0.0], 0.005)
    move = plan_cartesian(panda, Q0, T1, obstacles=[ball], max_step=0.1, jump_threshold=1.0)
    assert move.stop == "collision" and move.stop_detail["where"] == "segment"
    assert move.fraction == pytest.approx(1 / 3)
    names = {a for a, _ in move.stop_detail["pairs"]}
    assert names & {"panda_hand", "panda_leftfinger", "panda_rightfinger"}
    check = IndependentCheck(panda, [box((0.01, 0.01, 0.01), ball.center)])  # the ball's bounding cube
    assert not check.colliding(move.path[-1]) and not check.colliding(move.stop_q)
    inner = IndependentCheck(panda, [box((0.007, 0.007, 0.007), ball.center)])  # a cube inside the ball
    assert inner.first_collision(dense(np.array([move.path[-1], move.stop_q]))) > 0


def test_a_wrist_flip_is_a_joint_jump_with_its_size_and_place(ur5):
    """The UR5's decoupled line through its wrist singularity (q5 = 0 halfway): the wrist flips."""
    move = plan_cartesian(ur5, UR5_Q, ur5.fk(WRIST_BACK), interpolation="decoupled", self_collision=False)
    assert move.stop == "joint_jump"
    n = len(move.poses) - 1
    detail = move.stop_detail
    assert detail["index"] + 1 == n // 2  # at the middle of the line, where the wrist is straight
    assert move.fraction == pytest.approx((n // 2 - 1) / n)
    dq = np.abs(move.stop_q - move.path[-1])
    assert detail["size"] == pytest.approx(dq.max()) and detail["size"] > 0.25
    assert detail["joint"] == ur5.joint_names[int(np.argmax(dq))]
    assert np.all(np.abs(np.diff(move.path, axis=0)) <= 0.25)  # the path before is continuous
    assert f"({detail['joint']})" in move.message and "joint jump" in move.message


def test_a_low_jump_threshold_stops_at_the_first_step(panda):
    _, T1 = moved(panda, [0.05, 0.0, 0.0])
    move = plan_cartesian(panda, Q0, T1, jump_threshold=1e-6, self_collision=False)
    assert move.stop == "joint_jump" and move.fraction == 0.0 and len(move.path) == 1
    assert move.stop_detail["size"] == pytest.approx(np.abs(move.stop_q - Q0).max())


def test_the_screw_line_through_a_singular_wrist_stops_there(ur5):
    """The UR5's screw line from q5 = 0.3 to q5 = -0.3 is the wrist's own rotation: the joint path is
    q(s) = q_a + s (q_b - q_a), singular at s = 1/2."""
    move = plan_cartesian(ur5, UR5_Q, ur5.fk(WRIST_BACK), interpolation="screw", self_collision=False)
    assert move.stop == "singularity"
    n = len(move.poses) - 1
    assert move.stop_detail["index"] + 1 == n // 2 and move.fraction == pytest.approx((n // 2 - 1) / n)
    assert np.allclose(move.path, UR5_Q + np.outer(move.s, WRIST_BACK - UR5_Q), atol=1e-3)
    assert sigma_min(ur5, move.stop_q, "tool0") < 1e-3
    assert move.stop_detail["sigma_min"] == pytest.approx(sigma_min(ur5, move.stop_q, "tool0"), abs=1e-9)
    assert all(sigma_min(ur5, q, "tool0") > 1e-3 for q in move.path)
    assert np.allclose(move.sigma_min, [sigma_min(ur5, q, "tool0") for q in move.path])
    # without the singularity stop the same line is followed through it
    through = plan_cartesian(ur5, UR5_Q, ur5.fk(WRIST_BACK), interpolation="screw", self_collision=False,
                             singular_tol=0.0)
    assert through.success and np.allclose(through.path[-1], WRIST_BACK, atol=1e-3)


def test_turning_the_hand_past_joint_7_stops_at_its_limit(panda):
    _, T1 = moved(panda, [0.0, 0.0, 0.0], se3.rot_z(2.5))
    move = plan_cartesian(panda, Q0, T1)
    assert move.stop == "joint_limit" and 0.5 < move.fraction < 1.0
    assert move.stop_detail["joints"] == ["panda_joint7"] and move.stop_detail["sides"] == ["upper"]
    assert panda.upper[6] - move.stop_q[6] < 1e-3
    assert np.all(panda.upper - move.path > 1e-3) and np.all(move.path - panda.lower > 1e-3)
    assert "panda_joint7 at its upper limit" in move.message


def test_leaving_the_reach_stops_with_the_ik_failure(panda):
    T0, T1 = moved(panda, [0.6, 0.0, 0.0])
    move = plan_cartesian(panda, Q0, T1)
    assert move.stop in ("ik_failed", "joint_limit") and 0.0 < move.fraction < 1.0
    assert move.stop_detail["position_error"] > 1e-4 and "residual" in move.stop_detail["detail"]
    reference = reference_line(T0, T1, move.s, "decoupled")
    assert max(se3.pose_error(panda.fk(q, HAND), T)[0] for q, T in zip(move.path, reference)) < 1e-4


def test_a_start_in_collision_does_not_move(panda):
    T0, T1 = moved(panda, [0.0, 0.1, 0.0])
    move = plan_cartesian(panda, Q0, T1, obstacles=[box((0.2, 0.2, 0.2), T0[:3, 3])])
    assert move.stop == "collision" and move.fraction == 0.0 and move.path.shape == (0, 7)
    assert move.trajectory is None and move.message.startswith("stopped by collision before the first step")
    assert ("panda_hand", "obstacle[0]:box") in move.stop_detail["pairs"]


def test_the_answer_does_not_depend_on_the_clock(panda):
    _, T1 = moved(panda, [0.0, 0.1, -0.05], se3.rot_x(0.2))
    a = plan_cartesian(panda, Q0, T1, iteration_budget=200)
    b = plan_cartesian(panda, Q0, T1, iteration_budget=200)
    assert np.array_equal(a.path, b.path) and np.array_equal(a.trajectory.positions, b.trajectory.positions)


def test_max_time_caps_the_whole_move(panda):
    """On a fake clock (1 ms a reading): a 0.05 s move ends by its cap, its path still on the line."""
    T0, T1 = moved(panda, [0.0, 0.3, 0.0])
    plan_cartesian(panda, Q0, T1, self_collision=False)  # nothing left to build
    with stepping_clock(1e-3) as clock:
        move = plan_cartesian(panda, Q0, T1, self_collision=False, max_time=0.05)
    assert clock.now <= 0.05 + 5e-3, clock.now
    assert move.stop == "time_cap" and 0.0 <= move.fraction < 1.0 and move.stop_q is None
    reference = reference_line(T0, T1, move.s, "decoupled")
    assert max(se3.pose_error(panda.fk(q, HAND), T)[0] for q, T in zip(move.path, reference)) < 1e-4


def test_line_steps_follow_the_path_of_the_origin():
    """A quarter turn about the z axis through (-0.5, 0, 0): the origin moves on an arc of 0.5 pi / 2 m
    (screw) or on its chord of 0.5 sqrt(2) m (decoupled)."""
    T1 = np.eye(4)
    T1[:3, :3] = se3.rot_z(np.pi / 2)
    T1[:3, 3] = [-0.5, 0.5, 0.0]
    assert line_steps(np.eye(4), T1, 0.01, 10.0, "screw") == int(np.ceil(0.25 * np.pi / 0.01))
    assert line_steps(np.eye(4), T1, 0.01, 10.0, "decoupled") == int(np.ceil(0.5 * np.sqrt(2) / 0.01))
    assert line_steps(np.eye(4), T1, 10.0, 0.1, "screw") == 16
    assert line_steps(np.eye(4), np.eye(4), 0.01, 0.05) == 1


def test_bad_input(panda):
    _, T1 = moved(panda, [0.1, 0.0, 0.0])
    with pytest.raises(InputError, match="robot"):
        plan_cartesian("panda", Q0, T1)
    with pytest.raises(ShapeError, match="start"):
        plan_cartesian(panda, Q0[:6], T1)
    with pytest.raises(ShapeError, match="T_goal"):
        plan_cartesian(panda, Q0, np.eye(3))
    with pytest.raises(InputError, match="max_step"):
        plan_cartesian(panda, Q0, T1, max_step=0.0)
    with pytest.raises(InputError, match="max_rotation_step"):
        plan_cartesian(panda, Q0, T1, max_rotation_step=-1.0)
    with pytest.raises(InputError, match="interpolation"):
        plan_cartesian(panda, Q0, T1, interpolation="spline")
    with pytest.raises(InputError, match="jump_threshold"):
        plan_cartesian(panda, Q0, T1, jump_threshold=0)
    with pytest.raises(InputError, match="singular_tol"):
        plan_cartesian(panda, Q0, T1, singular_tol=-1e-3)
    with pytest.raises(InputError, match="both None"):
        plan_cartesian(panda, Q0, T1, iteration_budget=None, max_time=None)
    with pytest.raises(InputError, match="acceleration_limits"):
        plan_cartesian(panda, Q0, T1, acceleration_limits=-1.0)
    with pytest.raises(InputError, match="relax"):
        plan_cartesian(panda, Q0, T1, relax=("spin",))
    with pytest.raises(FrameError, match="nowhere"):
        plan_cartesian(panda, Q0, T1, frame="nowhere")
    with pytest.raises(InputError, match="start"):
        plan_cartesian(panda, Q0 + 10.0, T1)
