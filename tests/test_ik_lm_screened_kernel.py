"""The screened LM start (ik.lm.screened_kernel): one compiled call that certifies the start with the sphere
pre-check, runs the LM from a certified start, then certifies the converged run's rows (answer first), against
the separate calls (``run_start``, ``first_uncertified``, ``certify_configuration``) and against coal.

Over many random targets and starts in a scene with a wall and a table (and the arm itself):

* a start the pre-check cannot certify does not run (flag "start uncertified", no iterations, no rows);
* every other start runs exactly as ``run_start`` does (the same status, iterations, rows and iterates);
* the flag says "certified" exactly when the run did not converge or ``first_uncertified`` certifies every
  row from the answer back to the row after the start, and then coal finds every one of them free; otherwise
  the row is the first uncertified one;
* with ``check_start=False`` the start is not asked (it runs);
* the collision checker's test of a run's rows, started from the screen's first uncertified row, gives the
  answer it gives from the first row (and coal's);
* the checked LM (``ik.solve`` with ``self_collision``) runs no start the screen could not certify unless the
  admission then admits it, and no refused start's iterations are counted.
"""

import numpy as np
import pytest

from kinserve import ik, robots
from kinserve.ik.lm import kernel as lm_kernel
from kinserve.ik.lm import solver as lm_solver
from kinserve.ik.lm.screened_kernel import run_screened_start
from kinserve.ik.lm.status import CONVERGED, ROWS_CERTIFIED, ROWS_UNCERTIFIED, START_UNCERTIFIED
from kinserve.ik.state import ik_state
from kinserve.ik.targets import Target
from kinserve.kinematics.precheck_kernels import certify_configuration, first_uncertified

FRAME = "panda_link8"


def _box(centre, size):
    T = np.eye(4)
    T[:3, 3] = centre
    return ik.Box(T, size)


@pytest.fixture(scope="module")
def panda():
    robot = robots.load("panda", tip=FRAME)
    ik.warm(robot, FRAME)
    return robot


OBSTACLES = (_box((0.65, 0.0, -0.05), (0.7, 1.2, 0.1)), _box((0.45, 0.0, 0.5), (0.05, 1.0, 1.0)))


@pytest.fixture(scope="module")
def scene(panda):
    checker = ik_state(panda).collision_checker(OBSTACLES, True, 0.0)
    return checker.constraint.scene, checker.precheck


def _arguments(robot, q0, T, max_iter=60):
    chain = robot.lm_chains.chains[robot.frame_id(FRAME)]
    tgt = Target(robot, T, FRAME)
    rows = max_iter + 1
    return (chain.geometry, chain.joints, q0, robot.lower, robot.upper, tgt.T, not tgt.full, tgt.A, tgt.kept,
            1e-8, 1e-6, lm_solver.DAMPING, lm_solver.DAMPING_GAIN, lm_solver.STALL_RATIO,
            lm_solver.STALL_PATIENCE, max_iter, np.empty((rows, robot.nq)), np.empty((rows, 2)))


def test_screened_start_equals_the_separate_calls_and_coal(panda, scene):
    coal_scene, pre = scene
    rng = np.random.default_rng(11)
    seen = {START_UNCERTIFIED: 0, ROWS_CERTIFIED: 0, ROWS_UNCERTIFIED: 0}
    for _ in range(300):
        T = panda.fk(panda.random_q(rng), FRAME)
        q0 = panda.random_q(rng)
        args = _arguments(panda, q0, T)
        status, it, k, flag, row = run_screened_start(*args, pre.floats, pre.ints, pre.tolerance, True)
        start_free = certify_configuration(pre.floats, pre.ints, q0, pre.tolerance)
        if not start_free:
            assert (it, k, flag, row) == (0, 0, START_UNCERTIFIED, -1)
            np.testing.assert_array_equal(args[16][0], q0)
            seen[flag] += 1
            continue
        plain = _arguments(panda, q0, T)
        assert (status, it, k) == lm_kernel.run_start(*plain)
        np.testing.assert_array_equal(args[16][:k], plain[16][:k])
        if status != CONVERGED:
            assert flag == ROWS_CERTIFIED and row == -1
            seen[flag] += 1
            continue
        rows = np.ascontiguousarray(args[16][k - 1:0:-1])  # answer first, the start left out
        first = first_uncertified(pre.floats, pre.ints, rows, 0, pre.tolerance)
        if first < len(rows):
            assert flag == ROWS_UNCERTIFIED and row == first  # the first row the caller's check starts from
        else:
            assert flag == ROWS_CERTIFIED and row == -1
        seen[flag] += 1
        if flag == ROWS_CERTIFIED:
            assert not any(coal_scene.in_collision(q) for q in (*rows, q0))
    assert min(seen.values()) >= 3, seen  # every flag was met


def test_check_start_false_skips_the_start(panda, scene):
    _, pre = scene
    rng = np.random.default_rng(3)
    for _ in range(200):
        q0 = panda.random_q(rng)
        if not certify_configuration(pre.floats, pre.ints, q0, pre.tolerance):
            break
    assert not certify_configuration(pre.floats, pre.ints, q0, pre.tolerance)
    T = panda.fk(panda.random_q(rng), FRAME)
    status, it, k, flag, _ = run_screened_start(*_arguments(panda, q0, T), pre.floats, pre.ints,
                                                pre.tolerance, False)
    assert flag != START_UNCERTIFIED and k >= 1
    assert (status, it, k) == lm_kernel.run_start(*_arguments(panda, q0, T))


def test_the_checker_goes_on_from_the_screens_first_uncertified_row(panda, scene):
    coal_scene, pre = scene
    checker = ik_state(panda).collision_checker(OBSTACLES, True, 0.0)
    rng = np.random.default_rng(12)
    met = 0
    for _ in range(400):
        T = panda.fk(panda.random_q(rng), FRAME)
        args = _arguments(panda, panda.random_q(rng), T)
        status, it, k, flag, row = run_screened_start(*args, pre.floats, pre.ints, pre.tolerance, True)
        if flag != ROWS_UNCERTIFIED:
            continue
        met += 1
        rows = np.ascontiguousarray(args[16][k - 1:0:-1])
        hinted = checker.first_violation(rows, row)
        assert hinted == checker.first_violation(rows)
        hits = [coal_scene.in_collision(q) for q in rows]
        assert hinted == (hits.index(True) if True in hits else -1)
    assert met >= 5


def test_the_checked_lm_runs_only_admitted_starts_and_counts_only_their_iterations(panda, scene):
    coal_scene, pre = scene
    checker = ik_state(panda).collision_checker(OBSTACLES, True, 0.0)
    screen = checker.screen
    calls = []

    def recording_run(*args):
        out = screen.run(*args)
        calls.append((args[2].copy(), args[-1], out))
        return out

    checker.screen = screen._replace(run=recording_run)
    rng = np.random.default_rng(21)
    refused = checked = 0
    try:
        for i in range(60):
            q = panda.random_q(rng)
            if coal_scene.in_collision(q):
                continue
            calls.clear()
            res = ik.solve(panda, panda.fk(q, FRAME), panda.random_q(rng), frame=FRAME, self_collision=True,
                           obstacles=list(OBSTACLES), seed=i)
            if res.info.get("strategy") != "unconstrained, checked":
                continue
            checked += 1
            ran = 0
            for j, (q0, check_start, (status, it, k, flag, row)) in enumerate(calls):
                if flag == START_UNCERTIFIED:  # nothing ran; the start was not certified
                    assert check_start and (it, k) == (0, 0)
                    assert not certify_configuration(pre.floats, pre.ints, q0, pre.tolerance)
                    admitted = j + 1 < len(calls) and not calls[j + 1][1] \
                        and np.array_equal(calls[j + 1][0], q0)
                    if admitted:  # run again only after the admission said yes: coal finds it free
                        assert not coal_scene.in_collision(q0)
                    else:
                        refused += 1
                    continue
                ran += it
            assert res.iterations == ran, (res.iterations, ran)
    finally:
        checker.screen = screen
    assert checked >= 20 and refused >= 3, (checked, refused)
