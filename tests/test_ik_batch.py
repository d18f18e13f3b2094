"""kinserve.ik.batch.solve_many: same answers as one-by-one solving, in order, on 2 processes; validation up front."""

import numpy as np
import pytest

from kinserve import ik
from kinserve import robots
from kinserve.kinematics import se3
from kinserve.kinematics.errors import InputError, NonFiniteError


@pytest.fixture(scope="module")
def ur5():
    return robots.load("ur5", geometry=False)


def _valid(robot, T, res):
    pe, re = se3.pose_error(robot.fk(res.q), T)
    return res.success and pe < 1e-4 and re < 1e-3 and robot.within_limits(res.q)


def test_solve_many_on_two_processes(ur5):
    rng = np.random.default_rng(3)
    Q = ur5.random_q(rng, 24)
    poses = ur5.fk_batch(Q)
    q0 = ur5.random_q(rng, 24)
    many = ik.solve_many(ur5, poses, q0, processes=2, chunksize=5, progress=False, seed=2)
    assert len(many) == 24
    for i, res in enumerate(many):  # in order, each a valid solution of its own target
        assert _valid(ur5, poses[i], res)
        assert res.history is None and res.method == "lm"
    serial = ik.solve_many(ur5, poses, q0, processes=1, chunksize=5, progress=False, seed=2)
    assert all(np.array_equal(a.q, b.q) for a, b in zip(many, serial))  # deterministic for a chunking and seed
    kept = ik.solve_many(ur5, poses[:3], q0[:3], backend="serial", keep_history=True, progress=False)
    assert kept[0].history is not None and _valid(ur5, poses[0], kept[0])


def test_stacked_lm_on_a_large_chunk():
    panda = robots.load("panda", geometry=False)
    rng = np.random.default_rng(8)
    poses = panda.fk_batch(panda.random_q(rng, 150), "panda_hand")
    res = ik.solve_many(panda, poses, panda.random_q(rng, 150), processes=1, progress=False)
    assert all(r.info.get("batched") for r in res)
    assert all(_valid(panda, poses[i], r) for i, r in enumerate(res))
    assert all(r.elapsed > 0 and r.iterations >= 0 for r in res)
    # an unreachable target in the batch is a failure with the best configuration, not an exception
    bad = poses[:30].copy()
    bad[5, :3, 3] = (3.0, 0.0, 0.5)
    out = ik.solve_many(panda, bad, processes=1, progress=False, max_time=0.01)
    assert not out[5].success and out[5].position_error > 1.0 and panda.within_limits(out[5].q)
    assert all(out[i].success for i in range(30) if i != 5)


def test_analytic_robots_and_relaxed_targets_go_target_by_target():
    youbot = robots.load("youbot", geometry=False)
    poses = youbot.fk_batch(youbot.random_q(np.random.default_rng(1), 10))
    res = ik.solve_many(youbot, poses, processes=1, progress=False)
    assert all(r.method == "analytic" and _valid(youbot, poses[i], r) for i, r in enumerate(res))


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
        ik.solve_many(ur5, good, backend="dask")
    with pytest.raises(InputError, match="processes"):
        ik.solve_many(ur5, good, processes=0)
    with pytest.raises(InputError, match="single"):
        ik.solve_many(ur5, good[0])
    with pytest.raises(InputError, match="unknown option"):
        ik.solve_many(ur5, good, processes=1, frobnicate=True)
    assert ik.solve_many(ur5, []) == []
