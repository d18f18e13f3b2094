"""The compiled distances of convex shapes (kinserve.kinematics.convex_distance, hull_table) against coal, and
the compiled advancement on them (motion_kernels.advance_on_distances) against the Python one on coal.

* the cores: a hull's vertices, a box's corners, a sphere's centre and a capsule's segment ends, grown by
  their radii, placed in their joints' frames; a cylinder has none;
* GJK's bound, from no start and from the last configuration's: never above coal's distance (1e-9 m), within
  a few micrometres of it for separated shapes, at most 0 for intersecting ones - for the Panda's hulls and
  boxes against each other, against a box, a capsule, a cylinder and a ball, and for a carried sphere and
  capsule;
* the advancement: on random edges of a cluttered scene its decisions are those of
  ``edges.advance`` on coal's steps (the same pairs, rates and budget) but for a few at the margin, and it
  answers NOT_MEASURED for a pair with an obstacle mesh or a carried cylinder (coal decides then).
"""

from __future__ import annotations

import math

import coal
import numba
import numpy as np
import pinocchio as pin
import pytest

from kinserve import ik, robots
from kinserve.kinematics.convex_distance import core_distance_bound, obstacle_radius
from kinserve.kinematics.hull_table import UNSUPPORTED, VERTICES, core_points, hull_table
from kinserve.kinematics.motion_kernels import CERTIFIED, NOT_MEASURED, REFUSED, advance_on_distances
from kinserve.kinematics.precheck_kernels import SELF_PAIR, tree_placements, unpack
from kinserve.planners.motion.clearance import ClearanceOracle, pair_rates
from kinserve.planners.motion.edges import MAX_ADVANCES, EdgeCertifier, advance
from kinserve.planners.motion.reach import pair_reach

from collision_scenes import pose, tilted_clutter


@numba.njit(cache=False)
def _bounds(floats, ints, points, geoms, radius, q, guesses, above=math.inf, below=-math.inf, grown=False):
    """Per pair-table row: GJK's lower bound of the shapes' distance at ``q`` (cores less radii; ``above``,
    ``below``: the early ends, between the cores; ``grown``: the bound between the cores instead)."""
    tree, joints, spheres, sgeoms, pairs, obstacles = unpack(floats, ints)
    X = np.empty((joints.shape[0] + 1, 12))
    tree_placements(tree, joints, q, X)
    S, T = np.empty((4, 3)), np.empty((7, 3))
    out = np.full(pairs.shape[0], np.nan)
    for p in range(pairs.shape[0]):
        a, b = pairs[p, 0], pairs[p, 1]
        own = pairs[p, 2] == SELF_PAIR
        if geoms[a, 0] != VERTICES or (own and geoms[b, 0] != VERTICES):
            continue
        rb = radius[b] if own else obstacle_radius(obstacles, b)
        if rb < 0.0:
            continue
        out[pairs[p, 3]] = core_distance_bound(points, geoms, X, a, b, obstacles, not own, S, T,
                                               guesses[p], above, below) - (0.0 if grown else radius[a] + rb)
    return out


def _coal_distances(scene, q: np.ndarray) -> np.ndarray:
    data, gd = scene.model.createData(), pin.GeometryData(scene.geometry)
    for req in gd.distanceRequests:
        req.gjk_tolerance = 1e-9
    pin.computeDistances(scene.model, data, scene.geometry, gd, q)
    return np.array([r.min_distance for r in gd.distanceResults])


def _check_bounds(robot, obstacles, n: int, seed: int, rest: float = 0.2) -> dict:
    """GJK's bounds against coal's distances on ``n`` configurations (each also from the last one's GJK
    starts, a ``rest`` rad step away); counts of the pairs seen apart and intersecting."""
    scene = robot.collision_scene(obstacles)
    pre = scene.precheck()
    hulls = pre.hulls
    rng = np.random.default_rng(seed)
    seen = {"apart": 0, "intersecting": 0}
    for _ in range(n):
        q = robot.random_q(rng)
        guesses = np.zeros((len(scene.pairs), 3))
        for step in (q, np.clip(q + rng.uniform(-rest, rest, robot.nq), robot.lower, robot.upper)):
            lower = _bounds(pre.floats, pre.ints, hulls.points, hulls.geoms, hulls.radius, step, guesses)
            exact = _coal_distances(scene, step)
            measured = ~np.isnan(lower)
            assert measured.sum() >= len(scene.pairs) // 2
            lb, d = lower[measured], exact[measured]
            assert np.all(lb <= d + 1e-9), (lb - d).max()
            apart = d > 1e-5
            assert np.all(d[apart] - lb[apart] <= 1e-5), (d[apart] - lb[apart]).max()
            assert np.all(lb[d < -1e-6] <= 1e-9)
            seen["apart"] += int(apart.sum())
            seen["intersecting"] += int((d < -1e-6).sum())
    return seen


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda")


def test_cores_are_the_vertices_corners_centres_and_segment_ends():
    mesh = coal.BVHModelOBBRSS()
    mesh.beginModel(0, 40)
    mesh.addVertices(np.random.default_rng(0).normal(size=(40, 3)))
    mesh.endModel()
    mesh.buildConvexHull(True, "Qt")
    hull = mesh.convex
    points, r = core_points(hull)
    assert r == 0.0 and np.allclose(points, np.asarray(hull.points()))
    corners, r = core_points(coal.Box(0.2, 0.4, 0.6))
    assert r == 0.0 and sorted(map(tuple, corners.tolist())) == sorted(
        (x, y, z) for x in (-0.1, 0.1) for y in (-0.2, 0.2) for z in (-0.3, 0.3))
    centre, r = core_points(coal.Sphere(0.3))
    assert r == 0.3 and centre.tolist() == [[0.0, 0.0, 0.0]]
    ends, r = core_points(coal.Capsule(0.1, 0.8))
    assert r == 0.1 and ends.tolist() == [[0.0, 0.0, -0.4], [0.0, 0.0, 0.4]]
    assert core_points(coal.Cylinder(0.1, 0.8)) is None
    M = pin.SE3(pin.rpy.rpyToMatrix(0.1, 0.2, 0.3), np.array([0.1, -0.2, 0.3]))
    objects = [pin.GeometryObject("box", 3, 3, M, coal.Box(0.2, 0.4, 0.6)),
               pin.GeometryObject("cyl", 2, 2, M, coal.Cylinder(0.1, 0.8))]
    table = hull_table(objects)
    assert table.geoms.tolist() == [[VERTICES, 0, 8, 3], [UNSUPPORTED, 8, 8, 2]]
    assert np.allclose(table.points, corners @ M.rotation.T + M.translation)


def test_the_bound_is_below_coal_and_close_to_it_for_hulls_boxes_and_every_obstacle_kind(panda):
    seen = _check_bounds(panda, tilted_clutter(), n=60, seed=1)
    assert seen["apart"] > 1000 and seen["intersecting"] > 20


def test_early_ends_tell_which_side_of_the_threshold_the_distance_is(panda):
    """Stopped once the lower bound exceeds a threshold or the upper bound reaches it, GJK still returns a
    lower bound, and it is above the threshold exactly when the bound run to full accuracy is."""
    scene = panda.collision_scene(tilted_clutter())
    pre = scene.precheck()
    h = pre.hulls
    rng = np.random.default_rng(7)
    sides = {True: 0, False: 0}
    for _ in range(60):
        q = panda.random_q(rng)
        full = _bounds(pre.floats, pre.ints, h.points, h.geoms, h.radius, q, np.zeros((len(scene.pairs), 3)),
                       grown=True)
        for t in (1e-5, 0.01, 0.05):
            early = _bounds(pre.floats, pre.ints, h.points, h.geoms, h.radius, q,
                            np.zeros((len(scene.pairs), 3)), t, t, True)
            measured = ~np.isnan(full)
            assert np.array_equal(measured, ~np.isnan(early))
            assert np.all(early[measured] <= full[measured] + 1e-12)
            near = np.abs(full[measured] - t) < 1e-7  # (within GJK's accuracy of t: either side is right)
            above_full, above_early = full[measured] > t, early[measured] > t
            assert np.array_equal(above_full[~near], above_early[~near])
            sides[True] += int(above_early.sum())
            sides[False] += int((~above_early).sum())
    assert sides[True] > 100 and sides[False] > 100


def test_carried_spheres_and_capsules_are_measured_too(panda):
    robot = panda.copy()
    robot.attach("ball", ik.Sphere((0.0, 0.0, 0.12), 0.04), "panda_hand")
    robot.attach("stick", ik.Capsule((0.0, 0.0, 0.05), (0.0, 0.1, 0.25), 0.02), "panda_link6")
    hulls = robot.collision_scene(tilted_clutter()).precheck().hulls
    assert (hulls.geoms[-2:, 0] == VERTICES).all() and np.allclose(hulls.radius[-2:], [0.04, 0.02])
    seen = _check_bounds(robot, tilted_clutter(), n=25, seed=2)
    assert seen["apart"] > 300


def _random_edges(robot, scene, certifier, rng, n):
    """Edges with free ends whose spheres hand pairs over (their hard pairs and stretch)."""
    out = []
    while len(out) < n:
        a = robot.random_q(rng)
        b = np.clip(a + rng.normal(scale=0.5, size=robot.nq), robot.lower, robot.upper)
        if scene.in_collision(a) or scene.in_collision(b):
            continue
        stage = certifier.sphere_stage(a, b)
        if stage is not None and len(stage[0]):
            out.append((a, b, stage))
    return out


def test_the_compiled_advancement_decides_as_the_python_one_on_coal(panda):
    scene = panda.collision_scene(tilted_clutter())
    certifier = EdgeCertifier(ClearanceOracle(scene), pair_reach(panda.model, scene))
    pre = certifier.oracle.precheck
    hulls = pre.hulls
    rng = np.random.default_rng(3)
    verdicts = {CERTIFIED: 0, REFUSED: 0}
    agree = 0
    edges = _random_edges(panda, scene, certifier, rng, 60)
    for a, b, (hard, lo, hi) in edges:
        u = b - a
        w = pair_rates(certifier.stretch_rates(a, u, hard, lo, hi))
        counts = np.zeros(2, dtype=np.int64)
        verdict = advance_on_distances(pre.floats, pre.ints, hulls.points, hulls.geoms, hulls.radius,
                                       pre.table_rows[hard], a, u, w.need, w.inverse, w.offset, lo, hi,
                                       MAX_ADVANCES, counts)
        assert verdict in (CERTIFIED, REFUSED) and counts[0] >= 1 and counts[1] >= counts[0]
        verdicts[verdict] += 1
        ks, need, inverse, offset = hard.tolist(), w.need.tolist(), w.inverse.tolist(), w.offset.tolist()
        step = certifier.oracle.step
        on_coal = advance(lambda s: step(a + s * u, ks, need, inverse, offset), lo, hi, MAX_ADVANCES)
        agree += (verdict == CERTIFIED) == on_coal
    assert verdicts[CERTIFIED] >= 10 and verdicts[REFUSED] >= 5
    assert agree >= len(edges) - 2


def test_pairs_it_does_not_measure_are_left_to_coal(panda, tmp_path):
    mesh_file = tmp_path / "block.obj"
    V = np.array([[x, y, z] for x in (0, 0.2) for y in (0, 0.2) for z in (0, 0.2)]) + (0.35, -0.1, 0.35)
    faces = [(1, 3, 4), (1, 4, 2), (5, 6, 8), (5, 8, 7), (1, 2, 6), (1, 6, 5), (3, 7, 8), (3, 8, 4),
             (1, 5, 7), (1, 7, 3), (2, 4, 8), (2, 8, 6)]
    mesh_file.write_text("".join(f"v {x} {y} {z}\n" for x, y, z in V)
                         + "".join(f"f {a} {b} {c}\n" for a, b, c in faces))
    robot = panda.copy()
    robot.attach("can", ik.Cylinder(pose((0.0, 0.0, 0.1)), 0.03, 0.1), "panda_hand")
    for obstacles, unmeasured in (([ik.Mesh(str(mesh_file))], "obstacle"),
                                  (tilted_clutter(), "carried cylinder")):
        scene = robot.collision_scene(obstacles)
        pre = scene.precheck()
        hulls = pre.hulls
        if unmeasured == "obstacle":
            rows = [p for p in range(len(scene.pairs)) if scene.pairs[p][1] >= scene.n_robot]
        else:
            can = len(hulls.geoms) - 1
            assert hulls.geoms[can, 0] == UNSUPPORTED
            rows = [p for p in range(len(scene.pairs)) if can in scene.pairs[p]]
        hard = np.array(rows[:3], dtype=np.int64)
        q = robot.neutral()
        u = np.full(robot.nq, 0.1)
        w = pair_rates(np.ones(len(hard)))
        counts = np.zeros(2, dtype=np.int64)
        assert advance_on_distances(pre.floats, pre.ints, hulls.points, hulls.geoms, hulls.radius,
                                    pre.table_rows[hard], q, u, w.need, w.inverse, w.offset, 0.0, 1.0,
                                    MAX_ADVANCES, counts) == NOT_MEASURED, unmeasured
        assert counts.tolist() == [0, 0]
