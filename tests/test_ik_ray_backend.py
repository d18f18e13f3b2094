"""solve_many on a local 2-CPU Ray gives the same results as the local backends."""

import gc
import warnings

import numpy as np
import pytest

from kinserve import robots
from kinserve.ik import solve_many

ray = pytest.importorskip("ray")


@pytest.fixture(scope="module")
def local_ray():
    # ray.init leaves a probe socket of its own to the garbage collector: collect it here, where its
    # ResourceWarning (Ray's, not ours) is ignored, instead of in whichever test runs next
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResourceWarning)
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
        gc.collect()
    yield ray
    ray.shutdown()


@pytest.mark.parametrize("robot_name, relax", [("panda", ()), ("scara", ("phi",))])
def test_ray_matches_local_backends(local_ray, robot_name, relax):
    robot = robots.load(robot_name, geometry=False)
    Q = robot.random_q(3, n=40)
    targets = robot.fk_batch(Q)
    kw = dict(seed=4, relax=relax, chunksize=5, progress=False, iteration_budget=2000)  # no clock decides
    serial = solve_many(robot, targets, backend="serial", **kw)
    local = solve_many(robot, targets, backend="processes", processes=2, **kw)
    remote = solve_many(robot, targets, backend="ray", processes=2, **kw)
    assert len(remote) == 40
    for a, b, c in zip(serial, local, remote):
        assert a.success == b.success == c.success
        assert np.allclose(a.q, c.q, atol=1e-12) and np.allclose(b.q, c.q, atol=1e-12)
    assert all(r.success for r in remote)
    for r, T in zip(remote, targets):  # and they are right, checked by FK
        assert np.linalg.norm(robot.fk(r.q)[:3, 3] - T[:3, 3]) < 1e-4


def test_ray_timeout_kills_the_actors(local_ray):
    from kinserve.kinematics.errors import WorkerTimeoutError

    panda = robots.load("panda", geometry=False)
    far = np.repeat(np.eye(4)[None], 40, axis=0)
    far[:, :3, 3] = (3.0, 0.0, 0.5)  # unreachable: every target spends its whole 0.05 s budget
    import time

    t0 = time.monotonic()
    with pytest.raises(WorkerTimeoutError, match=r"Ray actor .* targets\[\d+:\d+\]"):
        solve_many(panda, far, backend="ray", processes=2, relax=("yaw",), max_time=0.05, chunksize=20,
                   timeout=0.3, progress=False)
    # a hang guard only (the actors' start-up on a busy machine is most of it): the error names the chunk
    assert time.monotonic() - t0 < 60
    # the killed actors gave their CPUs back: a new batch gets both
    assert ray.available_resources().get("CPU", 0) == 2 or _cpus_freed_within(5.0)


def _cpus_freed_within(seconds):
    import time

    t_end = time.monotonic() + seconds
    while time.monotonic() < t_end:
        if ray.available_resources().get("CPU", 0) == 2:
            return True
        time.sleep(0.1)
    return False
