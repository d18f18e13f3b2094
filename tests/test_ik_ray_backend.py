"""solve_many on a local 2-CPU Ray gives the same results as the local backends."""

import numpy as np
import pytest

from kinserve import robots
from kinserve.ik import solve_many

ray = pytest.importorskip("ray")


@pytest.fixture(scope="module")
def local_ray():
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield ray
    ray.shutdown()


@pytest.mark.parametrize("robot_name, relax", [("panda", ()), ("scara", ("phi",))])
def test_ray_matches_local_backends(local_ray, robot_name, relax):
    robot = robots.load(robot_name, geometry=False)
    Q = robot.random_q(3, n=40)
    targets = robot.fk_batch(Q)
    serial = solve_many(robot, targets, backend="serial", seed=4, relax=relax, chunksize=5, progress=False)
    local = solve_many(robot, targets, backend="processes", processes=2, seed=4, relax=relax, chunksize=5, progress=False)
    remote = solve_many(robot, targets, backend="ray", processes=2, seed=4, relax=relax, chunksize=5, progress=False)
    assert len(remote) == 40
    for a, b, c in zip(serial, local, remote):
        assert a.success == b.success == c.success
        assert np.allclose(a.q, c.q, atol=1e-12) and np.allclose(b.q, c.q, atol=1e-12)
    assert all(r.success for r in remote)
    for r, T in zip(remote, targets):  # and they are right, checked by FK
        assert np.linalg.norm(robot.fk(r.q)[:3, 3] - T[:3, 3]) < 1e-4
