"""kinserve.ik.solve: every bad input of the issue raises from kinematics.errors; method "auto" dispatch;
Result fields."""

import numpy as np
import pinocchio as pin
import pytest

from kinserve import ik, robots
from kinserve.kinematics.errors import (
    FrameError,
    InputError,
    KinserveError,
    NonFiniteError,
    RotationError,
    ShapeError,
)

SPHERE = ik.Sphere((0.4, -0.7, 0.5), 0.2)
#: Iterations of every start together, no time limit: for the solves that must succeed or be repeated.
BUDGET = dict(iteration_budget=2000)


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda", geometry=False)


@pytest.fixture(scope="module")
def scara():
    return robots.load("scara", geometry=False)


@pytest.fixture(scope="module")
def T(panda):
    return panda.fk(np.array([0.1, -0.3, 0.2, -1.9, 0.1, 1.8, 0.5])).copy()


@pytest.mark.parametrize(
    "kwargs,error,match",
    [
        (dict(target="nan"), NonFiniteError, "target"),
        (dict(target="inf"), NonFiniteError, "target"),
        (dict(target="skew"), RotationError, "rotation"),
        (dict(target="3x4"), ShapeError, "shape"),
        (dict(q0=[0.0] * 6), ShapeError, "q0"),
        (dict(q0=[np.nan] * 7), NonFiniteError, "q0"),
        (dict(frame="panda_link99"), FrameError, "panda_link99"),
        (dict(relax=("x", "wobble")), InputError, "wobble"),
        (dict(method="newton"), InputError, "method"),
        (dict(backend="cplex"), InputError, "backend"),
        (dict(tol_pos=0.0), InputError, "tol_pos"),
        (dict(tol_rot=np.nan), NonFiniteError, "tol_rot"),
        (dict(max_time=-1.0), InputError, "max_time"),
        (dict(seed=-3), InputError, "seed"),
        (dict(seed=1.5), InputError, "seed"),
        (dict(centring=-1.0), InputError, "centring"),
        (dict(spheres=[((0.5, 0.5, 0.5), -0.1)]), InputError, "radius"),
        (dict(spheres=[((0.0, 0.0, 0.1), 0.2)]), InputError, "base"),
        (dict(method="lm", spheres=[SPHERE]), InputError, "sphere"),
        (dict(method="lm", centring=1.0), InputError, "centring"),
        (dict(method="lm", bogus_option=1), InputError, "bogus_option"),
    ],
)
def test_bad_input_raises_clear_errors(panda, T, kwargs, error, match):
    kwargs = dict(kwargs)
    target = T.copy()
    kind = kwargs.pop("target", None)
    if kind == "nan":
        target[1, 3] = np.nan
    elif kind == "inf":
        target[0, 0] = np.inf
    elif kind == "skew":
        target[:3, :3] = target[:3, :3] @ np.diag([1.0, 1.0, 1.2])
    elif kind == "3x4":
        target = target[:3]
    if kind is None and "q0" not in kwargs:
        kwargs["q0"] = panda.neutral()
    with pytest.raises(error, match=match) as info:
        ik.solve(panda, target, **kwargs)
    assert isinstance(info.value, KinserveError)


def test_sphere_containing_the_start_configuration_is_not_an_error(panda, T):
    # issue 10: a start is only a guess - the solve begins from collision-free starts and says so
    q0 = panda.neutral()
    hand = panda.fk(q0)[:3, 3]
    sphere = ik.Sphere(hand, 0.05)
    res = ik.solve(panda, T, q0, spheres=[sphere], **BUDGET)
    assert res.success and "q0" in res.message, res.message
    from kinserve.ik.constraints.obstacles import ObstacleAvoidance

    avoid = ObstacleAvoidance([sphere], tool_frames=("panda_hand",)).bind(panda)
    panda.fk(res.q)
    assert avoid.clearances(panda.data).min() >= 0.0


def test_robot_argument_checked(T):
    with pytest.raises(InputError, match=r"robot must be a kinserve Robot .*robots.load\(.panda.\) loads it"):
        ik.solve("panda", T)


def test_auto_dispatch(panda, scara, T):
    assert ik.solve(panda, T).method == "lm"
    assert ik.solve(panda, T, centring=1.0).method == "qp"
    Ts = scara.fk(np.array([0.3, 0.6, 0.5, 0.2])).copy()
    assert ik.solve(scara, Ts).method == "analytic"
    assert ik.solve(scara, Ts, relax=("yaw",)).method == "analytic"
    # obstacles: the unconstrained answer is kept when its whole path is clear ("lm"), else the constrained QP
    assert ik.solve(scara, Ts, spheres=[SPHERE]).method in ("lm", "qp")
    assert ik.solve(scara, Ts, spheres=[SPHERE], method="qp").method == "qp"
    res = ik.solve(scara, Ts, relax=("yaw",))
    assert res.q[3] == pytest.approx(0.0)  # the closed form centres the free wrist joint too
    # SE3 targets are accepted
    assert ik.solve(panda, pin.SE3(T), **BUDGET).success


def test_result_fields(panda, T):
    res = ik.solve(panda, T, seed=4, **BUDGET)
    assert isinstance(res, ik.Result)
    assert res.success and res.q.shape == (7,) and panda.within_limits(res.q)
    assert 0 <= res.position_error < 1e-4 and 0 <= res.orientation_error < 1e-3
    assert res.iterations >= 0 and res.restarts >= 0 and res.elapsed > 0
    assert res.message == "converged" and res.frame == "panda_hand"
    assert isinstance(res.history, ik.History) and len(res.history) == res.history.q.shape[0]
    assert "ok" in res.summary()
    again = ik.solve(panda, T, seed=4, **BUDGET)
    assert np.array_equal(res.q, again.q)  # deterministic for a seed
    other_frame = ik.solve(panda, panda.fk(res.q, "panda_link8"), frame="panda_link8", **BUDGET)
    assert other_frame.success and other_frame.frame == "panda_link8"


def test_tolerances_are_honoured(panda, T):
    kw = dict(prefer_q0=True, seed_table=False, **BUDGET)
    loose = ik.solve(panda, T, panda.neutral(), tol_pos=1e-2, tol_rot=1e-1, **kw)
    tight = ik.solve(panda, T, panda.neutral(), tol_pos=1e-9, tol_rot=1e-9, **kw)
    assert loose.success and tight.success
    assert loose.position_error < 1e-2 and tight.position_error < 1e-9
    assert loose.iterations < tight.iterations


@pytest.mark.parametrize("name", ["panda", "ur5", "youbot", "scara", "planar4r"])
def test_auto_on_random_reachable_targets(name):
    from kinserve.kinematics import se3

    robot = robots.load(name, geometry=False)
    rng = np.random.default_rng(31)
    for q in robot.random_q(rng, 20):
        T = robot.fk(q).copy()
        res = ik.solve(robot, T, robot.random_q(rng), **BUDGET)
        assert res.success, (name, res.message)
        assert robot.within_limits(res.q)
        pe, re = se3.pose_error(robot.fk(res.q), T)
        assert pe < 1e-4 and re < 1e-3


def test_sphere_errors_name_their_argument(panda, T):
    with pytest.raises(FrameError) as info:
        ik.solve(panda, T, spheres=[ik.Sphere((0, 0, 0), 0.1, frames=["no_such_frame"])])
    assert info.value.argument == "spheres"
    with pytest.raises(InputError, match="base") as info:
        ik.solve(panda, T, spheres=[ik.Sphere((0, 0, 0), 0.2)])
    assert info.value.argument == "spheres"
    with pytest.raises(NonFiniteError) as info:
        ik.solve(panda, T, [0.0] * 6 + [float("nan")])
    assert info.value.argument == "q0"


@pytest.mark.parametrize("options",
                         [dict(prefer_q0=True), dict(), dict(seed_table=False, max_iter=30),
                          dict(max_starts=2)])
def test_short_path_gives_the_general_path_answer(panda, options):
    """The pose request of ik.solve (defaults elsewhere) answers exactly as the general target request."""
    from kinserve.ik.request import target_request
    from kinserve.ik.solve import run

    rng = np.random.default_rng(8)
    options = {**options, **BUDGET}  # (no clock: a time limit could cut one answer and not the other)
    for _ in range(15):
        T = panda.fk(panda.random_q(rng)).copy()
        q0 = panda.random_q(rng)
        for method in ("auto", "lm"):
            a = ik.solve(panda, T, q0, method=method, seed=2, **options)
            b = run(target_request(panda, T, q0, method=method, seed=2, options=dict(options)))
            assert np.array_equal(a.q, b.q) and a.iterations == b.iterations and a.restarts == b.restarts
            assert a.success == b.success and a.message == b.message and a.method == b.method == "lm"
            assert np.array_equal(a.history.q, b.history.q)
            assert np.array_equal(a.history.position_error, b.history.position_error)


def test_short_path_errors_name_their_argument(panda, T):
    with pytest.raises(ShapeError) as info:
        ik.solve(panda, T, [0.0] * 3, prefer_q0=True)
    assert info.value.argument == "q0"
    with pytest.raises(InputError, match="max_step"):
        ik.solve(panda, T, method="lm", max_step=0.1)  # a QP option: the general path names it
