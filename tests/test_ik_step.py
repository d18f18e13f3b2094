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
    avoid = ik.ObstacleAvoidance([ik.Sphere(mid + [0.0, 0.1, 0.0], 0.05), ik.Sphere(mid - [0.0, 0.1, 0.0], 0.05),
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
        res = ik.solve(panda, tasks=[ik.FrameTask(None, T2, relax=("roll", "pitch", "yaw"))], constraints=[table], seed=k)
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
