"""``plan_motion`` to a pose goal: the goal set of collision-free IK solutions, the plan to it, its failures.

Every answer is checked independently: poses with ``robot.fk`` and Pinocchio's SO(3) log, collisions with
the URDF's triangle meshes (``motion_scenes.IndependentCheck``, not the planner's convex model). Budgets
are iteration counts (``max_time=None``): no answer depends on the machine's speed.
"""

import numpy as np
import pinocchio as pin
import pytest

from kinserve import planners, robots
from kinserve.kinematics.errors import FrameError, InputError, NonFiniteError, RotationError, ShapeError
from kinserve.planners.motion.pose_goal import GOAL_SEPARATION
from kinserve.planners.motion.request import goal_kind

from motion_scenes import IndependentCheck, blocked_problems, box, dense, shelf_scene

#: A start and a configuration whose hand pose is the goal, free of self-collision (no obstacles).
START = np.array([1.4, 0.3, 0.0, -1.8, 0.0, 2.0, 0.8])
Q_GOAL = np.array([-1.4, 0.3, 0.0, -1.8, 0.0, 2.0, 0.8])
TOL_POS, TOL_ROT = 1e-4, 1e-3
BUDGET = dict(max_time=None, max_iterations=3000)


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda")


@pytest.fixture(scope="module")
def scene():
    return shelf_scene()


@pytest.fixture(scope="module")
def check(panda, scene):
    return IndependentCheck(panda, scene)


@pytest.fixture(scope="module")
def problem(panda, scene):
    """A free start and goal configuration of the shelf scene whose straight line collides."""
    return blocked_problems(panda, scene, 1, seed=0)[0]


def _pose_errors(robot, q, T, frame="panda_hand"):
    """(position error (m), rotation vector log(R* R^T) (rad, world axes)) of ``frame`` at ``q``."""
    F = robot.fk(q, frame)
    return float(np.linalg.norm(F[:3, 3] - T[:3, 3])), pin.log3(T[:3, :3] @ F[:3, :3].T)


def test_the_problems_are_free(panda, check, problem):
    assert not check.colliding(problem[0]) and not check.colliding(problem[1])
    assert not panda.in_collision(START) and not panda.in_collision(Q_GOAL)


def test_goal_set_has_separate_collision_free_solutions_and_the_plan_reaches_the_pose(panda, scene, check,
                                                                                       problem):
    start, q_goal = problem
    T = panda.fk(q_goal, "panda_hand")
    plan = planners.plan_motion(panda, start, T, obstacles=scene, seed=3, **BUDGET)
    assert plan.success, plan.message
    goals = plan.goals
    assert goals.shape[1] == 7 and 2 <= len(goals) <= 4
    assert plan.stats["goal_set_size"] == len(goals) and plan.stats["ik_starts"] >= len(goals)
    assert plan.stats["ik_time"] > 0.0 and plan.stats["ik_iterations"] > 0
    gaps = [np.linalg.norm(a - b) for i, a in enumerate(goals) for b in goals[i + 1:]]
    assert min(gaps) > GOAL_SEPARATION
    for q in goals:
        position, rotation = _pose_errors(panda, q, T)
        assert position < TOL_POS and np.linalg.norm(rotation) < TOL_ROT
        assert np.all(q >= panda.lower) and np.all(q <= panda.upper)
        assert not check.colliding(q)
    np.testing.assert_array_equal(plan.path[-1], goals[plan.goal_index])
    np.testing.assert_array_equal(plan.path[0], start)
    position, rotation = _pose_errors(panda, plan.path[-1], T)
    assert position < TOL_POS and np.linalg.norm(rotation) < TOL_ROT
    assert check.first_collision(dense(plan.path)) == -1


def test_a_pinocchio_se3_and_a_frame_name_are_pose_goals(panda):
    T = panda.fk(Q_GOAL, "panda_link8")
    plan = planners.plan_motion(panda, START, pin.SE3(T), frame="panda_link8", seed=1, goal_count=2, **BUDGET)
    assert plan.success, plan.message
    assert len(plan.goals) == 2
    position, rotation = _pose_errors(panda, plan.path[-1], T, "panda_link8")
    assert position < TOL_POS and np.linalg.norm(rotation) < TOL_ROT


def test_relaxed_yaw_matches_the_kept_components_only(panda, scene, problem):
    start, q_goal = problem
    T = panda.fk(q_goal, "panda_hand")
    plan = planners.plan_motion(panda, start, T, obstacles=scene, relax=("yaw",), seed=2, **BUDGET)
    assert plan.success, plan.message
    yaws = []
    for q in plan.goals:
        position, rotation = _pose_errors(panda, q, T)
        assert position < TOL_POS and np.linalg.norm(rotation[:2]) < TOL_ROT
        yaws.append(abs(rotation[2]))
    assert max(yaws) > 0.05  # the free component is used: some solution turns about the world z axis
    position, rotation = _pose_errors(panda, plan.path[-1], T)
    assert position < TOL_POS and np.linalg.norm(rotation[:2]) < TOL_ROT


def test_a_pose_enclosed_by_an_obstacle_fails_with_the_reason(panda):
    T = panda.fk(Q_GOAL, "panda_hand")
    cage = box((0.2, 0.2, 0.2), T[:3, 3])
    assert not panda.in_collision(START, [cage])
    plan = planners.plan_motion(panda, START, T, obstacles=[cage], seed=0, **BUDGET)
    assert not plan.success
    assert plan.message.startswith("no collision-free IK solution reaches the goal pose (")
    assert "starts tried" in plan.message and "obstacle[0]:box" in plan.message
    assert plan.goals.shape == (0, 7) and plan.path.shape == (0, 7) and plan.goal_index == -1
    assert plan.trajectory is None and plan.stats["ik_starts"] > 0 and plan.stats["iterations"] == 0


def test_a_pose_out_of_reach_fails_with_the_best_residual(panda):
    T = panda.fk(Q_GOAL, "panda_hand")
    T[:3, 3] = (1.6, 0.0, 0.5)  # the Panda reaches about 0.86 m from its shoulder
    plan = planners.plan_motion(panda, START, T, seed=0, goal_count=2, **BUDGET)
    assert not plan.success
    assert plan.message.startswith("no collision-free IK solution reaches the goal pose (4 starts tried; "
                                   "best residual ")
    residual = float(plan.message.split("best residual ")[1].split(" m")[0])
    assert residual > 0.5
    assert plan.goals.shape == (0, 7) and plan.stats["ik_starts"] == 4


def test_same_seed_same_goal_set_and_path(panda, scene, problem):
    start, q_goal = problem
    T = panda.fk(q_goal, "panda_hand")
    fresh = robots.load("panda")
    a = planners.plan_motion(fresh, start, T, obstacles=scene, seed=5, **BUDGET)
    b = planners.plan_motion(panda, start, T, obstacles=scene, seed=5, **BUDGET)
    assert a.success and b.success
    np.testing.assert_array_equal(a.goals, b.goals)
    np.testing.assert_array_equal(a.path, b.path)
    assert a.goal_index == b.goal_index
    c = planners.plan_motion(panda, start, T, obstacles=scene, seed=6, **BUDGET)
    assert not np.array_equal(c.goals, a.goals)


def test_bad_pose_goals_raise_errors_naming_the_argument(panda):
    T = panda.fk(Q_GOAL, "panda_hand")
    skew = T.copy()
    skew[:3, :3] *= 1.1
    with pytest.raises(RotationError, match="goal"):
        planners.plan_motion(panda, START, skew, **BUDGET)
    nan = T.copy()
    nan[0, 3] = np.nan
    with pytest.raises(NonFiniteError, match="goal"):
        planners.plan_motion(panda, START, nan, **BUDGET)
    with pytest.raises(FrameError, match="no_such_frame"):
        planners.plan_motion(panda, START, T, frame="no_such_frame", **BUDGET)
    with pytest.raises(InputError, match="relax"):
        planners.plan_motion(panda, START, T, relax=("spin",), **BUDGET)
    with pytest.raises(InputError, match="goal_count"):
        planners.plan_motion(panda, START, T, goal_count=0, **BUDGET)
    with pytest.raises(InputError, match="pose goal"):
        planners.plan_motion(panda, START, Q_GOAL, frame="panda_hand", **BUDGET)
    with pytest.raises(ShapeError, match="goal must be one configuration"):
        planners.plan_motion(panda, START, np.zeros((2, 4, 4)), **BUDGET)


def test_a_4x4_goal_on_a_four_joint_robot_is_a_goal_set_unless_a_frame_or_relax_says_pose():
    scara = robots.load("scara")
    assert scara.nq == 4
    T = scara.fk(np.zeros(4))
    assert goal_kind(scara, T) == "goal set"
    assert goal_kind(scara, T, frame=scara.tip) == "pose"
    assert goal_kind(scara, T, relax=("yaw",)) == "pose"
    assert goal_kind(scara, pin.SE3(T)) == "pose"
    panda = robots.load("panda")
    assert goal_kind(panda, T) == "pose"
    assert goal_kind(panda, np.zeros((4, 7))) == "goal set"
    assert goal_kind(panda, np.zeros(7)) == "configuration"
