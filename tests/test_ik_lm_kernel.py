"""The compiled LM kernel (ik.lm.kernel) and the robot's compiled chains (ik.lm.chains), against Pinocchio and
against the Python iteration.

* the chain's pose and LOCAL Jacobian against Pinocchio's ``updateFramePlacement`` /
  ``getFrameJacobian`` on arms with revolute (aligned and unaligned axes) and prismatic joints;
* its SE(3) logarithm against ``pinocchio.log6``, including angles near 0 and near pi;
* whole solves, full pose and relaxed (world and target axes): the same starts, iterations and answers (to
  rounding) as the Python iteration (no compiled chain), every iterate inside the joint limits,
  history errors equal to FK's;
* every frame's packed chain equals ``serial_chain``; ``ik.lm.warm`` gives the robot (and its copies) its
  chains, which survive pickling;
* chains the kernel does not model (free-flyer, continuous joints) keep Pinocchio's algorithms.
"""

import numpy as np
import pinocchio as pin
import pytest

from kinserve import ik, robots
from kinserve.ik.lm import kernel as lm_kernel
from kinserve.ik.lm import solver as lm_solver
from kinserve.ik.targets import Target
from kinserve.kinematics import Robot, se3
from kinserve.kinematics.serial_chain import PRISMATIC, REVOLUTE, serial_chain


@pytest.fixture
def python_lm(monkeypatch):
    """Solve with the Python iteration (Pinocchio calls) instead of the kernel: the solver finds no chain."""
    def solve(*args, **kwargs):
        with monkeypatch.context() as m:
            m.setattr(lm_solver, "compiled_chain", lambda robot, fid: None)
            return ik.solve(*args, **kwargs)
    return solve


@pytest.mark.parametrize("name", ["panda", "ur5", "scara", "pr", "finger_edu", "baxter"])
def test_pose_and_jacobian_match_pinocchio(name):
    robot = robots.load(name, geometry=False)
    model, data = robot.model, robot.model.createData()
    fid = robot.frame_id(robot.tip)
    geometry, joints = serial_chain(model, fid)
    assert set(joints[:, 0]) <= {REVOLUTE, PRISMATIC}
    n = len(joints)
    for q in robot.random_q(np.random.default_rng(5), 40):
        R, p, J = np.empty((3, 3)), np.empty(3), np.empty((6, n))
        lm_kernel.pose_and_jacobian(geometry, joints, q, R, p, J)
        pin.computeJointJacobians(model, data, q)
        M = pin.updateFramePlacement(model, data, fid)
        J_pin = pin.getFrameJacobian(model, data, fid, pin.LOCAL)
        assert np.abs(R - M.rotation).max() < 1e-12 and np.abs(p - M.translation).max() < 1e-12
        assert np.abs(J - J_pin[:, joints[:, 1]]).max() < 1e-12
        others = np.setdiff1d(np.arange(model.nv), joints[:, 1])
        assert not np.any(J_pin[:, others])  # the columns the kernel leaves out are zero


def test_prismatic_and_unaligned_joints_are_modelled():
    scara = robots.load("scara", geometry=False)
    assert PRISMATIC in serial_chain(scara.model, scara.frame_id(scara.tip))[1][:, 0]
    finger = robots.load("finger_edu", geometry=False)
    assert "JointModelRevoluteUnaligned" in {j.shortname() for j in finger.model.joints}
    assert serial_chain(finger.model, finger.frame_id(finger.tip)) is not None


def _random_rotation_at(rng, angle):
    axis = rng.normal(size=3)
    return pin.exp3(axis / np.linalg.norm(axis) * angle)


@pytest.mark.parametrize("regime", ["random", "near_zero", "near_pi"])
def test_log6_matches_pinocchio(regime):
    rng = np.random.default_rng(11)
    worst = 0.0
    for _ in range(500):
        A, B = pin.SE3.Random(), pin.SE3.Random()
        if regime != "random":  # oMf^-1 oMd at an angle close to 0 or to pi
            angle = 10 ** rng.uniform(-11, -1)
            B.rotation = (A.rotation
                          @ _random_rotation_at(rng, angle if regime == "near_zero" else np.pi - angle))
        e = np.empty(6)
        t2 = lm_kernel._log6(A.rotation.copy(), A.translation.copy(), B.rotation.copy(),
                             B.translation.copy(), e)
        M = A.actInv(B)
        worst = max(worst, np.abs(e - pin.log6(M).vector).max())
        assert t2 == pytest.approx(M.translation @ M.translation, rel=1e-12, abs=1e-15)
    assert worst < 1e-9


@pytest.mark.parametrize("name, relax, relax_frame", [
    ("panda", (), "world"), ("ur5", (), "world"), ("scara", (), "world"),
    ("panda", ("roll", "pitch", "yaw"), "world"), ("panda", ("yaw",), "target"), ("ur5", ("z",), "world"),
    ("panda", ("x", "roll"), "target"), ("scara", ("roll", "pitch"), "world"),
])
def test_compiled_solve_matches_python_iteration(name, relax, relax_frame, python_lm):
    robot = robots.load(name, geometry=False)
    rng = np.random.default_rng(2)
    Q = robot.random_q(rng, 30)
    # half the starts random, half near the limits (the active-set re-solve runs)
    starts = robot.random_q(rng, 30)
    starts[::2] = np.where(rng.random((15, robot.nq)) < 0.5, robot.lower + 1e-3, robot.upper - 1e-3)
    # no clock: a time limit could cut the (slower) Python iteration and not the kernel
    opts = dict(seed=3, max_starts=4, relax=relax, relax_frame=relax_frame, iteration_budget=1000)
    for T, q0 in zip(robot.fk_batch(Q), starts):
        a = ik.solve(robot, T, q0, **opts)
        b = python_lm(robot, T, q0, **opts)
        assert a.success == b.success and a.restarts == b.restarts and a.iterations == b.iterations
        assert np.abs(a.q - b.q).max() < 1e-7
        H = a.history
        assert H.q.shape == b.history.q.shape
        assert np.all(H.q >= robot.lower) and np.all(H.q <= robot.upper)  # every iterate inside the limits
        target = Target(robot, T, robot.tip, relax, relax_frame)
        for qi, pe, re in zip(H.q, H.position_error, H.orientation_error):  # recorded errors = FK's
            if relax:
                pe_fk, re_fk = target.errors_at(robot, qi)
            else:  # (full pose: the errors of oMf^-1 oMd, the same numbers)
                pe_fk, re_fk = se3.pose_error(robot.fk(qi), T)
            assert pe == pytest.approx(pe_fk, abs=1e-12) and re == pytest.approx(re_fk, abs=1e-9)
        if a.success:
            assert target.within(*target.errors_at(robot, a.q), 1e-4, 1e-3)


def test_failed_solve_answers_the_best_iterate(python_lm):
    robot = robots.load("panda", geometry=False)
    T = np.eye(4)
    T[:3, 3] = (2.0, 0.0, 0.5)  # out of reach
    a = ik.solve(robot, T, robot.neutral(), seed=0, max_starts=5, iteration_budget=1000)
    b = python_lm(robot, T, robot.neutral(), seed=0, max_starts=5, iteration_budget=1000)
    assert not a.success and "out of reach" in a.message
    assert a.position_error == pytest.approx(b.position_error, abs=1e-9)
    assert np.abs(a.q - b.q).max() < 1e-7


def _model_with(joint_model) -> Robot:
    model = pin.Model()
    base = model.addJoint(0, joint_model, pin.SE3.Identity(), "base")
    arm = model.addJoint(base, pin.JointModelRZ(), pin.SE3(np.eye(3), np.array([0.3, 0.0, 0.0])), "arm")
    model.addJointFrame(arm)
    model.addFrame(pin.Frame("tool", arm, model.getFrameId("arm"),
                             pin.SE3(np.eye(3), np.array([0.4, 0.0, 0.0])), pin.FrameType.OP_FRAME))
    model.lowerPositionLimit[:] = -3.0
    model.upperPositionLimit[:] = 3.0
    return Robot(model, tip="tool", name="toy")


@pytest.mark.parametrize("joint", [pin.JointModelTranslation(), pin.JointModelSphericalZYX()])
def test_other_joints_keep_pinocchio_algorithms(joint):
    robot = _model_with(joint)
    fid = robot.frame_id("tool")
    assert serial_chain(robot.model, fid) is None
    assert lm_solver.compiled_chain(robot, fid) is None
    q_goal = np.full(robot.nq, 0.3)
    T = robot.fk(q_goal, "tool")
    # (seed tables sample with the batch FK, which models revolute / prismatic joints only: start from q0;
    # the solver itself, as the front door's request builds a seed table for the frame)
    res = lm_solver.solve_lm(robot, Target(robot, T, "tool"), np.full(robot.nq, 0.2),
                             seed_table_enabled=False, prefer_q0=True, seed=0, iteration_budget=1000)
    assert res.success and se3.pose_error(robot.fk(res.q), T)[0] < 1e-4


@pytest.mark.parametrize("joint", [pin.JointModelFreeFlyer(), pin.JointModelRUBZ(), pin.JointModelPlanar()])
def test_configuration_spaces_other_than_vectors_are_not_packed(joint):
    model = pin.Model()
    j = model.addJoint(0, joint, pin.SE3.Identity(), "j")
    model.addJointFrame(j)
    assert serial_chain(model, model.getFrameId("j")) is None


def test_chain_with_a_joint_off_the_path():
    """A second branch: its joint gets no column and keeps its value."""
    model = pin.Model()
    a = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "a")
    b = model.addJoint(a, pin.JointModelRY(), pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.3])), "b")
    # off the path
    c = model.addJoint(a, pin.JointModelRX(), pin.SE3(np.eye(3), np.array([0.0, 0.2, 0.0])), "c")
    for j in (b, c):
        model.addJointFrame(j)
    model.addFrame(pin.Frame("tool", b, model.getFrameId("b"), pin.SE3(np.eye(3), np.array([0.3, 0.0, 0.0])),
                             pin.FrameType.OP_FRAME))
    model.lowerPositionLimit[:] = -3.0
    model.upperPositionLimit[:] = 3.0
    robot = Robot(model, tip="tool", name="branch")
    geometry, joints = serial_chain(model, robot.frame_id("tool"))
    assert joints[:, 1].tolist() == [model.joints[a].idx_q, model.joints[b].idx_q]
    q_goal = np.array([0.4, -0.7, 0.0])
    T = robot.fk(q_goal, "tool")
    q0 = np.array([0.0, 0.0, 1.1])
    res = ik.solve(robot, T, q0, frame="tool", relax=(), method="lm", prefer_q0=True, seed=0,
                   iteration_budget=1000)
    assert res.success and res.q[2] == 1.1  # the off-path joint never moves


def test_a_fresh_process_loads_the_kernels_outside_the_time_budget():
    """The first solve of a process (plain, then with obstacles) imports Numba and loads the compiled code
    before any solver's clock starts: a 20 ms budget is enough for both. The solver's clock is the CPU clock
    there (``fake_clock.cpu_clock``): the budget counts the solve's own work, not the machine's other load
    (loading the kernels, several hundred ms of CPU, would still overrun it)."""
    import subprocess
    import sys
    from pathlib import Path

    code = (
        "from fake_clock import cpu_clock  # (the child runs in tests/: its folder is on its path)\n"
        "CPU_CLOCK = cpu_clock()\n"
        "CPU_CLOCK.__enter__()  # (held: a dropped context manager would restore the real clock)\n"
        "import numpy as np\n"
        "from kinserve import ik, robots\n"
        "r = robots.load('panda', geometry=False)\n"
        "rng = np.random.default_rng(0)\n"
        "q, q0 = r.random_q(rng, 2)\n"
        "T = r.fk(q)\n"
        "a = ik.solve(r, T, q0, max_time=0.02, seed=0)\n"
        "b = ik.solve(r, T, q0, obstacles=[ik.Sphere((3.0, 3.0, 3.0), 0.1)], max_time=0.02, seed=0)\n"
        "print(a.success, b.success, a.elapsed < 0.02, b.elapsed < 0.02)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                         cwd=Path(__file__).resolve().parent)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["True"] * 4, out.stdout


@pytest.mark.parametrize("name", ["panda", "ur5", "scara", "baxter", "finger_edu"])
def test_every_frame_packs_the_chain_of_serial_chain(name):
    from kinserve.ik.lm.chains import packed_chains

    robot = robots.load(name, geometry=False)
    packed = packed_chains(robot.model)
    assert len(packed) == robot.model.nframes
    for fid, chain in enumerate(packed):
        want = serial_chain(robot.model, fid)
        assert (chain is None) == (want is None)
        if want is not None:
            assert np.array_equal(chain[0], want[0]) and np.array_equal(chain[1], want[1])
            assert chain[1].dtype == np.int64 and chain[1].flags.c_contiguous


def test_warm_gives_the_robot_its_chains_shared_by_copies_and_pickles():
    import pickle

    from kinserve.ik import lm
    from kinserve.ik.lm.chains import compiled_chain

    robot = robots.load("ur5", geometry=False)
    chains = lm.warm(robot)
    assert robot.lm_chains is chains and robot.copy().lm_chains is chains
    fid = robot.frame_id(robot.tip)
    assert compiled_chain(robot, fid) is chains.chain(fid) and chains.chain(fid).kernel is lm_kernel
    other = pickle.loads(pickle.dumps(robot))
    back = other.lm_chains.chain(fid)
    assert back.kernel is lm_kernel and np.array_equal(back.geometry, chains.chain(fid).geometry)
    T = robot.fk(robot.random_q(np.random.default_rng(1)))
    a = ik.solve(robot, T, seed=0, iteration_budget=1000)
    b = ik.solve(other, T, seed=0, iteration_budget=1000)
    assert a.success and np.array_equal(a.q, b.q)
