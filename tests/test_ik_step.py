"""kinserve.ik.step: one control-loop velocity with velocity limits, obstacles and user constraints."""

import numpy as np
import pinocchio as pin
import pytest

from kinserve import ik, robots
from kinserve.kinematics.errors import InputError


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda", geometry=False)


class AboveTable(ik.Constraint):
    """A user constraint: the tool frame stays above height ``h`` (velocity damper on z)."""

    def __init__(self, frame, height):
        super().__init__(name="above table")
        self.frame, self.h = frame, height

    def bind(self, robot):
        self.fid = robot.frame_id(self.frame)
        return self

    def rows(self, robot, data, q, dt=None):
        z = pin.updateFramePlacement(robot.model, data, self.fid).translation[2]
        Jz = pin.getFrameJacobian(robot.model, data, self.fid, pin.LOCAL_WORLD_ALIGNED)[2:3]
        return Jz, np.array([-0.5 * (z - self.h)]), np.array([np.inf])

    def margin(self, robot, data, q):
        return pin.updateFramePlacement(robot.model, data, self.fid).translation[2] - self.h


def test_velocity_limits_bound_every_joint(panda):
    rng = np.random.default_rng(0)
    T = panda.fk(panda.random_q(rng)).copy()
    tasks = [ik.FrameTask(None, T), ik.PostureTask(panda.neutral(), priority=2)]
    vmax = np.array([0.5, 0.4, 0.3, 0.6, 0.5, 0.9, 1.0])
    q = panda.random_q(rng)
    v = ik.step(panda, tasks, [ik.VelocityLimits(vmax)], q, 0.02)
    assert np.all(np.abs(v) <= vmax + 1e-9) and np.abs(v / vmax).max() > 0.99  # far away: saturated
    free = ik.step(panda, tasks, [], q, 0.02)
    assert np.abs(free).max() > vmax.max()


def test_steps_converge_and_stay_clear(panda):
    rng = np.random.default_rng(1)
    q = panda.random_q(rng)
    T = panda.fk(panda.random_q(rng)).copy()
    mid = 0.5 * (panda.fk(q)[:3, 3] + T[:3, 3])
    avoid = ik.ObstacleAvoidance([ik.Sphere(mid + [0.0, 0.1, 0.0], 0.05),
                                  ik.Sphere(mid - [0.0, 0.1, 0.0], 0.05),
                                  ik.Sphere(mid + [0.0, 0.0, 0.1], 0.05)]).bind(panda)
    tasks = [ik.FrameTask(None, T), ik.PostureTask(panda.neutral(), weight=1e-3, priority=2)]
    cons = [avoid, ik.VelocityLimits(2.0)]
    pin.forwardKinematics(panda.model, panda.data, q)
    start_clear = avoid.clearances(panda.data).min()
    lowest = np.inf
    for _ in range(400):
        v = ik.step(panda, tasks, cons, q, 0.01)
        q = np.clip(q + 0.01 * v, panda.lower, panda.upper)
        pin.forwardKinematics(panda.model, panda.data, q)
        lowest = min(lowest, avoid.clearances(panda.data).min())
    assert lowest >= min(0.0, start_clear) - 1e-3  # first order: never deeper than a millimetre
    err = np.linalg.norm(panda.fk(q)[:3, 3] - T[:3, 3])
    assert err < 1e-3 or lowest < 0.01  # reached, or held back by an obstacle in the way


def test_user_constraint_in_step_and_solve(panda):
    rng = np.random.default_rng(2)
    table = AboveTable("panda_hand", 0.3)
    for k in range(6):
        q = panda.random_q(rng)
        if panda.fk(q)[2, 3] < 0.35:
            continue
        T = panda.fk(panda.random_q(rng)).copy()
        T[2, 3] = 0.1  # below the table: the constraint wins
        q_next = q
        for _ in range(100):
            v = ik.step(panda, [ik.FrameTask(None, T, relax=("roll", "pitch", "yaw"))], [table], q_next, 0.05)
            q_next = np.clip(q_next + 0.05 * v, panda.lower, panda.upper)
        assert panda.fk(q_next)[2, 3] > 0.3 - 1e-3
        T2 = T.copy()
        T2[2, 3] = 0.5
        res = ik.solve(panda, tasks=[ik.FrameTask(None, T2, relax=("roll", "pitch", "yaw"))],
                       constraints=[table], seed=k)
        assert all(panda.fk(qi)[2, 3] >= 0.3 - 1e-9 for qi in res.history.q[1:])


def test_step_validation(panda):
    T = np.eye(4)
    task = ik.FrameTask(None, panda.fk(panda.neutral()).copy())
    with pytest.raises(InputError, match="dt"):
        ik.step(panda, [task], [], panda.neutral(), 0.0)
    with pytest.raises(InputError, match="q"):
        ik.step(panda, [task], [], None, 0.01)
    with pytest.raises(InputError, match="v_max"):
        ik.VelocityLimits(-1.0)
    with pytest.raises(InputError, match="v_max"):
        ik.step(panda, [task], [ik.VelocityLimits([1.0, 2.0])], panda.neutral(), 0.01)
    assert np.allclose(ik.step(panda, [task], [], panda.neutral(), 0.01), 0.0, atol=1e-9)
    del T


def _setup(panda, rng, level=2):
    """Issue 10's control step: frame task, posture task, 3 spheres r 5 cm near the hand, velocity limits."""
    q = panda.random_q(rng)
    T = panda.fk(panda.random_q(rng)).copy()
    hand = panda.fk(q)[:3, 3]
    spheres = [ik.Sphere(hand + rng.normal(0.0, 0.12, 3), 0.05) for _ in range(3)]
    tasks = [ik.FrameTask(None, T),
             ik.PostureTask(panda.middle(), weight=1.0 if level == 2 else 1e-2, priority=level)]
    return q, T, spheres, tasks, [ik.ObstacleAvoidance(spheres), ik.VelocityLimits(2.0)]


def test_cached_step_is_the_step_of_fresh_objects(panda):
    """Repeated calls on the same objects (the cached, bound problem) give the bytes of a first call on
    freshly made objects, at every q, with the target moved by set_target in between."""
    rng = np.random.default_rng(20)
    for level in (1, 2):
        q, T, spheres, tasks, cons = _setup(panda, rng, level)
        for k in range(12):
            q = panda.random_q(rng)
            T = panda.fk(panda.random_q(rng)).copy()
            tasks[0].set_target(T)
            cached = ik.step(panda, tasks, cons, q, 0.01)
            fresh = ik.step(panda, [ik.FrameTask(None, T),
                                    ik.PostureTask(panda.middle(), weight=tasks[1].weight,
                                                                          priority=level)],
                            [ik.ObstacleAvoidance(spheres), ik.VelocityLimits(2.0)], q, 0.01)
            assert np.array_equal(cached, fresh), (level, k)


def test_cached_problem_is_rebuilt_when_a_task_or_constraint_changes(panda):
    rng = np.random.default_rng(21)
    q, T, spheres, tasks, cons = _setup(panda, rng)
    frame, posture = tasks
    vel = cons[1]
    ik.step(panda, tasks, cons, q, 0.01)

    def fresh(q_ref, weight, priority, v_max, target=T):
        return ik.step(panda, [ik.FrameTask(None, target),
                               ik.PostureTask(q_ref, weight=weight, priority=priority)],
                       [ik.ObstacleAvoidance(spheres), ik.VelocityLimits(v_max)], q, 0.01)

    q_ref = panda.random_q(rng)
    posture.q_ref = q_ref
    assert np.array_equal(ik.step(panda, tasks, cons, q, 0.01), fresh(q_ref, 1.0, 2, 2.0))
    posture.priority = 1
    posture.weight = 0.1
    one_level = ik.step(panda, tasks, cons, q, 0.01)
    assert np.array_equal(one_level, fresh(q_ref, 0.1, 1, 2.0))
    vel.v_max = 0.3
    v = ik.step(panda, tasks, cons, q, 0.01)
    assert np.array_equal(v, fresh(q_ref, 0.1, 1, 0.3)) and np.abs(v).max() <= 0.3 + 1e-12
    T2 = panda.fk(panda.random_q(rng)).copy()
    frame.T = T2  # assignment goes through set_target (validated)
    assert np.array_equal(ik.step(panda, tasks, cons, q, 0.01), fresh(q_ref, 0.1, 1, 0.3, T2))
    centring = ik.CentringTask(weights=1.0, priority=2)
    both = [frame, centring]
    ik.step(panda, both, cons, q, 0.01)
    centring.weights = np.linspace(0.0, 1.0, 7)
    assert np.array_equal(ik.step(panda, both, cons, q, 0.01),
                          ik.step(panda, [ik.FrameTask(None, T2), ik.CentringTask(np.linspace(0.0, 1.0, 7))],
                                  [ik.ObstacleAvoidance(spheres), ik.VelocityLimits(0.3)], q, 0.01))


def test_changed_inputs_are_validated_again(panda):
    rng = np.random.default_rng(22)
    q, T, spheres, tasks, cons = _setup(panda, rng)
    ik.step(panda, tasks, cons, q, 0.01)
    with pytest.raises(InputError, match="weight"):
        tasks[1].weight = -1.0
    with pytest.raises(InputError, match="priority"):
        tasks[1].priority = 0
    with pytest.raises(InputError, match="v_max"):
        cons[1].v_max = [1.0, np.nan]
    with pytest.raises(InputError, match="target"):
        tasks[0].T = np.zeros((4, 4))
    assert np.isfinite(ik.step(panda, tasks, cons, q, 0.01)).all()  # the failed assignments changed nothing
    tasks[1].q_ref = [0.0, 0.0, 0.0]  # a vector, but not this robot's: the next bind names it
    with pytest.raises(InputError, match="q_ref"):
        ik.step(panda, tasks, cons, q, 0.01)
    cons[1].v_max = [1.0, 2.0]
    tasks[1].q_ref = panda.middle()
    with pytest.raises(InputError, match="v_max"):
        ik.step(panda, tasks, cons, q, 0.01)


def test_step_keeps_every_damper_row_and_the_hierarchy(panda):
    """At random q, the returned velocity keeps the obstacle rows ``n^T J v dt >= -xi c`` of every pair within
    reach (independently of the rows the step used: the constraint's ``rows_all``), the velocity and joint
    limits, and the frame task's first-order progress of the frame task alone (strict priority)."""
    rng = np.random.default_rng(23)
    held = 0
    for k in range(30):
        q, T, spheres, tasks, cons = _setup(panda, rng)
        dt = 0.01
        v = ik.step(panda, tasks, cons, q, dt)
        assert np.abs(v).max() <= 2.0 + 1e-9
        assert np.all(q + v * dt >= panda.lower - 1e-12) and np.all(q + v * dt <= panda.upper + 1e-12)
        avoid = ik.ObstacleAvoidance(spheres).bind(panda)
        pin.computeJointJacobians(panda.model, panda.data, q)
        c, G = avoid.rows_all(panda, panda.data)
        near = c < avoid.influence
        assert np.all(G[near] @ (v * dt) >= -avoid.gain * c[near] - 1e-12), k
        held += int(np.any(np.abs(G[near] @ (v * dt) + avoid.gain * c[near]) < 1e-9))
        alone = ik.step(panda, tasks[:1], cons, q, dt)
        J = panda.jacobian(q)
        assert np.allclose(J @ v, J @ alone, atol=1e-7), k
    assert held >= 1  # some damper row was active: the check is not vacuous


def test_step_validates_damping_and_backend(panda):
    task = ik.FrameTask(None, panda.fk(panda.random_q(np.random.default_rng(24))).copy())
    q = panda.neutral()
    for bad in (-1.0, float("nan"), float("inf"), "0.1", True):
        with pytest.raises(InputError, match="damping"):
            ik.step(panda, [task], [], q, 0.01, damping=bad)
    for bad in ("no-such-solver", 3, None):
        with pytest.raises(InputError, match="backend"):
            ik.step(panda, [task], [], q, 0.01, backend=bad)
    for bad in (float("nan"), -0.01, float("inf"), "0.01", True):
        with pytest.raises(InputError, match="dt"):
            ik.step(panda, [task], [], q, bad)
    assert np.isfinite(ik.step(panda, [task], [], q, 1, damping=0)).all()  # ints are numbers too
    v1 = ik.step(panda, [task], [ik.VelocityLimits(1.0)], q, 0.01, backend="DAQP")  # any case
    assert np.array_equal(v1, ik.step(panda, [task], [ik.VelocityLimits(1.0)], q, 0.01))


def test_the_bound_problem_is_kept_by_the_robots_ik_state_per_thread(panda):
    """The control loop's bound problem lives on the robot's IKState (no module-level cache): found again by
    the identity of the objects (equal new objects are bound anew), per thread (another thread binds its own
    on its own Data), at most STEP_PROBLEMS_PER_THREAD kept, and clear_caches(robot) drops them."""
    import sys
    import threading

    import kinserve
    from kinserve.ik.state import ik_state
    from kinserve.ik.step_problems import STEP_PROBLEMS_PER_THREAD

    step_module = sys.modules["kinserve.ik.step"]
    assert not any(isinstance(v, dict) for k, v in vars(step_module).items() if not k.startswith("__"))
    robot = panda.copy()  # shares the IK state of panda, but is another robot: its own entries
    rng = np.random.default_rng(25)
    q, T, spheres, tasks, cons = _setup(robot, rng)
    store = ik_state(robot).step_problems
    ik.step(robot, tasks, cons, q, 0.01)
    pb = store.entries[0].problem
    assert store.entries[0].robot is robot and pb.data is robot.data
    ik.step(robot, tasks, cons, q, 0.01)
    assert store.entries[0].problem is pb  # found again: not bound anew
    twin = [ik.FrameTask(None, T), tasks[1]]  # an equal, new frame task: a new bind
    ik.step(robot, twin, cons, q, 0.01)
    assert store.entries[0].problem is not pb and store.entries[0].tasks[0] is twin[0]
    ik.step(robot, tasks, cons, q, 0.01)
    assert store.entries[0].problem is pb  # the older entry, moved to the front
    seen = {}

    def other_thread():
        seen["before"] = len(ik_state(robot).step_problems.entries)
        v = ik.step(robot, tasks, cons, q, 0.01)
        mine = ik_state(robot).step_problems.entries[0].problem
        seen.update(v=v, problem=mine, data=mine.data is robot.data)

    worker = threading.Thread(target=other_thread)
    worker.start()
    worker.join()
    assert seen["before"] == 0 and seen["problem"] is not pb and seen["data"]
    assert np.array_equal(seen["v"], ik.step(robot, tasks, cons, q, 0.01))
    assert store.entries[0].problem is pb  # this thread's store untouched
    for k in range(STEP_PROBLEMS_PER_THREAD + 3):
        ik.step(robot, [ik.FrameTask(None, T)], cons, q, 0.01)
    assert len(store.entries) == STEP_PROBLEMS_PER_THREAD
    assert all(e.problem is not pb for e in store.entries)  # the least recently used went first
    kinserve.clear_caches(robot)
    assert ik_state(robot).step_problems is not store
    ik.step(robot, tasks, cons, q, 0.01)
    assert ik_state(robot).step_problems.entries[0].problem is not pb
