"""The bounds behind certified edges, against Pinocchio's kinematics and coal's distances.

* ``geometry_reach``: no vertex of a collision hull moves farther than ``R_g . |dq|``
  (world positions by Pinocchio's forward kinematics);
* ``pair_reach``: no pair distance (coal) changes by more than ``W[p] . |dq|``, and
  changing only the joints that carry both geometries of a self pair leaves its
  distance as it is;
* the clearance oracle's radius equals the one from every exact distance, and its
  bounds never exceed coal's distances;
* an edge that passes through a small obstacle between the cheap probes is refused,
  the same edge without the obstacle is certified.
"""

import numpy as np
import pinocchio as pin
import pytest

from kinserve import ik, robots
from kinserve.kinematics.collision_model import bounding_sphere
from kinserve.planners.motion.clearance import (
    CLEARANCE_FLOOR,
    TOLERANCE,
    Clearance,
    ClearanceOracle,
    need_of,
    pair_rates,
)
from kinserve.planners.motion.edges import PROBES, EdgeCertifier
from kinserve.planners.motion.reach import carrying_joints, geometry_reach, joint_kinds, pair_reach

from motion_scenes import shelf_scene


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda")


def _world_vertices(robot, q):
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, q)
    out = []
    for shape in robot.collision.shape_data():
        M = data.oMi[shape["joint"]].homogeneous @ shape["placement"]
        V = shape["vertices"] if shape["kind"] == "convex" else np.zeros((1, 3))
        out.append(V @ M[:3, :3].T + M[:3, 3])
    return out


def test_no_hull_vertex_moves_farther_than_its_reach(panda):
    model = panda.model
    kinds = joint_kinds(model)
    reach = []
    for obj in panda.collision.geometry.geometryObjects:
        centre, radius = bounding_sphere(obj.geometry, pin.SE3(obj.placement))
        reach.append(geometry_reach(model, obj.parentJoint, centre, radius, kinds))
    rng = np.random.default_rng(0)
    worst = 0.0
    for scale in (0.01, 0.3, 2.0):
        for _ in range(15):
            q = panda.random_q(rng)
            q2 = np.clip(q + scale * rng.normal(size=7), panda.lower, panda.upper)
            for R, V, V2 in zip(reach, _world_vertices(panda, q), _world_vertices(panda, q2)):
                moved = np.max(np.linalg.norm(V2 - V, axis=1))
                bound = float(R @ np.abs(q2 - q))
                assert moved <= bound + 1e-12
                worst = max(worst, moved / bound if bound > 0 else 0.0)
    assert worst > 0.3  # the bound is not vacuous


def test_pair_distances_change_no_faster_than_the_pair_reach(panda):
    obstacles = shelf_scene()
    scene = panda.collision_scene(obstacles)
    W = pair_reach(panda.model, scene)
    assert W.shape == (len(scene.pairs), 7) and np.all(W >= 0.0)
    rng = np.random.default_rng(1)
    for _ in range(30):
        q = panda.random_q(rng)
        q2 = np.clip(q + 0.2 * rng.normal(size=7), panda.lower, panda.upper)
        d, d2 = scene.distance_arrays(q).distance, scene.distance_arrays(q2).distance
        both = (d > 0) & (d2 > 0)
        assert np.all(np.abs(d2 - d)[both] <= (W @ np.abs(q2 - q))[both] + 1e-6)


def test_joints_that_carry_both_geometries_do_not_change_a_self_distance(panda):
    scene = panda.collision_scene(())
    W = pair_reach(panda.model, scene)
    geoms = scene.geometry.geometryObjects
    rng = np.random.default_rng(2)
    joint = [int(g.parentJoint) for g in geoms]
    pairs = [(int(a), int(b)) for a, b in scene.pairs]
    for p, (a, b) in enumerate(pairs):
        common = carrying_joints(panda.model, joint[a]) & carrying_joints(panda.model, joint[b])
        assert np.all(W[p][common] == 0.0)
    q = panda.random_q(rng)
    q2 = q.copy()
    q2[0] += 0.7  # joint 1 carries every moving link; the base is on joint 0
    moving = [p for p, (a, b) in enumerate(pairs) if joint[a] and joint[b]]
    d, d2 = scene.distance_arrays(q).distance, scene.distance_arrays(q2).distance
    np.testing.assert_allclose(d2[moving], d[moving], atol=1e-6)


def test_the_oracle_radius_is_the_exact_one_and_its_bounds_are_lower_bounds(panda):
    obstacles = shelf_scene()
    scene = panda.collision_scene(obstacles)
    W = pair_reach(panda.model, scene)
    oracle = ClearanceOracle(scene)
    assert oracle.precheck is not None
    assert oracle.data is scene.workspace().data  # the thread's shared Data: the scene's queries run between
    rng = np.random.default_rng(3)
    tested = 0
    while tested < 25:
        q = panda.random_q(rng)
        exact = scene.distance_arrays(q).distance
        if exact.min() < 1e-3:
            continue
        c = oracle.clearance(q)
        assert np.all(c.distance <= exact + 1e-9)
        w = W @ np.abs(rng.normal(size=7))
        rho = oracle.radius(c, pair_rates(w))
        assert rho == pytest.approx(np.min((exact - TOLERANCE) / w), rel=1e-6)
        assert c.exact.sum() < len(exact)  # coal asked for a few pairs only
        np.testing.assert_allclose(c.distance[c.exact], exact[c.exact], atol=1e-9)
        tested += 1


def test_a_clearance_makes_its_sphere_bounds_on_first_read_and_keeps_its_refinements(panda):
    """``oracle.clearance(q)`` asks nothing until ``distance`` or ``exact`` is read; then it holds the
    pre-check's ``pair_lower_bounds`` of ``q`` (one clearance counted), none exact; a refinement stays."""
    from kinserve.kinematics.precheck_kernels import pair_lower_bounds

    scene = panda.collision_scene(shelf_scene())
    oracle = ClearanceOracle(scene)
    q = panda.neutral()
    c = oracle.clearance(q)
    assert oracle.distance_checks == 0 and oracle.checks == 0
    assert not c.exact.any() and oracle.distance_checks == 1
    pre = oracle.precheck
    np.testing.assert_array_equal(c.distance, pair_lower_bounds(pre.floats, pre.ints, q))
    oracle.refine(c, np.array([0, 2]))
    assert c.exact[[0, 2]].all() and c.exact.sum() == 2 and oracle.distance_checks == 1
    # coal's GJK answers within its tolerance (the certificates keep TOLERANCE in reserve for it)
    np.testing.assert_allclose(c.distance[[0, 2]], scene.distance_arrays(q).distance[[0, 2]], atol=1e-6)
    with pytest.raises(ValueError, match="distances"):
        Clearance(q)


def _edge_through_a_small_ball(robot):
    """An edge whose middle part sweeps the hand's tool point through a 5 mm ball, and the ball."""
    a = np.array([0.2, 0.3, 0.0, -1.8, 0.0, 2.0, 0.8])
    b = a.copy()
    b[0] += 0.6
    s_hit = 0.4
    centre = robot.fk(a + s_hit * (b - a), "panda_hand_tcp")[:3, 3]
    return a, b, s_hit, ik.Sphere(centre, 0.005)


def test_an_edge_through_a_small_obstacle_between_the_probes_is_refused(panda):
    a, b, s_hit, ball = _edge_through_a_small_ball(panda)
    obstacles = [ball]
    assert panda.in_collision(a + s_hit * (b - a), obstacles)
    for s in (0.0, *PROBES, 1.0):
        assert not panda.in_collision(a + s * (b - a), obstacles)
    scene = panda.collision_scene(obstacles)
    certifier = EdgeCertifier(ClearanceOracle(scene), pair_reach(panda.model, scene))
    start, end = certifier.clearance(a), certifier.clearance(b)
    assert certifier.clear(start) and certifier.clear(end)
    assert not certifier.blocked(a, b)
    assert not certifier.certify(start, end)


def test_the_same_edge_without_the_obstacle_is_certified(panda):
    a, b, _, ball = _edge_through_a_small_ball(panda)
    far = ik.Sphere(np.asarray(ball.center) + np.array([0.0, 0.0, 2.0]), 0.005)
    scene = panda.collision_scene([far])
    certifier = EdgeCertifier(ClearanceOracle(scene), pair_reach(panda.model, scene))
    assert certifier.certify(certifier.clearance(a), certifier.clearance(b))
    assert certifier.oracle.checks >= 1  # the sphere stage certified it...
    assert certifier.oracle.distance_checks == 0  # ...without the ends' pair bounds (made only when read)


def test_a_pair_that_does_not_move_only_has_to_be_apart(panda):
    scene = panda.collision_scene(())
    oracle = ClearanceOracle(scene)
    P = len(scene.pairs)
    d = np.full(P, 0.05)
    d[3] = 0.5 * CLEARANCE_FLOOR
    c = Clearance(panda.neutral(), d, np.ones(P, dtype=bool))
    rates = np.ones(P)
    assert oracle.radius(c, pair_rates(rates)) == -1.0
    assert oracle.floor_violation(c, need_of(np.ones(P, dtype=bool))) == 3
    rates[3] = 0.0
    assert oracle.radius(c, pair_rates(rates)) == pytest.approx((0.05 - TOLERANCE) / 1.0)
    assert oracle.floor_violation(c, need_of(rates > 0)) == -1
    d[3] = 0.0
    assert oracle.radius(c, pair_rates(rates)) == -1.0
    assert oracle.radius(c, pair_rates(np.zeros(P))) == -1.0
    d[3] = 1e-6
    assert oracle.radius(c, pair_rates(np.zeros(P))) == float("inf")


def _edges_with_clear_ends(panda, obstacles, certifier, rng):
    """Endless random edges ``(a, b, clearance of a, clearance of b)`` (steps of 0.4 rad per joint, normal)
    whose two ends are free and above the clearance floor."""
    while True:
        a = panda.random_q(rng)
        b = np.clip(a + rng.normal(scale=0.4, size=panda.nq), panda.lower, panda.upper)
        ca, cb = certifier.clearance(a), certifier.clearance(b)
        if not (panda.in_collision(a, obstacles) or panda.in_collision(b, obstacles)) \
                and certifier.clear(ca) and certifier.clear(cb):
            yield a, b, ca, cb


def test_edges_certified_with_pairs_handed_to_the_exact_stage_are_free_when_densely_checked(panda):
    """Random edges in the shelf scene: an edge ``certify`` accepts is free at samples no more than 0.5 mrad
    apart per joint (the independent mesh check; the first four of each route); edges certified on the
    spheres alone, edges whose close pairs the spheres hand over to coal (``hard_pairs``), and refused edges
    all occur."""
    from motion_scenes import DENSE_STEP, IndependentCheck, dense

    obstacles = shelf_scene()
    check = IndependentCheck(panda, obstacles)
    scene = panda.collision_scene(obstacles)
    certifier = EdgeCertifier(ClearanceOracle(scene), pair_reach(panda.model, scene))
    routes = {"spheres": 0, "handed over": 0, "refused": 0}
    for a, b, ca, cb in _edges_with_clear_ends(panda, obstacles, certifier, np.random.default_rng(8)):
        if min(routes.values()) >= 3 and sum(routes.values()) >= 12:
            break
        hard = certifier.hard_pairs(a, b)
        if not certifier.certify(ca, cb):
            routes["refused"] += 1
            continue
        route = "spheres" if hard is not None and not len(hard) else "handed over"
        routes[route] += 1
        if routes[route] <= 4:  # the first few of each route
            samples = dense(np.array([a, b]), DENSE_STEP)
            assert check.first_collision(samples) == -1


def test_edges_certified_on_every_pair_with_coal_refinements_are_free_when_densely_checked(panda):
    """The exact stage on every pair (``certify_exactly``: the route of an edge whose spheres hand over more
    than HARD_PAIRS pairs): random edges in the shelf scene it accepts are free at samples no more than
    0.5 mrad apart per joint (the independent mesh check); accepted and refused edges both occur."""
    from kinserve.planners.motion.edges import MAX_ADVANCES

    from motion_scenes import DENSE_STEP, IndependentCheck, dense

    obstacles = shelf_scene()
    check = IndependentCheck(panda, obstacles)
    scene = panda.collision_scene(obstacles)
    certifier = EdgeCertifier(ClearanceOracle(scene), pair_reach(panda.model, scene))
    outcomes = {True: 0, False: 0}
    for a, b, ca, cb in _edges_with_clear_ends(panda, obstacles, certifier, np.random.default_rng(9)):
        if min(outcomes.values()) >= 3:
            break
        ok = certifier.certify_exactly(ca, cb, MAX_ADVANCES)
        outcomes[ok] += 1
        if ok and outcomes[True] <= 3:
            assert check.first_collision(dense(np.array([a, b]), DENSE_STEP)) == -1
