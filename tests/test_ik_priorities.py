"""Strict priorities along the iterations (kinserve.ik.qp.level_progress, ik.qp.task_solver): a lower level
never keeps a higher one from reaching what it reaches alone, and still does its own job.

Every solve here is decided by iterations (max_starts, max_iter), never by the clock: an iteration budget
and no max_time (the budget, ITERATIONS, exceeds max_starts x max_iter: it never ends a solve itself).
"""

import numpy as np
import pinocchio as pin
import pytest

from kinserve import ik, robots
from kinserve.ik.problem import Problem
from kinserve.ik.qp import level_progress, task_solver
from kinserve.ik.qp.hierarchy import hierarchical_step, level_steps
from kinserve.ik.qp.level_progress import LevelStall, LowerShares, ObjectiveWatch, Trial

ITERATIONS = 10_000
BUDGET = dict(iteration_budget=ITERATIONS, max_starts=10, max_iter=200)
TRIALS = 40


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda")


@pytest.fixture(scope="module")
def baxter():
    return robots.load("baxter")


def test_the_reported_posture_case_converges(panda):
    """The reproducer of the bug (b69b75b): the posture at level 2 kept level 1 from converging in 251
    starts, while level 1 alone converged from its first start."""
    F = "panda_link8"
    lo, hi = np.asarray(panda.lower), np.asarray(panda.upper)
    rng = np.random.default_rng(2026)
    Q = rng.uniform(lo, hi, (200, 7))
    Q0 = rng.uniform(lo, hi, (200, 7))
    T = np.asarray(panda.fk(Q[1], F))
    qref = (lo + hi) / 2 + 0.4 * (hi - lo) * rng.uniform(-1, 1, 7)
    pos = ik.FrameTask(F, T, relax=("roll", "pitch", "yaw"), priority=1)
    alone = ik.solve(panda, tasks=[pos], q0=Q0[1], iteration_budget=ITERATIONS, max_starts=1)
    res = ik.solve(panda, tasks=[pos, ik.PostureTask(qref, priority=2)], q0=Q0[1],
                   iteration_budget=ITERATIONS, max_starts=1)
    assert alone.success
    assert res.success, res.message
    assert res.position_error < 1e-4
    assert np.linalg.norm(panda.fk(res.q, F)[:3, 3] - T[:3, 3]) < 1e-4  # (checked against FK, not the report)


def _same_success(robot, goals_of, seed):
    """Per target: (alone, with a posture at the level below) successes, same q0 and seed."""
    lo, hi = np.asarray(robot.lower), np.asarray(robot.upper)
    rng = np.random.default_rng(seed)
    out = []
    for i in range(TRIALS):
        goals = goals_of(rng.uniform(lo, hi))
        q0, q_ref = rng.uniform(lo, hi), rng.uniform(lo, hi)
        below = max(t.priority for t in goals) + 1
        alone = ik.solve(robot, tasks=goals, q0=q0, seed=i, **BUDGET)
        res = ik.solve(robot, tasks=goals + [ik.PostureTask(q_ref, priority=below)], q0=q0, seed=i, **BUDGET)
        if res.success:
            assert res.position_error < 1e-4 and res.orientation_error < 1e-3
        out.append((alone.success, res.success))
    return out


def test_level_one_succeeds_with_a_posture_as_alone_panda(panda):
    """Position-only hand target at level 1, a random posture at level 2 (40 targets from FK of random
    configurations): level 1's success is the same with the posture as alone. (At b69b75b, 10 of 40 of such
    targets failed with the posture and succeeded alone.)"""
    F = "panda_link8"

    def goals_of(q):
        return [ik.FrameTask(F, np.asarray(panda.fk(q, F)), relax=("roll", "pitch", "yaw"))]

    pairs = _same_success(panda, goals_of, 2026)
    assert all(w >= a for a, w in pairs)  # what level 1 meets alone it meets with the posture (guaranteed)
    assert [w for _, w in pairs] == [a for a, _ in pairs]
    assert sum(a for a, _ in pairs) == TRIALS  # (reachable targets: a comparison of successes, not failures)


def test_level_one_succeeds_with_a_posture_as_alone_baxter(baxter):
    """Both Baxter hands (6-D each) at level 1, a posture at level 2."""
    frames = ("left_gripper", "right_gripper")

    def goals_of(q):
        return [ik.FrameTask(f, np.asarray(baxter.fk(q, f))) for f in frames]

    pairs = _same_success(baxter, goals_of, 2026)
    assert all(w >= a for a, w in pairs)
    assert [w for _, w in pairs] == [a for a, _ in pairs]
    assert sum(a for a, _ in pairs) >= TRIALS - 2


def test_goal_levels_one_and_two_with_a_posture_at_three(panda):
    """Position at level 1, orientation (a goal too) at level 2, posture at level 3: the goals are met as
    with the two goal levels alone."""
    F = "panda_link8"

    def goals_of(q):
        T = np.asarray(panda.fk(q, F))
        return [ik.FrameTask(F, T, relax=("roll", "pitch", "yaw")), ik.FrameTask(F, T, relax=("x", "y", "z"),
                                                                                 priority=2)]

    lo, hi = np.asarray(panda.lower), np.asarray(panda.upper)
    rng = np.random.default_rng(9)
    for i in range(12):
        goals = goals_of(rng.uniform(lo, hi))
        q0, q_ref = rng.uniform(lo, hi), rng.uniform(lo, hi)
        alone = ik.solve(panda, tasks=goals, q0=q0, seed=i, **BUDGET)
        res = ik.solve(panda, tasks=goals + [ik.PostureTask(q_ref, priority=3)], q0=q0, seed=i, **BUDGET)
        assert res.success >= alone.success, (i, res.message)
        assert alone.success, alone.message


def test_the_posture_does_its_job_in_the_freedom_left(panda):
    """Start at a solution of level 1 (the hand's position) with a posture that is itself a solution (so it
    is reachable in the freedom left): the posture error falls, level 1 stays within tolerance at every
    iterate, and in most cases the posture is reached, within 60 iterations of one start."""
    F = "panda_link8"
    lo, hi = np.asarray(panda.lower), np.asarray(panda.upper)
    rng = np.random.default_rng(5)
    reached = 0
    for i in range(12):
        q_ref = rng.uniform(lo, hi)
        pos = ik.FrameTask(F, np.asarray(panda.fk(q_ref, F)), relax=("roll", "pitch", "yaw"))
        start = ik.solve(panda, tasks=[pos], q0=rng.uniform(lo, hi), seed=i, **BUDGET)
        assert start.success
        res = ik.solve(panda, tasks=[pos, ik.PostureTask(q_ref)], q0=start.q, prefer_q0=True, seed=i,
                       iteration_budget=ITERATIONS, max_starts=1, max_iter=60)
        assert res.success, res.message
        assert np.linalg.norm(res.q - q_ref) < np.linalg.norm(start.q - q_ref)
        assert np.all(res.history.position_error < 1e-4)
        assert np.linalg.norm(panda.fk(res.q, F)[:3, 3] - panda.fk(q_ref, F)[:3, 3]) < 1e-4
        reached += np.linalg.norm(res.q - q_ref) < 1e-3
    assert reached >= 6  # (the others end in a local minimum of the posture on the self-motion manifold)


def test_a_start_the_lower_levels_spoil_is_run_again_with_them_held(panda, monkeypatch):
    """With the shares taken greedily (the lower levels' whole steps, as at b69b75b) the first runs of many
    starts fail; the second run with the lower levels held until the goals are met still meets every goal
    that level 1 meets alone."""
    def greedy(self, q, state, steps, accept, first=None, correct=None):
        qn, st = first if first is not None else accept(steps.total)
        return Trial(qn, st, (1.0,) * len(steps.lower), False, any(d is not None for d in steps.lower))

    held = []
    iterate = task_solver._iterate

    def counting(run, q, record, st, hold, spent):
        held.append(hold)
        return iterate(run, q, record, st, hold, spent)

    monkeypatch.setattr(LowerShares, "take", greedy)
    monkeypatch.setattr(task_solver, "_iterate", counting)
    F = "panda_link8"
    lo, hi = np.asarray(panda.lower), np.asarray(panda.upper)
    rng = np.random.default_rng(2026)
    for i in range(12):
        pos = ik.FrameTask(F, np.asarray(panda.fk(rng.uniform(lo, hi), F)), relax=("roll", "pitch", "yaw"))
        q0, q_ref = rng.uniform(lo, hi), rng.uniform(lo, hi)
        alone = ik.solve(panda, tasks=[pos], q0=q0, seed=i, **BUDGET)
        res = ik.solve(panda, tasks=[pos, ik.PostureTask(q_ref)], q0=q0, seed=i, **BUDGET)
        assert alone.success and res.success, (i, res.message)
    assert sum(held) >= 3  # the second runs were needed (the greedy first runs failed)


def _levels(robot, q, tasks):
    pin.computeJointJacobians(robot.model, robot.data, q)
    return [(J, e) for e, J in (t.bind(robot).compute(robot, robot.data, q) for t in tasks)]


def test_level_steps_are_the_parts_of_the_hierarchical_step(panda):
    """Each lower level's part moves in the null space of every level above it; the parts sum to the step."""
    rng = np.random.default_rng(0)
    for _ in range(10):
        q = panda.random_q(rng)
        T = panda.fk(panda.random_q(rng)).copy()
        tasks = [ik.FrameTask(None, T, relax=("roll", "pitch", "yaw")),
                 ik.FrameTask(None, T, relax=("x", "y", "z", "roll")), ik.PostureTask(panda.random_q(rng))]
        lv = _levels(panda, q, tasks)
        lb, ub = np.maximum(panda.lower - q, -0.3), np.minimum(panda.upper - q, 0.3)
        steps = level_steps(lv, lb, ub, lam=1e-6)
        dq, lower = hierarchical_step(lv, lb, ub, lam=1e-6)
        parts = [d for d in steps.lower if d is not None]
        assert np.allclose(steps.total, steps.first + sum(parts), atol=1e-12)
        assert np.array_equal(steps.total, dq) and np.allclose(lower, dq - steps.first, atol=1e-12)
        J1, J2 = lv[0][0], lv[1][0]
        for k, d in enumerate(steps.lower):
            if d is not None:
                assert np.allclose(J1 @ d, 0.0, atol=1e-9)
                if k == 1:
                    assert np.allclose(J2 @ d, 0.0, atol=1e-9)
        # convex combinations of the partial sums keep the box (what LowerShares relies on)
        for shares in ((0.5, 0.25), (1.0, 0.0), (0.125, 0.125)):
            s = steps.first + sum(b * d for b, d in zip(shares, steps.lower) if d is not None)
            assert np.all(s >= lb - 1e-9) and np.all(s <= ub + 1e-9)  # (the QP solver's tolerance)


def test_the_shares_keep_the_first_level_converging(panda):
    """Iterations from the reproducer's start: where the whole step (posture included) would undo what level
    1's own step gains, the shares taken leave level 1 at least half its predicted decrease, or no worse
    than its own step."""
    F = "panda_link8"
    lo, hi = np.asarray(panda.lower), np.asarray(panda.upper)
    rng = np.random.default_rng(2026)
    Q = rng.uniform(lo, hi, (200, 7))
    Q0 = rng.uniform(lo, hi, (200, 7))
    T = np.asarray(panda.fk(Q[1], F))
    qref = (lo + hi) / 2 + 0.4 * (hi - lo) * rng.uniform(-1, 1, 7)
    pb = Problem(panda, [ik.FrameTask(F, T, relax=("roll", "pitch", "yaw")), ik.PostureTask(qref)])
    q = np.clip(Q0[1], lo, hi)
    worse = 0
    for _ in range(6):
        st = pb.state(q)
        (J1, e1), _ = st[0]
        lb, ub, G, gl, gu = pb.box_and_rows(q, None, 1.0)
        steps = level_steps(st[0], lb, ub, G, gl, gu, lam=0.01 * st[1] ** 2 + 1e-5)

        def accept(dq, q=q):
            qn = np.clip(q + dq, lo, hi)
            return qn, pb.state(qn)

        f_alone = float(np.sum(accept(steps.first)[1][0][0][1] ** 2))
        f_whole = float(np.sum(accept(steps.total)[1][0][0][1] ** 2))
        trial = LowerShares(pb, 1e-4, 1e-3).take(q, st, steps, accept)
        f, m = float(e1 @ e1), float(np.sum((e1 + J1 @ steps.first) ** 2))
        f_new = float(np.sum(trial.state[0][0][1] ** 2))
        assert f_new <= max(m + 0.5 * (f - m), f_alone) + 1e-15 or np.sqrt(f_new) < 1e-4
        worse += f_whole > m + 0.5 * (f - m) and f_whole > f_alone  # the whole step would have failed
        q = trial.q
    assert worse >= 1


def test_the_stall_is_judged_on_the_first_unmet_goal_level():
    stall = LevelStall(3, 0.7, 2)
    # level 0 converging while level 1 (unmet) is stuck: never stalled
    for k in range(10):
        assert not stall.stalled([(0.1 * 0.5 ** k, 0.0), (0.3, 0.2), (0.0, 0.0)], 1e-4, 1e-3)
    # level 0 met: level 1 now decides, and it does not improve
    assert not stall.stalled([(1e-5, 0.0), (0.3, 0.2), (0.0, 0.0)], 1e-4, 1e-3)  # (its first record)
    assert not stall.stalled([(1e-5, 0.0), (0.3, 0.2), (0.0, 0.0)], 1e-4, 1e-3)
    assert stall.stalled([(2e-5, 0.0), (0.3, 0.2), (0.0, 0.0)], 1e-4, 1e-3)


def test_objectives_are_stationary_when_their_merits_stop_improving(panda):
    pb = Problem(panda, [ik.FrameTask(None, np.eye(4)), ik.PostureTask(panda.middle()),
                         ik.CentringTask(priority=3)])
    watch = ObjectiveWatch(pb)
    assert watch.levels == [1, 2]

    def levels(f2, f3):
        return [(None, np.zeros(6)), (None, np.array([np.sqrt(f2)])), (None, np.array([np.sqrt(f3)]))]

    for k in range(20):  # a level that keeps improving by 1 % keeps the start going
        assert not watch.stationary(levels(10.0 * 0.99 ** k, 1.0))
    f2 = 10.0 * 0.99 ** 19
    wobble = [levels(f2 * (1 + 1e-5 * (-1) ** k), 1.0) for k in range(level_progress.OBJECTIVE_PATIENCE)]
    assert [watch.stationary(lv) for lv in wobble] == [False] * (len(wobble) - 1) + [True]


def test_level_goal_errors_are_the_goal_tasks_errors_per_level(panda):
    rng = np.random.default_rng(4)
    T = panda.fk(panda.random_q(rng)).copy()
    tasks = [ik.FrameTask(None, T, relax=("roll", "pitch", "yaw")),
             ik.PostureTask(panda.middle(), priority=2),
             ik.FrameTask(None, T, relax=("x", "y", "z"), priority=2)]
    pb = Problem(panda, tasks)
    assert pb.goal_levels == [0, 1]
    q = panda.random_q(rng)
    _, pe, re, es = pb.evaluate(q)
    errs = pb.level_goal_errors(es)
    p_hand = np.linalg.norm(panda.fk(q)[:3, 3] - T[:3, 3])
    assert errs[0] == pytest.approx((p_hand, 0.0))
    rot = pin.log3(panda.fk(q)[:3, :3].T @ T[:3, :3])
    assert errs[1][0] == 0.0 and errs[1][1] == pytest.approx(np.linalg.norm(rot), rel=1e-6)
    assert (pe, re) == (max(e[0] for e in errs), max(e[1] for e in errs))
