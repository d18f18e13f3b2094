"""kinserve.ik.lm.solver: random reachable targets converge within tolerance, limits hold, restarts are
deterministic; the Python iteration equals the compiled one; an iteration budget bounds the work and never
reads the clock."""

import numpy as np
import pytest

from kinserve import robots
from kinserve.ik.lm.solver import _bounded_step, solve_lm
from kinserve.ik.targets import Target
from kinserve.kinematics import se3

ROBOTS = {"panda": 30, "ur5": 25, "youbot": 20, "scara": 20, "planar4r": 20}


#: Iterations of every start together: no time limit decides a solve that must succeed or be repeated.
BUDGET = 2000


def _reachable(robot, rng, n):
    return [(q, robot.fk(q).copy()) for q in robot.random_q(rng, n)]


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_random_reachable_targets_converge_within_limits(name):
    robot = robots.load(name, geometry=False)
    rng = np.random.default_rng(2024)
    for q_true, T in _reachable(robot, rng, ROBOTS[name]):
        q0 = robot.random_q(rng)
        res = solve_lm(robot, Target(robot, T), q0, iteration_budget=BUDGET)
        assert res.success, (name, res.message)
        assert robot.within_limits(res.q)
        pe, re = se3.pose_error(robot.fk(res.q), T)
        assert pe < 1e-4 and re < 1e-3
        assert res.position_error == pytest.approx(pe, abs=1e-12)
        assert res.orientation_error == pytest.approx(re, abs=1e-9)
        assert res.method == "lm" and res.message == "converged"


def test_history_records_the_returned_run():
    robot = robots.load("panda", geometry=False)
    rng = np.random.default_rng(5)
    T = robot.fk(robot.random_q(rng)).copy()
    res = solve_lm(robot, Target(robot, T), robot.random_q(rng))
    h = res.history
    assert len(h) == h.q.shape[0] and h.q.shape[1] == robot.nq
    assert np.allclose(h.q[-1], res.q)
    # every recorded error is the true error of the recorded configuration
    for q, pe, re in zip(h.q, h.position_error, h.orientation_error):
        p_ref, r_ref = se3.pose_error(robot.fk(q), T)
        assert pe == pytest.approx(p_ref, abs=1e-12) and re == pytest.approx(r_ref, abs=1e-9)
        assert robot.within_limits(q)
    # task_error (evaluated lazily) is the signed world-axis error
    te = h.task_error
    assert te.shape == (len(h), 6)
    assert np.allclose(np.linalg.norm(te[:, :3], axis=1), h.position_error, atol=1e-12)


def test_deterministic_for_a_seed_and_restarts_counted():
    robot = robots.load("ur5", geometry=False)
    rng = np.random.default_rng(9)
    T = robot.fk(robot.random_q(rng)).copy()
    q0 = robot.random_q(rng)
    a = solve_lm(robot, Target(robot, T), q0, seed=3, seed_table_enabled=False, iteration_budget=BUDGET)
    b = solve_lm(robot, Target(robot, T), q0, seed=3, seed_table_enabled=False, iteration_budget=BUDGET)
    assert np.array_equal(a.q, b.q) and a.iterations == b.iterations and a.restarts == b.restarts


def test_unreachable_target_is_a_result_with_the_best_q():
    robot = robots.load("panda", geometry=False)
    T = np.eye(4)
    T[:3, 3] = (2.5, 0.0, 0.5)  # far beyond the ~0.9 m reach
    res = solve_lm(robot, Target(robot, T), robot.neutral(), iteration_budget=300)  # several starts
    assert not res.success
    assert "target may be out of reach" in res.message
    assert robot.within_limits(res.q)
    assert res.position_error > 1.0
    assert res.restarts >= 1
    # the best configuration stretches towards the target: much closer than the start
    assert res.position_error < se3.pose_error(robot.fk(robot.neutral()), T)[0]


def test_position_only_relaxation():
    robot = robots.load("panda", geometry=False)
    rng = np.random.default_rng(11)
    for _ in range(10):
        T = robot.fk(robot.random_q(rng)).copy()
        T_other = T.copy()
        T_other[:3, :3] = se3.rot_x(2.0) @ T[:3, :3]  # orientation that does not matter
        tgt = Target(robot, T_other, relax=("roll", "pitch", "yaw"))
        res = solve_lm(robot, tgt, robot.random_q(rng), iteration_budget=BUDGET)
        assert res.success and res.orientation_error == 0.0
        assert np.linalg.norm(robot.fk(res.q)[:3, 3] - T[:3, 3]) < 1e-4


def test_bounded_step_keeps_limits_and_uses_the_free_joints():
    # a 2x3 Jacobian: joint 0 would overshoot its limit; the re-solve moves the other joints instead
    J = np.array([[1.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    e = np.array([1.0, 0.2])
    q = np.zeros(3)
    lo, hi = np.full(3, -1.0), np.array([0.1, 1.0, 1.0])
    qn = _bounded_step(J, e, 1e-9, q, lo, hi)
    assert np.all(qn <= hi + 1e-12) and np.all(qn >= lo - 1e-12)
    assert qn[0] == pytest.approx(0.1)
    assert J @ qn == pytest.approx(e, abs=1e-6)  # still solves the linearised task exactly


def test_relaxed_targets_rank_starts_by_position_only():
    # position-only tracking: q0 next to the solution must be the first start whatever the (ignored)
    # target orientation says, so the answer stays on q0's branch
    youbot = robots.load("youbot", geometry=False)
    q0 = np.array([0.2, 0.4, -0.8, 0.5, 0.1])
    T = youbot.fk(np.array([0.22, 0.39, -0.79, 0.5, 0.1])).copy()
    T[:3, :3] = se3.rot_x(2.5)  # an orientation the relaxed task ignores
    res = solve_lm(youbot, Target(youbot, T, relax=("roll", "pitch", "yaw")), q0, iteration_budget=BUDGET)
    assert res.success and res.restarts == 0
    assert np.abs(res.q - q0).max() < 0.1


def test_accept_rejects_converged_runs_and_tries_the_next_start():
    """``solve_lm(accept=...)``: the test sees each converged run (start first, answer last); a rejected run
    is followed by the next start; when every converged run is rejected the result says so and fails."""
    from kinserve import robots
    from kinserve.ik.lm.solver import solve_lm
    from kinserve.ik.targets import Target

    robot = robots.load("panda", geometry=False)
    rng = np.random.default_rng(21)
    T = robot.fk(robot.random_q(rng))
    tgt = Target(robot, T)
    seen = []

    def second_only(qs):
        seen.append(np.array(qs))
        return len(seen) >= 2

    res = solve_lm(robot, tgt, robot.random_q(rng), seed=4, accept=second_only, iteration_budget=BUDGET)
    assert res.success and len(seen) == 2 and res.restarts >= 1
    assert np.array_equal(seen[1][-1], res.q) and np.array_equal(res.history.q, seen[1])
    for run in seen:  # every run converged: its last configuration meets the target
        pe, re = tgt.errors_at(robot, run[-1])
        assert pe < 1e-4 and re < 1e-3
    never = solve_lm(robot, tgt, robot.random_q(rng), seed=4, accept=lambda qs: False, max_starts=3,
                     iteration_budget=BUDGET)
    assert not never.success and "rejected" in never.message and never.restarts == 2


def test_admit_skips_starts_without_running_them():
    """``solve_lm(admit=...)``: refused starts cost no run and no start; all refused: a failed result, not a
    crash."""
    from kinserve import robots
    from kinserve.ik.lm.solver import ADMIT_MISSES, solve_lm
    from kinserve.ik.targets import Target

    robot = robots.load("panda", geometry=False)
    rng = np.random.default_rng(22)
    tgt = Target(robot, robot.fk(robot.random_q(rng)))
    q0 = robot.random_q(rng)
    offered = []

    def not_first_two(q):
        offered.append(np.array(q))
        return len(offered) > 2

    res = solve_lm(robot, tgt, q0, seed=5, admit=not_first_two, iteration_budget=BUDGET)
    # the run began at the first admitted start
    assert res.success and np.array_equal(res.history.q[0], offered[2])
    assert res.restarts == len(offered) - 3  # refused starts are not counted
    none = solve_lm(robot, tgt, q0, seed=5, admit=lambda q: False, iteration_budget=BUDGET)
    assert not none.success and "admitted" in none.message and none.restarts == 0
    assert f"{ADMIT_MISSES} refused" in none.message and np.all(np.isfinite(none.q))


def _start_buffers(robot, max_iter):
    return np.empty((max_iter + 1, robot.nq)), np.empty((max_iter + 1, 2))


@pytest.mark.parametrize("name, relax, relax_frame", [
    ("panda", (), "world"), ("ur5", (), "world"), ("panda", ("roll", "pitch", "yaw"), "world"),
    ("panda", ("yaw",), "target"), ("ur5", ("z", "roll"), "target"), ("scara", ("roll", "pitch"), "world"),
])
def test_python_iteration_equals_the_compiled_one(name, relax, relax_frame):
    """python_start (Pinocchio's algorithms) and the kernel's run_start take the same iterates from the same
    start: same status and count, every configuration and squared error to 1e-10, starts at and beyond the
    limits included (the active-set re-solve runs)."""
    from kinserve.ik.lm.chains import compiled_chain
    from kinserve.ik.lm.solver import DAMPING, DAMPING_GAIN, STALL_PATIENCE, STALL_RATIO, python_start

    robot = robots.load(name, geometry=False)
    rng = np.random.default_rng(4)
    chain = compiled_chain(robot, robot.frame_id(robot.tip))
    assert chain is not None
    lo, hi = robot.lower, robot.upper
    checked = steps = 0
    for T, q0 in zip(robot.fk_batch(robot.random_q(rng, 25)), robot.random_q(rng, 25)):
        q0 = np.where(rng.random(robot.nq) < 0.3, np.where(rng.random(robot.nq) < 0.5, lo, hi), q0)
        tgt = Target(robot, T, relax=relax, relax_frame=relax_frame)
        qa, ea = _start_buffers(robot, 40)
        qb, eb = _start_buffers(robot, 40)
        a = chain.kernel.run_start(chain.geometry, chain.joints, q0, lo, hi, tgt.T, not tgt.full, tgt.A,
                                   tgt.kept, 1e-8, 1e-6, DAMPING, DAMPING_GAIN, STALL_RATIO,
                                   STALL_PATIENCE, 40, qa, ea)
        b = python_start(robot.model, robot.model.createData(), tgt, q0, lo, hi, 1e-8, 1e-6,
                         DAMPING, 40, qb, eb)
        assert a == b
        k = a[2]
        assert np.abs(qa[:k] - qb[:k]).max() < 1e-10 and np.abs(ea[:k] - eb[:k]).max() < 1e-10
        assert np.all(qa[:k] >= lo) and np.all(qa[:k] <= hi)
        checked += 1
        steps += k
    assert checked == 25 and steps > 100  # real runs, not one-row stalls


def _unreachable(robot):
    T = np.eye(4)
    T[:3, 3] = (2.0, 0.0, 0.5)
    return Target(robot, T)


def test_iteration_budget_bounds_every_start_together():
    robot = robots.load("panda", geometry=False)
    tgt = _unreachable(robot)
    for budget in (1, 7, 60, 130):
        res = solve_lm(robot, tgt, robot.neutral(), seed=1, iteration_budget=budget)
        assert not res.success and res.iterations == budget
        assert f"iteration budget exhausted ({budget} iterations)" in res.message
    # a reachable target converges within a generous budget as without one: the same answer
    rng = np.random.default_rng(6)
    T = robot.fk(robot.random_q(rng))
    q0 = robot.random_q(rng)
    free = solve_lm(robot, Target(robot, T), q0, seed=2, max_time=60.0)  # a time limit that does not bind
    capped = solve_lm(robot, Target(robot, T), q0, seed=2, iteration_budget=10_000)
    assert capped.success and np.array_equal(free.q, capped.q) and free.iterations == capped.iterations


def test_iteration_budget_never_lets_the_clock_decide(monkeypatch):
    """With iteration_budget and no max_time the answer is that of the inputs and seed alone: a clock that
    jumps by an hour at every reading changes nothing (with a time budget it would stop after one start)."""
    from kinserve.ik.lm import solver as lm_solver

    robot = robots.load("ur5", geometry=False)
    tgt = _unreachable(robot)
    calm = solve_lm(robot, tgt, robot.neutral(), seed=3, iteration_budget=200)
    ticks = iter(range(0, 10**9, 3600))
    monkeypatch.setattr(lm_solver, "_now", lambda: float(next(ticks)))
    jumpy = solve_lm(robot, tgt, robot.neutral(), seed=3, iteration_budget=200)
    assert np.array_equal(calm.q, jumpy.q) and calm.iterations == jumpy.iterations == 200
    assert calm.restarts == jumpy.restarts > 1 and calm.message == jumpy.message
    timed = solve_lm(robot, tgt, robot.neutral(), seed=3, max_time=1.0, iteration_budget=200)
    # the clock counts only with max_time
    assert timed.restarts == 0 and "time budget exhausted" in timed.message
