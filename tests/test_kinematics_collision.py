"""Robot collision queries against independent code: a GeometryModel built in this test with pinocchio/coal
only (URDF + SRDF, hulls, the scene's obstacles), closed-form distances of kinematics.shapes, named errors."""

from pathlib import Path

import coal
import numpy as np
import pinocchio as pin
import pytest

from kinserve import robots
from kinserve.kinematics import errors
from kinserve.kinematics.precheck_verdicts import UNDECIDED, carried_pairs
from kinserve.kinematics.shapes import Box, Capsule, Cylinder, Mesh, Sphere
from kinserve.robots import paths

from collision_scenes import SCENE, fresh_requests
from collision_scenes import pose as _pose

#: Two more obstacles in the arm's workspace (a broad phase must handle any number).
EXTRA = [Box(_pose((0.4, 0.1, 0.5)), (0.1, 0.1, 0.1)), Sphere((0.3, 0.3, 0.3), 0.08)]


def _independent(name: str, urdf: str, srdf: str, locked=(), scene=SCENE):
    """Model + collision GeometryModel (hulls, SRDF pairs, scene pairs) built with pinocchio/coal directly."""
    erd = paths.example_robot_data_dir()
    pkg = [str(paths.example_robot_data_package_dir())]
    model = pin.buildModelFromUrdf(str(erd / urdf))
    geom = pin.buildGeomFromUrdf(model, str(erd / urdf), pin.GeometryType.COLLISION, package_dirs=pkg)
    if locked:
        ids = [model.getJointId(j) for j in locked]
        model, geom = pin.buildReducedModel(model, geom, ids, pin.neutral(model))
    for g in geom.geometryObjects:
        if isinstance(g.geometry, coal.BVHModelBase):
            g.geometry.buildConvexHull(True, "Qt")
            g.geometry = g.geometry.convex
    geom.addAllCollisionPairs()
    pin.removeCollisionPairs(model, geom, str(erd / srdf))
    n_robot = geom.ngeoms
    for k, ob in enumerate(scene):
        shape = coal.Box(*ob.size) if ob.kind == "box" else coal.Sphere(ob.radius)
        idx = geom.addGeometryObject(pin.GeometryObject(f"box{k}", 0, 0, pin.SE3(ob.pose), shape))
        for i in range(n_robot):
            if geom.geometryObjects[i].parentJoint != 0:  # the fixed base is not paired with the scene
                geom.addCollisionPair(pin.CollisionPair(i, idx))
    return model, geom


@pytest.mark.parametrize("name, urdf, srdf, locked", [
    ("panda", "panda_description/urdf/panda.urdf", "panda_description/srdf/panda.srdf",
     ("panda_finger_joint1", "panda_finger_joint2")),
    ("ur5", "ur_description/urdf/ur5_robot.urdf", "ur_description/srdf/ur5.srdf", ()),
])
def test_in_collision_agrees_with_independent_coal_model(name, urdf, srdf, locked):
    robot = robots.load(name)
    model, geom = _independent(name, urdf, srdf, locked)
    assert list(model.names)[1:] == robot.joint_names
    assert robot.collision.pair_source == "srdf"
    assert len(robot.collision.self_pairs) + sum(
        1 for g in robot.collision.geometry.geometryObjects
        if g.parentJoint != 0) * len(SCENE) == len(geom.collisionPairs)
    data, gdata = model.createData(), pin.GeometryData(geom)
    Q = robot.random_q(np.random.default_rng(7), 1000)
    ours_self = np.array([robot.in_collision(q) for q in Q])
    ours_scene = np.array([robot.in_collision(q, SCENE) for q in Q])
    ref_scene = np.array([pin.computeCollisions(model, data, geom, gdata, q, True) for q in Q])
    n_self = len(robot.collision.self_pairs)
    ref_self = []
    for q in Q:
        pin.computeCollisions(model, data, geom, gdata, q, False)
        ref_self.append(any(gdata.collisionResults[k].isCollision() for k in range(n_self)))
    assert np.array_equal(ours_scene, ref_scene)
    assert np.array_equal(ours_self, np.array(ref_self))
    assert 0 < ours_scene.sum() < len(Q)  # both answers occur: the test can fail
    # a scene of four obstacles, broad phase against pair-by-pair coal
    model4, geom4 = _independent(name, urdf, srdf, locked, SCENE + EXTRA)
    gdata4 = pin.GeometryData(geom4)
    ours4 = np.array([robot.in_collision(q, SCENE + EXTRA) for q in Q])
    ref4 = np.array([pin.computeCollisions(model4, data, geom4, gdata4, q, True) for q in Q])
    assert np.array_equal(ours4, ref4) and ours4.sum() > ours_scene.sum()
    # named pairs: every reported pair really collides in the independent model
    def name_of(g):
        if g.parentJoint or not g.name.startswith("box"):
            return model.frames[g.parentFrame].name
        return f"obstacle[{int(g.name[3:])}]:box"

    for q in Q[ours_scene][:20]:
        pin.computeCollisions(model, data, geom, gdata, q, False)
        ref_links = set()
        for k, cp in enumerate(geom.collisionPairs):
            if gdata.collisionResults[k].isCollision():
                a, b = (geom.geometryObjects[i] for i in (cp.first, cp.second))
                ref_links.add((name_of(a), name_of(b)))
        assert set(robot.collisions(q, SCENE)) == ref_links


def _link_cylinder(robot, q, link, length, radius):
    """World pose of planar4r's collision cylinder of ``link`` (axis along the link's x, centred)."""
    offset = _pose((0.5 * length, 0.0, 0.0), pin.rpy.rpyToMatrix(0.0, np.pi / 2, 0.0))
    return Cylinder(robot.fk(q, link) @ offset, radius, length)


def test_distances_match_closed_forms_for_spheres():
    robot = robots.load("planar4r")
    rng = np.random.default_rng(3)
    lengths = {"link1": 1.0, "link2": 0.8, "link3": 0.6, "link4": 0.4}
    for _ in range(30):
        q = robot.random_q(rng)
        ball = Sphere(rng.uniform([-2, -2, -0.3], [2, 2, 0.3]), rng.uniform(0.05, 0.4))
        dist = robot.distances(q, [ball], self_collision=False)
        assert set(dist) == {(link, "obstacle[0]:sphere") for link in lengths}
        for link, L in lengths.items():
            cyl = _link_cylinder(robot, q, link, L, 0.8 * 0.04)
            expected = float(cyl.signed_distance(ball.center)[0]) - ball.radius
            got = dist[(link, "obstacle[0]:sphere")]
            assert got.distance == pytest.approx(expected, abs=1e-6)
            # witness points lie on the two surfaces, apart by the distance along the normal
            assert abs(float(cyl.signed_distance(got.point_a)[0])) < 1e-6
            assert abs(float(ball.signed_distance(got.point_b)[0])) < 1e-6
            assert np.allclose(got.point_b - got.point_a, got.distance * got.normal, atol=1e-6)
        assert robot.min_distance(q, [ball], self_collision=False) == pytest.approx(
            min(d.distance for d in dist.values()))
        assert robot.in_collision(q, [ball],
                                  self_collision=False) == (min(d.distance for d in dist.values()) < 0)


def test_box_distance_witness_points_and_sign():
    robot = robots.load("panda")
    q = robot.neutral()
    dist = robot.distances(q, SCENE)
    for (a, b), d in dist.items():
        if b.startswith("obstacle"):
            box = SCENE[int(b[len("obstacle["):].split("]")[0])]
            assert abs(float(box.signed_distance(d.point_b)[0])) < 1e-6
            assert np.allclose(d.point_b - d.point_a, d.distance * d.normal, atol=1e-6)
    # push the table up into the arm: the distance of the hand to it goes negative, and in_collision says so
    hand_z = robot.fk(q, "panda_hand")[2, 3]
    table = Box(_pose((0.3, 0.0, hand_z)), (0.3, 0.3, 0.1))
    assert robot.in_collision(q, [table])
    assert robot.min_distance(q, [table]) < 0
    assert ("panda_hand", "obstacle[0]:box") in robot.collisions(q, [table])


def test_self_collision_pairs_are_named_by_link():
    robot = robots.load("planar4r")
    q = np.array([0.0, 3.0, 3.0, 0.0])  # folded back: link3 crosses link1
    pairs = robot.collisions(q)
    assert ("link1", "link3") in pairs
    assert all(a != b for a, b in pairs)
    assert robot.in_collision(q)
    assert not robot.in_collision(np.zeros(4))
    assert robot.min_distance(q) < 0 < robot.min_distance(np.zeros(4))


def test_obstacles_as_dicts_and_per_copy_sharing():
    robot = robots.load("panda")
    q = robot.neutral()
    as_dicts = [b.to_dict() for b in SCENE]
    assert robot.in_collision(q, as_dicts) == robot.in_collision(q, SCENE)
    assert robot.copy().collision is robot.collision  # built once, shared by copies


def test_collision_model_survives_pickling():
    import pickle

    robot = robots.load("ur5")
    q = robot.random_q(1)
    other = pickle.loads(pickle.dumps(robot))
    assert other.collision_model is None  # meshes do not travel; the model is rebuilt from the URDF text
    assert other.in_collision(q, SCENE) == robot.in_collision(q, SCENE)
    assert other.min_distance(q, SCENE) == pytest.approx(robot.min_distance(q, SCENE), abs=1e-9)


def test_hull_volume_ratio_reports_the_hull_error():
    ratios = robots.load("panda").collision.hull_volume_ratio
    assert len(ratios) == 9
    assert all(1.0 <= r < 1.001 for r in ratios.values())  # the Panda's meshes are convex


# ------------------------------------------------------------------ bad input
NO_COLLISION_URDF = """<robot name="bare">
  <link name="base"/><link name="l1"><visual><geometry><box size="0.1 0.1 0.1"/></geometry></visual></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>"""


def test_urdf_without_collision_elements_is_a_clear_error():
    robot = robots.load(NO_COLLISION_URDF)
    with pytest.raises(errors.ModelError, match="no <collision> elements"):
        robot.in_collision([0.0])
    with pytest.raises(errors.ModelError, match="no <collision> elements"):
        robot.min_distance([0.0], [Sphere((1, 0, 0), 0.1)])


def test_srdf_with_unknown_link_is_named():
    erd = paths.example_robot_data_dir()
    srdf = (erd / "panda_description/srdf/panda.srdf").read_text().replace('link2="panda_link4"',
                                                                           'link2="panda_lnk4"', 1)
    with pytest.raises(errors.ModelError, match="'panda_lnk4'.*Did you mean: panda_link4"):
        robots.load("panda", srdf=srdf)
    # a Robot built by hand with that SRDF text: the same named error on the first collision query
    panda = robots.load("panda", geometry=False)
    bad = type(panda)(panda.model, name="panda", source=panda.source,
                      package_dirs=panda.package_dirs, srdf=srdf)
    with pytest.raises(errors.ModelError, match="'panda_lnk4'.*Did you mean: panda_link4"):
        bad.in_collision(bad.neutral())
    # an SRDF for a seed robot replaces the computed pairs
    four = robots.load("planar4r",
                       srdf='<robot name="p"><disable_collisions link1="link1" link2="link3"/></robot>')
    assert four.collision.pair_source == "srdf" and ("link1", "link3") in four.collision.disabled
    folded = [0.0, 3.0, 3.0, 0.0]
    assert ("link1", "link3") in robots.load("planar4r").collisions(folded)
    assert ("link1", "link3") not in four.collisions(folded)
    with pytest.raises(errors.ModelError, match="SRDF file .* does not exist"):
        robots.load("planar4r", srdf="/nonexistent/robot.srdf")


def test_bad_obstacles_and_q_are_named():
    robot = robots.load("ur5")
    q = robot.neutral()
    with pytest.raises(errors.InputError, match="box size entries must be positive"):
        robot.in_collision(q, [{"kind": "box", "pose": np.eye(4).tolist(), "size": [0.1, 0.0, 0.1]}])
    with pytest.raises(errors.InputError, match="sphere radius must be positive"):
        robot.collisions(q, [{"kind": "sphere", "center": [0, 0, 0], "radius": -1}])
    with pytest.raises(errors.InputError, match=r"obstacles\[0\] kind must be one of"):
        robot.distances(q, [{"kind": "torus"}])
    with pytest.raises(errors.InputError, match="obstacles must be a sequence"):
        robot.in_collision(q, 3.0)
    with pytest.raises(errors.ShapeError, match=r"q must have shape \(6,\)"):
        robot.in_collision(q[:3])
    with pytest.raises(errors.NonFiniteError):
        robot.in_collision(np.full(6, np.nan))


_BAD_Q = [  # (q of the Panda's 7 entries, or the wrong length; the error; its words)
    (np.zeros(3), errors.ShapeError, r"q must have shape \(7,\), got shape \(3,\)"),
    ([0.0] * 10, errors.ShapeError, r"q must have shape \(7,\), got shape \(10,\)"),
    ("abc", errors.ShapeError, "q must be a sequence of 7 numbers"),
    (np.full(7, np.nan), errors.NonFiniteError, r"q must hold finite numbers .* \[0\]=nan"),
    (np.r_[np.zeros(6), np.inf], errors.NonFiniteError, r"bad entries: \[6\]=inf"),
    (np.full(7, 1e300), errors.NonFiniteError, r"magnitude <= 1e\+06; bad entries: \[0\]=1e\+300"),
]


@pytest.mark.parametrize("query", ["in_collision", "colliding", "distance_arrays", "min_distance", "near"])
def test_scene_queries_name_a_bad_q(query):
    """A scene's queries (a public object: ``robot.collision_scene``) check ``q`` as the robot's do: a wrong
    length or a non-numeric ``q`` is a ShapeError, NaN, inf or a huge entry a NonFiniteError - never
    Pinocchio's exception, and never an answer (the pre-check certified ``1e300`` free before)."""
    robot = robots.load("panda")
    scene = robot.collision_scene(SCENE)
    call = (lambda q: scene.near(0.01, q)) if query == "near" else getattr(scene, query)
    for q, error, words in _BAD_Q:
        with pytest.raises(error, match=words):
            call(q)
    q = robot.neutral()
    if query == "distance_arrays":
        np.testing.assert_array_equal(call(q.tolist()).distance, call(q).distance)
    else:
        assert call(q.tolist()) == call(q)


@pytest.mark.parametrize("query", ["in_collision", "collisions", "distances", "min_distance"])
def test_robot_queries_name_a_bad_q(query):
    """The front door (``robot.in_collision(q, shapes)`` and friends) words a bad ``q`` as the scene does;
    ``in_collision`` leaves the check to the scene's call (the compiled pre-check bounds a float vector
    itself), so it must raise the same errors, in a new scene and in the one it just built."""
    robot = robots.load("panda")
    call = getattr(robot, query)
    for q, error, words in _BAD_Q:
        for shapes in (list(SCENE), SCENE):  # a new list each time (a new scene), then the same objects
            with pytest.raises(error, match=words):
                call(q, shapes)
    q = robot.neutral()
    if query == "distances":
        a, b = call(q.tolist(), SCENE), call(q, SCENE)
        assert list(a) == list(b) and [d.distance for d in a.values()] == [d.distance for d in b.values()]
    else:
        assert call(q.tolist(), SCENE) == call(q, SCENE)


def test_scene_distances_do_not_depend_on_the_queries_before():
    """Same ``q``, same distances, to the bit, whatever was asked in between: the workspaces' GJK starts from
    its default guess (Pinocchio's cached guess made the same ``q`` answer up to 1.7e-6 m apart)."""
    robot = robots.load("panda")
    scene = robot.collision_scene(SCENE)
    qs = robot.random_q(rng=3, n=40)
    first = [scene.distance_arrays(q) for q in qs]
    for k, q in enumerate(qs):
        for other in qs[k + 1:k + 4]:  # other configurations in between
            scene.distance_arrays(other)
        again = scene.distance_arrays(q)
        for a, b in zip(first[k], again):
            np.testing.assert_array_equal(a, b)
        scene.min_distance(qs[-1 - k])
        assert scene.min_distance(q) == (float(first[k].distance.min()), int(first[k].distance.argmin()))
        scene.near(0.05, qs[-1 - k])
        assert scene.near(0.05, q) == scene.near(0.05, q)


def test_scene_pre_check_leaves_an_unbounded_q_undecided():
    """The compiled pre-check judges only a ``q`` with one entry per joint and ``q·q < MAX_ABS**2``: any other
    is exactly UNDECIDED (the scene's input check then words the error); a large but valid ``q`` is judged."""
    robot = robots.load("panda")
    pre = robot.collision_scene(SCENE).precheck()
    classify = lambda q: pre.classify(pre.floats, pre.ints, q, pre.tolerance)  # noqa: E731
    for q, _, _ in _BAD_Q:
        if isinstance(q, np.ndarray):
            assert classify(q) == UNDECIDED
    q = robot.neutral().copy()
    assert classify(q) != UNDECIDED or carried_pairs(classify(q))
    q[0] = 2 * np.pi * 1e4  # the same pose as q, 10^4 turns away: valid, and judged alike
    assert classify(q) == classify(robot.neutral())
    assert robot.collision_scene(SCENE).in_collision(q) == robot.in_collision(robot.neutral(), SCENE)


def test_scene_first_collision_names_a_bad_row():
    robot = robots.load("panda")
    scene = robot.collision_scene(SCENE)
    rows = np.repeat(robot.neutral()[None], 4, axis=0)
    expected = scene.first_collision(rows)
    assert scene.first_collision(list(rows)) == expected
    assert scene.first_collision([]) == -1
    bad = rows.copy()
    bad[2, 4] = np.nan
    with pytest.raises(errors.NonFiniteError, match=r"qs must hold finite numbers .* \[18\]=nan"):
        scene.first_collision(bad)
    with pytest.raises(errors.NonFiniteError, match=r"qs\[2\] must hold finite numbers"):
        scene.first_collision(list(bad))
    with pytest.raises(errors.ShapeError, match=r"qs must have shape \(N, 7\), got shape \(4, 6\)"):
        scene.first_collision(rows[:, :6])
    with pytest.raises(errors.ShapeError, match=r"qs\[1\] must have shape \(7,\)"):
        scene.first_collision([rows[0], rows[1, :3]])
    assert scene.first_collision(q for q in rows) == expected
    with pytest.raises(errors.ShapeError,
                       match=r"qs must be a sequence of configurations or a float \(N, 7\) array, got float"):
        scene.first_collision(3.0)


def test_open_mesh_obstacle_is_a_named_error(tmp_path: Path):
    stl = tmp_path / "open.obj"
    # tetrahedron missing a face
    stl.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\n")
    with pytest.raises(errors.ModelError, match="not a closed surface"):
        Mesh(stl)
    closed = tmp_path / "tet.obj"
    closed.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
    robot = robots.load("ur5")
    tet = Mesh(closed, _pose((0.3, 0.2, 0.3)), scale=0.2)
    d = robot.min_distance(robot.neutral(), [tet], self_collision=False)
    assert np.isfinite(d)


def test_queries_are_thread_safe():
    """One Robot shared by threads: each thread has its own Data / GeometryData / broad phase."""
    from concurrent.futures import ThreadPoolExecutor

    robot = robots.load("panda")
    Q = robot.random_q(np.random.default_rng(9), 400)
    serial = [(robot.in_collision(q, SCENE), robot.min_distance(q, SCENE)) for q in Q]

    def work(chunk):
        return [(robot.in_collision(q, SCENE), robot.min_distance(q, SCENE)) for q in chunk]

    with ThreadPoolExecutor(4) as pool:
        parallel = [r for part in pool.map(work, np.array_split(Q, 8)) for r in part]
    assert [c for c, _ in parallel] == [c for c, _ in serial]
    # GJK starts from the previous call's direction (per thread): distances agree to rounding
    assert np.allclose([d for _, d in parallel], [d for _, d in serial], rtol=0, atol=1e-12)


# ------------------------------------------------------------------ broad phase
def _obstacles_at_the_surface(robot, q, rng, k):
    """``k`` random spheres / boxes / capsules (1-6 cm) centred near random vertices of the arm's collision
    shapes at ``q``: their distances to the arm straddle zero, so near misses and grazing hits are common."""
    shapes = [s for s in robot.collision_geometry(q) if s["joint"] != 0]
    out = []
    for _ in range(k):
        s = shapes[rng.integers(len(shapes))]
        local = s["vertices"][rng.integers(len(s["vertices"]))] if s["kind"] == "convex" else np.zeros(3)
        centre = (s["pose"] @ np.append(local, 1.0))[:3] + rng.normal(scale=0.05, size=3)
        size = rng.uniform(0.005, 0.03)
        kind = rng.integers(3)
        R = pin.rpy.rpyToMatrix(*rng.uniform(-np.pi, np.pi, 3))
        if kind == 0:
            out.append(Sphere(centre, size))
        elif kind == 1:
            out.append(Box(_pose(centre, R), rng.uniform(0.01, 0.05, 3)))
        else:
            out.append(Capsule(centre - R[:, 0] * size, centre + R[:, 0] * size, 0.5 * size))
    return out


def _pairs_by_broad_phase(scene, q):
    """Indices of the colliding pairs as the scene's broad phase finds them (no early stop)."""
    ws = scene.workspace()
    data, gd, bpm = ws.data, ws.geometry_data, ws.manager
    for res in gd.collisionResults:
        # pairs the broad phase skips keep their result: start from "no collision"
        res.clear()
    pin.computeCollisions(scene.model, data, bpm, q, False)
    return {k for k, res in enumerate(gd.collisionResults) if res.isCollision()}


def _pairs_by_all_pairs_narrow_phase(scene, q):
    """Indices of the colliding pairs by GJK on every pair (no broad phase), on a GeometryData of its own."""
    data, gd = scene.model.createData(), fresh_requests(pin.GeometryData(scene.geometry))
    pin.computeCollisions(scene.model, data, scene.geometry, gd, q, False)
    return {k for k, res in enumerate(gd.collisionResults) if res.isCollision()}


@pytest.mark.parametrize("n_obstacles, manager", [(3, "Naive"), (110, "DynamicAABBTree")])
def test_broad_phase_never_skips_a_colliding_pair(n_obstacles, manager):
    """Random configurations with obstacles at the arm's surface: the broad phase (naive manager for small
    scenes, AABB tree for large ones) finds exactly the colliding pairs of all-pairs GJK, self pairs included,
    and ``in_collision`` says yes exactly when one exists."""
    robot = robots.load("panda")
    rng = np.random.default_rng(11)
    n_configs = 150 if n_obstacles < 10 else 25
    hits = grazing = 0
    for q in robot.random_q(rng, n_configs):
        obstacles = _obstacles_at_the_surface(robot, q, rng, n_obstacles)
        scene = robot.collision_scene(obstacles)
        assert manager in type(scene.workspace().manager).__name__, "the manager this case is meant to test"
        expected = _pairs_by_all_pairs_narrow_phase(scene, q)
        assert _pairs_by_broad_phase(scene, q) == expected
        assert robot.in_collision(q, obstacles) == bool(expected)
        hits += bool(expected)
        d = scene.min_distance(q)[0]
        grazing += abs(d) < 5e-3
    assert 0.2 * n_configs < hits <= n_configs  # both answers occur (with 110 obstacles nearly all collide)
    if n_obstacles < 10:
        assert hits < 0.9 * n_configs
        assert grazing > 0.05 * n_configs  # cases within 5 mm of the boundary (16 of 150 with this seed)


def test_near_pairs_match_all_pairs_gjk_with_the_margin():
    """``scene.near(threshold)`` (broad phase with inflated AABBs, then GJK on the candidates) returns exactly
    the pairs that GJK with ``security_margin = threshold`` on every pair finds, for thresholds from 0 to 10
    cm."""
    robot = robots.load("panda")
    rng = np.random.default_rng(12)
    found = 0
    for q in robot.random_q(rng, 60):
        scene = robot.collision_scene(SCENE + _obstacles_at_the_surface(robot, q, rng, 2))
        for threshold in (0.0, 0.01, 0.05, 0.1):
            data, gd = scene.model.createData(), pin.GeometryData(scene.geometry)
            for req in gd.collisionRequests:
                req.security_margin = threshold
            pin.computeCollisions(scene.model, data, scene.geometry, gd, q, False)
            expected = [k for k, res in enumerate(gd.collisionResults) if res.isCollision()]
            assert scene.near(threshold, q) == expected
            found += len(expected)
            # the witness distances of the near pairs are below the threshold (placements left by near)
            for k in expected[:3]:
                assert scene.near_distance(threshold, k)[0] < threshold + 1e-6
    assert found > 200  # near pairs are common: the comparison has substance


def test_scene_pairs_follow_the_geometry_model_and_equal_obstacles_share_the_layout():
    """The scene's pair table (indices, joints, names) is the GeometryModel's; the same obstacle objects reuse
    one scene; new objects of equal values get a scene of their own on the same layout, with the same
    pre-check arrays."""
    robot = robots.load("panda")
    for self_collision in (True, False):
        scene = robot.collision_scene(SCENE + EXTRA, self_collision)
        gm = scene.geometry
        assert scene.pairs.tolist() == [[cp.first, cp.second] for cp in gm.collisionPairs]
        joint = [g.parentJoint for g in gm.geometryObjects]
        assert scene.pair_joints.tolist() == [[joint[a], joint[b]] for a, b in scene.pairs.tolist()]
        assert len(scene) == (len(robot.collision.self_pairs) if self_collision else 0) + 4 * sum(
            1 for g in gm.geometryObjects[:scene.n_robot] if g.parentJoint != 0)
    same = [Box(b.pose, b.size) for b in SCENE]  # new objects, equal values
    assert robot.collision_scene(list(SCENE)) is robot.collision_scene(list(SCENE))
    first = robot.collision_scene(SCENE)
    for other in (robot.collision_scene(same), robot.collision_scene([b.to_dict() for b in SCENE])):
        assert other is not first and other.layout is first.layout
        assert np.array_equal(other.precheck().floats, first.precheck().floats)
    moved = [Box(_pose((0.65, 0.0, -0.04)), (0.7, 1.2, 0.1)), SCENE[1]]
    assert robot.collision_scene(moved) is not robot.collision_scene(SCENE)
    assert robot.collision_scene(SCENE, self_collision=False) is not robot.collision_scene(SCENE)
    q = np.array([0.0, 0.3, 0.0, -2.0, 0.0, 2.6, 0.8])

    def to_table(obstacles):
        return min(d.distance for (_, b), d in robot.distances(q, obstacles).items()
                   if b == "obstacle[0]:box")

    assert to_table(SCENE) - to_table(moved) == pytest.approx(0.01, abs=1e-6)  # the table top is 1 cm higher


def test_clear_caches_forgets_the_scene_layouts_and_builds_no_collision_model():
    """``kinserve.clear_caches(robot)`` drops the collision model's scene layouts and last scene: the same
    shapes then get a new layout and a new scene, which answers as the old one (still valid for its holder);
    on a robot whose collision model was never built it builds none."""
    import kinserve

    robot = robots.load("panda")
    cm = robot.collision
    scene = robot.collision_scene(SCENE)
    q = np.array([0.0, 0.3, 0.0, -2.0, 0.0, 2.6, 0.8])
    kinserve.clear_caches(robot)
    again = robot.collision_scene(SCENE)
    assert robot.collision is cm and again is not scene and again.layout is not scene.layout
    assert again.min_distance(q) == scene.min_distance(q)
    assert robot.collision_scene(SCENE) is again and cm.layout(tuple(SCENE)) is again.layout
    kinserve.clear_caches()  # the registry's models too: the next load parses anew (no shared model)
    fresh = robots.load("ur5")
    kinserve.clear_caches(fresh)
    assert fresh._collision_holder[0] is None


def test_a_new_tuple_gets_one_scene_however_it_is_asked_again():
    """``cached_scene`` misses a new tuple; the scene built for it (``scene`` or the front door ``scene_of``)
    answers every later lookup of the tuple or of a list of its objects; dict forms are validated into new
    shapes on each call, so they get a new scene of the same layout."""
    robot = robots.load("panda")
    cm = robot.collision
    obstacles = (Box(_pose((0.5, -0.3, 0.2)), (0.13, 0.17, 0.19)), Sphere((0.2, 0.4, 0.6), 0.07))
    assert cm.cached_scene(obstacles) is None
    scene = cm.scene_of(obstacles)
    assert scene.obstacles is obstacles
    assert cm.scene(obstacles) is scene and cm.scene_of(list(obstacles)) is scene
    assert cm.cached_scene(obstacles) is scene and robot.collision_scene(obstacles) is scene
    other = (Box(_pose((0.5, -0.3, 0.2)), (0.13, 0.17, 0.19)), Sphere((0.2, 0.4, 0.6), 0.07))  # equal values
    assert cm.cached_scene(other) is None  # equal values, other objects: a scene of their own, same layout
    assert cm.scene(other) is not scene and cm.scene(other).layout is scene.layout
    assert cm.scene(other) is cm.scene(other)
    assert cm.scene(obstacles, self_collision=False) is not scene
    dicts = [o.to_dict() for o in obstacles]
    first = cm.scene_of(dicts)
    assert first.obstacles == obstacles and first.layout is scene.layout
    assert cm.scene_of(dicts) is not first  # new shapes: a new scene
    mixed = [obstacles[0], dicts[1]]
    a = cm.scene_of(mixed)
    assert a.obstacles[0] is obstacles[0] and a.obstacles[1] == obstacles[1]
    assert cm.scene_of(mixed) is not a  # the dict is a new shape each time: never the last scene's key


def test_the_model_keeps_only_the_last_scene_it_built():
    """A new obstacle set frees the scene before it: memory stays bounded however many scenes pass through the
    front door (a layout keeps the shapes of its first scene, a thread's coal workspace those it placed
    last); the very objects of the last scene answer that scene (a tuple, or a list of the same objects); a
    list changed in place gets a scene of its new objects."""
    import gc
    import weakref

    robot = robots.load("panda")
    cm = robot.collision
    q = np.array([0.0, 0.3, 0.0, -2.0, 0.0, 2.6, 0.8])
    first = [Box(_pose((0.5, -0.3, 0.2)), (0.13, 0.17, 0.19)), Sphere((0.2, 0.4, 0.6), 0.07)]
    robot.in_collision(q, first)
    scene = weakref.ref(robot.collision_scene(first))
    assert robot.collision_scene(list(first)) is scene() and robot.collision_scene(tuple(first)) is scene()
    del first
    gc.collect()
    assert scene() is not None  # the model holds its last scene
    robot.in_collision(q, [Sphere((0.3, 0.1, 0.5), 0.05)])
    gc.collect()
    assert scene() is None
    last = weakref.ref(robot.collision_scene([Sphere((0.3, 0.2, 0.5), 0.05)]))
    robot.in_collision(q, [Sphere((0.3, 0.3, 0.5), 0.05)])
    assert last() is None and cm.cached_scene([]) is None
    changing = [Sphere((0.5, 0.0, 0.4), 0.05)]
    a = robot.collision_scene(changing)
    changing[0] = Sphere((0.5, 0.0, 0.41), 0.05)
    b = robot.collision_scene(changing)
    assert b is not a and b.obstacles[0] is changing[0]


@pytest.mark.parametrize("entry", ["in_collision", "collision_scene", "scene_of", "scene", "dicts", "shape"])
def test_the_old_scene_is_freed_before_the_new_one_is_built(entry, monkeypatch):
    """When the model holds the last reference to its last scene, a new obstacle set frees that scene before
    the new scene is built (the memory peak holds one scene's arrays), through every entry: no local of the
    look-up keeps it alive until then."""
    import weakref

    from kinserve.kinematics import collision_model

    robot = robots.load("panda")
    cm = robot.collision
    q = np.array([0.0, 0.3, 0.0, -2.0, 0.0, 2.6, 0.8])
    old = weakref.ref(cm.scene_of((Box(_pose((0.5, -0.3, 0.2)), (0.13, 0.17, 0.19)),)))
    alive_when_built = []
    real_scene = collision_model.CollisionScene

    def recording_scene(layout, obstacles):
        alive_when_built.append(old() is not None)
        return real_scene(layout, obstacles)

    monkeypatch.setattr(collision_model, "CollisionScene", recording_scene)
    new = Box(_pose((0.4, 0.3, 0.3)), (0.1, 0.1, 0.1))
    {"in_collision": lambda: robot.in_collision(q, (new,)),
     "collision_scene": lambda: robot.collision_scene([new]),
     "scene_of": lambda: cm.scene_of((new,)),
     "scene": lambda: cm.scene(iter([new])),
     "dicts": lambda: cm.scene_of([new.to_dict()]),
     "shape": lambda: cm.scene_of(new)}[entry]()
    assert alive_when_built == [False] and old() is None
    assert cm.cached_scene([]) is None and cm._last_scene.obstacles[0] == new


def test_an_undecided_first_check_places_only_the_obstacles_of_its_pairs():
    """A new scene whose first undecided configuration leaves pairs with one obstacle places that obstacle
    alone in coal; the other queries - on this scene and on another scene of the layout, in any order - place
    the rest and answer like an independent coal model of their own obstacles."""
    robot = robots.load("panda")
    rng = np.random.default_rng(5)
    centres = rng.uniform((0.3, -0.4, 0.2), (0.6, 0.4, 0.7), size=(2, 4, 3))
    sets = [[Box(_pose(c), (0.12, 0.12, 0.12)) for c in row] for row in centres]
    scenes = [robot.collision_scene(obs) for obs in sets]
    assert scenes[1].layout is scenes[0].layout
    refs = []
    for obs in sets:
        model, geom = _independent(*PANDA, scene=obs)
        refs.append((model, model.createData(), geom, pin.GeometryData(geom)))
    layout = scenes[0].layout
    pre = scenes[1].precheck()
    Q = robot.random_q(rng, 3000)
    one = None
    for q in Q:  # a configuration the spheres and the hulls leave to coal on pairs of one obstacle of scene 1
        verdict = pre.classify(pre.floats, pre.ints, q, pre.tolerance)
        if verdict > UNDECIDED:
            verdict = pre.hull_verdict(pre.floats, pre.ints, *pre.hull_arguments, q, verdict,
                                       pre.tolerance)
        if verdict >= UNDECIDED:
            pairs = carried_pairs(verdict) if verdict > UNDECIDED else \
                pre.uncertified_pairs(pre.floats, pre.ints, q, pre.tolerance).tolist()
            slots = {layout.pair_obstacle[p] for p in pairs} - {-1}
            if len(slots) == 1:
                one = q, slots.pop()
                break
    assert one is not None
    q, slot = one
    scenes[0].workspace()  # every obstacle of scene 0 in place
    model, data, geom, gd = refs[1]
    assert scenes[1].in_collision(q) == bool(pin.computeCollisions(model, data, geom, gd, q, True))
    placed = layout.pair_workspace(scenes[1].obstacles, np.array([], dtype=np.int64)).placed
    assert [p is o for p, o in zip(placed, scenes[1].obstacles)] == [k == slot for k in range(4)]
    assert [p is o for p, o in zip(placed, scenes[0].obstacles)] == [k != slot for k in range(4)]
    for k, q in enumerate(Q[:200]):  # in_collision (pairs), colliding (every pair) alternating
        s = k % 2
        model, data, geom, gd = refs[s]
        truth = bool(pin.computeCollisions(model, data, geom, gd, q, True))
        assert scenes[s].in_collision(q) == truth
        assert bool(scenes[1 - s].colliding(q)) == bool(pin.computeCollisions(*refs[1 - s], q, False))


PANDA = ("panda", "panda_description/urdf/panda.urdf", "panda_description/srdf/panda.srdf",
         ("panda_finger_joint1", "panda_finger_joint2"))


def test_scenes_of_moved_obstacles_share_a_layout_and_answer_for_their_own_placements():
    """A moved obstacle (same shape, new pose) gives a new scene on the same SceneLayout (geometry objects,
    pairs, per-thread GeometryData): each scene answers like an independent coal model of its own obstacles,
    with queries alternating between the scenes on one thread and spread over threads; another size is
    another layout."""
    from concurrent.futures import ThreadPoolExecutor

    robot = robots.load("panda")
    rng = np.random.default_rng(21)
    centres = rng.uniform((0.25, -0.35, 0.25), (0.55, 0.35, 0.65), size=(4, 3))
    obstacle_sets = [SCENE + [Box(_pose(c), (0.15, 0.15, 0.15))] for c in centres]
    obstacle_sets.append(SCENE + [Box(_pose(centres[0]), (0.25, 0.15, 0.15))])  # another size
    scenes = [robot.collision_scene(obs) for obs in obstacle_sets]
    assert all(s.layout is scenes[0].layout for s in scenes[:4]) and scenes[4].layout is not scenes[0].layout
    assert len({id(s) for s in scenes}) == 5
    refs = []
    for obs in obstacle_sets:
        model, geom = _independent(*PANDA, scene=obs)
        refs.append((model, model.createData(), geom, pin.GeometryData(geom)))
    Q = robot.random_q(rng, 150)

    def answers(qs):
        return [[s.in_collision(q) for s in scenes] for q in qs]  # alternate between the scenes per q

    ours = np.array(answers(Q))
    ref = np.array([[pin.computeCollisions(m, d, g, gd, q, True) for m, d, g, gd in refs] for q in Q])
    assert np.array_equal(ours, ref)
    assert (ours != ours[:, :1]).any(axis=1).sum() > 10  # the placements matter: scenes disagree on many q
    assert 0 < ours.sum() < ours.size
    for q in Q[:30]:  # signed distances too (pinocchio.computeDistances on the independent model)
        for s, (m, d, g, gd) in zip(scenes, refs):
            k = pin.computeDistances(m, d, g, gd, q)
            assert s.min_distance(q)[0] == pytest.approx(gd.distanceResults[k].min_distance, abs=1e-5)
    with ThreadPoolExecutor(3) as pool:
        parallel = [row for part in pool.map(answers, np.array_split(Q, 6)) for row in part]
    assert np.array_equal(np.array(parallel), ours)


def test_check_and_path_loop_agree_with_computecollisions_over_every_pair():
    """The bound broad-phase check (fk, placements, AABBs, collide) and its path loop give the answer of
    pinocchio.computeCollisions over every pair (no broad phase) on the scene's own GeometryModel."""
    import pinocchio as pin

    from kinserve import ik, robots

    robot = robots.load("panda")
    T = np.eye(4)
    T[:3, 3] = (0.65, 0.0, -0.05)
    W = np.eye(4)
    W[:3, 3] = (0.0, -0.6, 0.5)
    scene = robot.collision_scene([ik.Box(T, (0.7, 1.2, 0.1)), ik.Box(W, (1.5, 0.05, 1.0))])
    gm = scene.geometry
    gd = pin.GeometryData(gm)
    data = robot.model.createData()
    qs = list(robot.random_q(np.random.default_rng(21), 400))
    truth = [bool(pin.computeCollisions(robot.model, data, gm, gd, q, True)) for q in qs]
    assert 0 < sum(truth) < len(truth)
    assert [scene.in_collision(q) for q in qs] == truth
    for lo in range(0, 400, 40):
        chunk = qs[lo:lo + 40]
        expected = next((k for k, t in enumerate(truth[lo:lo + 40]) if t), -1)
        assert scene.first_collision(chunk) == expected
    assert scene.first_collision([]) == -1


def test_layouts_share_the_threads_data_and_answer_alike_interleaved():
    """Every layout of a robot uses the thread's one ``pinocchio.Data`` (a Data holds nv^3 tensors: one per
    layout took 1.4 GB for TIAGo dual's 32 cached layouts); another thread has its own. Queries of two
    scenes interleaved answer exactly as each scene's queries asked alone."""
    import threading

    robot = robots.load("panda")
    ball = robot.collision_scene([Sphere([0.4, 0.1, 0.5], 0.12)])
    shelf = robot.collision_scene([Box(_pose([0.5, -0.2, 0.3]), [0.3, 0.3, 0.04])])
    assert ball.layout is not shelf.layout
    assert ball.workspace().data is shelf.workspace().data
    other = []
    thread = threading.Thread(target=lambda: other.append(ball.workspace().data))
    thread.start()
    thread.join()
    assert other[0] is not ball.workspace().data
    qs = robot.random_q(rng=11, n=60)

    def answers(scene, q):
        return (scene.in_collision(q), scene.distance_arrays(q).distance.tolist(), scene.near(0.05, q),
                scene.first_collision([q, robot.neutral()]))

    alone = [[answers(scene, q) for q in qs] for scene in (ball, shelf)]
    interleaved = [(answers(ball, q), answers(shelf, q)) for q in qs]
    assert [a for a, _ in interleaved] == alone[0] and [b for _, b in interleaved] == alone[1]
    assert any(a[0] for a in alone[0]) and not all(a[0] for a in alone[0])  # both verdicts met
