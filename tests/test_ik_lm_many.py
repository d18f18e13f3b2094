"""kinserve.ik.lm.many: many targets in one compiled call give each the answer solve_lm gives it alone.

* reachable and unreachable targets, full pose and relaxed (world and target axes), with and without ``q0``,
  ``q0`` ranked or first, the seed table off, a start limit and an iteration budget: the same configuration
  (bit for bit), success, iterations, restarts and message as ``solve_lm`` target by target;
* a target whose prepared starts run out goes to the fallback, and only such a target.
"""

import numpy as np
import pytest

from kinserve import robots
from kinserve.ik.lm import many
from kinserve.ik.lm.many import ManySettings, solve_lm_many
from kinserve.ik.lm.solver import solve_lm
from kinserve.ik.targets import Target


def _targets(robot, rng, n, unreachable=3):
    poses = robot.fk_batch(robot.random_q(rng, n))
    poses[:unreachable, :3, 3] = (2.5, 0.3, 0.4)  # beyond reach: searched until a limit
    return poses, robot.random_q(rng, n)


def _alone(robot, poses, q0s, relax, relax_frame, settings, i):
    tgt = Target(robot, poses[i], robot.tip, relax, relax_frame)
    kw = {k: getattr(settings, k) for k in ("tol_pos", "tol_rot", "seed", "max_iter", "damping", "max_starts",
                                             "seed_table_enabled", "prefer_q0",
                                            "iteration_budget", "max_time")}
    return solve_lm(robot, tgt, None if q0s is None else q0s[i], **kw)


def _same(robot, poses, q0s, relax, relax_frame, settings):
    a = solve_lm_many(robot, robot.tip, poses, q0s, relax=relax, relax_frame=relax_frame, settings=settings)
    for i in range(len(poses)):
        b = _alone(robot, poses, q0s, relax, relax_frame, settings, i)
        assert np.array_equal(a.q[i], b.q), i
        assert (a.success[i], a.iterations[i], a.restarts[i], a.message[i]) == \
            (b.success, b.iterations, b.restarts, b.message), i
        assert a.position_error[i] == b.position_error and a.orientation_error[i] == b.orientation_error
    return a


@pytest.mark.parametrize("name, relax, relax_frame", [
    ("panda", (), "world"), ("ur5", ("z",), "world"), ("panda", ("yaw",), "target"),
    ("scara", ("roll", "pitch"),
                                                                                         "world"),
])
@pytest.mark.parametrize("options, with_q0", [
    (dict(max_starts=4), True), (dict(max_starts=4), False), (dict(max_starts=4, prefer_q0=True), True),
    (dict(max_starts=3, seed_table_enabled=False, seed=5), True), (dict(iteration_budget=40, seed=2), True),
])
def test_answers_equal_solve_lm_target_by_target(name, relax, relax_frame, options, with_q0):
    # no clock: an iteration budget far above the start limits' iterations, when none is given
    options = {"iteration_budget": 10_000, **options}
    robot = robots.load(name, geometry=False)
    poses, q0s = _targets(robot, np.random.default_rng(7), 30)
    a = _same(robot, poses, q0s if with_q0 else None, relax, relax_frame, ManySettings(**options))
    assert a.success[3:].mean() > 0.7 and not a.success[:3].any()  # real solves and real failures
    assert np.all(a.q >= robot.lower) and np.all(a.q <= robot.upper)


def test_default_limits_converged_targets_equal_solve_lm():
    """Without a start or iteration limit (the time budget bounds the search) every target that converges in
    its prepared starts has solve_lm's answer. (A time budget of 60 s, not the default 0.1 s: one that no
    busy machine makes bind.)"""
    robot = robots.load("panda", geometry=False)
    poses, q0s = _targets(robot, np.random.default_rng(8), 60, unreachable=0)
    a = _same(robot, poses, q0s, (), "world", ManySettings(max_time=60.0))
    assert a.success.all() and a.restarts.max() >= 1


def test_targets_whose_prepared_starts_run_out_go_to_the_fallback(monkeypatch):
    robot = robots.load("ur5", geometry=False)
    poses, q0s = _targets(robot, np.random.default_rng(9), 20, unreachable=4)
    monkeypatch.setattr(many, "TABLE_STARTS", 1)
    monkeypatch.setattr(many, "RANDOM_STARTS", 0)
    # more than three starts' worth on an unreachable one
    settings = ManySettings(iteration_budget=300, seed=1)
    asked = []

    def fallback(i):
        asked.append(i)
        return _alone(robot, poses, q0s, (), "world", settings, i)

    a = solve_lm_many(robot, robot.tip, poses, q0s, settings=settings, fallback=fallback)
    assert set(range(4)) <= set(asked)  # every unreachable target, each once
    assert len(asked) == len(set(asked)) and all(a.restarts[i] <= 2 for i in range(20) if i not in asked)
    for i in range(20):  # the fallback's answers, and those of the first start (common to both sequences)
        if i in asked or a.restarts[i] == 0:
            b = _alone(robot, poses, q0s, (), "world", settings, i)
            assert (np.array_equal(a.q[i], b.q) and a.message[i] == b.message
                    and a.iterations[i] == b.iterations)
    assert all("iteration budget exhausted (300 iterations)" in a.message[i] for i in range(4))
