"""One ``Robot`` shared by 8 threads gives bit-for-bit the answers of one thread (FK, Jacobians, IK).

Each thread works on its own Pinocchio ``Data`` (``Robot.data`` is per thread). The
interpreter's switch interval is cut to 1 us and a garbage collection (with a
Python callback, i.e. a point where the interpreter may switch threads) runs
at nearly every allocation while the threads run, so that they interleave
inside every call sequence - between Pinocchio's forward kinematics and the
read of the frame placement it left in ``Data``, which is where a shared
``Data`` used to hand one thread the pose of another thread's configuration
(about 10 wrong poses in 12,000 under these conditions; 1-3 with the defaults).
"""

import gc
import sys
import threading

import numpy as np
import pytest

from kinserve import ik, robots

THREADS = 8


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda", geometry=False)


def _switch_point(phase, info):
    """A Python call inside every garbage collection: the interpreter may hand the GIL over here."""


@pytest.fixture
def fast_switching():
    old_interval, old_threshold = sys.getswitchinterval(), gc.get_threshold()
    sys.setswitchinterval(1e-6)
    gc.callbacks.append(_switch_point)
    gc.set_threshold(1)
    try:
        yield
    finally:
        gc.set_threshold(*old_threshold)
        gc.callbacks.remove(_switch_point)
        sys.setswitchinterval(old_interval)


def run_threads(work, n_items: int) -> list:
    """``work(i)`` for ``i in range(n_items)``, items dealt round-robin to THREADS threads started
    together."""
    out = [None] * n_items
    errors = []
    barrier = threading.Barrier(THREADS)

    def worker(k):
        try:
            barrier.wait()
            for i in range(k, n_items, THREADS):
                out[i] = work(i)
        except BaseException as exc:  # pragma: no cover - reported below
            errors.append(exc)

    threads = [threading.Thread(target=worker, args=(k,)) for k in range(THREADS)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors
    return out


def test_each_thread_has_its_own_data(panda):
    seen = run_threads(lambda i: panda.data, THREADS)
    assert len({id(d) for d in seen}) == THREADS
    assert all(d is not panda.data for d in seen)
    assert panda.data is panda.data  # stable within a thread


def test_fk_bit_identical_over_12000_calls(panda, fast_switching):
    Q = panda.random_q(np.random.default_rng(1), 12_000)
    frames = ["panda_link8", "panda_link4", "panda_hand"]
    ref = [panda.fk(Q[i], frames[i % 3]).copy() for i in range(len(Q))]
    got = run_threads(lambda i: panda.fk(Q[i], frames[i % 3]).copy(), len(Q))
    wrong = [i for i in range(len(Q)) if not np.array_equal(got[i], ref[i])]
    assert wrong == []


def test_jacobians_and_fk_all_bit_identical(panda, fast_switching):
    Q = panda.random_q(np.random.default_rng(2), 4000)
    refs = ("world", "local", "spatial")
    ref = [panda.jacobian(Q[i], reference=refs[i % 3]).copy() for i in range(len(Q))]
    got = run_threads(lambda i: panda.jacobian(Q[i], reference=refs[i % 3]).copy(), len(Q))
    assert [i for i in range(len(Q)) if not np.array_equal(got[i], ref[i])] == []
    # fk_all and the analytic Jacobian read the thread's data after their own kinematics pass
    ref_all = [panda.fk_all(Q[i])["panda_link5"].copy() for i in range(400)]
    ref_a = [panda.analytic_jacobian(Q[i]).copy() for i in range(400)]
    got2 = run_threads(lambda i: (panda.fk_all(Q[i])["panda_link5"].copy(),
                                  panda.analytic_jacobian(Q[i]).copy()), 400)
    assert all(np.array_equal(g[0], r) for g, r in zip(got2, ref_all))
    assert all(np.array_equal(g[1], r) for g, r in zip(got2, ref_a))


def test_ik_identical_over_600_solves(panda, fast_switching):
    rng = np.random.default_rng(3)
    targets = panda.fk_batch(panda.random_q(rng, 600))
    q0s = panda.random_q(rng, 600)

    def solve(i):
        # an iteration budget and no time limit: the answer depends on the seed only, never on the thread's
        # share of the CPU
        r = ik.solve(panda, targets[i], q0s[i], seed=i, iteration_budget=2000)
        return r.q.copy(), r.success, r.iterations

    ref = [solve(i) for i in range(600)]
    got = run_threads(solve, 600)
    assert all(r[1] for r in ref)
    differ = [i for i in range(600)
              if not (np.array_equal(got[i][0], ref[i][0]) and got[i][1:] == ref[i][1:])]
    assert differ == []


def test_qp_ik_with_spheres_and_centring_identical(fast_switching):
    scara = robots.load("scara", geometry=False)
    rng = np.random.default_rng(4)
    targets = scara.fk_batch(scara.random_q(rng, 48))

    def solve(i):
        r = ik.solve(scara, targets[i], relax=("z",), centring=1.0, method="qp", seed=i,
                     iteration_budget=2000)
        return r.q.copy(), r.success

    ref = [solve(i) for i in range(48)]
    got = run_threads(solve, 48)
    assert all(np.array_equal(g[0], r[0]) and g[1] == r[1] for g, r in zip(got, ref))


def test_copy_and_pickle_give_fresh_per_thread_workspaces(panda):
    import pickle

    clone = pickle.loads(pickle.dumps(panda))
    other = panda.copy()
    q = panda.random_q(np.random.default_rng(5))
    T = panda.fk(q)
    assert np.array_equal(clone.fk(q), T) and np.array_equal(other.fk(q), T)
    assert clone.data is not panda.data and other.data is not panda.data
    per_thread = run_threads(lambda i: (clone.data, other.data), THREADS)
    assert len({id(d) for d, _ in per_thread}) == THREADS and len({id(d) for _, d in per_thread}) == THREADS


def test_first_use_of_a_new_model_builds_one_seed_table_and_one_solver(panda, fast_switching):
    from kinserve.ik.state import closed_form_solver, seed_table
    from kinserve.kinematics import Robot

    fresh = Robot(panda.model.copy(), tip=panda.tip, name="panda-copy")  # a model no cache has seen
    got = run_threads(lambda i: (seed_table(fresh, fresh.tip), closed_form_solver(fresh, fresh.tip)), THREADS)
    assert len({id(t) for t, _ in got}) == 1 and all(s is None for _, s in got)
    table = got[0][0]
    assert not table.Q.flags.writeable and not table.G.flags.writeable  # shared, so read-only
    with pytest.raises(ValueError):
        table.Q[0, 0] = 0.0
