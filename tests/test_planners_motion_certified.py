"""Returned paths and trajectories of ``plan_motion`` are collision free as continuous motions.

Random problems on the Panda among four boxes (table, pillar, side wall, shelf),
each with a start and goal whose straight line collides, so the planner searches.
Every segment of ``plan.path`` and of the trajectory's sample polyline is sampled
at steps of at most 0.5 mrad per joint (max-norm) and every sample is checked by
an independent collision model (:class:`motion_scenes.IndependentCheck`: the
URDF's meshes, not the planner's hulls; ``pinocchio.computeCollisions``, not the
planner's scene or bounds).
"""

import numpy as np
import pytest

from kinserve import planners, robots

from motion_scenes import DENSE_STEP, IndependentCheck, blocked_problems, dense, shelf_scene


@pytest.fixture(scope="module")
def setting():
    robot = robots.load("panda")
    obstacles = shelf_scene()
    check = IndependentCheck(robot, obstacles)
    problems = blocked_problems(robot, obstacles, 3, seed=11)
    plans = [planners.plan_motion(robot, a, b, obstacles=obstacles, seed=k, max_time=None,
                                  max_iterations=1500) for k, (a, b) in enumerate(problems)]
    return robot, obstacles, check, problems, plans


def test_the_independent_check_sees_meshes_and_collisions(setting):
    robot, obstacles, check, problems, _ = setting
    assert "BVHModelOBBRSS" in check.kinds and not any("Convex" in kind for kind in check.kinds)
    a, b = problems[0]
    line = a + np.linspace(0.0, 1.0, 64)[:, None] * (b - a)
    assert check.first_collision(line) >= 0  # the straight line collides: the check has teeth


def test_every_problem_is_solved_from_start_to_goal(setting):
    _, _, _, problems, plans = setting
    for (a, b), plan in zip(problems, plans):
        assert plan.success, plan.message
        np.testing.assert_array_equal(plan.path[0], a)
        np.testing.assert_array_equal(plan.path[-1], b)
        np.testing.assert_array_equal(plan.raw_path[0], a)
        np.testing.assert_array_equal(plan.raw_path[-1], b)
        assert plan.goal_index == 0
        assert plan.stats["nodes"] > 2 and plan.stats["iterations"] >= 1


def test_dense_samples_of_every_path_are_free(setting):
    robot, _, check, _, plans = setting
    for plan in plans:
        samples = dense(plan.path)
        assert np.max(np.abs(np.diff(samples, axis=0))) <= DENSE_STEP + 1e-12
        assert np.all(samples >= robot.lower - 1e-12) and np.all(samples <= robot.upper + 1e-12)
        assert check.first_collision(samples) == -1


def test_dense_samples_of_every_trajectory_are_free(setting):
    robot, _, check, _, plans = setting
    for plan in plans:
        samples = dense(plan.trajectory.positions)
        assert check.first_collision(samples) == -1
        assert np.all(samples >= robot.lower - 1e-9) and np.all(samples <= robot.upper + 1e-9)


def test_dense_samples_of_a_raw_path_are_free(setting):
    _, _, check, _, plans = setting
    plan = plans[0]
    assert len(plan.raw_path) > 2
    assert check.first_collision(dense(plan.raw_path[:4])) == -1
