"""The ``iteration_budget`` option: the iterations of all starts together; alone, no clock decides the answer.

With ``iteration_budget`` and no ``max_time`` an answer must depend only on the
inputs and the seed. Checked by running each solve twice: on the real clock and
on a clock that leaps 1000 s at every reading (every deadline is past at once) -
the two answers must be bit-identical. The same leaping clock with a
``max_time`` does end a solve early (so the check can fail).
"""

from __future__ import annotations

import numpy as np
import pytest
from fake_clock import stepping_clock

from kinserve import ik, robots
from kinserve.ik.tasks.centring_task import CentringTask

BUDGET_DONE = "iteration budget exhausted"
#: Seconds each clock reading advances by: every deadline is past at the first reading after its start.
LEAP = 1000.0


def leaping_clock():
    """A clock leaping :data:`LEAP` seconds at every reading, in place of the real clocks
    (:func:`fake_clock.stepping_clock`)."""
    return stepping_clock(LEAP)


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda", geometry=False)


@pytest.fixture(scope="module")
def targets(panda):
    rng = np.random.default_rng(7)
    reachable = np.asarray(panda.fk(panda.random_q(rng))).copy()
    far = reachable.copy()
    far[:3, 3] = (1.6, 0.2, 0.6)  # beyond the Panda's reach (~0.86 m from the shoulder)
    return {"reachable": reachable, "far": far}


def assert_same_answer(a: ik.Result, b: ik.Result) -> None:
    assert a.q.tobytes() == b.q.tobytes()
    assert (a.success, a.iterations, a.restarts) == (b.success, b.iterations, b.restarts)
    assert a.message == b.message
    assert (a.position_error, a.orientation_error) == (b.position_error, b.orientation_error)


SPHERE = ik.Sphere((0.35, 0.0, 0.55), 0.08)
CASES = {
    "qp": dict(method="qp"),
    "qp centring sphere": dict(method="qp", centring=1.0, spheres=[SPHERE]),
    "lm": dict(method="lm"),
    "auto": dict(method="auto"),
    "auto sphere": dict(method="auto", spheres=[SPHERE]),
    "dls": dict(method="dls"),
}


@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("which", ["reachable", "far"])
def test_an_iteration_budget_alone_leaves_the_clock_out(panda, targets, case, which):
    def solve():
        return ik.solve(panda, targets[which], panda.neutral(), iteration_budget=60, **CASES[case])

    on_real = solve()
    with leaping_clock():
        on_leaping = solve()
    assert_same_answer(on_real, on_leaping)
    assert on_real.iterations <= 60
    if which == "far":  # nothing converges: the budget ends the solve
        assert not on_real.success and BUDGET_DONE in on_real.message


def test_with_max_time_the_clock_counts_again(panda, targets):
    """``max_time`` and ``iteration_budget`` together: whichever ends first. On the leaping clock the time is
    up after the first iteration; on the real clock a generous ``max_time`` leaves the budget to end it."""
    far = targets["far"]
    with leaping_clock():
        cut = ik.solve(panda, far, method="qp", max_time=5.0, iteration_budget=60)
    assert "time budget exhausted" in cut.message and cut.iterations < 5
    full = ik.solve(panda, far, method="qp", max_time=120.0, iteration_budget=60)
    assert full.iterations == 60 and BUDGET_DONE in full.message


@pytest.mark.parametrize("budget", [1, 2, 13, 37])
def test_the_budget_counts_the_iterations_of_every_start(panda, targets, budget):
    res = ik.solve(panda, targets["far"], method="qp", iteration_budget=budget)
    assert not res.success and res.iterations == budget
    assert f"{BUDGET_DONE} ({budget} iterations)" in res.message
    if budget == 37:  # (each start stalls in a few iterations: several starts shared the budget)
        assert res.restarts >= 2
        assert f"in {res.restarts + 1} starts ({budget} iterations" in res.message


def test_a_budget_that_does_not_bind_changes_nothing(panda, targets):
    """A solve that converges well inside the budget gives the answer it gives with only a (generous) time
    limit: the budget only bounds the work."""
    T = targets["reachable"]
    for kw in (dict(method="qp"), dict(method="qp", centring=1.0)):
        timed = ik.solve(panda, T, panda.neutral(), max_time=120.0, **kw)
        budgeted = ik.solve(panda, T, panda.neutral(), iteration_budget=5000, **kw)
        assert timed.success and timed.iterations < 200
        assert_same_answer(timed, budgeted)


def test_tasks_api_takes_the_budget(panda, targets):
    tasks = [ik.FrameTask("panda_link8", targets["far"]), CentringTask(1.0, priority=2)]
    res = ik.solve(panda, tasks=tasks, q0=panda.neutral(), iteration_budget=25)
    assert not res.success and res.iterations == 25 and f"{BUDGET_DONE} (25 iterations)" in res.message
    with leaping_clock():
        again = ik.solve(panda, tasks=tasks, q0=panda.neutral(), iteration_budget=25)
    assert_same_answer(res, again)


@pytest.mark.parametrize("method", ["jacobian_transpose", "pseudo_inverse", "dls"])
def test_classical_methods_run_one_start_within_the_budget(method):
    """One start: the run ends on the smaller of ``max_iter`` and the budget (one iterate more in history)."""
    scara = robots.load("scara", geometry=False)
    T = scara.fk(np.array([0.6, 1.1, 0.55, 0.4]))
    q0 = np.array([0.2, 0.6, 0.4, 0.0])
    relax = ("roll", "pitch")
    cut = ik.solve(scara, T, q0, method=method, relax=relax, iteration_budget=2)
    assert not cut.success and cut.iterations == 2 and len(cut.history.q) == 3
    assert cut.message == f"{BUDGET_DONE} (2 iterations)"
    free = ik.solve(scara, T, q0, method=method, relax=relax, iteration_budget=100000)
    plain = ik.solve(scara, T, q0, method=method, relax=relax)
    assert free.success and free.iterations > 2
    assert_same_answer(free, plain)
    np.testing.assert_array_equal(free.history.q[:3], cut.history.q)  # the same path, cut after 2 steps
    capped = ik.solve(scara, T, q0, method=method, relax=relax, iteration_budget=50, max_iter=1)
    assert capped.iterations == 1 and "iteration limit (1) reached" in capped.message
