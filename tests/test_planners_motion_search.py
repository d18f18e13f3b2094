"""RRT-Connect and the simplifier: determinism, goal sets, shorter paths, budgets, the stats."""

import numpy as np
import pytest

from kinserve import planners, robots
from kinserve.planners.motion.shortcut import path_length

from motion_scenes import blocked_problems, shelf_scene


@pytest.fixture(scope="module")
def setting():
    robot = robots.load("panda")
    obstacles = shelf_scene()
    problems = blocked_problems(robot, obstacles, 2, seed=23)
    return robot, obstacles, problems


def _plan(robot, obstacles, a, b, **kw):
    args = dict(obstacles=obstacles, seed=7, max_time=None, max_iterations=1500)
    args.update(kw)
    return planners.plan_motion(robot, a, b, **args)


def test_the_same_seed_gives_the_same_plan(setting):
    robot, obstacles, problems = setting
    a, b = problems[0]
    first, second = _plan(robot, obstacles, a, b), _plan(robot, obstacles, a, b)
    assert first.success and second.success
    np.testing.assert_array_equal(first.raw_path, second.raw_path)
    np.testing.assert_array_equal(first.path, second.path)
    np.testing.assert_array_equal(first.trajectory.times, second.trajectory.times)
    np.testing.assert_array_equal(first.trajectory.positions, second.trajectory.positions)
    for key in ("checks", "distance_checks", "pair_distances", "nodes", "iterations", "length_before",
                "length_after"):
        assert first.stats[key] == second.stats[key]
    other = _plan(robot, obstacles, a, b, seed=8)
    assert other.success
    assert other.raw_path.shape != first.raw_path.shape or not np.array_equal(other.raw_path, first.raw_path)


def test_a_time_budget_alone_also_plans(setting):
    robot, obstacles, problems = setting
    a, b = problems[1]
    plan = _plan(robot, obstacles, a, b, max_time=30.0, max_iterations=None)
    assert plan.success, plan.message
    assert plan.stats["plan_time"] >= 0.0 and plan.stats["parameterize_time"] > 0.0


def test_simplification_shortens_and_keeps_the_ends(setting):
    robot, obstacles, problems = setting
    for a, b in problems:
        plan = _plan(robot, obstacles, a, b)
        assert plan.success
        stats = plan.stats
        assert stats["length_before"] == pytest.approx(path_length(plan.raw_path), rel=1e-12)
        assert stats["length_after"] == pytest.approx(path_length(plan.path), rel=1e-12)
        assert stats["length_after"] <= stats["length_before"]
        assert stats["length_after"] < 0.9 * stats["length_before"]  # a random tree's path has detours
        assert len(plan.path) <= len(plan.raw_path)
        np.testing.assert_array_equal(plan.path[[0, -1]], plan.raw_path[[0, -1]])
        assert stats["checks"] >= stats["distance_checks"] > 0 and stats["pair_distances"] > 0


def test_without_simplification_the_path_is_the_raw_path(setting):
    robot, obstacles, problems = setting
    a, b = problems[0]
    plan = _plan(robot, obstacles, a, b, simplify=False)
    assert plan.success
    np.testing.assert_array_equal(plan.path, plan.raw_path)
    assert plan.stats["length_after"] == plan.stats["length_before"]


def test_a_goal_set_reaches_one_of_its_goals(setting):
    robot, obstacles, problems = setting
    a, _ = problems[0]
    goals = np.array([b for _, b in problems[1:]] + [problems[0][1]])
    plan = _plan(robot, obstacles, a, goals)
    assert plan.success
    assert 0 <= plan.goal_index < len(goals)
    np.testing.assert_array_equal(plan.path[-1], goals[plan.goal_index])
    np.testing.assert_array_equal(plan.trajectory.positions[-1], goals[plan.goal_index])
    as_list = _plan(robot, obstacles, a, list(goals))
    np.testing.assert_array_equal(as_list.path, plan.path)


def test_a_free_straight_line_is_taken_directly():
    robot = robots.load("panda")
    a = np.array([0.3, 0.2, 0.0, -1.5, 0.0, 1.8, 0.5])
    b = np.array([0.6, 0.1, 0.2, -1.7, 0.1, 1.9, 0.3])
    plan = planners.plan_motion(robot, a, b, seed=0, max_time=None, max_iterations=10)
    assert plan.success and plan.stats["iterations"] == 0
    np.testing.assert_array_equal(plan.path, np.array([a, b]))


def test_plan_results_are_read_only(setting):
    robot, obstacles, problems = setting
    a, b = problems[0]
    plan = _plan(robot, obstacles, a, b, max_iterations=300)
    with pytest.raises(ValueError):
        plan.path[0, 0] = 1.0
    with pytest.raises(AttributeError):
        plan.success = False
    assert "MotionPlan(" in repr(plan)


def test_a_pruned_node_and_its_descendants_are_never_a_nearest_neighbour_again():
    """SearchTree.prune: the node and everything grown from it leave the nearest-neighbour search, its
    siblings and the root stay; a root's edge counts as certified, a lazily added edge does not until
    marked."""
    from kinserve.planners.motion.clearance import Clearance
    from kinserve.planners.motion.search_tree import SearchTree

    def c(x):
        return Clearance(np.array([x, 0.0]), np.zeros(0), np.zeros(0, dtype=bool))

    tree = SearchTree(2, capacity=2)  # grows while nodes are added
    root = tree.add(c(0.0), -1)
    a = tree.add(c(1.0), root, certified=False)
    b = tree.add(c(2.0), a, certified=False)
    sibling = tree.add(c(-1.0), root, certified=False)
    grandchild = tree.add(c(3.0), b, certified=False)
    assert tree.certified(root) and not tree.certified(a)
    tree.mark_certified(a)
    assert tree.certified(a)
    assert tree.nearest(np.array([2.9, 0.0])) == grandchild
    tree.prune(b)
    assert tree.nearest(np.array([2.9, 0.0])) == a  # b and its child are gone
    assert tree.nearest(np.array([-0.9, 0.0])) == sibling
    tree.prune(a)
    assert tree.nearest(np.array([5.0, 0.0])) == root
    assert tree.branch(grandchild) == [grandchild, b, a, root]  # the records stay


def test_certify_branch_prunes_at_the_first_edge_that_fails(setting):
    """A branch root -> a -> b whose second edge passes through an obstacle: certify_branch certifies the
    first edge, prunes b at the second and says False; a branch of free edges is certified whole."""
    from kinserve import ik
    from kinserve.planners.motion.clearance import ClearanceOracle
    from kinserve.planners.motion.edges import EdgeCertifier
    from kinserve.planners.motion.reach import pair_reach
    from kinserve.planners.motion.rrt_connect import certify_branch
    from kinserve.planners.motion.search_tree import SearchTree

    robot, _, _ = setting
    q0 = np.array([0.2, 0.3, 0.0, -1.8, 0.0, 2.0, 0.8])
    qa, qb = q0.copy(), q0.copy()
    qa[0] += 0.3
    qb[0] += 0.9
    hit = robot.fk(qa + 0.4 * (qb - qa), "panda_hand_tcp")[:3, 3]
    ball = ik.Sphere(hit, 0.005)
    assert robot.in_collision(qa + 0.4 * (qb - qa), [ball]) and not robot.in_collision(qb, [ball])
    scene = robot.collision_scene([ball])
    certifier = EdgeCertifier(ClearanceOracle(scene), pair_reach(robot.model, scene))
    tree = SearchTree(robot.nq)
    root = tree.add(certifier.clearance(q0), -1)
    a = tree.add(certifier.clearance(qa), root, certified=False)
    b = tree.add(certifier.clearance(qb), a, certified=False)
    assert not certify_branch(tree, b, certifier)
    assert tree.certified(a) and not tree.certified(b)
    assert tree.nearest(qb) == a
    assert certify_branch(tree, a, certifier)


def test_corner_cutting_moves_a_waypoint_to_its_neighbours_midpoint_only_when_both_halves_are_free(setting):
    """cut_corners: a free corner becomes the straight line (the waypoint at its neighbours' midpoint, the
    path shorter, the ends kept); a corner whose midpoint is in an obstacle stays where it was, and so does
    a free one whose cut would gain less than CORNER_MIN_GAIN (without a certificate asked)."""
    from kinserve import ik
    from kinserve.planners.motion.clearance import ClearanceOracle
    from kinserve.planners.motion.edges import EdgeCertifier
    from kinserve.planners.motion.reach import pair_reach
    from kinserve.planners.motion.shortcut import CORNER_MIN_GAIN, CertifiedPath, cut_corners

    robot, _, _ = setting
    a = np.array([0.2, 0.3, 0.0, -1.8, 0.0, 2.0, 0.8])
    b, v = a.copy(), a.copy()
    b[0] += 0.8
    v[0] += 0.4
    v[3] += 0.3  # the corner: off the straight line a -> b
    mid = 0.5 * (a + b)

    def corner(obstacles, v=v):
        scene = robot.collision_scene(obstacles)
        certifier = EdgeCertifier(ClearanceOracle(scene), pair_reach(robot.model, scene))
        path = CertifiedPath(np.array([a, v, b]), [certifier.clearance(q) for q in (a, v, b)])
        assert all(certifier.certify(p, q) for p, q in zip(path.clearances[:-1], path.clearances[1:]))
        asked = certifier.oracle.checks
        cut = cut_corners(path, certifier)
        return path, cut, certifier.oracle.checks - asked

    path, cut, _ = corner([])
    np.testing.assert_array_equal(cut.points[[0, 2]], path.points[[0, 2]])
    np.testing.assert_allclose(cut.points[1], mid, atol=0.0)
    assert path_length(cut.points) == pytest.approx(float(np.linalg.norm(b - a)), rel=1e-12)
    assert path_length(cut.points) < path_length(path.points)
    assert cut.clearances[1].q is not path.clearances[1].q

    ball = ik.Sphere(robot.fk(mid, "panda_hand_tcp")[:3, 3], 0.02)  # the midpoint is in collision
    assert robot.in_collision(mid, [ball]) and not robot.in_collision(v, [ball])
    path, kept, _ = corner([ball])
    np.testing.assert_array_equal(kept.points, path.points)

    shallow = a + 0.5 * (b - a)
    shallow[3] += 0.01  # gain 2 sqrt(0.4^2 + 0.01^2) - 0.8 = 2.5e-4 rad
    path, kept, asked = corner([], shallow)
    gain = path_length(path.points) - float(np.linalg.norm(b - a))
    assert 0.0 < gain < CORNER_MIN_GAIN
    np.testing.assert_array_equal(kept.points, path.points)
    assert asked == 0


def test_vertex_removal_drops_a_waypoint_on_its_neighbours_segment_without_a_certificate(setting):
    """on_chord: a waypoint between its neighbours on their segment (within 1e-12 rad) is on it; one off it
    by 1e-9 rad, or on the line beyond an end, is not. remove_vertices drops the waypoints of a straight run
    (as RRT-Connect's connect steps make them) without asking for a certificate, and certifies the segment
    of a corner before dropping it."""
    from kinserve.planners.motion.clearance import ClearanceOracle
    from kinserve.planners.motion.edges import EdgeCertifier
    from kinserve.planners.motion.reach import pair_reach
    from kinserve.planners.motion.shortcut import CertifiedPath, remove_vertices

    robot, _, _ = setting
    scene = robot.collision_scene(())
    certifier = EdgeCertifier(ClearanceOracle(scene), pair_reach(robot.model, scene))
    a = np.array([0.2, 0.3, 0.0, -1.8, 0.0, 2.0, 0.8])
    u = np.array([0.3, -0.2, 0.1, 0.2, 0.0, -0.1, 0.3])
    off = np.zeros(7)
    off[4] = 1e-9
    assert certifier.on_chord(a, a + 0.3 * u, a + u)
    assert not certifier.on_chord(a, a + 0.3 * u + off, a + u)
    assert not certifier.on_chord(a, a + 1.3 * u, a + u) and not certifier.on_chord(a, a, a)

    run = np.array([a + s * u for s in (0.0, 0.25, 0.5, 0.75, 1.0)])  # a straight run
    path = CertifiedPath(run, [certifier.clearance(q) for q in run])
    asked = []
    real = certifier.certify
    certifier.certify = lambda *args, **kw: asked.append(1) or real(*args, **kw)
    out = remove_vertices(path, certifier)
    np.testing.assert_array_equal(out.points, run[[0, -1]])
    assert not asked
    corner = run.copy()
    corner[2, 3] += 0.2
    out = remove_vertices(CertifiedPath(corner, [certifier.clearance(q) for q in corner]), certifier)
    assert len(asked) >= 1 and len(out.points) < len(corner)
