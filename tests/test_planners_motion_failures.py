"""``plan_motion`` failures are results with their reason; invalid arguments raise errors naming them."""

import numpy as np
import pytest

from kinserve import planners, robots
from kinserve.kinematics.errors import InputError, JointLimitError, NonFiniteError, ShapeError

from motion_scenes import box

START = np.array([1.4, 0.3, 0.0, -1.8, 0.0, 2.0, 0.8])
GOAL = np.array([-1.4, 0.3, 0.0, -1.8, 0.0, 2.0, 0.8])


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda")


def _around_hand(robot, q, size=0.05):
    """A box centred on the hand at ``q``: the hand is in collision with it."""
    return box((size, size, size), robot.fk(q, "panda_hand")[:3, 3])


def test_a_start_in_collision_names_the_pairs(panda):
    obstacles = [_around_hand(panda, START)]
    pairs = panda.collisions(START, obstacles)
    assert pairs
    plan = planners.plan_motion(panda, START, GOAL, obstacles=obstacles, seed=0, max_time=None,
                                max_iterations=50)
    assert not plan.success
    assert plan.message.startswith("start is in collision: ")
    for a, b in pairs:
        assert f"{a} with {b}" in plan.message
    assert "obstacle[0]:box" in plan.message
    assert plan.path.shape == (0, 7) and plan.raw_path.shape == (0, 7)
    assert plan.trajectory is None and plan.goal_index == -1
    assert plan.stats["iterations"] == 0


def test_a_goal_in_collision_names_the_pairs(panda):
    obstacles = [_around_hand(panda, GOAL)]
    plan = planners.plan_motion(panda, START, GOAL, obstacles=obstacles, seed=0, max_time=None,
                                max_iterations=50)
    assert not plan.success
    assert plan.message.startswith("goal is in collision: ")
    assert "panda_hand with obstacle[0]:box" in plan.message


def test_self_collision_is_named_and_can_be_switched_off(panda):
    folded = np.array([0.0, 1.7, 0.0, -3.0, 0.0, 3.7, 0.0])
    pairs = panda.collisions(folded)
    assert pairs and not any("obstacle" in b for _, b in pairs)
    plan = planners.plan_motion(panda, START, folded, seed=0, max_time=None, max_iterations=50)
    assert not plan.success and plan.message.startswith("goal is in collision: ")
    assert f"{pairs[0][0]} with {pairs[0][1]}" in plan.message
    free = planners.plan_motion(panda, START, folded, self_collision=False, seed=0, max_time=None,
                                max_iterations=300)
    assert free.success, free.message


def test_a_goal_set_uses_its_free_goals(panda):
    obstacles = [_around_hand(panda, GOAL)]
    other = GOAL.copy()
    other[0] = 2.0
    plan = planners.plan_motion(panda, START, [GOAL, other], obstacles=obstacles, seed=0, max_time=None,
                                max_iterations=300)
    assert plan.success, plan.message
    assert plan.goal_index == 1
    np.testing.assert_array_equal(plan.path[-1], other)
    blocked = planners.plan_motion(panda, START, np.array([GOAL, GOAL]), obstacles=obstacles, seed=0,
                                   max_time=None, max_iterations=50)
    assert not blocked.success
    assert blocked.message.startswith("goal[0] is in collision: ")
    assert "goal[1] is in collision" in blocked.message


def test_a_walled_off_goal_is_not_found_within_the_budget(panda):
    # a block beside the shoulder: link 1 (moved by joint 1 alone) hits it whenever |q1| <= 0.6, so the
    # free configurations with q1 > 0.6 and those with q1 < -0.6 are not connected (|q1| <= 2.9 < pi)
    block = [box((0.03, 0.03, 0.03), (0.0, -0.11, 0.333))]
    rng = np.random.default_rng(0)
    for q1 in np.linspace(-0.6, 0.6, 25):
        q = panda.random_q(rng)
        q[0] = q1
        assert ("panda_link1", "obstacle[0]:box") in panda.collisions(q, block)
    assert not panda.in_collision(START, block) and not panda.in_collision(GOAL, block)
    plan = planners.plan_motion(panda, START, GOAL, obstacles=block, seed=0, max_time=None,
                                max_iterations=150)
    assert not plan.success
    assert plan.message.startswith("no path found within the budget (150 iterations")
    assert plan.stats["iterations"] == 150 and plan.stats["nodes"] > 2


def test_a_start_below_the_clearance_floor_is_refused(panda):
    T = panda.fk(START, "panda_hand")
    plate = box((3.0, 3.0, 0.01), T[:3, 3] + np.array([0.0, 0.0, 1.0]))
    gap = panda.min_distance(START, [plate], self_collision=False)
    moved = box((3.0, 3.0, 0.01), plate.pose[:3, 3] - np.array([0.0, 0.0, gap - 5e-5]))
    close = panda.min_distance(START, [moved], self_collision=False)
    assert 0.0 < close < 1e-4
    plan = planners.plan_motion(panda, START, GOAL, obstacles=[moved], seed=0, max_time=None,
                                max_iterations=10)
    assert not plan.success and plan.message.startswith("start is closer than the clearance floor")
    assert "with obstacle[0]:box at " in plan.message


def test_start_and_goal_equal_give_a_one_point_trajectory(panda):
    plan = planners.plan_motion(panda, START, START, seed=0, max_time=None, max_iterations=10)
    assert plan.success and plan.trajectory.n_points == 1 and plan.stats["timing"] == "none"


@pytest.mark.parametrize("kwargs, error, words", [
    (dict(start=np.zeros(6)), ShapeError, "start"),
    (dict(start=[np.nan] * 7), NonFiniteError, "start"),
    (dict(start=np.full(7, 3.5)), JointLimitError, "start"),
    (dict(goal=np.zeros(5)), ShapeError, "goal"),
    (dict(goal=np.zeros((2, 6))), ShapeError, "goal"),
    (dict(goal=np.zeros((0, 7))), ShapeError, "goal"),
    (dict(goal=np.zeros((2, 2, 7))), ShapeError, "goal"),
    (dict(goal=[GOAL, np.full(7, 3.5)]), JointLimitError, "goal[1]"),
    (dict(goal="home"), ShapeError, "goal"),
    (dict(obstacles=[1, 2]), InputError, "obstacles"),
    (dict(obstacles="box"), InputError, "obstacles"),
    (dict(max_time=0.0), InputError, "max_time"),
    (dict(max_time=float("nan")), InputError, "max_time"),
    (dict(max_iterations=0), InputError, "max_iterations"),
    (dict(max_iterations=2.5), InputError, "max_iterations"),
    (dict(max_time=None, max_iterations=None), InputError, "max_iterations"),
    (dict(seed=-1), InputError, "seed"),
    (dict(seed=1.5), InputError, "seed"),
    (dict(acceleration_limits=-1.0), InputError, "acceleration_limits"),
    (dict(acceleration_limits=np.ones(3)), ShapeError, "acceleration_limits"),
    (dict(acceleration_limits=[1.0] * 6 + [np.inf]), NonFiniteError, "acceleration_limits"),
    (dict(self_collision="yes"), InputError, "self_collision"),
    (dict(simplify=1), InputError, "simplify"),
])
def test_invalid_arguments_raise_errors_naming_them(panda, kwargs, error, words):
    args = dict(start=START, goal=GOAL, max_time=None, max_iterations=5, seed=0)
    args.update(kwargs)
    start, goal = args.pop("start"), args.pop("goal")
    with pytest.raises(error) as caught:
        planners.plan_motion(panda, start, goal, **args)
    assert words in str(caught.value)


def test_the_robot_must_be_a_robot():
    with pytest.raises(InputError, match="robot"):
        planners.plan_motion("panda", START, GOAL)
