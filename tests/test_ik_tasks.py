"""kinserve.ik.tasks: task errors and Jacobians against finite differences, a user task, two hands at once."""

import numpy as np
import pinocchio as pin
import pytest

from kinserve import ik, robots
from kinserve.kinematics import errors
from kinserve.kinematics.errors import FrameError, InputError, NonFiniteError


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda", geometry=False)


def _e(robot, task, q):
    pin.computeJointJacobians(robot.model, robot.data, q)
    return task.compute(robot, robot.data, q)


def _fd_jacobian(robot, task, q, h=1e-6):
    cols = []
    for i in range(robot.nq):
        dq = np.zeros(robot.nq)
        dq[i] = h
        cols.append((_e(robot, task, q + dq)[0] - _e(robot, task, q - dq)[0]) / (2 * h))
    return np.array(cols).T


class CoMTask(ik.Task):
    """A user task: the centre of mass at a point (e = c(q) - c*, J = dc/dq)."""

    def __init__(self, target, weight=1.0, priority=1):
        super().__init__(weight=weight, priority=priority, name="com")
        self.target = np.asarray(target, dtype=float)

    def compute(self, robot, data, q):
        J = pin.jacobianCenterOfMass(robot.model, data, q, False)
        return data.com[0] - self.target, J


@pytest.mark.parametrize("relax,axes", [((), "world"), (("roll", "pitch"), "world"), (("z", "yaw"), "target"),
                                        (("x",), "target")])
def test_frame_task_jacobian_matches_finite_differences(panda, relax, axes):
    rng = np.random.default_rng(3)
    T = panda.fk(panda.random_q(rng)).copy()
    task = ik.FrameTask("panda_hand", T, relax=relax, relax_frame=axes).bind(panda)
    for q in panda.random_q(rng, 4):
        e, J = _e(panda, task, q)
        assert e.shape == (6 - len(relax),) and J.shape == (6 - len(relax), panda.nq)
        assert np.allclose(J, _fd_jacobian(panda, task, q), atol=1e-6)


def test_frame_task_error_is_zero_at_the_target_and_matches_the_pose_distance(panda):
    rng = np.random.default_rng(4)
    q = panda.random_q(rng)
    T = panda.fk(q).copy()
    task = ik.FrameTask(None, T).bind(panda)
    assert task.frame_name == panda.tip
    assert np.allclose(_e(panda, task, q)[0], 0.0, atol=1e-12)
    q2 = panda.random_q(rng)
    T2 = panda.fk(q2)
    pe, re = task.errors(_e(panda, task, q2)[0])
    assert pe == pytest.approx(np.linalg.norm(T2[:3, 3] - T[:3, 3]))
    angle = np.arccos(np.clip((np.trace(T2[:3, :3].T @ T[:3, :3]) - 1) / 2, -1, 1))
    assert re == pytest.approx(angle, abs=1e-9)


def test_posture_centring_and_user_com_jacobians(panda):
    rng = np.random.default_rng(5)
    q_ref = panda.random_q(rng)
    for task in (ik.PostureTask(q_ref).bind(panda), ik.CentringTask([1, 2, 0, 1, 1, 3, 1]).bind(panda),
                 CoMTask((0.1, 0.0, 0.4))):
        for q in panda.random_q(rng, 3):
            e, J = _e(panda, task, q)
            assert np.allclose(J, _fd_jacobian(panda, task, q), atol=1e-6)
    # the centring task is today's objective: 1/2 |e|^2 = h(q)
    from kinserve.ik.tasks.centring_weights import centring_objective, centring_weights

    w = [1, 2, 0, 1, 1, 3, 1]
    e, _ = _e(panda, ik.CentringTask(w).bind(panda), q)
    assert 0.5 * e @ e == pytest.approx(centring_objective(panda, q, centring_weights(panda, w)))


def test_task_validation(panda):
    T = np.eye(4)
    with pytest.raises(InputError, match="priority"):
        ik.FrameTask("panda_hand", T, priority=0)
    with pytest.raises(InputError, match="weight"):
        ik.PostureTask(np.zeros(7), weight=-1)
    with pytest.raises(NonFiniteError):
        ik.PostureTask(np.zeros(7), weight=np.nan)
    with pytest.raises(InputError, match="relax"):
        ik.FrameTask("panda_hand", T, relax=("x", "y", "z", "roll", "pitch", "yaw"))
    with pytest.raises(InputError, match="relax_frame"):
        ik.FrameTask("panda_hand", T, relax_frame="tool")
    with pytest.raises(FrameError):
        ik.FrameTask("nope", T).bind(panda)
    with pytest.raises(InputError, match="q_ref"):
        ik.PostureTask(np.zeros(3)).bind(panda)
    with pytest.raises(InputError, match="CentringTask"):
        ik.CentringTask(0.0).bind(panda)
    with pytest.raises(InputError, match="tasks"):
        ik.solve(panda, tasks=[])
    with pytest.raises(InputError, match=r"tasks\[1\]"):
        ik.solve(panda, tasks=[ik.PostureTask(np.zeros(7)), "frame"])
    with pytest.raises(InputError, match="either"):
        ik.solve(panda, np.eye(4), tasks=[ik.PostureTask(np.zeros(7))])


def test_user_task_centre_of_mass_is_reached(panda):
    rng = np.random.default_rng(6)
    q = panda.random_q(rng)
    com = pin.centerOfMass(panda.model, panda.model.createData(), q)
    res = ik.solve(panda, tasks=[CoMTask(com), ik.PostureTask(panda.neutral(), priority=2)], seed=0,
                   iteration_budget=2000)
    assert res.success, res.message
    reached = pin.centerOfMass(panda.model, panda.model.createData(), res.q)
    assert np.linalg.norm(reached - com) < 1e-4
    assert [t["name"] for t in res.task_errors] == ["com", "posture"]
    assert (res.task_errors[0]["error"] < 1e-4 and res.task_errors[0]["goal"]
            and not res.task_errors[1]["goal"])


@pytest.mark.parametrize("frame_priority", [1, 2])
def test_history_names_a_user_tasks_rows_by_its_error_at_the_answer(panda, frame_priority):
    """A user task without ``components``: the history names its rows by their index, counted from its error
    at the answer (no extra kinematics in the solve), in the goals' given order whatever the priorities."""
    q = panda.random_q(np.random.default_rng(8))
    com = pin.centerOfMass(panda.model, panda.model.createData(), q)
    frame = ik.FrameTask(panda.tip, panda.fk(q).copy(), priority=frame_priority)
    alone = ik.solve(panda, tasks=[CoMTask(com)], seed=0, iteration_budget=2000)
    assert alone.history.components == ("0", "1", "2")
    assert alone.history.task_error.shape[1] == 3
    both = ik.solve(panda, tasks=[frame, CoMTask(com)], seed=0, iteration_budget=4000)
    assert both.success, both.message
    frame_rows = tuple(f"{frame.name}:{c}" for c in ("x", "y", "z", "roll", "pitch", "yaw"))
    assert both.history.components == frame_rows + ("com:0", "com:1", "com:2")
    assert both.history.task_error.shape[1] == 9
    last = both.history.task_error[-1]
    assert np.allclose(last[6:], com - pin.centerOfMass(panda.model, panda.model.createData(), both.q))


def _com_output(robot, data, q):
    J = pin.jacobianCenterOfMass(robot.model, data, q, False)
    return data.com[0] - np.array([0.1, 0.0, 0.4]), J


@pytest.mark.parametrize("output,weight,error,words", [
    (lambda e, J: None, 1.0, errors.InputError, "must return a pair (e, J), got NoneType"),
    (lambda e, J: (e, J, J), 1.0, errors.InputError, "must return a pair (e, J), got tuple"),
    (lambda e, J: ("e", J), 1.0, errors.InputError, "must return numbers"),
    (lambda e, J: (e[:, None], J), 1.0, errors.ShapeError, "must be a vector of m numbers, got shape (3, 1)"),
    (lambda e, J: (e, J[:2]), 1.0, errors.ShapeError, "must be 3 x 7"),
    (lambda e, J: (e, J[:, :5]), 1.0, errors.ShapeError, "got shape (3, 5)"),
    (lambda e, J: (e * np.nan, J), 1.0, errors.NonFiniteError, "the error e must hold finite numbers"),
    (lambda e, J: (e, J + np.inf), 1.0, errors.NonFiniteError, "the Jacobian J must hold finite numbers"),
    (lambda e, J: (e, J), [1.0, 2.0], errors.ShapeError, "weight must be a number or 3 numbers"),
])
@pytest.mark.parametrize("with_posture", [False, True])
def test_a_user_tasks_bad_output_is_named_not_solved(panda, output, weight, error, words, with_posture):
    """A user's compute that breaks the protocol raises kinserve's error naming the task's class - never a
    NumPy error, nor a solve that converges on NaN - alone (the unstacked level) and with another task."""

    class Broken(ik.Task):
        def compute(self, robot, data, q):
            return output(*_com_output(robot, data, q))

    tasks = [Broken(weight=weight)] + ([ik.PostureTask(panda.neutral(), priority=2)] if with_posture else [])
    with pytest.raises(error) as info:
        ik.solve(panda, tasks=tasks, seed=0, iteration_budget=200)
    assert words in str(info.value) and "Broken" in str(info.value)


def test_a_user_task_may_return_lists():
    """Lists are numbers too: a user task returning plain lists solves like one returning arrays."""
    panda = robots.load("panda", geometry=False)

    class Listed(ik.Task):
        def compute(self, robot, data, q):
            e, J = _com_output(robot, data, q)
            return e.tolist(), J.tolist()

    res = ik.solve(panda, tasks=[Listed()], seed=0, iteration_budget=2000)
    assert res.success, res.message
    reached = pin.centerOfMass(panda.model, panda.model.createData(), res.q)
    assert np.linalg.norm(reached - [0.1, 0.0, 0.4]) < 1e-4


def test_baxter_reaches_a_pose_with_each_hand_at_once():
    baxter = robots.load("baxter", geometry=False)
    assert baxter.nq == 14
    rng = np.random.default_rng(7)
    for k in range(3):
        q = baxter.random_q(rng)
        TL, TR = baxter.fk(q, "left_gripper").copy(), baxter.fk(q, "right_gripper").copy()
        res = ik.solve(baxter, tasks=[ik.FrameTask("left_gripper", TL),
                                      ik.FrameTask("right_gripper", TR)], seed=k, iteration_budget=2000)
        assert res.success, res.message
        for frame, T in (("left_gripper", TL), ("right_gripper", TR)):
            got = baxter.fk(res.q, frame)
            assert np.linalg.norm(got[:3, 3] - T[:3, 3]) < 1e-4
            assert np.arccos(np.clip((np.trace(got[:3, :3].T @ T[:3, :3]) - 1) / 2, -1, 1)) < 1e-3
        assert baxter.within_limits(res.q)
        assert len(res.task_errors) == 2 and res.frame == "left_gripper,right_gripper"
        assert res.history.task_error.shape[1] == 12


@pytest.mark.parametrize("posture_first", [True, False])
def test_task_errors_follow_the_given_order_whatever_the_priorities(posture_first):
    """Result.task_errors lists the tasks as given, each with its own error (checked here by FK), even when a
    lower-priority task comes first (the solver evaluates them by level)."""
    panda = robots.load("panda", geometry=False)
    q0 = panda.random_q(np.random.default_rng(0))
    T = panda.fk(panda.random_q(np.random.default_rng(1)))
    frame, posture = ik.FrameTask(panda.tip, T), ik.PostureTask(panda.middle())
    tasks = [posture, frame] if posture_first else [frame, posture]
    res = ik.solve(panda, tasks=tasks, q0=q0, seed=0, iteration_budget=2000)
    assert res.success, res.message
    names = [t["name"] for t in res.task_errors]
    assert names == [t.name for t in tasks]
    by_name = {t["name"]: t for t in res.task_errors}
    p_true = np.linalg.norm(panda.fk(res.q)[:3, 3] - T[:3, 3])
    assert by_name[frame.name]["position_error"] == pytest.approx(p_true, abs=1e-9) and p_true < 1e-4
    assert by_name[posture.name]["error"] == pytest.approx(np.linalg.norm(res.q - panda.middle()), rel=1e-9)
