"""Robot collision queries against independent code: a GeometryModel built in this test with pinocchio/coal
only (URDF + SRDF, hulls, the scene's obstacles), closed-form distances of kinematics.shapes, named errors."""

from pathlib import Path

import coal
import numpy as np
import pinocchio as pin
import pytest

from kinserve import robots
from kinserve.kinematics import errors
from kinserve.kinematics.shapes import Box, Cylinder, Mesh, Sphere
from kinserve.robots import paths


def _pose(xyz, R=None):
    T = np.eye(4)
    T[:3, 3] = xyz
    if R is not None:
        T[:3, :3] = R
    return T


#: The issue's Panda scene: a table top and a wall.
SCENE = [Box(_pose((0.65, 0.0, -0.05)), (0.7, 1.2, 0.1)), Box(_pose((0.0, -0.6, 0.5)), (1.5, 0.05, 1.0))]
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
        1 for g in robot.collision.geometry.geometryObjects if g.parentJoint != 0) * len(SCENE) == len(geom.collisionPairs)
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
    for q in Q[ours_scene][:20]:
        pin.computeCollisions(model, data, geom, gdata, q, False)
        ref_links = set()
        for k, cp in enumerate(geom.collisionPairs):
            if gdata.collisionResults[k].isCollision():
                a, b = (geom.geometryObjects[i] for i in (cp.first, cp.second))
                name_of = lambda g: model.frames[g.parentFrame].name if g.parentJoint or not g.name.startswith("box") \
                    else f"obstacle[{int(g.name[3:])}]:box"
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
        assert robot.in_collision(q, [ball], self_collision=False) == (min(d.distance for d in dist.values()) < 0)


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
    srdf = (erd / "panda_description/srdf/panda.srdf").read_text().replace('link2="panda_link4"', 'link2="panda_lnk4"', 1)
    with pytest.raises(errors.ModelError, match="'panda_lnk4'.*Did you mean: panda_link4"):
        robots.load("panda", srdf=srdf)
    # a Robot built by hand with that SRDF text: the same named error on the first collision query
    panda = robots.load("panda", geometry=False)
    bad = type(panda)(panda.model, name="panda", source=panda.source, package_dirs=panda.package_dirs, srdf=srdf)
    with pytest.raises(errors.ModelError, match="'panda_lnk4'.*Did you mean: panda_link4"):
        bad.in_collision(bad.neutral())
    # an SRDF for a seed robot replaces the computed pairs
    four = robots.load("planar4r", srdf='<robot name="p"><disable_collisions link1="link1" link2="link3"/></robot>')
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


def test_open_mesh_obstacle_is_a_named_error(tmp_path: Path):
    stl = tmp_path / "open.obj"
    stl.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\n")  # tetrahedron missing a face
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
