"""Time parameterisation of motion plans: limits on every sample, finite differences, rest at both ends.

Plans on the Panda among boxes (toppra on the blended path), then the pieces on
their own: the blended path's derivatives against finite differences and its
continuity, the rest-to-rest fallback when toppra fails, the uniform slow-down.
"""

from types import SimpleNamespace

import numpy as np
import pytest

from kinserve import planners, robots
from kinserve.planners.motion.blended_path import BlendedPath
from kinserve.planners.motion.timing import (
    evaluate,
    grid_times,
    load_toppra,
    rest_to_rest_profile,
    time_parameterize,
    within_limits,
)

from motion_scenes import blocked_problems, shelf_scene


@pytest.fixture(scope="module")
def plans():
    robot = robots.load("panda")
    obstacles = shelf_scene()
    out = []
    for k, (a, b) in enumerate(blocked_problems(robot, obstacles, 2, seed=5)):
        accelerations = None if k == 0 else 3.0
        plan = planners.plan_motion(robot, a, b, obstacles=obstacles, seed=k, max_time=None,
                                    max_iterations=1500, acceleration_limits=accelerations)
        v = np.array(robot.model.velocityLimit)
        a_max = 2.0 * v if accelerations is None else np.full(robot.nq, accelerations)
        out.append((plan, v, a_max, a, b))
    return out


def test_plans_are_timed_by_toppra_from_rest_to_rest(plans):
    for plan, _, _, a, b in plans:
        assert plan.success, plan.message
        traj = plan.trajectory
        assert plan.stats["timing"] == "toppra"
        assert traj.joint_names == robots.load("panda").joint_names
        assert traj.times[0] == 0.0 and traj.duration > 0.0
        np.testing.assert_array_equal(traj.positions[0], a)
        np.testing.assert_array_equal(traj.positions[-1], b)
        np.testing.assert_array_equal(traj.velocities[0], 0.0)
        np.testing.assert_array_equal(traj.velocities[-1], 0.0)


def test_velocity_and_acceleration_limits_hold_on_every_sample(plans):
    for plan, v, a_max, _, _ in plans:
        traj = plan.trajectory
        assert np.all(np.abs(traj.velocities) <= v * (1 + 1e-9))
        assert np.all(np.abs(traj.accelerations) <= a_max * (1 + 1e-9))
        assert np.max(np.abs(traj.velocities) / v) > 0.5  # the limits are used, not just kept


def test_finite_differences_of_positions_keep_the_limits(plans):
    for plan, v, a_max, _, _ in plans:
        t, Q = plan.trajectory.times, plan.trajectory.positions
        h = np.diff(t)[:, None]
        mean_velocity = np.diff(Q, axis=0) / h
        assert np.all(np.abs(mean_velocity) <= v * (1 + 1e-3))
        second = 2.0 * (mean_velocity[1:] - mean_velocity[:-1]) / (h[1:] + h[:-1])
        assert np.all(np.abs(second) <= a_max * (1 + 1e-3))


def test_velocities_agree_with_the_positions(plans):
    for plan, _, a_max, _, _ in plans:
        t, Q, V = plan.trajectory.times, plan.trajectory.positions, plan.trajectory.velocities
        h = np.diff(t)[:, None]
        central = (Q[2:] - Q[:-2]) / (t[2:] - t[:-2])[:, None]
        # the mean of a velocity with |dv/dt| <= a over [t - h1, t + h2] differs from v(t) by <= a max(h1, h2)
        assert np.all(np.abs(central - V[1:-1]) <= a_max * np.maximum(h[1:], h[:-1]) + 1e-9)
        assert np.all(np.abs(np.diff(V, axis=0)) <= a_max * h * (1 + 1e-6) + 1e-12)


def test_toppra_is_not_slower_than_stopping_at_every_waypoint(plans):
    for plan, v, a_max, _, _ in plans:
        stops = rest_to_rest_profile(plan.path, v, a_max)
        assert plan.trajectory.duration <= 1.05 * grid_times(stops)[-1]


def test_blended_path_derivatives_match_finite_differences():
    rng = np.random.default_rng(3)
    points = np.cumsum(rng.normal(size=(5, 3)), axis=0)
    path = BlendedPath(points, [0.0, 0.3, 0.2, 0.25, 0.0])
    s = np.linspace(0.0, path.length, 4001)[1:-1]
    s = s[np.min(np.abs(s[:, None] - path.breaks[None, :]), axis=1) > 1e-4]  # away from the breaks
    h = 1e-6
    np.testing.assert_allclose((path(s + h) - path(s - h)) / (2 * h), path(s, 1), atol=1e-6)
    np.testing.assert_allclose((path(s + h, 1) - path(s - h, 1)) / (2 * h), path(s, 2), atol=1e-5)
    np.testing.assert_allclose(path(0.0), points[0], atol=1e-12)
    np.testing.assert_allclose(path(path.length), points[-1], atol=1e-9)


def test_blended_path_is_c1_with_unit_speed_on_straight_parts():
    rng = np.random.default_rng(4)
    points = np.cumsum(rng.normal(size=(6, 4)), axis=0)
    path = BlendedPath(points, [0.0, 0.2, 0.1, 0.3, 0.2, 0.0])
    for b in path.breaks[1:-1]:
        np.testing.assert_allclose(path(b - 1e-9), path(b + 1e-9), atol=1e-8)
        np.testing.assert_allclose(path(b - 1e-9, 1), path(b + 1e-9, 1), atol=1e-6)
    straight = np.all(path.curvatures == 0.0, axis=1)
    assert straight.any() and (~straight).sum() == 4
    mids = 0.5 * (path.breaks[:-1] + path.breaks[1:])
    np.testing.assert_allclose(np.linalg.norm(path(mids[straight], 1), axis=1), 1.0)
    # each blend runs from w - delta e_in to w + delta e_out: the curve passes within delta of its corner
    for w, d in zip(points[1:-1], path.delta[1:-1]):
        s = np.linspace(0.0, path.length, 20001)
        assert np.min(np.linalg.norm(path(s) - w, axis=1)) <= d


def _failing_toppra():
    def fail(*args, **kwargs):
        raise ValueError("no parameterisation")

    real = load_toppra()
    return SimpleNamespace(algorithm=SimpleNamespace(TOPPRA=fail), constraint=real.constraint,
                           exceptions=real.exceptions)


def test_rest_to_rest_fallback_stops_at_every_waypoint_on_the_segments():
    points = np.array([[0.0, 0.0], [1.0, 0.5], [1.5, -0.5], [0.5, -1.0]])
    v, a = np.array([1.0, 2.0]), np.array([2.0, 3.0])
    timed = time_parameterize(_failing_toppra(), points, np.full(4, 0.1), v, a, ["j1", "j2"])
    assert timed.method == "rest-to-rest"
    traj = timed.trajectory
    for w in points:  # every waypoint is a sample, reached at rest
        k = int(np.argmin(np.linalg.norm(traj.positions - w, axis=1)))
        np.testing.assert_allclose(traj.positions[k], w, atol=1e-12)
        np.testing.assert_allclose(traj.velocities[k], 0.0, atol=1e-12)
    for q in traj.positions:  # every sample on a segment
        gaps = []
        for p0, p1 in zip(points[:-1], points[1:]):
            f = np.clip(np.dot(q - p0, p1 - p0) / np.dot(p1 - p0, p1 - p0), 0.0, 1.0)
            gaps.append(np.linalg.norm(p0 + f * (p1 - p0) - q))
        assert min(gaps) < 1e-12
    assert np.all(np.abs(traj.velocities) <= v * (1 + 1e-9))
    assert np.all(np.abs(traj.accelerations) <= a * (1 + 1e-9))


def test_toppra_times_a_corner_without_stopping():
    points = np.array([[0.0, 0.0], [1.0, 0.5], [1.5, -0.5]])
    v, a = np.array([1.0, 2.0]), np.array([2.0, 3.0])
    timed = time_parameterize(load_toppra(), points, np.full(3, 0.1), v, a, ["j1", "j2"])
    assert timed.method == "toppra"
    traj = timed.trajectory
    near_corner = np.argmin(np.linalg.norm(traj.positions - points[1], axis=1))
    assert np.linalg.norm(traj.velocities[near_corner]) > 0.05  # the blend keeps it moving
    assert np.all(np.abs(traj.velocities) <= v * (1 + 1e-9))
    assert np.all(np.abs(traj.accelerations) <= a * (1 + 1e-9))


def test_within_limits_slows_a_profile_uniformly():
    points = np.array([[0.0, 0.0], [1.0, 0.5]])
    path = BlendedPath(points, [0.0, 0.0])
    v, a = np.array([1.0, 2.0]), np.array([2.0, 3.0])
    fast = rest_to_rest_profile(points, v, a)
    slow = within_limits(path, fast, v / 2, a / 4)
    ratio = fast.sd[1:-1] / slow.sd[1:-1]
    np.testing.assert_allclose(ratio, ratio[0])
    assert ratio[0] >= 2.0
    times = grid_times(slow)
    _, qd, qdd = evaluate(path, slow, times, np.linspace(0.0, times[-1], 500))
    assert np.all(np.abs(qd) <= v / 2 * (1 + 1e-9)) and np.all(np.abs(qdd) <= a / 4 * (1 + 1e-9))
    assert within_limits(path, fast, v, a) is fast
