"""Bad input to the planners (outside ``planners.mobile``): refused with kinserve's own errors, before any
work - never a hang, an unbounded allocation, a silent NaN or a raw third-party exception.

Each test also runs a valid neighbouring input, so a check cannot be too strict. No test reads the real
clock: the pose goal's time budget is tested on a fake clock that jumps past it at the first reading.
"""

from __future__ import annotations

import os
import types

import numpy as np
import pytest

import kinserve
from kinserve import planners, robots
from kinserve.kinematics.errors import InputError, NonFiniteError, ShapeError
from kinserve.planners import (
    JointTrajectory,
    cartesian_to_joint,
    cubic_coefficients,
    cubic_time_scaling,
    damped_pseudo_inverse,
    finite_difference_velocities,
    held_karp,
    intermediate_poses,
    interpolate_checkpoints,
    minimum_time,
    path_cost,
    plan_cartesian,
    plan_many,
    se3_polynomial_trajectory,
    shortest_order,
    task_coordinates,
    time_scaling,
    via_point_trajectory,
)
from kinserve.planners.checkpoint_order import HELD_KARP_LIMIT
from kinserve.planners.checks import MAX_SAMPLES
from kinserve.planners.motion import batch, pose_goal
from kinserve.planners.motion.request import MAX_GOAL_COUNT

Q0 = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8])
NO_CLOCK = dict(max_time=None, iteration_budget=300)


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda", geometry=False)


@pytest.fixture(scope="module")
def panda_geometry():
    return robots.load("panda")


@pytest.fixture(scope="module")
def line(panda):
    T0 = panda.fk(Q0, "panda_link8").copy()
    T1 = T0.copy()
    T1[:3, 3] += [0.02, 0.0, 0.0]
    return T0, T1


def _trajectory() -> JointTrajectory:
    return JointTrajectory(["a", "b"], np.array([0.0, 1.0]), np.array([[0.0, 0.0], [1.0, 2.0]]))


# ------------------------------------------------------------------ 1. pose goals: bounded and timed
def test_goal_count_is_bounded_before_any_work(panda):
    goal = kinserve.pose([0.45, -0.35, 0.3], quat=[1, 0, 0, 0])
    for bad in (10**9, MAX_GOAL_COUNT + 1, 0):
        with pytest.raises(InputError, match=rf"goal_count must be an integer from 1 to {MAX_GOAL_COUNT}"):
            planners.plan_motion(panda, Q0, goal, goal_count=bad, max_time=1.0)


def test_pose_goal_search_stops_when_max_time_is_spent(panda_geometry, monkeypatch):
    clock = iter(np.arange(0.0, 1e6, 10.0))  # every reading 10 s after the one before
    monkeypatch.setattr(pose_goal, "time", types.SimpleNamespace(perf_counter=lambda: float(next(clock))))
    goal = kinserve.pose([0.45, -0.35, 0.3], quat=[1, 0, 0, 0])
    plan = planners.plan_motion(panda_geometry, Q0, goal, goal_count=MAX_GOAL_COUNT, max_time=1.0, seed=0)
    assert not plan.success
    assert "time budget max_time = 1 s was spent (0 starts tried" in plan.message
    assert plan.stats["ik_starts"] == 0


# ------------------------------------------------------------------ 2. no unbounded allocation
def test_plan_cartesian_refuses_a_step_that_makes_too_many_poses(panda, line):
    with pytest.raises(InputError, match=r"max_step must be at least 2e-08 m \(1,000,000 steps at most over "
                                         r"this 0.02 m path\), got 1e-12"):
        plan_cartesian(panda, Q0, line[1], frame="panda_link8", max_step=1e-12, self_collision=False)
    move = plan_cartesian(panda, Q0, line[1], frame="panda_link8", max_step=0.01, self_collision=False)
    assert move.success and len(move.poses) == 3


def test_cartesian_to_joint_refuses_too_many_steps(panda, line):
    with pytest.raises(InputError, match=r"steps must be an integer from 1 to 999,998 \(1,000,000 poses"):
        cartesian_to_joint(panda, list(line), Q0, frame="panda_link8", steps=10**9, **NO_CLOCK)
    plan = cartesian_to_joint(panda, list(line), Q0, frame="panda_link8", steps=1, **NO_CLOCK)
    assert plan.success and len(plan.poses) == 3


def test_pose_sampling_counts_are_bounded(line):
    T0, T1 = line
    with pytest.raises(InputError, match=r"n must be an integer from 0 to 999,998, got 1000000000000"):
        intermediate_poses(T0, T1, 10**12)
    with pytest.raises(InputError, match=r"n must be an integer from 0 to 999,998"):
        interpolate_checkpoints([T0, T1], 10**12)
    with pytest.raises(InputError, match=r"make 1,000,003 poses; at most 1,000,000 are accepted "
                                         r"\(n <= 499998\)"):
        interpolate_checkpoints([T0, T1, T0], MAX_SAMPLES // 2)
    assert intermediate_poses(T0, T1, 3).shape == (3, 4, 4)
    assert interpolate_checkpoints([T0, T1, T0], 2).shape == (7, 4, 4)
    tr = se3_polynomial_trajectory(T0, T1, 1.0)
    with pytest.raises(InputError, match=r"n must be an integer from 2 to 1,000,000"):
        tr.sample(10**12)
    assert tr.sample(5)[1].shape == (5, 4, 4)
    scaling = cubic_time_scaling(1.0)
    with pytest.raises(InputError, match=r"n must be an integer from 2 to 1,000,000"):
        scaling.sample(10**12)
    assert scaling.sample(4)[0].shape == (4,)


def test_via_point_sampling_step_is_bounded():
    traj = via_point_trajectory([[0.0, 0.0], [1.0, 2.0]], [0.0, 2.0])
    with pytest.raises(InputError, match=r"dt must be at least 2e-06 s \(1,000,000 steps at most over this "
                                         r"2 s trajectory\), got 1e-12"):
        traj.sample(1e-12)
    with pytest.raises(InputError, match=r"dt must be at least 2e-06 s"):
        traj.to_joint_trajectory(1e-12, ["a", "b"])
    assert len(traj.sample(0.5)[0]) == 5
    assert traj.to_joint_trajectory(0.5, ["a", "b"]).n_points == 5


def test_exact_ordering_is_bounded():
    pts = np.random.default_rng(0).random((30, 2))
    with pytest.raises(InputError, match=rf"exact_limit must be an integer from 0 to {HELD_KARP_LIMIT}"):
        shortest_order(pts, exact_limit=10**6)
    with pytest.raises(InputError, match=rf"held_karp takes at most {HELD_KARP_LIMIT} points .* got 40"):
        held_karp(np.ones((40, 40)))
    assert shortest_order(pts[:6], exact_limit=HELD_KARP_LIMIT).optimal
    assert held_karp(np.ones((4, 4)))[1] == 3.0


# ------------------------------------------------------------------ 3. no silent wrong answers
@pytest.mark.parametrize("t", [np.nan, None, "a", [0.5, np.inf]])
def test_trajectory_times_must_be_finite_numbers(t, line):
    traj = _trajectory()
    with pytest.raises(InputError, match=r"t must be a number or an array of numbers|t must hold finite"):
        traj.position_at(t)
    tr = se3_polynomial_trajectory(*line, 1.0)
    with pytest.raises(InputError, match=r"t must"):
        tr.pose(t)
    with pytest.raises(InputError, match=r"t must"):
        tr.body_twist(t)
    with pytest.raises(InputError, match=r"t must"):
        cubic_time_scaling(1.0).s(t)
    via = via_point_trajectory([[0.0], [1.0]], [0.0, 1.0])
    with pytest.raises(InputError, match=r"t must"):
        via.evaluate(t)


def test_valid_times_are_still_evaluated(line):
    np.testing.assert_allclose(_trajectory().position_at(0.5), [[0.5, 1.0]])
    tr = se3_polynomial_trajectory(*line, 1.0)
    np.testing.assert_allclose(tr.pose(1.0), line[1], atol=1e-12)
    assert tr.body_twist([0.0, 0.5]).shape == (2, 6)
    assert cubic_time_scaling(1.0).s(0.5) == pytest.approx(0.5)
    q, _, _ = via_point_trajectory([[0.0], [1.0]], [0.0, 1.0]).evaluate(1.0)
    np.testing.assert_allclose(q, [1.0])


@pytest.mark.parametrize("v0", [np.nan, None, "fast"])
def test_boundary_values_must_be_finite_numbers(v0):
    with pytest.raises(InputError, match=r"v0 must"):
        cubic_time_scaling(1.0, v0=v0)
    with pytest.raises(InputError, match=r"x0 must"):
        cubic_coefficients(1.0, x0=v0, x1=1.0)
    with pytest.raises(InputError, match=r"v0 must"):
        via_point_trajectory([[0.0], [1.0]], [0.0, 1.0], v0=v0)
    assert cubic_time_scaling(1.0, v0=0.5).s(1.0) == pytest.approx(1.0)
    np.testing.assert_allclose(cubic_coefficients(1.0, x0=0.0, x1=1.0), [0, 0, 3, -2])


def test_time_scaling_rates_are_single_numbers():
    with pytest.raises(InputError, match=r"v0 must be a number, got \[\]"):
        cubic_time_scaling(1.0, v0=[])
    with pytest.raises(InputError, match=r"a1 must be a number"):
        planners.quintic_time_scaling(1.0, a1=[1.0, 2.0])
    assert planners.quintic_time_scaling(1.0, a1=0.5).s(1.0) == pytest.approx(1.0)


def test_resolved_rate_step_count_is_bounded(panda):
    with pytest.raises(InputError, match=r"n \(number of steps\) must be an integer from 0 to 1,000,000"):
        planners.resolved_rate(panda, [0.01, 0.0, 0.0], Q0, 10**12, 0.01, axes=["x", "y", "z"])
    result = planners.resolved_rate(panda, [0.01, 0.0, 0.0], Q0, 2, 0.01, axes=["x", "y", "z"])
    assert len(result.times) == 3


def test_poses_along_and_cost_functions_fail_cleanly(line):
    with pytest.raises(InputError, match=r"scaling must be a time scaling"):
        planners.poses_along(*line, None, [0.0, 1.0])
    assert planners.poses_along(*line, cubic_time_scaling(1.0), [0.0, 1.0]).shape == (2, 4, 4)
    pts = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]
    with pytest.raises(InputError, match=r"the cost function failed on points 0 and 1: ZeroDivisionError"):
        shortest_order(pts, cost=lambda a, b: 1 / 0)
    assert shortest_order(pts, cost=lambda a, b: 1.0).cost == 2.0


def test_finite_differences_refuse_repeated_times():
    with pytest.raises(InputError, match=r"times must be strictly increasing, got times\[0\] = 0.0"):
        finite_difference_velocities(np.zeros((3, 2)), [0.0, 0.0, 1.0])
    V = finite_difference_velocities(np.array([[0.0], [1.0], [2.0]]), [0.0, 1.0, 2.0])
    np.testing.assert_allclose(V, [[1.0], [1.0], [1.0]])


@pytest.mark.parametrize("name", ["jump_threshold", "limit_margin", "singular_tol"])
def test_cartesian_thresholds_must_be_finite(panda, line, name):
    with pytest.raises(NonFiniteError, match=rf"{name} must be finite"):
        cartesian_to_joint(panda, list(line), Q0, frame="panda_link8", steps=1, **{name: np.nan}, **NO_CLOCK)


def test_held_karp_and_path_cost_refuse_bad_costs_and_orders():
    with pytest.raises(InputError, match=r"costs must be >= 0 and not NaN"):
        held_karp(np.full((4, 4), np.nan))
    C = np.ones((3, 3))
    with pytest.raises(InputError, match=r"order\[1\] must be an index in \[0, 2\], got -1"):
        path_cost(C, [0, -1])
    with pytest.raises(InputError, match=r"order must visit each point at most once"):
        path_cost(C, [0, 0, 0])
    with pytest.raises(InputError, match=r"order\[1\] must be an index in \[0, 2\], got 3"):
        path_cost(C, [0, 3])
    assert path_cost(C, [0, 2, 1], return_to_start=True) == 3.0


def test_task_coordinates_refuse_unknown_axes(panda):
    with pytest.raises(ShapeError, match=r"unknown task component 'nope' in axes"):
        task_coordinates(panda, Q0, ["nope"])
    with pytest.raises(InputError, match=r"resolved-rate task axes must be among x, y, z, yaw"):
        task_coordinates(panda, Q0, ["roll"])
    x = task_coordinates(panda, Q0, ["x", "yaw"])
    assert x[0] == pytest.approx(panda.fk(Q0)[0, 3])


# ------------------------------------------------------------------ 4. kinserve errors, not raw ones
def test_cartesian_to_joint_negative_max_time(panda, line):
    with pytest.raises(InputError, match=r"max_time must be positive, got -1.0"):
        cartesian_to_joint(panda, list(line), Q0, frame="panda_link8", steps=1, max_time=-1.0)


def test_plan_many_refuses_bad_planner_keywords_and_processes(panda):
    problems = [(Q0, Q0)]
    with pytest.raises(InputError, match=r"planner must be a function planning one problem"):
        plan_many(panda, problems, processes=1, planner="x")
    with pytest.raises(InputError, match=r"unknown keyword\(s\) bogus_kw for plan_motion; "
                                         r"accepted: .*max_time"):
        plan_many(panda, problems, processes=1, bogus_kw=1)
    with pytest.raises(InputError, match=r"processes must be an integer from 1 to 1024 or None, got 1000000"):
        plan_many(panda, problems, processes=10**6)

    def stand_in(robot, start, goal, *, obstacles=(), seed=None, **kwargs):
        return os.getpid()

    assert plan_many(panda, problems, processes=1024, planner=stand_in, self_collision=False) == [os.getpid()]
    assert batch.worker_count(1024, 50) <= (os.cpu_count() or 1)
    assert batch.worker_count(1, 50) == 1


def test_joint_names_must_be_a_sequence():
    with pytest.raises(InputError, match=r"joint_names must be a sequence of joint names"):
        JointTrajectory(None, [0.0], [[0.0]])
    via = via_point_trajectory([[0.0], [1.0]], [0.0, 1.0])
    with pytest.raises(InputError, match=r"joint_names must be a sequence of joint names"):
        via.to_joint_trajectory(0.1, None)
    with pytest.raises(ShapeError, match=r"joint_names must name the trajectory's 1 components, got 2"):
        via.to_joint_trajectory(0.1, ["a", "b"])
    assert via.to_joint_trajectory(0.5, ["a"]).joint_names == ["a"]


@pytest.mark.parametrize("T", [1e300, "long", None, np.nan])
def test_durations_must_be_bounded_numbers(T, line):
    with pytest.raises(InputError, match=r"T must|duration must"):
        cubic_time_scaling(T)
    with pytest.raises(InputError, match=r"T must|duration must|needs T"):
        time_scaling("quintic", T)
    with pytest.raises(InputError, match=r"duration must"):
        se3_polynomial_trajectory(*line, T)
    assert time_scaling("quintic", 1e6).duration == 1e6


def test_minimum_time_refuses_mismatched_lengths_and_non_numbers():
    with pytest.raises(ShapeError, match=r"distance, v_max and a_max must each be one number or a vector of "
                                         r"the same length, got shapes \(1,\), \(2,\), \(2,\)"):
        minimum_time("trapezoidal", [1.0], [1.0, 1.0], [1.0, 1.0])
    with pytest.raises(ShapeError, match=r"distance must be a number or an array of numbers, got 'far'"):
        minimum_time("cubic", "far", 1.0, 1.0)
    with pytest.raises(InputError, match=r"distance must"):
        time_scaling("trapezoidal", v_max=1.0, a_max=1.0, distance="far")
    assert minimum_time("trapezoidal", [1.0, 2.0], [1.0, 1.0], 1.0) == pytest.approx(3.0)


@pytest.mark.parametrize("start", [np.nan, None, 9, 1.5, True])
def test_ordering_indices_are_checked(start):
    pts = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    with pytest.raises(InputError, match=r"start must be an index"):
        shortest_order(pts, start=start)
    with pytest.raises(InputError, match=r"start must be an index"):
        held_karp(np.ones((3, 3)), start=start)
    assert shortest_order(pts, start=2).order[0] == 2


def test_held_karp_takes_a_list():
    assert held_karp([[0, 1], [1, 0]]) == ([0, 1], 1.0)
    with pytest.raises(ShapeError, match=r"cost matrix must be square"):
        held_karp([[0, 1, 2], [1, 0, 2]])


def test_damped_pseudo_inverse_refuses_non_finite_matrices():
    with pytest.raises(NonFiniteError, match=r"J must hold finite numbers"):
        damped_pseudo_inverse(np.full((2, 2), np.nan))
    with pytest.raises(ShapeError, match=r"J must be a numeric array"):
        damped_pseudo_inverse("abc")
    with pytest.raises(InputError, match=r"damping must be zero or positive, got -1"):
        damped_pseudo_inverse(np.eye(2), damping=-1)
    Jp, s = damped_pseudo_inverse(np.diag([2.0, 4.0]))
    np.testing.assert_allclose(Jp, np.diag([0.5, 0.25]))


def test_resolved_rate_thresholds_and_circle_are_checked():
    """track_reference's thresholds and follow_circle's radius and angular velocity: NaN, infinities, zero
    or negative values (where they make no sense) and text are named before any step; valid ones run."""
    from kinserve.planners.resolved_rate import follow_circle, track_reference

    robot = robots.load("planar4r")
    q0 = robot.neutral() + 0.3
    ref = lambda t: (np.zeros(2), np.zeros(2))  # noqa: E731
    cases = [("sigma_threshold", 0.0, InputError, "sigma_threshold must be positive"),
             ("sigma_threshold", float("nan"), NonFiniteError, "sigma_threshold must be"),
             ("lambda_max", -1.0, InputError, "lambda_max must be zero or positive"),
             ("max_step_error", float("inf"), NonFiniteError, "max_step_error must be"),
             ("max_joint_rate", "fast", InputError, "max_joint_rate must be a number")]
    for key, value, error, words in cases:
        with pytest.raises(error, match=words):
            track_reference(robot, ref, q0, 3, 0.01, axes=["x", "y"], **{key: value})
    for radius, error, words in [(0.0, InputError, "radius must be positive"),
                                 (float("nan"), NonFiniteError, "radius must be finite"),
                                 ("a", InputError, "radius must be a number")]:
        with pytest.raises(error, match=words):
            follow_circle(robot, [0.5, 0.0], radius, q0, 3, 0.01, axes=["x", "y"])
    with pytest.raises(InputError, match="angular_velocity must be a number"):
        follow_circle(robot, [0.5, 0.0], 0.1, q0, 3, 0.01, axes=["x", "y"], angular_velocity="a")
    assert len(follow_circle(robot, [0.5, 0.0], 0.1, q0, 3, 0.01, axes=["x", "y"]).q) == 4


@pytest.mark.parametrize("dt", [1e-300, 1e-9])
def test_cartesian_to_joint_names_a_dt_too_short_for_its_velocities(panda, line, dt):
    """The finite-difference velocities overflow or pass the 1e6 bound: an InputError naming dt and the least
    dt for these positions (it said 'velocities must hold finite numbers' after the solves); that dt works."""
    with pytest.raises(InputError, match=r"dt = .* s is too short .* dt must be at least") as info:
        cartesian_to_joint(panda, list(line), Q0, frame="panda_link8", steps=3, dt=dt, **NO_CLOCK)
    least = float(str(info.value).rsplit("at least ", 1)[1].split(" s")[0])
    plan = cartesian_to_joint(panda, list(line), Q0, frame="panda_link8", steps=3, dt=least, **NO_CLOCK)
    assert np.all(np.isfinite(plan.trajectory.velocities))
    assert np.max(np.abs(plan.trajectory.velocities)) <= 1e6


def test_cartesian_to_joint_names_a_dt_whose_last_time_passes_the_bound(panda, line, monkeypatch):
    """3 steps over one segment: 5 points, the last at 4 dt. dt = 2.5e5 s ends at 1e6 s, the bound, and is
    planned; 2.6e5 s ends at 1.04e6 s: an InputError naming dt and its largest value, raised before any
    pose is solved (it was 'times must hold finite numbers' with no argument, after the solves)."""
    from kinserve.planners import cartesian

    solved = []
    with monkeypatch.context() as patch:
        patch.setattr(cartesian, "follow_poses", lambda *a, **k: solved.append(a))
        with pytest.raises(InputError, match=r"dt = 260000 s over 5 points ends at 1\.04e\+06 s, .* dt must "
                                             r"be at most 2\.5e\+05 s") as info:
            cartesian_to_joint(panda, list(line), Q0, frame="panda_link8", steps=3, dt=2.6e5, **NO_CLOCK)
    assert info.value.argument == "dt" and solved == []
    plan = cartesian_to_joint(panda, list(line), Q0, frame="panda_link8", steps=3, dt=2.5e5, **NO_CLOCK)
    assert plan.success and plan.trajectory.times[-1] == 1e6


def test_from_positions_last_time_bound():
    """N points at a step of dt end at (N - 1) dt, which must be at most 1e6 s: 3 points at 5e5 s end on the
    bound; one step more is refused, naming dt and the largest dt (rounded down to four digits)."""
    from kinserve.planners.joint_trajectory import JointTrajectory

    Q = [[0.0], [1.0], [2.0]]
    assert JointTrajectory.from_positions(["a"], Q, 5e5).times.tolist() == [0.0, 5e5, 1e6]
    with pytest.raises(InputError, match=r"dt = 500001 s over 3 points .* at most 5e\+05 s") as info:
        JointTrajectory.from_positions(["a"], Q, 500001.0)
    assert info.value.argument == "dt"
    with pytest.raises(InputError, match=r"dt must be at most 3\.333e\+05 s"):
        JointTrajectory.from_positions(["a"], Q + [[3.0]], 5e5)


def test_from_positions_velocity_bound_is_the_documented_one():
    """Positions 0, 0.3, 0.5: the second-order one-sided difference at the start is (4 x 0.3 - 0.5) / (2 dt)
    = 0.35 / dt, the largest, so dt = 3.5e-7 s is the least (given as 3.501e-07, rounded up); 1 % less is
    refused, and the velocities at the least dt are within 1e6."""
    from kinserve.planners.joint_trajectory import JointTrajectory

    Q = [[0.0, 0.0], [0.3, 0.1], [0.5, 0.2]]
    with pytest.raises(InputError, match=r"dt must be at least 3\.501e-07 s"):
        JointTrajectory.from_positions(["a", "b"], Q, 0.99 * 3.5e-7)
    trajectory = JointTrajectory.from_positions(["a", "b"], Q, 3.501e-7)
    assert np.max(np.abs(trajectory.velocities)) <= 1e6
    assert np.max(np.abs(trajectory.velocities)) == pytest.approx(0.35 / 3.501e-7)


@pytest.mark.parametrize("value", ["no", 0, None])
def test_planner_flags_must_be_true_or_false(panda, line, value):
    """``stop_on_failure``, ``closed_loop`` and ``stop_on_singularity`` were read by truthiness ("no" meant
    yes); a reference that is not a function was Python's "'numpy.ndarray' object is not callable"."""
    from kinserve.planners import track_reference

    with pytest.raises(InputError, match="stop_on_failure must be True or False"):
        cartesian_to_joint(panda, list(line), Q0, frame="panda_link8", steps=1, stop_on_failure=value,
                           **NO_CLOCK)

    def ref(t):
        return np.zeros(3), np.zeros(3)

    for flag in ("closed_loop", "stop_on_singularity"):
        with pytest.raises(InputError, match=f"{flag} must be True or False"):
            track_reference(panda, ref, Q0, 2, 0.01, axes=["x", "y", "z"], **{flag: value})
    with pytest.raises(InputError, match="reference must be a function t -> .*, got ndarray"):
        track_reference(panda, np.zeros((3, 3)), Q0, 2, 0.01, axes=["x", "y", "z"])
    assert len(track_reference(panda, ref, Q0, 2, 0.01, axes=["x", "y", "z"], closed_loop=np.True_).q) == 3


@pytest.mark.parametrize("value", ["no", 0, None])
def test_trajectory_and_interpolation_flags_must_be_true_or_false(value):
    """``zero_ends="no"`` zeroed the end velocities, ``include_ends="no"`` returned the two ends too; each
    flag is now refused by name, from every call that takes it."""
    Q, t = np.linspace(0.0, 1.0, 5)[:, None] * np.ones(2), np.linspace(0.0, 1.0, 5)
    T1 = np.eye(4)
    T1[:3, 3] = [1.0, 0.0, 0.0]
    calls = {"zero_ends": lambda v: planners.finite_difference_velocities(Q, t, zero_ends=v),
             "zero_end_velocities": lambda v: planners.JointTrajectory.from_positions(
                 ["a", "b"], Q, 0.25, zero_end_velocities=v),
             "include_ends": lambda v: planners.intermediate_poses(np.eye(4), T1, 3, include_ends=v)}
    for flag, call in calls.items():
        with pytest.raises(InputError, match=f"{flag} must be True or False"):
            call(value)
    assert np.all(planners.finite_difference_velocities(Q, t, zero_ends=np.False_)[0] != 0.0)
    assert len(planners.intermediate_poses(np.eye(4), T1, 3, include_ends=np.True_)) == 5


# ------------------------------------------------------------------ 3. robots, choices, budgets, files
@pytest.fixture(scope="module")
def p4():
    return robots.load("planar4r")


def _ref(t):
    return np.zeros(2), np.zeros(2)


Q4 = np.full(4, 0.3)
ROBOT_CALLS = {
    "cartesian_to_joint": lambda r, line: cartesian_to_joint(r, list(line), Q0, frame="panda_link8", steps=1,
                                                             **NO_CLOCK),
    "resolved_rate": lambda r, line: planners.resolved_rate(r, [0.01, 0.0], Q4, 3, 0.01, axes=["x", "y"]),
    "track_reference": lambda r, line: planners.track_reference(r, _ref, Q4, 3, 0.01, axes=["x", "y"]),
    "follow_circle": lambda r, line: planners.follow_circle(r, [0.5, 0.0], 0.1, Q4, 3, 0.01, axes=["x", "y"]),
    "task_coordinates": lambda r, line: task_coordinates(r, Q0, ["x"]),
    "plan_many": lambda r, line: plan_many(r, [(Q4, Q4 + 0.2)], processes=1),
    "joint_vector": lambda r, line: planners.motion.joint_vector(r, {"j": 0.0}),
}


@pytest.mark.parametrize("robot", ["panda", None])
@pytest.mark.parametrize("call", list(ROBOT_CALLS), ids=list(ROBOT_CALLS))
def test_robot_must_be_a_robot(panda, line, robot, call):
    """A robot's name or None was Python's "'str' object has no attribute 'check_q'" (or 'fk')."""
    with pytest.raises(InputError, match=r"^robot must be a kinserve Robot \(robots.load\(\.\.\.\)\), got "):
        ROBOT_CALLS[call](robot, line)
    assert task_coordinates(panda, Q0, ["x"]).shape == (1,)


def test_plan_max_time_is_bounded(p4):
    """max_time=1e300 was accepted by plan_motion and plan_many (inf was refused); it is bounded by 1e6 s as
    ik.solve bounds its own."""
    from kinserve.planners.motion import request

    with pytest.raises(NonFiniteError, match=r"^max_time must be finite with magnitude <= 1e\+06, got "
                                             r"1e\+300"):
        planners.plan_motion(p4, Q4, Q4 + 0.2, max_time=1e300)
    with pytest.raises(NonFiniteError, match=r"shared keywords of plan_motion\): max_time must be finite"):
        plan_many(p4, [(Q4, Q4 + 0.2)], processes=1, max_time=1e300)
    assert request._budget(1e6, None).max_time == 1e6


EMPTY = np.zeros(0)
CHOICE_CALLS = [
    ("interpolate", lambda r, L: planners.interpolate(*L, [0.5], method=EMPTY), r"^method must be one of "
     r"'decoupled', 'screw', got array\("),
    ("intermediate_poses", lambda r, L: intermediate_poses(*L, 0, method=EMPTY), r"^method must be one of"),
    ("time_scaling", lambda r, L: time_scaling(EMPTY, 1.0), r"^kind must be one of 'cubic', 'quintic', "
     r"'trapezoidal', got array"),
    ("minimum_time", lambda r, L: minimum_time(EMPTY, 1.0, 1.0, 1.0), r"^kind must be one of"),
    ("se3 order", lambda r, L: se3_polynomial_trajectory(*L, 1.0, order=EMPTY), r"^order must be one of "
     r"'cubic', 'quintic'"),
    ("via method", lambda r, L: via_point_trajectory([[0.0], [1.0]], [0, 1], method=EMPTY),
     r"^method must be one of 'cubic_spline', 'quintic'"),
    ("from_positions", lambda r, L: JointTrajectory.from_positions(["a"], [[0.0], [1.0]], 1.0,
                                                                   velocities=EMPTY),
     r"^velocities must be one of 'finite_difference', None"),
    ("cartesian_to_joint", lambda r, L: cartesian_to_joint(r, list(L), Q0, steps=1, interpolation=EMPTY),
     r"^interpolation must be one of"),
    ("line_steps", lambda r, L: planners.cartesian_move.line_steps(*L, 0.01, 0.05, []),
     r"^interpolation must be one of"),
    ("plan_many backend", lambda r, L: plan_many(r, [], processes=1, backend=EMPTY),
     r"^backend must be one of 'local', 'ray', got array"),
]


@pytest.mark.parametrize("call, regex", [c[1:] for c in CHOICE_CALLS], ids=[c[0] for c in CHOICE_CALLS])
def test_names_given_as_arrays_or_lists_are_refused(panda, line, call, regex):
    """A method / kind / order / backend given as an array was NumPy's "truth value of an empty array is
    ambiguous" (a list: "unhashable type"); each is now refused by name with the choices."""
    with pytest.raises(InputError, match=regex):
        call(panda, line)
    assert planners.interpolate(*line, [0.5], method="screw").shape == (1, 4, 4)
    assert time_scaling("quintic", 1.0).duration == 1.0


@pytest.mark.parametrize("kw, regex", [
    ({"relax": 0}, r"^relax must be a sequence of component names"),
    ({"relax": 2.5}, r"^relax must be a sequence of component names"),
    ({"relax": np.nan}, r"^relax must be a sequence of component names"),
    ({"relax": ["bogus"]}, r"^relax: unknown component 'bogus'"),
    ({"method": []}, r"^method must be one of \('auto'"),
    ({"method": "nope"}, r"^method must be one of \('auto'"),
    ({"interpolation": EMPTY}, r"^interpolation must be one of 'decoupled', 'screw'"),
])
def test_plan_cartesian_checks_relax_and_method(panda, line, kw, regex):
    """relax=0 was Python's "'int' object is not iterable", method=[] "unhashable type: 'list'"."""
    with pytest.raises(InputError, match=regex):
        plan_cartesian(panda, Q0, line[1], frame="panda_link8", self_collision=False, **kw)
    move = plan_cartesian(panda, Q0, line[1], frame="panda_link8", self_collision=False, relax=None,
                          method="auto")
    assert move.success


@pytest.mark.parametrize("call, exc, regex", [
    (lambda jt: jt.to_json(indent=17), InputError, r"^indent must be an integer from 0 to 16, got 17$"),
    (lambda jt: jt.to_json(indent="no"), InputError, r"^indent must be an integer, got 'no'"),
    (lambda jt: jt.to_json(indent=2.5), InputError, r"^indent must be an integer, got 2.5"),
    (lambda jt: jt.to_json(path=0), InputError, r"^path must be a file path \(str or os.PathLike\), got 0"),
    (lambda jt: jt.to_csv(path=0), InputError, r"^path must be a file path"),
    (lambda jt: jt.save(0), InputError, r"^path must be a file path"),
    (lambda jt: JointTrajectory.load(None), InputError, r"^path must be a file path"),
    (lambda jt: JointTrajectory.from_json(0), InputError, r"^source must be JSON text or a path"),
    (lambda jt: JointTrajectory.from_json(b"\x80{}"), InputError, r"^trajectory JSON is malformed"),
    (lambda jt: JointTrajectory.from_csv(0), InputError, r"^source must be CSV text or a path"),
    (lambda jt: JointTrajectory.from_csv("time_from_start,position:a\n0,1\n2\n"), ShapeError,
     r"^trajectory CSV rows have 1 values for 2 columns"),
    (lambda jt: JointTrajectory.from_csv("time_from_start,position:a\n\n\n"), InputError,
     r"needs a header row and at least one data row"),
    (lambda jt: JointTrajectory.from_dict({"joint_names": ["a"], "points": [
        {"positions": "x", "time_from_start": 0}]}), ShapeError, r"^positions must be a numeric array"),
    (lambda jt: JointTrajectory.from_dict({"joint_names": 0, "points": [
        {"positions": [0.0], "time_from_start": 0}]}), InputError, r"^joint_names must be a sequence"),
], ids=["indent 17", "indent text", "indent float", "json path", "csv path", "save", "load", "from_json",
        "json bytes", "from_csv", "csv ragged", "csv blank", "from_dict positions", "from_dict names"])
def test_trajectory_files_check_their_arguments(tmp_path, call, exc, regex):
    """indent=10**9 wrote for minutes and gigabytes (tested with 17, the least refused, to stay cheap if the
    check is lost), indent='no' wrote 'no' as the indent, 2.5 / a path 0 / a source 0 were Python's
    TypeErrors, a text position NumPy's ValueError, a blank CSV a raw IndexError."""
    with pytest.raises(exc, match=regex):
        call(_trajectory())
    jt = _trajectory()
    assert JointTrajectory.from_json(jt.to_json(tmp_path / "t.json", indent=16)).n_points == 2
    assert JointTrajectory.from_csv(jt.to_csv(str(tmp_path / "t.csv")) + "\n\n").n_points == 2


def test_a_scene_document_must_be_a_planning_scene(tmp_path):
    """A file holding another message (here a trajectory, named 'no') was read as an empty scene: no
    obstacle, silently; a bare value ('yes', 'no' with no such file, 3) is refused alike."""
    path = tmp_path / "no"
    path.write_text(_trajectory().to_json())
    for source in (path, "{}"):
        with pytest.raises(InputError, match=r"is not a MoveIt PlanningScene: it has none of the fields "):
            planners.read_planning_scene(source)
    for text, kind in (("yes", "bool"), ("no", "bool"), ("3", "int")):
        with pytest.raises(InputError, match=rf"^planning scene must be a YAML mapping .*, got {kind}$"):
            planners.read_planning_scene(text)
    assert planners.read_planning_scene("name: empty\nworld: {}") == []


@pytest.mark.parametrize("kw, regex", [
    ({"shapes": 0}, r"^shapes must be a sequence of shapes \(boxes, spheres, cylinders\), got 0"),
    ({"shapes": kinserve.ik.Sphere([0, 0, 0], 0.1)}, r"^shapes must be a sequence of shapes"),
    ({"name": object()}, r"^name must be the scene's name \(a string\), got <object"),
    ({"name": np.nan}, r"^name must be the scene's name \(a string\), got nan"),
])
def test_write_planning_scene_checks_shapes_and_name(kw, regex):
    """shapes=0 was "'int' object is not iterable", name=object() yaml's RepresenterError, name=nan was
    written as '.nan'."""
    args = {"shapes": [kinserve.ik.Sphere([0, 0, 0], 0.1)], **kw}
    with pytest.raises(InputError, match=regex):
        planners.write_planning_scene(**args)
    assert len(planners.read_planning_scene(planners.write_planning_scene((), name="x"))) == 0


@pytest.mark.parametrize("kw, regex", [
    ({"start": np.nan}, r"^MotionRequest.start must be a mapping joint name \(str\) -> value, got nan"),
    ({"goal": "no"}, r"^MotionRequest.goal must be a mapping joint name"),
    ({"goal": {1: 0.0}}, r"^MotionRequest.goal must be a mapping joint name"),
    ({"start": {"j1": True}}, r"^MotionRequest.start must hold numbers \(not true/false/yes/no or text\)"),
    ({"start": {"j1": np.nan}}, r"^MotionRequest.start must hold finite numbers with \|x\| <= 1e\+06"),
    ({"group": object()}, r"^MotionRequest.group must be a planning group name \(str, '' for none\)"),
])
def test_motion_request_checks_its_fields(kw, regex):
    """MotionRequest(start=nan, goal='no', group=object()) was accepted; construction checks what the
    reader checks."""
    args = {"start": {"j1": 0.1}, "goal": {"j1": 0.2}, **kw}
    with pytest.raises(InputError, match=regex):
        planners.MotionRequest(**args)
    request = planners.MotionRequest({"j1": 1}, {"j1": np.float32(0.5)}, "arm")
    assert request.start == {"j1": 1.0} and type(request.goal["j1"]) is float


def test_reference_must_return_a_pair_and_its_own_errors_propagate(p4):
    """A reference returning one number was Python's "cannot unpack non-iterable float object"; an
    exception raised by the reference itself is the caller's and propagates unchanged."""
    with pytest.raises(InputError, match=r"^reference\(t\) must return a pair \(x_ref, xdot_ref\) of 2 "
                                         r"numbers each \(one per axis of \('x', 'y'\)\), got 0.0 at t = 0"):
        planners.track_reference(p4, lambda t: 0.0, Q4, 3, 0.01, axes=["x", "y"])
    with pytest.raises(ZeroDivisionError):
        planners.track_reference(p4, lambda t: 1 / 0, Q4, 3, 0.01, axes=["x", "y"])
    assert len(planners.track_reference(p4, lambda t: [np.zeros(2), np.zeros(2)], Q4, 3, 0.01,
                                        axes=["x", "y"]).q) == 4


def test_via_point_t0_and_circle_steps_are_always_checked(p4):
    """t0='no' was ignored when the times were given; follow_circle took n=True as one step."""
    with pytest.raises(InputError, match=r"^t0 must be a number, got 'no'"):
        via_point_trajectory([[0.0], [1.0], [2.0]], [0, 1, 2], t0="no")
    with pytest.raises(InputError, match=r"^n \(number of steps\) must be an integer, got True"):
        planners.follow_circle(p4, [0.5, 0.0], 0.1, Q4, True, 0.01, axes=["x", "y"])
    assert via_point_trajectory([[0.0], [1.0], [2.0]], [0, 1, 2], t0=5.0).times[0] == 0.0
