"""kinserve.ik.qp.hierarchy: strict priorities never degrade a higher level; weights inside a level."""

import numpy as np
import pinocchio as pin
import pytest

from kinserve import ik, robots
from kinserve.ik.qp.hierarchy import _line_level, hierarchical_step, stack_level
from kinserve.ik.qp.line_kernel import line_level, line_qp


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda", geometry=False)


def _levels(robot, q, tasks):
    pin.computeJointJacobians(robot.model, robot.data, q)
    out = []
    for t in tasks:
        e, J = t.bind(robot).compute(robot, robot.data, q)
        out.append((J, e))
    return out


def test_lower_levels_never_change_the_higher_levels_velocity(panda):
    rng = np.random.default_rng(0)
    big = np.full(panda.nq, 10.0)
    for _ in range(10):
        q = panda.random_q(rng)
        # level 1: position of the hand (3 rows), level 2: orientation (3 rows), level 3: posture
        T = panda.fk(panda.random_q(rng)).copy()
        tasks = [ik.FrameTask(None, T, relax=("roll", "pitch", "yaw")),
                 ik.FrameTask(None, T, relax=("x", "y", "z")), ik.PostureTask(panda.random_q(rng))]
        lv = _levels(panda, q, tasks)
        lb, ub = -big, big
        one, _ = hierarchical_step(lv[:1], lb, ub, lam=1e-6)
        two, _ = hierarchical_step(lv[:2], lb, ub, lam=1e-6)
        three, lower = hierarchical_step(lv, lb, ub, lam=1e-6)
        J1, J2 = lv[0][0], lv[1][0]
        assert np.allclose(J1 @ two, J1 @ one, atol=1e-9) and np.allclose(J1 @ three, J1 @ one, atol=1e-9)
        assert np.allclose(J2 @ three, J2 @ two, atol=1e-9)
        # and each lower level does at least as well on its own task as without it
        e2 = lv[1][1]
        assert np.linalg.norm(J2 @ two + e2) <= np.linalg.norm(J2 @ one + e2) + 1e-12
        assert np.allclose(three, one + lower)


def test_priorities_hold_with_constraints(panda):
    rng = np.random.default_rng(1)
    q = panda.random_q(rng)
    T = panda.fk(panda.random_q(rng)).copy()
    lv = _levels(panda, q, [ik.FrameTask(None, T, relax=("roll", "pitch", "yaw")),
                            ik.PostureTask(panda.neutral())])
    lb, ub = np.maximum(panda.lower - q, -0.2), np.minimum(panda.upper - q, 0.2)
    G = rng.normal(size=(3, panda.nq))
    gl, gu = np.full(3, -0.05), np.full(3, np.inf)
    one, _ = hierarchical_step(lv[:1], lb, ub, G, gl, gu, lam=1e-4)
    two, _ = hierarchical_step(lv, lb, ub, G, gl, gu, lam=1e-4)
    for dq in (one, two):
        assert np.all(dq >= lb - 1e-9) and np.all(dq <= ub + 1e-9) and np.all(G @ dq >= gl - 1e-9)
    assert np.allclose(lv[0][0] @ two, lv[0][0] @ one, atol=1e-8)


def test_weights_inside_a_level_are_a_weighted_least_squares(panda):
    rng = np.random.default_rng(2)
    q = panda.random_q(rng)
    a = ik.PostureTask(panda.random_q(rng), weight=4.0, priority=1)
    b = ik.PostureTask(panda.random_q(rng), weight=1.0, priority=1)
    lv = _levels(panda, q, [a, b])
    J, e = stack_level([(lv[0][1], lv[0][0]), (lv[1][1], lv[1][0])], [2.0, None])  # sqrt(4), weight 1
    dq, _ = hierarchical_step([(J, e)], np.full(7, -np.inf), np.full(7, np.inf), lam=0.0)
    # minimiser of 4 |dq + ea|^2 + |dq + eb|^2
    assert np.allclose(dq, -(4 * lv[0][1] + lv[1][1]) / 5)


def test_three_levels_in_a_full_solve(panda):
    rng = np.random.default_rng(3)
    for k in range(4):
        T = panda.fk(panda.random_q(rng)).copy()
        q_rest = panda.random_q(rng)
        alone = ik.solve(panda, tasks=[ik.FrameTask(None, T)], seed=k, iteration_budget=2000)
        res = ik.solve(panda, tasks=[ik.FrameTask(None, T), ik.PostureTask(q_rest, priority=2),
                                     ik.CentringTask(priority=3)], seed=k, iteration_budget=2000)
        assert alone.success and res.success, res.message
        assert res.position_error < 1e-4 and res.orientation_error < 1e-3
        assert [t["priority"] for t in res.task_errors] == [1, 2, 3]


def test_a_lower_level_on_a_line_is_solved_exactly_as_the_qp_solver_does(panda, monkeypatch):
    """6-D frame task on 7 joints: the posture level has one free direction; its closed form (line_qp)
    agrees with the QP solver (shortcut=False) and keeps every bound and row."""
    from kinserve.ik.qp import hierarchy as hierarchy

    monkeypatch.setattr(hierarchy, "LINE_LEVEL", True)
    rng = np.random.default_rng(4)
    lines = 0
    for k in range(40):
        q = panda.random_q(rng)
        near = k % 2 == 0  # a near target leaves level 1 inside its bounds; a far one saturates them
        T = panda.fk(np.clip(q + 0.1 * rng.normal(size=7), panda.lower, panda.upper) if near
                     else panda.random_q(rng)).copy()
        lv = _levels(panda, q, [ik.FrameTask(None, T), ik.PostureTask(panda.random_q(rng))])
        step = [0.05, 0.2, 1.0][k % 3]
        lb, ub = np.maximum(panda.lower - q, -step), np.minimum(panda.upper - q, step)
        G = rng.normal(size=(3, panda.nq))
        gl = -rng.uniform(0.02, 1.0, 3)  # from binding to loose
        gu = np.where(rng.random(3) < 0.5, np.inf, -gl)
        fast, low = hierarchical_step(lv, lb, ub, G, gl, gu, lam=1e-4, max_step=0.5)
        slow, _ = hierarchical_step(lv, lb, ub, G, gl, gu, lam=1e-4, max_step=0.5, shortcut=False)
        one, _ = hierarchical_step(lv[:1], lb, ub, G, gl, gu, lam=1e-4, shortcut=False)
        assert np.allclose(fast, slow, atol=1e-7), (k, fast - slow)
        assert np.all(fast >= lb - 1e-9) and np.all(fast <= ub + 1e-9)
        assert np.all(G @ fast >= gl - 1e-9) and np.all(G @ fast <= gu + 1e-9)
        assert np.allclose(lv[0][0] @ fast, lv[0][0] @ one, atol=1e-9)  # the frame task's velocity is kept
        lines += np.linalg.norm(low) > 1e-9
    assert lines >= 5  # the posture level moved in several cases (not a vacuous comparison)


def test_line_qp_matches_brute_force():
    rng = np.random.default_rng(5)
    grid = np.linspace(-3, 3, 60001)
    for _ in range(200):
        a = rng.normal(size=5)
        a[rng.random(5) < 0.2] = 0.0
        lo, hi = -rng.random(5), rng.random(5)
        lo[rng.random(5) < 0.2] = -np.inf
        p, c = rng.random() + 0.1, rng.normal()
        # rows' values at z = 0 (feasible): the bounds on a z are lo - v, hi - v
        v = rng.uniform(np.maximum(lo, -1.0), hi)
        z = line_qp(p, c, a, v, lo + v, hi + v, 2.5)
        ok = ((np.abs(grid) <= 2.5)
              & np.all((a[:, None] * grid >= lo[:, None]) & (a[:, None] * grid <= hi[:, None]), axis=0))
        f = 0.5 * p * grid ** 2 + c * grid
        best = grid[ok][np.argmin(f[ok])]
        assert abs(z - best) < 2e-4 and abs(z) <= 2.5
        assert np.all(a * z >= lo - 1e-12) and np.all(a * z <= hi + 1e-12)


def test_line_qp_ignores_round_off_rows_at_their_bounds():
    """A joint at its bound (by round-off just past it) with a 1e-17 component along the line must not freeze
    the line (the S9 relax-z regression: centring stopped 5 cm short of the sphere)."""
    # row 0: the line barely touches it and it sits 1e-16 past its lower bound; row 1: the joint that moves
    z = line_qp(1.0, -0.3, np.array([1e-17, 1.0]), np.array([-1.0 - 4.5e-16, 0.0]), np.array([-1.0, -1.0]),
                np.array([1.0, 1.0]), 1.0)
    assert z == pytest.approx(0.3)
    # a genuine row (not round-off) still bounds the line
    z = line_qp(1.0, -0.3, np.array([0.5, 1.0]), np.array([0.95, 0.0]), np.array([-1.0, -1.0]),
                np.array([1.0, 1.0]), 1.0)
    assert z == pytest.approx(0.1)


def test_line_level_narrowing_box_first_is_line_qp_over_all_rows():
    """line_level reads the box first and skips the rows once the line is blocked: the same answer as
    line_qp over every row, for steps inside the box, at vertices of the box and on its faces (a blocked line
    gives exactly 0 in both; the objective's sums may differ in the last bits from NumPy's)."""

    rng = np.random.default_rng(6)
    blocked = 0
    for k in range(400):
        n, m = 7, 5
        z0 = rng.normal(size=n)
        z0[rng.random(n) < 0.15] = 0.0
        z0 /= np.linalg.norm(z0)
        lb, ub = -rng.uniform(0.01, 0.1, n), rng.uniform(0.01, 0.1, n)
        dq = rng.uniform(lb, ub)
        at = rng.random(n) < [0.0, 0.3, 1.0][k % 3]  # none, some, every coordinate at a bound
        dq[at] = np.where(rng.random(at.sum()) < 0.5, lb[at], ub[at])
        G = rng.normal(size=(m, n))
        Gd = G @ dq
        gl, gu = Gd - rng.uniform(0.0, 0.05, m), np.where(rng.random(m) < 0.5, np.inf,
                                                          Gd + rng.uniform(0.0, 0.05, m))
        Jk, ek = rng.normal(size=(3, n)), rng.normal(size=3)
        jz, r = Jk @ z0, Jk @ dq + ek
        got = z0 * line_level(z0, jz, Jk, ek, dq, lb, ub, G, gl, gu, 0.5)
        p, c = float(jz @ jz) + 1e-9, float(r @ jz)
        want = z0 * line_qp(p, c, np.concatenate((z0, G @ z0)), np.concatenate((dq, Gd)),
                            np.concatenate((lb, gl)), np.concatenate((ub, gu)), 0.5)
        assert np.allclose(got, want, rtol=1e-12, atol=1e-15) and got.any() == want.any(), k
        box_only = line_qp(p, c, z0, dq, lb, ub, 0.5)  # the hierarchy's call without rows: the box alone
        assert np.isclose(_line_level(z0, jz, Jk, ek, dq, lb, ub, None, None, None, 0.5), box_only,
                          rtol=1e-12, atol=1e-15), k
        blocked += not got.any()
    assert 50 < blocked < 390  # both the blocked line and the free one were exercised
