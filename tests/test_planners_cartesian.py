"""Cartesian path -> joint trajectory through IK: poses reached, continuity, events, bad input.

Each pose's IK ends on an iteration budget (``NO_CLOCK``: no per-pose time limit), so which poses are
reached does not depend on the machine's speed; the plan's total time cap is checked on a fake clock.
"""

import numpy as np
import pytest
from fake_clock import stepping_clock

from kinserve import robots
from kinserve.kinematics import InputError, RotationError, ShapeError, se3
from kinserve.planners import cartesian_to_joint, interpolate_checkpoints
from kinserve.planners.cartesian import PoseSolving, follow_poses


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda", geometry=False)


Q0 = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8])
#: Each pose's IK on iterations alone (an unreachable pose spends them all).
NO_CLOCK = dict(max_time=None, iteration_budget=300)


def line(panda, delta, rot=None):
    T0 = panda.fk(Q0, "panda_link8").copy()
    T1 = T0.copy()
    T1[:3, 3] += delta
    if rot is not None:
        T1[:3, :3] = T1[:3, :3] @ rot
    return T0, T1


@pytest.mark.parametrize("interpolation", ["decoupled", "screw"])
def test_straight_line_is_followed_continuously(panda, interpolation):
    T0, T1 = line(panda, [0.1, 0.15, -0.1], se3.rot_z(0.4))
    plan = cartesian_to_joint(panda, [T0, T1], Q0, frame="panda_link8", steps=15, dt=0.05,
                              interpolation=interpolation, **NO_CLOCK)
    assert plan.success and not plan.events
    Q = plan.trajectory.positions
    assert Q.shape == (17, 7)
    assert np.allclose(plan.trajectory.times, 0.05 * np.arange(17))
    for q, T in zip(Q, plan.poses):
        p_err, r_err = se3.pose_error(panda.fk(q, "panda_link8"), T)
        assert p_err < 1e-4 and r_err < 1e-3
        assert panda.within_limits(q)
    assert np.max(np.abs(np.diff(Q, axis=0))) < 0.2  # one branch, no jumps
    P = plan.poses[:, :3, 3]
    d = (T1[:3, 3] - T0[:3, 3]) / np.linalg.norm(T1[:3, 3] - T0[:3, 3])
    off = np.abs((P - T0[:3, 3]) - np.outer((P - T0[:3, 3]) @ d, d)).max()
    if interpolation == "decoupled":  # the origin moves on the straight segment between the ends
        assert off < 1e-12
    else:  # a screw motion with rotation sweeps the origin along a helix, off the chord
        assert off > 1e-3
    # velocities are the finite differences of the positions
    V = plan.trajectory.velocities
    assert np.allclose(V[1:-1], (Q[2:] - Q[:-2]) / 0.1, atol=1e-9)


def test_position_only_path_on_a_5dof_arm():
    youbot = robots.load("youbot", geometry=False)
    q0 = np.array([0.2, 0.4, -0.8, 0.5, 0.1])
    T0 = youbot.fk(q0)
    T1 = youbot.fk(np.array([0.6, 0.2, -0.6, 0.3, 0.1]))
    T1b = T1.copy()
    T1b[:3, :3] = T0[:3, :3]  # an orientation the 5-DOF arm cannot hold there: relax it
    plan = cartesian_to_joint(youbot, [T0, T1b], q0, steps=10, relax=("roll", "pitch", "yaw"), **NO_CLOCK)
    assert plan.success, plan.events
    for q, T in zip(plan.trajectory.positions, plan.poses):
        assert np.linalg.norm(youbot.fk(q)[:3, 3] - T[:3, 3]) < 1e-4


def test_unreachable_pose_is_reported_not_raised(panda):
    T0, T1 = line(panda, [2.0, 0.0, 0.0])  # 2 m further: out of reach
    plan = cartesian_to_joint(panda, [T0, T1], Q0, frame="panda_link8", steps=4, **NO_CLOCK)
    assert not plan.success
    failed = [e["index"] for e in plan.events if e["kind"] == "ik_failed"]
    assert failed and failed[-1] == 5 and 0 not in failed
    assert "not reached" in plan.message


def test_events_for_jumps_limits_and_singularity(panda):
    T0, T1 = line(panda, [0.05, 0.0, 0.0])
    plan = cartesian_to_joint(panda, [T0, T1], Q0, frame="panda_link8", steps=3, jump_threshold=1e-9,
                              limit_margin=10.0, singular_tol=10.0, **NO_CLOCK)
    kinds = {k: [e["index"] for e in plan.events if e["kind"] == k] for k in ("joint_jump",
                                                                              "limit_contact", "singular")}
    assert kinds["joint_jump"] == [1, 2, 3, 4]
    assert kinds["limit_contact"] == [0, 1, 2, 3, 4] and kinds["singular"] == [0, 1, 2, 3, 4]
    assert not plan.success  # jumps make the path discontinuous
    assert plan.manipulability.shape == (5,) and np.all(plan.manipulability > 0)


def test_bad_input(panda):
    T0, T1 = line(panda, [0.1, 0, 0])
    with pytest.raises(ShapeError, match="at least two"):
        cartesian_to_joint(panda, [T0])
    with pytest.raises(InputError, match="steps"):
        cartesian_to_joint(panda, [T0, T1], steps=0)
    with pytest.raises(InputError, match="dt"):
        cartesian_to_joint(panda, [T0, T1], dt=-1)
    with pytest.raises(InputError, match="interpolation"):
        cartesian_to_joint(panda, [T0, T1], interpolation="spline")
    bad = T1.copy()
    bad[:3, :3] *= 2
    with pytest.raises(RotationError, match=r"poses\[1\]"):
        cartesian_to_joint(panda, [T0, bad])
    with pytest.raises(ShapeError, match="q0"):
        cartesian_to_joint(panda, [T0, T1], q0=[0, 0])


def test_stop_on_failure_ends_the_plan_at_the_first_pose_not_reached(panda):
    T0, T1 = line(panda, [2.0, 0.0, 0.0])
    plan = cartesian_to_joint(panda, [T0, T1], Q0, frame="panda_link8", steps=8, stop_on_failure=True,
                              **NO_CLOCK)
    failed = [e["index"] for e in plan.events if e["kind"] == "ik_failed"]
    assert plan.stop_reason == "ik_failed" and len(failed) == 1
    assert len(plan.poses) == plan.trajectory.n_points == failed[0] + 1 < plan.total_poses == 10
    assert not plan.success and "stopped at the first pose not reached" in plan.message


def test_total_time_caps_the_whole_plan(panda):
    """On a fake clock (1 ms a reading): 0.1 s per pose, 0.5 s in all, the plan ends by its cap."""
    T0, T1 = line(panda, [2.0, 0.0, 0.0])
    cartesian_to_joint(panda, [T0, T1], Q0, frame="panda_link8", steps=1, **NO_CLOCK)  # nothing left to build
    with stepping_clock(1e-3) as clock:
        plan = cartesian_to_joint(panda, [T0, T1], Q0, frame="panda_link8", steps=40, max_time=0.1,
                                  total_time=0.5)
    assert clock.now <= 0.5 + 5e-3, clock.now
    assert plan.stop_reason == "time_cap" and len(plan.poses) < plan.total_poses == 42
    assert any(e["kind"] == "time_cap" for e in plan.events)
    assert np.all(np.isfinite(plan.trajectory.positions))
    full = cartesian_to_joint(panda, [T0, T1], Q0, frame="panda_link8", steps=3, **NO_CLOCK)
    assert full.stop_reason == "completed" and full.total_poses == len(full.poses) == 5


def test_events_carry_the_joint_the_size_and_the_side(panda):
    T0, T1 = line(panda, [0.05, 0.0, 0.0])
    margin = 1.0  # joint 4 (at -2.2) is 0.87 rad from its lower bound
    plan = cartesian_to_joint(panda, [T0, T1], Q0, frame="panda_link8", steps=3, jump_threshold=1e-9,
                              limit_margin=margin, **NO_CLOCK)
    Q = plan.trajectory.positions
    jumps = [e for e in plan.events if e["kind"] == "joint_jump"]
    for e in jumps:
        dq = np.abs(Q[e["index"]] - Q[e["index"] - 1])
        assert e["size"] == pytest.approx(dq.max()) and e["joint"] == panda.joint_names[int(np.argmax(dq))]
    for e in (e for e in plan.events if e["kind"] == "limit_contact"):
        q = Q[e["index"]]
        expected = [(name, "lower" if q[j] - panda.lower[j] < margin else "upper")
                    for j, name in enumerate(panda.joint_names)
                    if min(q[j] - panda.lower[j], panda.upper[j] - q[j]) < margin]
        assert list(zip(e["joints"], e["sides"])) == expected and expected
    assert jumps and any(e["kind"] == "limit_contact" for e in plan.events)


def test_follow_poses_stops_on_the_kinds_asked_and_runs_the_check_on_the_others(panda):
    T0, T1 = line(panda, [0.08, 0.0, 0.0])
    poses = interpolate_checkpoints([T0, T1], 6)
    solving = PoseSolving(frame="panda_link8", max_time=None, iteration_budget=300)
    seen = []

    def check(index, q):
        seen.append(index)
        return [{"kind": "blocked", "index": index, "detail": "test"}] if index == 3 else []

    track = follow_poses(panda, poses, Q0, solving, stop_on=("blocked",), check=check)
    assert track.stop_reason == "blocked" and seen == [0, 1, 2, 3] and len(track.q) == 4
    assert track.stop_events == [{"kind": "blocked", "index": 3, "detail": "test"}] and track.total == 8
    full = follow_poses(panda, poses, Q0, solving)
    assert full.stop_reason == "completed" and np.array_equal(full.q[:4], track.q)
    # a jump stop before the check: the check does not run on that solution
    seen.clear()
    jumpy = PoseSolving(frame="panda_link8", max_time=None, iteration_budget=300, jump_threshold=1e-9)
    stopped = follow_poses(panda, poses[1:], Q0, jumpy, stop_on=("joint_jump", "blocked"), q_before=Q0,
                           check=check)
    assert stopped.stop_reason == "joint_jump" and seen == [] and len(stopped.q) == 1
