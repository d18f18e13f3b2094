"""kinserve.ik.result: History bookkeeping, lazy task errors, pickling."""

import pickle

import numpy as np

from kinserve import ik, robots


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
