"""Bad input to the public IK entry points (ik.solve, ik.solve_all, ik.solve_many, ik.step, ik.warm,
ik.choose, the tasks): each is refused with kinserve's own error naming the argument, before any work
starts; a valid neighbouring value is still accepted."""

import importlib
import math
import os

import numpy as np
import pytest

from kinserve import ik, robots
from kinserve.ik.batch import solve_many as solve_many_module
from kinserve.ik.batch.runners import BACKENDS
from kinserve.kinematics.errors import InputError, NonFiniteError, ShapeError

SOLVE_MODULE = importlib.import_module("kinserve.ik.solve")  # (``kinserve.ik.solve`` is the function)
FAR = ([100.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0])  # unreachable: a solve would run its whole budget


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda")


@pytest.fixture(scope="module")
def arm():
    return robots.load("planar4r", geometry=False)


@pytest.fixture(scope="module")
def ur5():
    return robots.load("ur5")


@pytest.fixture(scope="module")
def target(panda):
    return panda.fk(panda.neutral(), "panda_hand").copy()


@pytest.fixture(scope="module")
def arm_target(arm):
    return arm.fk(np.array([0.4, 0.5, -0.3, 0.6])).copy()


def _no_work(*args, **kwargs):
    raise AssertionError("the call started working on an invalid argument")


# ----------------------------------------------------------------------------- ik.solve: scalars


@pytest.mark.parametrize("value", [1e300, np.float64(1e300), math.inf, math.nan, 0.0, -1.0])
def test_solve_refuses_max_time_before_solving(panda, monkeypatch, value):
    monkeypatch.setattr(SOLVE_MODULE, "choose_strategy", _no_work)  # refused before any solve
    with pytest.raises(InputError, match=r"max_time must be"):
        ik.solve(panda, FAR, max_time=value)


def test_solve_refuses_huge_max_time_with_its_bound(panda):
    with pytest.raises(NonFiniteError,
                       match=r"max_time must be finite with magnitude <= 1e\+06, got 1e\+300"):
        ik.solve(panda, FAR, max_time=1e300)


def test_solve_accepts_an_ordinary_max_time(panda, target):
    assert ik.solve(panda, target, max_time=0.5, seed=0).success
    assert ik.solve(panda, target, max_time=1e6, seed=0).success  # the bound itself is accepted


@pytest.mark.parametrize("name", ["tol_pos", "tol_rot"])
def test_solve_refuses_huge_tolerances(panda, monkeypatch, name):
    monkeypatch.setattr(SOLVE_MODULE, "choose_strategy", _no_work)
    with pytest.raises(NonFiniteError, match=rf"{name} must be finite with magnitude <= 1e\+06, got 1e\+300"):
        ik.solve(panda, FAR, **{name: 1e300})
    with pytest.raises(InputError, match=rf"{name} must be a number, got array"):
        ik.solve(panda, FAR, **{name: np.array([0.1, 0.2])})


def test_solve_with_huge_tolerances_in_the_task_door_and_other_routes(panda, target):
    task = ik.FrameTask("panda_hand", target)
    with pytest.raises(NonFiniteError, match=r"tol_pos must be finite"):
        ik.solve(panda, tasks=[task], tol_pos=1e300)
    with pytest.raises(NonFiniteError, match=r"tol_rot must be finite"):
        ik.solve(panda, target, centring=1.0, tol_rot=1e300)  # the general route (target_request)
    res = ik.solve(panda, FAR, tol_pos=1e-3, tol_rot=1e-2, max_time=0.05, seed=0)
    assert not res.success and res.position_error > 90  # far stays far: not reported as reached


def test_solve_all_refuses_huge_tolerances(arm, arm_target):
    with pytest.raises(NonFiniteError, match=r"tol_pos must be finite with magnitude <= 1e\+06"):
        ik.solve_all(arm, arm_target, tol_pos=1e300, tol_rot=1e300)
    assert ik.solve_all(arm, arm_target, tol_pos=1e-3, tol_rot=1e-2)


@pytest.mark.parametrize("kwargs, error, message", [
    ({"link_radius": 1e300}, NonFiniteError,
     r"link_radius must be a finite number >= 0 \(m\) at most 1e\+06"),
    ({"link_radius": np.array([0.1, 0.2])}, InputError, r"link_radius must be a number >= 0 \(m\)"),
    ({"link_radius": 1e300, "self_collision": True}, NonFiniteError, r"link_radius must be a finite number"),
    ({"centring": 1e300}, NonFiniteError, r"centring weights must be finite with magnitude <= 1e\+06"),
    ({"centring": "abc"}, InputError, r"centring must be a number or 7 numbers"),
    ({"collision_margin": 1e300}, NonFiniteError, r"collision margin must be finite with magnitude <= 1000"),
    ({"collision_margin": math.nan}, NonFiniteError, r"collision margin must be finite"),
    ({"collision_margin": np.array([0.1, 0.2])}, InputError, r"collision margin must be a number \(m\)"),
    ({"collision_margin": "0.1"}, InputError, r"collision margin must be a number \(m\), got '0.1'"),
    ({"self_collision": np.array([1, 0])}, InputError, r"self_collision must be True or False"),
    ({"seed": 2**64}, InputError, r"seed must be a non-negative integer \(at most 2\*\*64 - 1\) or None"),
    ({"seed": 10**300}, InputError, r"seed must be a non-negative integer .*got 1000000000.*\.\.\.$"),
    ({"method": np.array([1, 2])}, InputError, r"method must be one of"),
    ({"backend": np.array([1, 2])}, InputError, r"backend must be one of the installed QP solvers"),
    ({"relax_frame": np.array([1, 2])}, InputError, r"relax_frame must be one of 'world', 'target', got a"),
    ({"relax": np.array([1.0, 2.0])}, InputError, r"relax: component names must be strings"),
    ({"max_iter": 10**12}, InputError,
     r"option max_iter must be at most 100,000 \(accepted: an integer from 1"),
    ({"iteration_budget": 10**12}, InputError, r"option iteration_budget must be at most 1,000,000"),
    ({"max_starts": 10**12}, InputError, r"option max_starts must be at most 10,000,000"),
    ({"method": "analytic", "samples": 10**12}, InputError, r"option samples must be at most 10,000"),
    ({"damping": 1e300}, NonFiniteError, r"option damping must be finite with magnitude <= 1e\+06"),
])
def test_solve_refuses_absurd_keywords(panda, monkeypatch, kwargs, error, message):
    monkeypatch.setattr(SOLVE_MODULE, "choose_strategy", _no_work)
    with pytest.raises(error, match=message):
        ik.solve(panda, FAR, **kwargs)


def test_solve_accepts_the_neighbouring_keywords(panda, target):
    ok = dict(seed=0, max_time=1.0)
    assert ik.solve(panda, target, link_radius=0.02, spheres=[([2.0, 2.0, 2.0], 0.1)], **ok).success
    assert ik.solve(panda, target, centring=1e6, **ok).success
    assert ik.solve(panda, target, seed=2**64 - 1, max_time=1.0).success
    assert ik.solve(panda, target, max_iter=100_000, iteration_budget=1_000_000, max_starts=10**7,
                    **ok).success
    assert ik.solve(panda, target, relax=np.array(["yaw"]), **ok).success


# ----------------------------------------------------------------------------- ik.solve_all


@pytest.mark.parametrize("samples, message", [
    (10**12, r"samples must be an integer from 2 to 10,000, got 1000000000000"),
    (10_001, r"samples must be an integer from 2 to 10,000"),
    (1, r"samples must be an integer from 2 to 10,000, got 1"),
    (2.5, r"samples must be an integer, got 2.5"),
    (True, r"samples must be an integer, got True"),
])
def test_solve_all_refuses_absurd_samples(arm, arm_target, samples, message):
    with pytest.raises(InputError, match=message):
        ik.solve_all(arm, arm_target, samples=samples)


def test_solve_all_accepts_its_largest_sample_count(arm, arm_target):
    assert len(ik.solve_all(arm, arm_target, samples=2)) >= 2
    family = ik.solve_all(arm, arm_target, samples=10_000)  # the bound: sifted in n log n
    assert 10_000 <= len(family) <= 20_000
    assert all(r.success for r in family)


# ----------------------------------------------------------------------------- ik.solve_many


@pytest.fixture(scope="module")
def targets(target):
    return np.repeat(target[None], 3, axis=0)


@pytest.mark.parametrize("kwargs, error, message", [
    ({"processes": 10**6}, InputError, r"processes must be an integer from 1 to 1024 or None, got 1000000"),
    ({"processes": 0}, InputError, r"processes must be an integer from 1 to 1024 or None, got 0"),
    ({"processes": 2.0}, InputError, r"processes must be an integer from 1 to 1024 or None, got 2.0"),
    ({"chunksize": 10**12}, InputError, r"chunksize must be an integer from 1 to 10000000 or None"),
    ({"tol_pos": 1e300}, NonFiniteError, r"tol_pos must be finite with magnitude <= 1e\+06, got 1e\+300"),
    ({"tol_rot": 1e300}, NonFiniteError, r"tol_rot must be finite with magnitude <= 1e\+06, got 1e\+300"),
    ({"max_time": 1e300}, NonFiniteError, r"max_time must be finite with magnitude <= 1e\+06"),
    ({"timeout": 1e300}, NonFiniteError, r"timeout must be finite with magnitude <= 1e\+06"),
    ({"link_radius": 1e300}, NonFiniteError, r"link_radius must be a finite number >= 0"),
    ({"centring": 1e300}, NonFiniteError, r"centring weights must be finite"),
    ({"seed": 2**70}, InputError, r"seed must be a non-negative integer \(at most 2\*\*64 - 1\)"),
    ({"max_iter": 10**12}, InputError, r"option max_iter must be at most 100,000"),
    ({"keep_history": "no"}, InputError, r"keep_history must be True or False, got 'no'"),
    ({"progress": "no"}, InputError, r"progress \(or None\) must be True or False, got 'no'"),
    ({"progress": 0}, InputError, r"progress \(or None\) must be True or False, got 0"),
    ({"q0": "no"}, ShapeError,
     r"^q0 must be None, one configuration \(7 numbers\) or one per target \(shape \(3, 7\)\), got 'no'$"),
    ({"q0": [[True] * 7] * 3}, ShapeError, r"^q0 must be None, one configuration .*, got \[\[True"),
    ({"q0": [[0.0] * 7, [0.0] * 6]}, ShapeError, r"^q0 must be None, one configuration \(7 numbers\)"),
    ({"q0": np.zeros((2, 7))}, ShapeError, r"^q0 must be None, .* \(shape \(3, 7\)\), got shape \(2, 7\)$"),
    ({"q0": [[0.0] * 7] * 2 + [[0.0] * 6 + [np.nan]]}, NonFiniteError, r"^q0 must hold finite numbers"),
    ({"q0": np.zeros(6)}, ShapeError, r"^q0 must have shape \(7,\), got shape \(6,\)"),
    ({"backend": []}, InputError,
     r"^backend \(the execution backend; qp_backend names the QP solver\) must be one of 'processes', "
     r"'serial', 'ray', got \[\]$"),
    ({"backend": np.zeros(0)}, InputError, r"^backend \(the execution backend.* got array"),
    ({"backend": "daqp"}, InputError, r"^backend \(the execution backend.* got 'daqp'$"),
])
def test_solve_many_refuses_absurd_keywords_before_any_worker(panda, targets, monkeypatch, kwargs, error,
                                                              message):
    monkeypatch.setitem(BACKENDS, "processes", _no_work)
    monkeypatch.setitem(BACKENDS, "serial", _no_work)
    monkeypatch.setattr(solve_many_module, "run_serial", _no_work)
    with pytest.raises(error, match=message):
        ik.solve_many(panda, targets, **kwargs)


def test_solve_many_starts_no_more_workers_than_cores(panda, targets, monkeypatch):
    asked = []

    def runner(job, chunks, processes, on_done, limits):
        asked.append(processes)

    monkeypatch.setitem(BACKENDS, "processes", runner)
    monkeypatch.setattr(solve_many_module, "run_serial", runner)  # (chosen for one worker)
    many = np.repeat(targets[:1], 200, axis=0)
    ik.solve_many(panda, many, processes=1024, progress=False)
    ik.solve_many(panda, many, progress=False)
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    assert len(asked) == 2 and all(1 <= p <= min(cores, os.cpu_count() or 1) for p in asked)
    assert solve_many_module.worker_count(1024, 200) <= (os.cpu_count() or 1)
    assert solve_many_module.worker_count(5, 2) <= 2  # no more workers than targets
    assert solve_many_module.worker_count(64, 100, local=False) == 64  # a cluster: its own cores


def test_solve_many_accepts_the_neighbouring_values(panda, targets):
    res = ik.solve_many(panda, targets, processes=1, chunksize=10**7, tol_pos=1e-3, tol_rot=1e-2,
                        max_time=0.5, seed=0)
    assert [r.success for r in res] == [True] * 3
    res = ik.solve_many(panda, targets, backend="serial", processes=1024, seed=0)
    assert len(res) == 3 and all(r.success for r in res)


def test_solve_many_takes_q0_as_one_configuration_or_one_per_target(arm, arm_target):
    targets = np.stack([arm_target, arm_target])
    q = np.array([0.4, 0.5, -0.3, 0.6])
    for q0 in (q, q.tolist(), [q.tolist(), q.tolist()], np.stack([q, q]).astype(np.float32)):
        res = ik.solve_many(arm, targets, q0=q0, processes=1, seed=0)
        assert [r.success for r in res] == [True, True]


# ----------------------------------------------------------------------------- tasks


@pytest.mark.parametrize("name", [math.nan, object(), "", 3, b"tool", np.array(["a"]), ["a"]])
@pytest.mark.parametrize("owner, make", [
    ("FrameTask", lambda name, T: ik.FrameTask(None, T, name=name)),
    ("PostureTask", lambda name, T: ik.PostureTask([0.0] * 4, name=name)),
    ("CentringTask", lambda name, T: ik.CentringTask(name=name)),
    ("CollisionConstraint", lambda name, T: ik.CollisionConstraint([ik.Sphere([0, 0, 0], 0.1)], name=name)),
    ("Constraint", lambda name, T: ik.Constraint(name=name)),
])
def test_task_and_constraint_names_are_none_or_a_non_empty_str(arm_target, owner, make, name):
    """name=nan or object() was stored and printed in messages; CollisionConstraint(name="") fell back to its
    default and an array raised NumPy's "truth value ... is ambiguous"."""
    with pytest.raises(InputError, match=rf"^{owner} name must be None or a non-empty str, got "):
        make(name, arm_target)
    assert make("mine", arm_target).name == "mine"
    assert isinstance(make(None, arm_target).name, str)


@pytest.mark.parametrize("v_max, error, message", [
    (1e300, NonFiniteError, r"^v_max must hold finite numbers with magnitude <= 1e\+06; bad entries: \[0\]="),
    ([1.0, math.inf], NonFiniteError, r"^v_max must hold finite numbers .*\[1\]=inf"),
    (math.nan, NonFiniteError, r"^v_max must hold finite numbers"),
    (True, ShapeError, r"^v_max must be a number or an array of numbers, got True$"),
    (np.array([True, False]), ShapeError, r"^v_max must be a number or an array of numbers"),
    ("2", ShapeError, r"^v_max must be a number or an array of numbers, got '2'$"),
    (None, ShapeError, r"^v_max must be a number or an array of numbers, got None$"),
    ([], ShapeError, r"^v_max must be a number or a 1-D sequence of numbers \(one per joint\), got shape"),
    ([[1.0, 2.0]], ShapeError, r"^v_max must be a number or a 1-D sequence .*got shape \(1, 2\)"),
    (0.0, InputError, r"^v_max must be positive, got 0.0"),
    ([1.0, -1.0], InputError, r"^v_max must be positive"),
])
def test_velocity_limits_are_positive_bounded_numbers(v_max, error, message):
    """VelocityLimits(1e300) was accepted, True read as 1.0 and "2" as 2.0."""
    with pytest.raises(error, match=message):
        ik.VelocityLimits(v_max)
    limits = ik.VelocityLimits(1.0)
    with pytest.raises(error, match=message):
        limits.v_max = v_max
    assert limits.v_max == 1.0  # unchanged by the refused assignment


def test_velocity_limits_take_a_number_or_one_per_joint(arm, arm_target):
    q = np.array([0.4, 0.5, -0.3, 0.6])
    task = ik.FrameTask(None, arm_target)
    for v_max in (1e6, np.float32(2.0), 3, [1.0, 2.0, 3.0, 4.0], np.array([1, 2, 3, 4])):
        assert ik.step(arm, [task], [ik.VelocityLimits(v_max)], q=q).shape == (4,)
    mine = np.array([1.0, 2.0, 3.0, 4.0])
    ik.VelocityLimits(mine)
    assert mine.flags.writeable  # the caller's array is copied, not frozen


@pytest.mark.parametrize("robot", ["planar4r", None, 3, np.zeros(4)])
def test_target_refuses_what_is_not_a_robot(arm_target, robot):
    """ik.Target("planar4r", T) was "'str' object has no attribute 'tip'"."""
    with pytest.raises(InputError, match=r"^robot must be a kinserve Robot \(robots.load\(\.\.\.\)\), got "):
        ik.Target(robot, arm_target)


def test_target_takes_a_robot(arm, arm_target):
    assert ik.Target(arm, arm_target).frame == arm.tip


@pytest.mark.parametrize("relax_frame", [[], np.zeros(2), np.array(["world"]), None, "World"])
@pytest.mark.parametrize("make", [
    lambda arm, T, rf: ik.Target(arm, T, relax_frame=rf),
    lambda arm, T, rf: ik.FrameTask(None, T, relax_frame=rf),
])
def test_relax_frame_is_one_of_its_names(arm, arm_target, make, relax_frame):
    with pytest.raises(InputError, match=r"^relax_frame must be one of 'world', 'target', got "):
        make(arm, arm_target, relax_frame)
    assert make(arm, arm_target, "target").relax_frame == "target"


@pytest.mark.parametrize("method", [[], np.zeros(2), None, "frob"])
def test_check_options_refuses_a_method_that_is_not_a_name(method):
    """check_options([], {}) was "unhashable type: 'list'"."""
    from kinserve.ik.options import check_options

    with pytest.raises(InputError, match=r"^method must be one of \('auto', 'qp', "):
        check_options(method, {})
    check_options("lm", {"max_iter": 10})


@pytest.mark.parametrize("backend", [None, [], np.zeros(2), "no-such-solver"])
def test_step_backend_is_an_installed_qp_solver(arm, arm_target, backend):
    q = np.array([0.4, 0.5, -0.3, 0.6])
    with pytest.raises(InputError, match=r"^backend must be one of the installed QP solvers \["):
        ik.step(arm, [ik.FrameTask(None, arm_target)], q=q, backend=backend)
    assert ik.step(arm, [ik.FrameTask(None, arm_target)], q=q, backend="OSQP").shape == (4,)


def test_frame_task_refuses_a_weight_of_the_wrong_length(target):
    with pytest.raises(ShapeError, match=r"FrameTask weight must be a number or 6 numbers \(one per error "
                                         r"row of the task\), got 2"):
        ik.FrameTask("panda_hand", target, weight=[1, 2])
    with pytest.raises(ShapeError, match=r"FrameTask weight must be a number or 3 numbers"):
        ik.FrameTask("panda_hand", target, relax=("roll", "pitch", "yaw"), weight=[1.0] * 6)
    task = ik.FrameTask("panda_hand", target, weight=[1.0] * 6)
    with pytest.raises(ShapeError, match=r"FrameTask weight must be a number or 6 numbers"):
        task.weight = [1.0, 2.0]
    assert task.weight.tolist() == [1.0] * 6  # unchanged by the refused assignment


def test_task_weights_and_priorities_are_bounded(target):
    with pytest.raises(NonFiniteError, match=r"FrameTask weight must be finite with entries at most 1e\+06"):
        ik.FrameTask("panda_hand", target, weight=[1e300] * 6)
    with pytest.raises(NonFiniteError, match=r"FrameTask weight must be finite with magnitude <= 1e\+06"):
        ik.FrameTask("panda_hand", target, weight=1e300)
    with pytest.raises(InputError, match=r"FrameTask priority must be an integer >= 1 \(1 = highest level\) "
                                         r"and at most 1,000,000, got 1000000000000"):
        ik.FrameTask("panda_hand", target, priority=10**12)
    assert ik.FrameTask("panda_hand", target, weight=[1e6] * 6, priority=10**6).priority == 10**6


def test_solve_and_step_with_vector_weights(panda, target):
    q = panda.neutral()
    good = ik.FrameTask("panda_hand", target, weight=[1.0, 1.0, 1.0, 0.5, 0.5, 0.5])
    assert ik.solve(panda, tasks=[good], seed=0).success
    assert ik.step(panda, [good], q=q).shape == (panda.model.nv,)
    relaxed = ik.FrameTask("panda_hand", target, relax="yaw", weight=[1.0] * 5)
    assert ik.solve(panda, tasks=[relaxed], seed=0).success
    posture = ik.PostureTask(q, weight=[1.0, 2.0])  # its rows (nq) are known when bound
    with pytest.raises(ShapeError, match=r"PostureTask weight must be a number or 7 numbers"):
        ik.solve(panda, tasks=[good, posture])
    with pytest.raises(ShapeError, match=r"PostureTask weight must be a number or 7 numbers"):
        ik.step(panda, [good, posture], q=q)
    centring = ik.CentringTask(weight=[1.0, 2.0])
    with pytest.raises(ShapeError, match=r"CentringTask weight must be a number or 7 numbers"):
        ik.step(panda, [good, centring], q=q)
    posture.weight = [1.0] * 7
    assert ik.step(panda, [good, posture], q=q).shape == (panda.model.nv,)


# ----------------------------------------------------------------------------- ik.choose


@pytest.mark.parametrize("candidates, error, message", [
    ([[math.nan] * 6], NonFiniteError, r"candidates\[0\] must hold finite numbers"),
    ([None], ShapeError, r"candidates\[0\] must be a sequence of 6 numbers, got None"),
    ([[0, 0, 0]], ShapeError, r"candidates\[0\] must have shape \(6,\), got shape \(3,\)"),
    ("abc", InputError, r"candidates must be a sequence of ik.Result or joint vectors \(6 numbers each\)"),
    (None, InputError, r"candidates must be a sequence of ik.Result or joint vectors"),
    (3, InputError, r"candidates must be a sequence of ik.Result or joint vectors"),
    (np.zeros(6), ShapeError, r"candidates must have shape \(N, 6\), got shape \(6,\)"),
    ([[1e300] * 6], NonFiniteError, r"candidates\[0\] must hold finite numbers with magnitude <= 1e\+06"),
])
def test_choose_refuses_bad_candidates(ur5, candidates, error, message):
    with pytest.raises(error, match=message):
        ik.choose(ur5, candidates)


@pytest.mark.parametrize("criteria, message", [
    (None, r"criteria must be one name or a sequence of names from"),
    (3, r"criteria must be one name or a sequence of names from"),
    ((), r"criteria must name at least one of"),
    ([None], r"unknown criterion None"),
    ("beauty", r"unknown criterion 'beauty'"),
])
def test_choose_refuses_bad_criteria(ur5, criteria, message):
    with pytest.raises(InputError, match=message):
        ik.choose(ur5, [ur5.neutral()], criteria=criteria)


def test_choose_refuses_bad_frame_and_q_current_and_accepts_good_input(ur5):
    cands = [ur5.neutral(), ur5.neutral() + 0.3]
    with pytest.raises(NonFiniteError, match=r"q_current must hold finite numbers"):
        ik.choose(ur5, cands, criteria="displacement", q_current=[math.nan] * 6)
    with pytest.raises(InputError, match=r"unknown frame 'nope'"):
        ik.choose(ur5, cands, criteria="manipulability", frame="nope")
    with pytest.raises(InputError, match=r"frame must be a frame name or None"):
        ik.choose(ur5, cands, frame=3)
    assert ik.choose(ur5, cands, criteria="displacement", q_current=cands[1] + 0.01) == 1
    assert ik.choose(ur5, np.array(cands), criteria="displacement", q_current=cands[0]) == 0
    assert ik.choose(ur5, []) is None


# ----------------------------------------------------------------------------- ik.step, ik.warm


@pytest.mark.parametrize("tasks", [None, "abc", 3])
def test_step_refuses_bad_tasks(panda, target, tasks):
    with pytest.raises(InputError, match=r"tasks must be a sequence of ik.Task objects"):
        ik.step(panda, tasks, q=panda.neutral())


@pytest.mark.parametrize("dt, error, message", [
    (1e300, NonFiniteError, r"dt must be finite with magnitude <= 1e\+06, got 1e\+300"),
    (math.nan, NonFiniteError, r"dt must be finite"),
    (1e-300, InputError, r"dt must be at least 1e-09 s \(the control period\), got 1e-300"),
    (0.0, InputError, r"dt must be positive, got 0.0"),
    ("0.01", InputError, r"dt must be a positive number of seconds, got '0.01'"),
])
def test_step_refuses_bad_dt(panda, target, dt, error, message):
    with pytest.raises(error, match=message):
        ik.step(panda, [ik.FrameTask("panda_hand", target)], q=panda.neutral(), dt=dt)


def test_step_refuses_bad_damping_and_accepts_neighbours(panda, target):
    task = ik.FrameTask("panda_hand", target)
    with pytest.raises(NonFiniteError, match=r"damping must be finite with magnitude <= 1e\+06"):
        ik.step(panda, [task], q=panda.neutral(), damping=1e300)
    with pytest.raises(InputError, match=r"constraints must be a sequence of ik.Constraint objects"):
        ik.step(panda, [task], "abc", q=panda.neutral())
    v = ik.step(panda, task, None, q=panda.neutral(), dt=1e6, damping=1e6)
    assert v.shape == (panda.model.nv,) and np.all(np.isfinite(v))
    v = ik.step(panda, [task], q=panda.neutral(), dt=1e-9)
    assert np.all(np.isfinite(v))


@pytest.mark.parametrize("kwargs, error, message", [
    ({"frames": 3}, InputError, r"frames must be a frame name, a sequence of frame names or None"),
    ({"frames": [3]}, InputError, r"frames\[0\] must be a frame name \(str\), got 3"),
    ({"frames": ["nope"]}, InputError, r"unknown frame 'nope'"),
    ({"collision_margin": math.nan}, NonFiniteError, r"collision margin must be finite"),
    ({"collision_margin": -1.0}, InputError, r"collision margin must be >= 0"),
    ({"self_collision": "yes"}, InputError, r"self_collision must be True or False"),
    ({"obstacles": "abc"}, InputError, r"obstacles must be a sequence of shapes"),
])
def test_warm_refuses_bad_arguments_before_building(panda, monkeypatch, kwargs, error, message):
    monkeypatch.setattr("kinserve.ik.state.compiled_chains", _no_work)
    with pytest.raises(error, match=message):
        ik.warm(panda, **kwargs)


def test_warm_accepts_frames(panda):
    assert ik.warm(panda, "panda_hand", collision_margin=0.0) is not None
    assert ik.warm(panda, ("panda_hand", panda.tip)) is not None


@pytest.mark.parametrize("backend", ["processes", "serial"])
def test_ray_address_with_another_backend_is_refused_not_ignored(backend):
    """ik.solve_many and plan_many refuse a ray_address their backend would ignore (before any worker)."""
    from kinserve import ik, robots
    from kinserve.planners.motion import plan_many

    arm = robots.load("planar4r", geometry=False)
    Q = arm.random_q(0, n=2)
    with pytest.raises(InputError, match=f"ray_address is for backend='ray' only \\(backend='{backend}'"):
        ik.solve_many(arm, arm.fk_batch(Q), backend=backend, ray_address="127.0.0.1:1")
    with pytest.raises(InputError, match="ray_address is for backend='ray' only \\(backend='local'"):
        plan_many(arm, [(Q[0], Q[1])], backend="local", ray_address="127.0.0.1:1")
