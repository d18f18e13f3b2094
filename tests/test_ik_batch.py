"""kinserve.ik.batch.solve_many.solve_many: the answers of ik.solve one by one, in order, on 2 processes
(plain LM targets in one compiled call per chunk); validation up front."""

import numpy as np
import pytest

from kinserve import ik, robots
from kinserve.kinematics import se3
from kinserve.kinematics.errors import InputError, NonFiniteError

#: No time limit: every solve here that must succeed, or is compared with another, ends on iterations.
BUDGET = dict(iteration_budget=2000)


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
    many = ik.solve_many(ur5, poses, q0, processes=2, chunksize=5, progress=False, seed=2, **BUDGET)
    assert len(many) == 24
    for i, res in enumerate(many):  # in order, each a valid solution of its own target
        assert _valid(ur5, poses[i], res)
        assert res.history is None and res.method == "lm"
    serial = ik.solve_many(ur5, poses, q0, processes=1, chunksize=5, progress=False, seed=2, **BUDGET)
    # deterministic for a chunking and seed
    assert all(np.array_equal(a.q, b.q) for a, b in zip(many, serial))
    kept = ik.solve_many(ur5, poses[:3], q0[:3], backend="serial", keep_history=True, progress=False,
                         **BUDGET)
    assert kept[0].history is not None and _valid(ur5, poses[0], kept[0])


def _same_as_solve(many, one_by_one):
    for a, b in zip(many, one_by_one):
        assert np.array_equal(a.q, b.q) and a.success == b.success and a.message == b.message
        assert a.iterations == b.iterations and a.restarts == b.restarts and a.method == b.method == "lm"


def test_compiled_batch_on_a_large_chunk_answers_as_ik_solve():
    """Plain LM targets go through one compiled call per chunk and get ik.solve's own answers (same starts,
    same seed); an unreachable target is a failure with the best configuration, not an exception. (Iteration
    budgets, no clock, in this module: a time limit could cut one side of a comparison and not the other.)"""
    panda = robots.load("panda", geometry=False)
    rng = np.random.default_rng(8)
    poses = panda.fk_batch(panda.random_q(rng, 150), "panda_hand")
    q0 = panda.random_q(rng, 150)
    res = ik.solve_many(panda, poses, q0, processes=1, progress=False, seed=4, **BUDGET)
    assert all(r.info.get("batched") for r in res)
    assert all(_valid(panda, poses[i], r) for i, r in enumerate(res))
    assert all(r.elapsed > 0 and r.iterations >= 0 and r.history is None for r in res)
    _same_as_solve(res, [ik.solve(panda, T, q, seed=4, **BUDGET) for T, q in zip(poses, q0)])
    bad = poses[:30].copy()
    bad[5, :3, 3] = (3.0, 0.0, 0.5)
    out = ik.solve_many(panda, bad, processes=1, progress=False, iteration_budget=300)
    assert not out[5].success and out[5].position_error > 1.0 and panda.within_limits(out[5].q)
    assert "out of reach" in out[5].message
    assert all(out[i].success for i in range(30) if i != 5)


def test_relaxed_targets_and_lm_options_go_through_the_compiled_batch(ur5):
    panda = robots.load("panda", geometry=False)
    rng = np.random.default_rng(12)
    poses = panda.fk_batch(panda.random_q(rng, 40))
    poses[:, :3, :3] = poses[::-1, :3, :3]  # orientations off their positions: only the yaw-free rows count
    q0 = panda.random_q(rng, 40)
    kw = dict(relax=("yaw",), relax_frame="target", seed=3, max_starts=5, prefer_q0=True, **BUDGET)
    res = ik.solve_many(panda, poses, q0, processes=1, progress=False, **kw)
    assert all(r.info.get("batched") for r in res)
    _same_as_solve(res, [ik.solve(panda, T, q, **kw) for T, q in zip(poses, q0)])


def test_iteration_budget_in_solve_many_is_ik_solves(ur5):
    rng = np.random.default_rng(13)
    poses = ur5.fk_batch(ur5.random_q(rng, 20))
    poses[:4, :3, 3] = (2.0, 0.0, 0.3)  # unreachable: the budget ends their search
    res = ik.solve_many(ur5, poses, processes=1, progress=False, seed=1, iteration_budget=25)
    _same_as_solve(res, [ik.solve(ur5, T, seed=1, iteration_budget=25) for T in poses])
    assert all(r.iterations == 25 and "iteration budget exhausted (25 iterations)" in r.message
               for r in res[:4])
    assert all(r.success and r.iterations <= 25 for r in res[4:] if r.success)


def test_analytic_robots_and_relaxed_targets_go_target_by_target():
    youbot = robots.load("youbot", geometry=False)
    poses = youbot.fk_batch(youbot.random_q(np.random.default_rng(1), 10))
    res = ik.solve_many(youbot, poses, processes=1, progress=False)
    assert all(r.method == "analytic" and _valid(youbot, poses[i], r) for i, r in enumerate(res))


def test_solve_many_shared_q0_and_options(ur5):
    poses = ur5.fk_batch(ur5.random_q(np.random.default_rng(4), 6))
    res = ik.solve_many(ur5, list(poses), ur5.neutral(), processes=1, method="qp", qp_backend="daqp",
                        relax=("yaw",), **BUDGET)
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


def test_targets_validated_all_at_once_agree_with_target(ur5):
    """checked_poses accepts exactly what ik.targets.Target accepts; errors name the index."""
    import pinocchio as pin

    from kinserve.ik.batch.solve_many import checked_poses
    from kinserve.ik.targets import Target
    from kinserve.kinematics.validation import ROTATION_TOL

    rng = np.random.default_rng(9)
    good = ur5.fk_batch(ur5.random_q(rng, 50))
    assert np.array_equal(checked_poses(ur5, good, ur5.tip), good)
    assert np.array_equal(checked_poses(ur5, [pin.SE3(T) for T in good[:3]], ur5.tip), good[:3])
    # rotations perturbed around the tolerance: accepted by one iff accepted by the other
    for k in range(300):
        T = good[k % 50].copy()
        T[:3, :3] += rng.normal(size=(3, 3)) * ROTATION_TOL * rng.uniform(0.05, 1.5)
        try:
            Target(ur5, T)
            ok = True
        except InputError:
            ok = False
        try:
            checked_poses(ur5, T[None], ur5.tip)
            assert ok, k
        except InputError as exc:
            assert not ok and "targets[0]" in str(exc)
    bad = good[:6].copy()
    bad[1, 3, 0] = 0.1  # bottom row
    bad[2, :3, :3] = np.diag([1.0, 1.0, -1.0])  # a reflection, det -1
    bad[3, 0, 3] = np.inf
    bad[4, :3, :3] *= 1.01  # not orthonormal
    bad[5, 2, 3] = 1e9  # beyond any physical size
    for i in range(1, 6):
        one = good[:6].copy()
        one[i] = bad[i]
        try:
            Target(ur5, bad[i])
        except InputError as exc:
            expected = type(exc)
        with pytest.raises(expected, match=rf"targets\[{i}\]"):
            checked_poses(ur5, one, ur5.tip)
    with pytest.raises(InputError, match=r"targets\[1\]"):
        checked_poses(ur5, [good[0], np.eye(3)], ur5.tip)  # ragged: checked one by one
    with pytest.raises(InputError, match=r"targets\[1\]"):
        checked_poses(ur5, iter([good[0], "x"]), ur5.tip)  # an iterator is read once
    assert np.array_equal(checked_poses(ur5, (T for T in good[:4]), ur5.tip), good[:4])
    with pytest.raises(InputError, match="sequence of 4x4 poses, got str"):
        checked_poses(ur5, "poses", ur5.tip)


def test_options_are_checked_without_a_trial_solve(ur5, monkeypatch):
    from kinserve.ik.batch import worker as batch_worker

    calls = []
    real = batch_worker.run
    monkeypatch.setattr(batch_worker, "run", lambda *a, **k: calls.append(1) or real(*a, **k))
    poses = ur5.fk_batch(ur5.random_q(np.random.default_rng(6), 5))
    with pytest.raises(InputError, match="max_iter must be an integer"):
        ik.solve_many(ur5, poses, processes=1, relax=("yaw",), max_iter=0)
    with pytest.raises(NonFiniteError, match="damping"):
        ik.solve_many(ur5, poses, processes=1, damping=float("nan"))
    assert calls == []
    res = ik.solve_many(ur5, poses, processes=1, relax=("yaw",), max_iter=50, keep_history=True,
                        progress=False, **BUDGET)
    assert len(calls) == 5 and all(r.success for r in res)  # one solve per target, none to test the options
    res = ik.solve_many(ur5, poses, processes=1, relax=("yaw",), max_iter=50, progress=False, **BUDGET)
    assert len(calls) == 5 and all(r.success for r in res)  # the compiled batch: no ik.solve per target


def test_timeout_and_q0_rows_are_validated(ur5):
    poses = ur5.fk_batch(ur5.random_q(np.random.default_rng(7), 4))
    with pytest.raises(InputError, match="timeout must be positive"):
        ik.solve_many(ur5, poses, timeout=0)
    with pytest.raises(NonFiniteError, match="timeout must be finite"):
        ik.solve_many(ur5, poses, timeout=float("inf"))
    with pytest.raises(InputError, match="chunksize"):
        ik.solve_many(ur5, poses, chunksize=0)
    q0 = ur5.random_q(np.random.default_rng(8), 4)
    q0[3, 2] = np.nan
    with pytest.raises(NonFiniteError, match=r"q0\[3\]"):
        ik.solve_many(ur5, poses, q0)
