"""plan_motion with a carried object: a wall with a gap that the bare Panda's hand passes and a carried
20 cm cube does not (the gap is 16 cm wide); the planner takes the cube around (over the wall). Every
configuration is judged by an independent pinocchio/coal model (test_kinematics_attached.Independent), not
by kinserve's collision model."""

from __future__ import annotations

import numpy as np
import pytest
from test_kinematics_attached import Independent

from kinserve import planners, robots
from kinserve.kinematics.shapes import Box

from collision_scenes import pose

FRAME = "panda_hand_tcp"
CUBE = Box(np.eye(4), (0.2, 0.2, 0.2))  # centred on the fingertips' frame
GAP = (0.52, 0.68)  # x range of the gap (m)
WALL_TOP = 0.28  # the wall spans z in [0, WALL_TOP], x in [0.2, 1.0], y in [-0.02, 0.02]
#: Two boxes side by side with the gap between them, across the hand's way as joint 1 swings.
WALL = [Box(pose(((0.2 + GAP[0]) / 2, 0.0, WALL_TOP / 2)), (GAP[0] - 0.2, 0.04, WALL_TOP)),
        Box(pose(((GAP[1] + 1.0) / 2, 0.0, WALL_TOP / 2)), (1.0 - GAP[1], 0.04, WALL_TOP))]
#: Hand down at (0.37, -+0.47, 0.21): joint 1 at -0.9 and +0.9, on either side of the wall.
START = np.array([-0.9, 0.3, 0.0, -2.0, 0.0, 2.3, 0.785])
GOAL = np.array([0.9, 0.3, 0.0, -2.0, 0.0, 2.3, 0.785])
BUDGET = dict(max_time=None, max_iterations=3000)


def dense(path: np.ndarray, step: float = 0.01) -> np.ndarray:
    """The waypoints of ``path`` and points between them at most ``step`` rad apart in every joint."""
    out = [path[:1]]
    for a, b in zip(path[:-1], path[1:]):
        n = max(1, int(np.ceil(np.max(np.abs(b - a)) / step)))
        out.append(a + np.linspace(0.0, 1.0, n + 1)[1:, None] * (b - a))
    return np.concatenate(out)


@pytest.fixture(scope="module")
def scene():
    panda = robots.load("panda")
    carrying = panda.copy().attach("cube", CUBE, FRAME)
    ref = Independent(WALL)
    cube = [("cube", CUBE, FRAME, np.eye(4), carrying.attached["cube"].touch_links)]
    return panda, carrying, ref, cube


def test_the_bare_arm_passes_the_gap_and_the_cube_does_not(scene):
    panda, carrying, ref, cube = scene
    line = dense(np.array([START, GOAL]))
    hand = np.array([panda.fk(q, FRAME)[:3, 3] for q in line])
    crossing = line[np.argmin(np.abs(hand[:, 1]))]  # the hand in the wall's plane: inside the gap
    assert GAP[0] < panda.fk(crossing, FRAME)[0, 3] < GAP[1] and panda.fk(crossing, FRAME)[2, 3] < WALL_TOP
    assert not any(ref.pairs(q) for q in line)  # the bare arm's straight swing is free
    hits = [ref.pairs(q, cube) for q in line]
    assert all(p <= {frozenset(("attached:cube", f"obstacle[{k}]:box")) for k in (0, 1)} for p in hits)
    assert sum(map(bool, hits)) > 10  # the cube hits the wall, nothing else
    assert not ref.pairs(START, cube) and not ref.pairs(GOAL, cube)
    bare = planners.plan_motion(panda, START, GOAL, obstacles=WALL, seed=3, **BUDGET)
    assert bare.success and len(bare.path) == 2  # the straight swing, through the gap
    assert carrying.in_collision(crossing, WALL)


def test_plan_motion_takes_the_cube_around_the_wall(scene):
    panda, carrying, ref, cube = scene
    plan = planners.plan_motion(carrying, START, GOAL, obstacles=WALL, seed=3, **BUDGET)
    assert plan.success, plan.message
    assert np.allclose(plan.path[0], START) and np.allclose(plan.path[-1], GOAL)
    # every densely sampled configuration of the path, its raw path and its trajectory samples: the arm
    # (self pairs and wall) and the cube (wall and every link it may not touch) are free
    for name, qs in (("path", dense(plan.path)), ("raw path", dense(plan.raw_path)),
                     ("trajectory", plan.trajectory.positions)):
        bad = [q for q in qs if ref.pairs(q, cube)]
        assert not bad, (name, len(bad), ref.pairs(bad[0], cube))
    assert len(dense(plan.path)) > 100
    # around, not through: where the cube crosses the wall's plane it is above the wall
    qs = dense(plan.path, 0.002)
    centres = np.array([carrying.attached_poses(q)["cube"][:3, 3] for q in qs])
    k = int(np.argmin(np.abs(centres[:, 1])))
    assert centres[k, 2] > WALL_TOP or not (0.2 < centres[k, 0] < 1.0)
    # the bare robot's plan would carry the cube into the wall
    bare = planners.plan_motion(panda, START, GOAL, obstacles=WALL, seed=3, **BUDGET)
    assert any(ref.pairs(q, cube) for q in dense(bare.path))
    assert not np.array_equal(plan.path, bare.path)
    # the same request gives the same plan (iterations, not time, bound it)
    again = planners.plan_motion(carrying, START, GOAL, obstacles=WALL, seed=3, **BUDGET)
    assert np.array_equal(again.path, plan.path)


def test_a_plan_from_inside_the_wall_names_the_cube(scene):
    panda, carrying, ref, cube = scene
    line = dense(np.array([START, GOAL]))
    inside = next(q for q in line if ref.pairs(q, cube))
    plan = planners.plan_motion(carrying, inside, GOAL, obstacles=WALL, seed=3, **BUDGET)
    assert not plan.success and "attached:cube" in plan.message
    assert planners.plan_motion(panda, inside, GOAL, obstacles=WALL, seed=3, **BUDGET).success
