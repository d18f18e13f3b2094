"""kinserve.ik.closed_form: closed-form branches verified by FK; the 4R family; every youBot branch; SCARA;
2R/3R."""

import math
import re

import numpy as np
import pinocchio as pin
import pytest

from kinserve import ik, robots
from kinserve.ik.closed_form import PlanarChain, YouBotArm, two_link, wrap_into
from kinserve.ik.state import closed_form_solver
from kinserve.kinematics import Robot, se3
from kinserve.kinematics.errors import InputError


def planar_robot(lengths, limit=math.pi, tool_offset=0.0):
    """A planar nR arm built directly in Pinocchio: joints about z, links along x."""
    model = pin.Model()
    parent = 0
    placement = pin.SE3.Identity()
    for i, L in enumerate(lengths):
        parent = model.addJoint(parent, pin.JointModelRZ(), placement, f"j{i + 1}")
        model.lowerPositionLimit[i] = -limit
        model.upperPositionLimit[i] = limit
        placement = pin.SE3(np.eye(3), np.array([L, 0.0, 0.0]))
    tool = pin.SE3(se3.rot_z(tool_offset), np.array([lengths[-1], 0.0, 0.0]))
    model.addFrame(pin.Frame("tool", parent, 0, tool, pin.FrameType.OP_FRAME))
    return Robot(model, tip="tool", name=f"planar{len(lengths)}r", task_axes=("x", "y", "yaw"))


def test_two_link_law_of_cosines():
    sols, ok = two_link(1.2, 0.5, 1.0, 0.8)
    assert ok and len(sols) == 2
    for psi1, psi2, beta in sols:
        x = math.cos(psi1) + 0.8 * math.cos(psi2)
        y = math.sin(psi1) + 0.8 * math.sin(psi2)
        assert (x, y) == pytest.approx((1.2, 0.5), abs=1e-12)
    assert sols[0][2] == pytest.approx(-sols[1][2])
    sols, ok = two_link(3.0, 0.0, 1.0, 0.8)  # out of reach: stretched towards the target
    assert not ok and len(sols) == 1 and sols[0][2] == 0.0 and sols[0][0] == pytest.approx(0.0)


def test_wrap_into():
    # both ends of the range
    assert wrap_into(3.0 * math.pi, -math.pi, math.pi) == pytest.approx([-math.pi, math.pi])
    assert wrap_into(0.5, -2 * math.pi, 2 * math.pi) == pytest.approx([0.5 - 2 * math.pi, 0.5])
    assert wrap_into(2.0, -1.0, 1.0) == []


@pytest.mark.parametrize("lengths", [(1.0, 0.7), (1.0, 0.8, 0.5)])
def test_planar_2r_3r_branches(lengths):
    robot = planar_robot(lengths, tool_offset=0.3)
    solver = closed_form_solver(robot, "tool")
    assert isinstance(solver, PlanarChain) and solver.n_links == len(lengths)
    rng = np.random.default_rng(1)
    for q in robot.random_q(rng, 15):
        T = robot.fk(q).copy()
        relax = ("yaw",) if len(lengths) == 2 else ()
        res = ik.solve_all(robot, T, relax=relax)
        assert 1 <= len(res) <= 2
        assert all(r.success and robot.within_limits(r.q) for r in res)
        for r in res:  # verified by FK, independently of the solver
            assert np.linalg.norm(robot.fk(r.q)[:2, 3] - T[:2, 3]) < 1e-9
        assert any(np.allclose(r.q, q, atol=1e-9) for r in res)
        if len(res) == 2:
            assert {r.info["branch"] for r in res} == {"elbow up", "elbow down"}


def test_planar_4r_family_spans_the_one_parameter_set():
    robot = robots.load("planar4r", geometry=False)
    L = (1.0, 0.8, 0.6, 0.4)
    rng = np.random.default_rng(8)
    for q in robot.random_q(rng, 6):
        T = robot.fk(q).copy()
        fam = ik.solve_all(robot, T, samples=40)
        assert len(fam) >= 20
        assert all(r.success for r in fam)
        for r in fam:
            assert np.linalg.norm(robot.fk(r.q)[:2, 3] - T[:2, 3]) < 1e-9
            assert se3.rotation_angle(robot.fk(r.q)[:3, :3], T[:3, :3]) < 1e-9
        q1s = np.array([r.q[0] for r in fam])
        labels = {r.info["branch"] for r in fam}
        assert labels == {"elbow up", "elbow down"}
        # the expected set: q1 feasible iff |w - c2(q1)| in [|L2 - L3|, L2 + L3] (w: wrist point)
        yaw = math.atan2(T[1, 0], T[0, 0])
        w = T[:2, 3] - L[3] * np.array([math.cos(yaw), math.sin(yaw)])

        def dist(q1):
            return np.hypot(w[0] - L[0] * np.cos(q1), w[1] - L[0] * np.sin(q1))

        d = dist(q1s)
        assert np.all((d >= abs(L[1] - L[2]) - 1e-9) & (d <= L[1] + L[2] + 1e-9))  # every member is feasible
        grid = np.linspace(-math.pi, math.pi, 2001)
        feasible = grid[(dist(grid) >= abs(L[1] - L[2])) & (dist(grid) <= L[1] + L[2])]
        gap = np.abs(np.angle(np.exp(1j * (feasible[:, None] - q1s[None, :])))).min(axis=1)
        total = len(feasible) / len(grid) * 2 * math.pi
        assert gap.max() < 1.5 * total / 40 + 1e-3  # the samples cover the whole feasible set
        # incl. the generating q1
        assert np.abs(np.angle(np.exp(1j * (q1s - q[0])))).min() < 1.5 * total / 40 + 1e-3


def test_scara_closed_form_matches_the_s9_formulas():
    scara = robots.load("scara", geometry=False)
    a1 = a2 = 0.5
    rng = np.random.default_rng(21)
    for q in scara.random_q(rng, 15):
        T = scara.fk(q).copy()
        x, y, z = T[:3, 3]
        phi = q[0] + q[1] - q[3]  # tool yaw of S9
        # independent S9 formulas: d3 = 1 - z, theta2 = +-acos(...), theta1 = atan2(y, x) - atan2(...), theta4
        # = t1 + t2 - phi
        res = ik.solve_all(scara, T)
        assert res and all(r.success for r in res)
        c2 = (x * x + y * y - a1 * a1 - a2 * a2) / (2 * a1 * a2)
        for r in res:
            t1, t2, d3, t4 = r.q
            assert d3 == pytest.approx(1.0 - z, abs=1e-12)
            assert math.cos(t2) == pytest.approx(c2, abs=1e-9)
            t1_expected = math.atan2(y, x) - math.atan2(a2 * math.sin(t2), a1 + a2 * math.cos(t2))
            assert t1 == pytest.approx(math.remainder(t1_expected, 2 * math.pi), abs=1e-9)
            assert math.remainder(t1 + t2 - t4 - phi, 2 * math.pi) == pytest.approx(0.0, abs=1e-9)
        assert any(np.allclose(r.q, q, atol=1e-9) for r in res)


def test_youbot_returns_every_branch_within_limits():
    youbot = robots.load("youbot", geometry=False)
    solver = closed_form_solver(youbot, "tool")
    assert isinstance(solver, YouBotArm)
    rng = np.random.default_rng(5)
    n_multi = 0
    for q in youbot.random_q(rng, 25):
        T = youbot.fk(q).copy()
        res = ik.solve_all(youbot, T)
        assert all(r.success and youbot.within_limits(r.q) for r in res)
        for r in res:
            pe, re = se3.pose_error(youbot.fk(r.q), T)
            assert pe < 1e-9 and re < 1e-9
        assert any(np.allclose(r.q, q, atol=1e-8) for r in res)
        n_multi += len(res) > 1
        labels = [r.info["branch"] for r in res]
        assert len(set(labels)) == len(labels)
    assert n_multi > 0


def test_youbot_branches_are_complete():
    # independent check: numerical IK from many random starts finds no solution outside the closed-form set
    youbot = robots.load("youbot", geometry=False)
    rng = np.random.default_rng(6)
    for q in youbot.random_q(rng, 4):
        T = youbot.fk(q).copy()
        branches = [r.q for r in ik.solve_all(youbot, T)]
        found = 0
        for i, q0 in enumerate(youbot.random_q(rng, 15)):
            r = ik.solve(youbot, T, q0, method="lm", prefer_q0=True, seed_table=False, max_starts=10, seed=i,
                         tol_pos=1e-9, tol_rot=1e-9, iteration_budget=10 * 60)  # (max_starts x max_iter)
            if r.success:
                found += 1
                assert min(np.abs(r.q - b).max() for b in branches) < 1e-5
        assert found >= 10


def test_youbot_back_branch_reaches_over():
    youbot = robots.load("youbot", geometry=False)
    q = np.array([0.4, 0.3, -1.2, -0.5, 0.7])
    T = youbot.fk(q).copy()
    raw, note, _ = closed_form_solver(youbot, "tool").solve_all(T)
    assert note == ""
    sides = {label.split(",")[0] for _, label, *_ in raw}
    # the front branches are inside the limits; the back ones (theta1 + pi) are offered when in limits
    assert "front" in sides
    for qq, label, *_ in raw:
        if label.startswith("back"):
            assert math.remainder(qq[0] - q[0] - math.pi, 2 * math.pi) == pytest.approx(0.0, abs=1e-9)


def test_youbot_off_set_target_solves_the_nearest_reachable_pose():
    youbot = robots.load("youbot", geometry=False)
    q = np.array([0.2, 0.5, -0.9, 0.6, 0.3])
    T = youbot.fk(q).copy()
    T_off = T.copy()
    T_off[:3, :3] = se3.rot_z(0.15) @ T[:3, :3]  # tilts the approach axis out of the arm plane
    T_off[:3, 3] = T[:3, 3]
    res = ik.solve(youbot, T_off, method="analytic")
    assert not res.success
    assert "off the 5-DOF reachable set" in res.message
    reached = res.info["reached_pose"]
    pe, re = se3.pose_error(youbot.fk(res.q), reached)
    assert pe < 1e-9 and re < 1e-9  # the nearest reachable pose is reached exactly
    assert np.allclose(youbot.fk(res.q)[:3, 3], T_off[:3, 3], atol=1e-9)  # position kept
    assert 0 < res.orientation_error < 0.15 + 1e-9


def test_robots_without_closed_form():
    panda = robots.load("panda", geometry=False)
    assert closed_form_solver(panda, "panda_hand") is None
    with pytest.raises(InputError, match="no closed-form"):
        ik.solve_all(panda, panda.fk(panda.neutral()))
    with pytest.raises(InputError, match="no closed-form"):
        ik.solve(panda, panda.fk(panda.neutral()), method="analytic")


def test_youbot_branches_carry_their_own_notes_exact_first():
    """A target the back branch reaches exactly but the front one cannot (its wrist point is beyond the
    stretched arm): the exact branch comes first with a clean message, the other says what it is."""
    youbot = robots.load("youbot", geometry=False)
    q = np.array([-2.752, 1.487, 0.278, -1.497, -1.043])
    T = youbot.fk(q).copy()
    res = ik.solve_all(youbot, T)
    assert [r.success for r in res] == [True, False]
    exact, near = res
    assert (exact.message == "closed form" and exact.info["note"] == ""
            and exact.info["branch"].startswith("back"))
    assert np.allclose(exact.q, q, atol=1e-8)
    assert near.info["branch"].startswith("front") and "out of reach of the front branches" in near.message
    assert "nearest reachable position" in near.message and "stretched arm" in near.message
    # the stated shortfall is the branch's real position error (the arm points at the target, stretched)
    short_mm = float(re.search(r"([0-9.]+) mm short", near.message).group(1))
    assert short_mm == pytest.approx(1000 * near.position_error, rel=2e-3)
    # the independent check: the stretched arm's wrist-to-shoulder distance is a2 + a3
    assert abs(near.q[2]) < 1e-9 or abs(abs(near.q[2]) - math.pi) < 1e-9
    # ik.solve picks an exact branch when there is one, whatever the criteria rank first
    for criteria in ("joint_limit_distance", "displacement"):
        best = ik.solve(youbot, T, q0=near.q, method="analytic",
                        choose=criteria) if criteria == "displacement" else \
            ik.solve(youbot, T, method="analytic", choose=criteria)
        assert best.success and best.message == "closed form"


def test_youbot_off_set_target_branches_are_ordered_by_residual_and_labelled():
    youbot = robots.load("youbot", geometry=False)
    q = np.array([-2.752, 1.487, 0.278, -1.497, -1.043])
    T = youbot.fk(q).copy()
    T[:3, :3] = se3.rot_z(0.15) @ T[:3, :3]
    res = ik.solve_all(youbot, T)
    assert not any(r.success for r in res)
    residual = [r.position_error + r.orientation_error for r in res]
    assert residual == sorted(residual)
    assert "this branch reaches the nearest reachable pose" in res[0].message
    assert ("off the 5-DOF reachable set" in res[1].message
            and "out of reach of the front branches" in res[1].message)
    assert "this branch reaches" not in res[1].message
