"""kinserve.ik.starts.seed_table: the table ranks samples by the stated pose distance; start sequences are
deterministic."""

import itertools

import numpy as np

from kinserve import robots
from kinserve.ik.starts.seed_table import SeedTable, start_sequence
from kinserve.ik.state import seed_table


def test_ranking_matches_brute_force_pose_distance():
    robot = robots.load("ur5", geometry=False)
    table = SeedTable(robot, "tool0", n=300, rotation_weight=0.05)
    rng = np.random.default_rng(0)
    T = robot.fk(robot.random_q(rng)).copy()
    f = table.features(T[:3, :3], T[:3, 3])
    idx, dist = table.ranked(f, 10)
    brute = []
    for q in table.Q:
        Ti = robot.fk(q)
        brute.append(np.sum((Ti[:3, 3] - T[:3, 3]) ** 2) + 0.05 * np.sum((Ti[:3, :3] - T[:3, :3]) ** 2))
    brute = np.array(brute)
    assert np.array_equal(idx, np.argsort(brute)[:10])
    assert np.allclose(dist, np.sort(brute)[:10])


def test_table_is_cached_per_model_and_reproducible():
    a = robots.load("ur5", geometry=False)
    b = robots.load("ur5", geometry=False)
    assert seed_table(a, "tool0") is seed_table(b, "tool0")
    assert np.array_equal(SeedTable(a, "tool0", n=50).Q, SeedTable(b, "tool0", n=50).Q)


def test_start_sequence_order_and_determinism():
    robot = robots.load("ur5", geometry=False)
    table = SeedTable(robot, "tool0", n=100)
    rng = np.random.default_rng(1)
    T = robot.fk(robot.random_q(rng)).copy()
    f = table.features(T[:3, :3], T[:3, 3])
    q0 = robot.random_q(rng)
    idx, dist = table.ranked(f, 8)
    far = list(itertools.islice(start_sequence(robot, table, f, q0, 0, q0_distance=1e9), 10))
    assert all(np.array_equal(far[i], table.Q[idx[i]]) for i in range(8)) and np.array_equal(far[8], q0)
    # then the 8 full-range samples nearest by the pose distance, brute force here
    T_full = robot.fk_batch(table.Q_full, "tool0")
    d_full = (np.sum((T_full[:, :3, 3] - T[:3, 3]) ** 2, axis=1)
              + table.weight * np.sum((T_full[:, :3, :3] - T[:3, :3]) ** 2, axis=(1, 2)))
    after = list(itertools.islice(start_sequence(robot, table, f, q0, 0, q0_distance=1e9), 9, 17))
    assert all(np.array_equal(a, table.Q_full[i]) for a, i in zip(after, np.argsort(d_full)[:8]))
    mid = list(itertools.islice(start_sequence(robot, table, f, q0, 0,
                                               q0_distance=0.5 * (dist[2] + dist[3])), 5))
    assert np.array_equal(mid[2], table.Q[idx[2]]) and np.array_equal(mid[3], q0)  # q0 ranked by its distance
    near = list(itertools.islice(start_sequence(robot, table, f, q0, 0, q0_distance=0.0), 2))
    assert np.array_equal(near[0], q0)
    forced = next(start_sequence(robot, table, f, q0, 0, q0_distance=1e9, prefer_q0=True))
    assert np.array_equal(forced, q0)
    a = list(itertools.islice(start_sequence(robot, None, None, None, 5), 3))
    b = list(itertools.islice(start_sequence(robot, None, None, None, 5), 3))
    c = list(itertools.islice(start_sequence(robot, None, None, None, 6), 3))
    assert all(np.array_equal(x, y) for x, y in zip(a, b))
    assert not np.array_equal(a[0], c[0])
    assert all(robot.within_limits(x) for x in a)


