"""ik.batch.solve_many: same answers as one-by-one solving, in order, on 2 processes; validation up front."""

import numpy as np
import pytest

import ik
import robots
from kinematics.errors import InputError, NonFiniteError


@pytest.fixture(scope="module")
def ur5():
    return robots.load("ur5", geometry=False)


def test_solve_many_matches_serial_solves(ur5):
    rng = np.random.default_rng(3)
    Q = ur5.random_q(rng, 24)
    poses = ur5.fk_batch(Q)
    q0 = ur5.random_q(rng, 24)
    many = ik.solve_many(ur5, poses, q0, processes=2, chunksize=5, progress=False, seed=2)
    assert len(many) == 24
    for i, res in enumerate(many):
        one = ik.solve(ur5, poses[i], q0[i], seed=2)
        assert res.success and one.success
        assert np.array_equal(res.q, one.q)  # deterministic and order preserved
        assert res.history is None
    serial = ik.solve_many(ur5, poses, q0, backend="serial", keep_history=True, progress=False, seed=2)
    assert all(np.array_equal(a.q, b.q) for a, b in zip(many, serial))
    assert serial[0].history is not None


def test_solve_many_shared_q0_and_options(ur5):
    poses = ur5.fk_batch(ur5.random_q(np.random.default_rng(4), 6))
    res = ik.solve_many(ur5, list(poses), ur5.neutral(), processes=1, method="qp", qp_backend="daqp", relax=("yaw",))
    assert all(r.success and r.method == "qp" for r in res)


def test_solve_many_validates_everything_first(ur5):
    poses = ur5.fk_batch(ur5.random_q(np.random.default_rng(5), 4))
    poses[2, 0, 3] = np.nan
    with pytest.raises(NonFiniteError, match=r"targets\[2\]"):
        ik.solve_many(ur5, poses)
    good = ur5.fk_batch(ur5.random_q(np.random.default_rng(5), 4))
    with pytest.raises(InputError, match="q0"):
        ik.solve_many(ur5, good, np.zeros((3, 6)))
    with pytest.raises(InputError, match="backend"):
        ik.solve_many(ur5, good, backend="ray")
    with pytest.raises(InputError, match="processes"):
        ik.solve_many(ur5, good, processes=0)
    with pytest.raises(InputError, match="single"):
        ik.solve_many(ur5, good[0])
    with pytest.raises(InputError, match="unknown option"):
        ik.solve_many(ur5, good, processes=1, frobnicate=True)
    assert ik.solve_many(ur5, []) == []
