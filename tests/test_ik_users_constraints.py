"""A user's constraint (``ik.Constraint`` subclass written outside kinserve): what its ``rows`` and ``margin``
return is checked on every call, and an iteration budget bounds the starts even when each ends at once."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pinocchio as pin
import pytest

from kinserve import ik, robots
from kinserve.ik.constraints.base import is_users_constraint
from kinserve.kinematics import errors


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda", geometry=False)


def _target(panda):
    return panda.fk(panda.random_q(np.random.default_rng(1))).copy()


def _above(panda, height=0.2):
    """The docstring's example: the hand above a table at ``height`` (m): a damper row and a true check."""
    fid = panda.frame_id("panda_hand")

    def rows(robot, data, q):
        z = pin.updateFramePlacement(robot.model, data, fid).translation[2]
        Jz = pin.getFrameJacobian(robot.model, data, fid, pin.LOCAL_WORLD_ALIGNED)[2:3]
        return Jz, np.array([-0.5 * (z - height)]), np.array([np.inf])

    def margin(robot, data, q):
        return pin.updateFramePlacement(robot.model, data, fid).translation[2] - height

    return rows, margin


def _rows_only(rows):
    class RowsOnly(ik.Constraint):
        def rows(self, robot, data, q, dt=None):
            return rows(robot, data, q)

    return RowsOnly()


def _checked(margin):
    class Checked(ik.Constraint):
        def rows(self, robot, data, q, dt=None):
            return None, np.full(robot.model.nv, -np.inf), np.full(robot.model.nv, np.inf)

        def margin(self, robot, data, q):
            return margin(robot, data, q)

    return Checked()


@pytest.mark.parametrize("change,error,words", [
    (lambda G, lo, hi: None, errors.InputError, "must return a triple (G, lower, upper), got NoneType"),
    (lambda G, lo, hi: (G, lo), errors.InputError, "got tuple"),
    (lambda G, lo, hi: (G, "low", hi), errors.InputError, "must return numbers"),
    (lambda G, lo, hi: (G[:, :5], lo, hi), errors.ShapeError, "G must be k x 7"),
    (lambda G, lo, hi: (G[0], lo, hi), errors.ShapeError, "got shape (7,)"),
    (lambda G, lo, hi: (G, np.zeros(2), hi), errors.ShapeError, "lower and upper must hold 1 numbers each"),
    (lambda G, lo, hi: (None, lo, hi), errors.ShapeError, "must hold 7 numbers each (one per joint velocity"),
    (lambda G, lo, hi: (G * np.nan, lo, hi), errors.NonFiniteError, "G must hold finite numbers"),
    (lambda G, lo, hi: (G * 1e9, lo, hi), errors.NonFiniteError, "G must hold finite numbers"),
    (lambda G, lo, hi: (G, lo * np.nan, hi), errors.NonFiniteError, "no NaN"),
    (lambda G, lo, hi: (G, lo, np.full_like(hi, 1e9)), errors.NonFiniteError, "finite magnitude <= 1e+06"),
])
def test_bad_rows_are_named(panda, change, error, words):
    rows, _ = _above(panda)
    with pytest.raises(error) as info:
        ik.solve(panda, _target(panda), constraints=[_rows_only(lambda *a: change(*rows(*a)))], seed=0,
                 iteration_budget=300)
    assert words in str(info.value) and "RowsOnly" in str(info.value)


@pytest.mark.parametrize("value,error,words", [
    (float("nan"), errors.NonFiniteError, "returned NaN"),
    (None, errors.InputError, "must return one number (>= 0: satisfied), got NoneType"),
    (np.array([0.1, 0.2]), errors.InputError, "got ndarray"),
    ("0.1", errors.InputError, "got str"),
    (True, errors.InputError, "got bool"),
])
def test_bad_margins_are_named_not_looped_on(panda, value, error, words):
    """A NaN margin used to keep the solve starting new starts without end under an iteration budget."""
    with pytest.raises(error) as info:
        ik.solve(panda, _target(panda), constraints=[_checked(lambda *a: value)], seed=0,
                 iteration_budget=300)
    assert words in str(info.value) and "Checked" in str(info.value)


def test_good_rows_and_margins_in_lists_and_numpy_scalars_solve(panda):
    """Lists, NumPy scalars and 0-d arrays are numbers: the docstring's table constraint holds on every
    iterate of the answer, the hand ending above the table."""
    rows, margin = _above(panda, 0.25)

    class Listed(ik.Constraint):
        def rows(self, robot, data, q, dt=None):
            G, lo, hi = rows(robot, data, q)
            return G.tolist(), lo.tolist(), hi.tolist()

        def margin(self, robot, data, q):
            return np.array(margin(robot, data, q))

    rng = np.random.default_rng(2)
    q = next(q for q in panda.random_q(rng, 100) if panda.fk(q, "panda_hand")[2, 3] > 0.4)
    res = ik.solve(panda, panda.fk(q), constraints=[Listed()], seed=0, iteration_budget=3000)
    assert res.success, res.message
    assert all(panda.fk(q, "panda_hand")[2, 3] >= 0.25 - 1e-9 for q in res.history.q)


def test_only_users_constraints_are_checked():
    assert not any(is_users_constraint(c) for c in (ik.JointLimits(), ik.VelocityLimits(1.0)))
    assert is_users_constraint(_rows_only(lambda *a: None)) and is_users_constraint(_checked(lambda *a: 0.0))


def test_starts_that_end_at_once_still_spend_the_iteration_budget():
    """Rows no step can satisfy (1 <= sum(dq) <= -1): every start ends at its first iteration. Each start
    counts one iteration of the budget, so the solve ends with the reason; before, the budget never moved and
    new starts came without end. Run in a child process, killed if it does not answer within 120 s."""
    code = textwrap.dedent("""
        import numpy as np
        from kinserve import ik, robots

        class Infeasible(ik.Constraint):
            def rows(self, robot, data, q, dt=None):
                return np.ones((1, robot.model.nv)), np.array([1.0]), np.array([-1.0])

        panda = robots.load("panda", geometry=False)
        T = panda.fk(panda.random_q(np.random.default_rng(1)))
        res = ik.solve(panda, T, constraints=[Infeasible()], seed=0, iteration_budget=300)
        print(res.success, res.restarts + 1, "|", res.message)
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    success, starts, message = out.stdout.replace("|", " ", 1).split(maxsplit=2)
    assert success == "False" and int(starts) <= 300
    assert "QP infeasible" in message and "iteration budget exhausted (300 iterations)" in message
