"""kinserve.ik.result: History bookkeeping, lazy task errors, pickling; the one-line repr; the seed hint."""

import pickle
import re

import numpy as np
import pytest

from kinserve import ik, robots
from kinserve.kinematics.errors import InputError


def test_history_lazy_task_error_and_pickle():
    panda = robots.load("panda", geometry=False)
    T = panda.fk(panda.random_q(np.random.default_rng(1))).copy()
    res = ik.solve(panda, T, relax=("yaw",))
    h = res.history
    assert h.components == ("x", "y", "z", "roll", "pitch")
    data = pickle.loads(pickle.dumps(res))
    assert np.array_equal(data.q, res.q) and data.success == res.success
    assert data.history.task_error.shape == (len(h), 5)
    # the signed errors are the residuals of the kept components at each recorded q
    for q, row in zip(h.q, data.history.task_error):
        Tq = panda.fk(q)
        assert np.allclose(row[:3], T[:3, 3] - Tq[:3, 3], atol=1e-12)
    assert np.allclose(np.linalg.norm(data.history.task_error[:, :3], axis=1), h.position_error, atol=1e-12)


def test_empty_history():
    h = ik.History.empty(3, ("x", "y"))
    assert len(h) == 0 and h.task_error.shape == (0, 2)


REPR = re.compile(r"^Result\(success=(True|False), position_error=(\S+) m, orientation_error=(\S+) rad, "
                  r"iterations=(\d+), reason='(.*)'\)$")


def check_repr(res) -> str:
    """``repr(res)``: one line of at most 160 characters holding success, both errors, iterations and the
    reason, the numbers those of the result (to the printed precision)."""
    text = repr(res)
    assert "\n" not in text and len(text) <= 160 and str(res) == text, text
    m = REPR.match(text)
    assert m, text
    assert m.group(1) == str(bool(res.success)) and int(m.group(4)) == res.iterations
    assert float(m.group(2)) == pytest.approx(res.position_error, rel=0.06)
    assert float(m.group(3)) == pytest.approx(res.orientation_error, rel=0.06)
    return m.group(5)


def test_repr_is_one_short_line_for_one_arm_and_two():
    panda = robots.load("panda", geometry=False)
    T = panda.fk(panda.random_q(np.random.default_rng(2))).copy()
    res = ik.solve(panda, T, seed=1, iteration_budget=400)
    assert res.success and check_repr(res) == res.message == "converged"
    baxter = robots.load("baxter", geometry=False)
    q = baxter.random_q(np.random.default_rng(3))
    tasks = [ik.FrameTask(f, baxter.fk(q, f)) for f in ("left_gripper", "right_gripper")]
    two = ik.solve(baxter, tasks=tasks, seed=2, iteration_budget=300)
    assert len(two.q) == baxter.nq == 14 and len(two.task_errors) == 2
    assert two.success and check_repr(two) == two.message == "converged"
    assert "ok [" in two.summary() or "FAILED [" in two.summary()  # the longer summary() stays


def test_repr_shortens_a_long_reason_to_one_line():
    long = "stopped: " + "the obstacle is in the way\nof every start " * 20
    res = ik.Result(q=np.zeros(40), success=False, position_error=1.25, orientation_error=float("inf"),
                    iterations=123456, message=long)
    reason = check_repr(res)
    assert reason.endswith("...") and " ".join(long.split()).startswith(reason[:-3]) and len(reason) > 20
    assert "array" not in repr(res) and "orientation_error=inf rad" in repr(res)


def test_an_array_given_as_seed_points_at_q0():
    panda = robots.load("panda", geometry=False)
    q = panda.neutral()
    T = panda.fk(q).copy()
    for seed in (q, q.tolist(), tuple(q)):
        with pytest.raises(InputError, match=r"^seed is the random seed .*start configuration as q0="):
            ik.solve(panda, T, seed=seed)
    for bad in (-1, 1.5, "1", True):
        with pytest.raises(InputError, match="^seed must be a non-negative integer"):
            ik.solve(panda, T, seed=bad)
    assert ik.solve(panda, T, q0=q, seed=np.int64(3), iteration_budget=200).success
