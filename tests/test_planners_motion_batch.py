"""plan_many (planners/motion/batch.py): the plans of plan_motion one by one, on worker processes.

The process-handling tests use a small stand-in planner defined here (deterministic in its seed, able
to kill or stop its own worker), so they check the pool and not the planner; the equality with the real
``plan_motion`` runs on 6 small problems with iteration budgets.
"""

import os
import re
import signal
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pytest

from kinserve import robots
from kinserve.kinematics.errors import InputError, WorkerError, WorkerTimeoutError
from kinserve.kinematics.shapes import Box, Sphere
from kinserve.planners.motion import batch_workers
from kinserve.planners.motion.batch import motion_chunks, plan_many

from process_leaks import alive


class StandInPlan(NamedTuple):
    path: np.ndarray
    seed: int
    obstacles: int
    pid: int


def stand_in(robot, start, goal, *, obstacles=(), seed=None, waypoints=3, **kwargs):
    """A 'plan' through ``waypoints`` random configurations drawn from ``seed`` (deterministic)."""
    rng = np.random.default_rng(seed)
    path = np.vstack([start, robot.random_q(rng, n=waypoints), goal])
    return StandInPlan(path, seed, len(obstacles), os.getpid())


def dies_once(robot, start, goal, *, obstacles=(), seed=None, marker=None, **kwargs):
    """Kills its own process on problem 3 the first time (``marker`` file records that it did)."""
    if seed == 3 and not Path(marker).exists():
        Path(marker).write_text("killed")
        os.kill(os.getpid(), signal.SIGKILL)
    return stand_in(robot, start, goal, obstacles=obstacles, seed=seed)


def always_dies(robot, start, goal, *, seed=None, **kwargs):
    if seed == 2:
        os.kill(os.getpid(), signal.SIGKILL)
    return stand_in(robot, start, goal, seed=seed)


def stops_itself(robot, start, goal, *, seed=None, **kwargs):
    if seed == 1:
        os.kill(os.getpid(), signal.SIGSTOP)
    return stand_in(robot, start, goal, seed=seed)


def raises_input_error(robot, start, goal, *, seed=None, **kwargs):
    if seed == 4:
        raise InputError("goal is out of reach of this stand-in")
    return stand_in(robot, start, goal, seed=seed)


@pytest.fixture(scope="module")
def arm():
    return robots.load("planar4r", geometry=False)


def _problems(robot, n, seed=0):
    Q = robot.random_q(seed, n=2 * n)
    return [(Q[2 * i], Q[2 * i + 1]) for i in range(n)]


def _assert_gone(pids):
    deadline = time.monotonic() + 10.0
    while any(alive(p) for p in pids) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not [p for p in pids if alive(p)]


def test_chunks_cover_every_problem_once():
    for n, processes, size in [(1, 2, None), (7, 2, None), (100, 3, None), (10, 2, 4)]:
        chunks = motion_chunks(n, processes, size)
        assert [i for a, b in chunks for i in range(a, b)] == list(range(n))
        assert all(b > a for a, b in chunks)


def test_stand_in_plans_equal_one_by_one_and_no_worker_is_left(arm):
    problems = _problems(arm, 9)
    problems[4] = (*problems[4], [Sphere([1, 1, 0], 0.1), Box(np.eye(4), [0.1, 0.1, 0.1])])
    many = plan_many(arm, problems, processes=2, planner=stand_in, seed=10, self_collision=False,
                     waypoints=2)
    one_by_one = [stand_in(arm, p[0], p[1], obstacles=p[2] if len(p) == 3 else (), seed=10 + i, waypoints=2)
                  for i, p in enumerate(problems)]
    for a, b in zip(many, one_by_one):
        np.testing.assert_array_equal(a.path, b.path)
        assert (a.seed, a.obstacles) == (b.seed, b.obstacles)
    pids = {p.pid for p in many}
    assert os.getpid() not in pids and len(pids) >= 1
    _assert_gone(pids)


def test_one_process_plans_here(arm):
    many = plan_many(arm, _problems(arm, 3), processes=1, planner=stand_in, self_collision=False)
    assert {p.pid for p in many} == {os.getpid()} and [p.seed for p in many] == [0, 1, 2]


def test_killed_worker_chunk_is_retried(arm, tmp_path):
    marker = tmp_path / "killed"
    problems = _problems(arm, 6)
    many = plan_many(arm, problems, processes=2, chunksize=2, planner=dies_once, self_collision=False,
                     marker=str(marker))
    assert marker.exists()  # a worker did die on problem 3
    expected = [stand_in(arm, *p, seed=i) for i, p in enumerate(problems)]
    for a, b in zip(many, expected):
        np.testing.assert_array_equal(a.path, b.path)
    _assert_gone({p.pid for p in many})


def test_chunk_that_kills_two_workers_raises_and_leaves_none(arm):
    before = set(batch_workers_children())
    with pytest.raises(WorkerError, match=r"died twice on problems\[2:3\]"):
        plan_many(arm, _problems(arm, 4), processes=2, chunksize=1, planner=always_dies, self_collision=False)
    _assert_gone(set(batch_workers_children()) - before)


def test_stopped_worker_times_out_and_is_killed(arm, monkeypatch):
    monkeypatch.setattr(batch_workers, "STOPPED_GRACE", 0.5)
    before = set(batch_workers_children())
    with pytest.raises(WorkerTimeoutError, match=r"problems\[1:2\].*stopped"):
        plan_many(arm, _problems(arm, 3), processes=2, chunksize=1, planner=stops_itself,
                  self_collision=False)
    _assert_gone(set(batch_workers_children()) - before)


def test_worker_input_error_reaches_the_caller(arm):
    with pytest.raises(InputError, match="out of reach"):
        plan_many(arm, _problems(arm, 6), processes=2, planner=raises_input_error, self_collision=False)


def batch_workers_children():
    """Live child processes of this test process."""
    me = os.getpid()
    out = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                stat = Path(f"/proc/{entry}/stat").read_text()
            except OSError:
                continue
            if int(stat[stat.rindex(")") + 2:].split()[1]) == me and alive(int(entry)):
                out.append(int(entry))
    return out


@pytest.mark.parametrize("problems, words", [
    ("not problems", ["problems must be a sequence"]),
    ([([0.0] * 4,)], ["problems[0]", "(start, goal)"]),
    ([([0.0] * 4, [0.0] * 4), ([0.0] * 3, [0.0] * 4)], ["problems[1].start"]),
    ([([0.0] * 4, [0.0] * 4, ["ball"])], ["problems[0].obstacles"]),
    ([([0.0] * 4, [float("nan")] * 4)], ["problems[0].goal"]),
])
def test_problems_are_checked_before_any_work(arm, problems, words):
    with pytest.raises(InputError) as info:
        plan_many(arm, problems, planner=stand_in, self_collision=False)
    for w in words:
        assert w in str(info.value)


@pytest.mark.parametrize("kwargs, word", [
    ({"processes": 0}, "processes"), ({"chunksize": 1.5}, "chunksize"), ({"backend": "dask"}, "backend"),
    ({"seed": -1}, "seed"), ({"timeout": 0}, "timeout"), ({"obstacles": []}, "obstacles"),
])
def test_bad_arguments(arm, kwargs, word):
    with pytest.raises(InputError, match=word):
        plan_many(arm, _problems(arm, 2), planner=stand_in, self_collision=False, **kwargs)


def test_no_problem_no_work(arm):
    assert plan_many(arm, [], planner=stand_in) == []


@pytest.fixture(scope="module")
def panda_problems():
    robot = robots.load("panda", geometry=False)
    T = np.eye(4)
    T[:3, 3] = [0.5, 0.0, 0.4]
    obstacles = [Box(T, [0.1, 0.6, 0.05]), Sphere([0.0, 0.5, 0.6], 0.1)]
    rng = np.random.default_rng(7)
    free = [q for q in robot.random_q(rng, n=200) if not robot.in_collision(q, obstacles)][:12]
    problems = [(free[2 * i], free[2 * i + 1], obstacles if i % 2 == 0 else ()) for i in range(6)]
    return robot, problems


def test_plan_many_equals_plan_motion_one_by_one(panda_problems):
    from kinserve.planners.motion import plan_motion

    robot, problems = panda_problems
    kwargs = dict(max_time=None, max_iterations=3000)
    before = set(batch_workers_children())
    many = plan_many(robot, problems, processes=2, seed=5, **kwargs)
    left = set(batch_workers_children()) - before
    one_by_one = [plan_motion(robot, s, g, obstacles=o, seed=5 + i, **kwargs) for i, (s, g, o) in
                  enumerate(problems)]
    assert len(many) == 6 and sum(p.success for p in one_by_one) >= 3
    for a, b in zip(many, one_by_one):
        assert (a.success, a.goal_index) == (b.success, b.goal_index)
        np.testing.assert_array_equal(a.path, b.path)
        np.testing.assert_array_equal(a.raw_path, b.raw_path)
        if b.trajectory is not None:
            np.testing.assert_array_equal(a.trajectory.positions, b.trajectory.positions)
    _assert_gone(left)


def test_ray_backend_equals_local(panda_problems):
    ray = pytest.importorskip("ray")
    import gc
    import warnings

    robot, problems = panda_problems
    kwargs = dict(max_time=None, max_iterations=2000, seed=11)
    local = plan_many(robot, problems[:3], processes=2, **kwargs)
    with warnings.catch_warnings():  # Ray's own probe socket, collected here (as in test_ik_ray_backend)
        warnings.simplefilter("ignore", ResourceWarning)
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
        gc.collect()
    try:
        remote = plan_many(robot, problems[:3], processes=2, backend="ray", **kwargs)
    finally:
        ray.shutdown()
    for a, b in zip(remote, local):
        assert (a.success, a.goal_index) == (b.success, b.goal_index)
        np.testing.assert_array_equal(a.path, b.path)


@pytest.mark.parametrize("kwargs, word", [
    ({"max_time": -1.0}, "max_time"), ({"max_time": None}, "max_iterations"),
    ({"goal_count": 0}, "goal_count"), ({"simplify": "yes"}, "simplify"),
    ({"acceleration_limits": [1.0, 2.0]}, "acceleration_limits"),
    ({"self_collision": None}, "self_collision"),
])
def test_shared_keyword_values_are_checked_before_any_worker(arm, kwargs, word):
    """plan_motion's shared keywords are checked in the caller: no worker is started for a value every
    problem would refuse."""
    before = set(batch_workers_children())
    words = re.escape("plan_many (shared keywords of plan_motion): ") + f".*{word}"
    with pytest.raises(InputError, match=words):
        plan_many(arm, _problems(arm, 4), processes=2, **kwargs)
    assert set(batch_workers_children()) == before


def test_valid_shared_keywords_still_plan(arm):
    plans = plan_many(arm, _problems(arm, 2), processes=1, max_time=None, max_iterations=200, simplify=False)
    assert len(plans) == 2 and all(p.success in (True, False) for p in plans)
