"""The sphere pre-check of the collision scenes (kinematics.collision_spheres) against Pinocchio and coal.

* the tree's forward kinematics against Pinocchio's ``oMi`` (serial arms, a two-arm tree, prismatic and
  unaligned joints); models with other joints are not packed;
* every cover contains its geometry (points on and inside the robots' hulls, primitives, AABB fallback);
* obstacle bounds against the closed-form signed distances of kinematics.shapes;
* conservativeness on the Panda (SRDF pairs) with the benchmark's table and wall plus spheres, boxes,
  capsules, cylinders and a mesh near the arm's surface, and on the UR5: every pair's lower bound is below
  coal's distance, no configuration coal finds in collision is certified, certification is exactly "every
  bound above the tolerance", and ``in_collision`` / ``first_collision`` answer as pair-by-pair coal;
* the certification rate of the open scene (reported, above a floor).
"""

from concurrent.futures import ThreadPoolExecutor

import coal
import numpy as np
import pinocchio as pin
import pytest

from kinserve import robots
from kinserve.kinematics import collision_spheres as cs
from kinserve.kinematics.serial_chain import kinematic_tree, serial_chain
from kinserve.kinematics.shapes import Box, Capsule, Cylinder, Mesh, Sphere

from collision_scenes import SCENE
from collision_scenes import pose as _pose


def _rotation(rng):
    return pin.rpy.rpyToMatrix(*rng.uniform(-np.pi, np.pi, 3))


# ------------------------------------------------------------------ the tree
@pytest.mark.parametrize("name", ["panda", "ur5", "baxter", "scara", "finger_edu", "pr"])
def test_tree_placements_match_pinocchio_omi(name):
    robot = robots.load(name, geometry=False)
    model, data = robot.model, robot.model.createData()
    tree, joints = kinematic_tree(model)
    assert len(joints) == model.njoints - 1 and joints[:, 2].tolist() == list(model.parents)[1:]
    X = np.empty((model.njoints, 12))
    for q in robot.random_q(np.random.default_rng(3), 30):
        cs.tree_placements(tree, joints, q, X)
        pin.forwardKinematics(model, data, q)
        for j in range(model.njoints):
            M = data.oMi[j]
            assert np.abs(X[j, :9].reshape(3, 3) - M.rotation).max() < 1e-12
            assert np.abs(X[j, 9:] - M.translation).max() < 1e-12


@pytest.mark.parametrize("joint", [pin.JointModelFreeFlyer(), pin.JointModelRUBZ(),
                                   pin.JointModelSphericalZYX(), pin.JointModelPlanar()])
def test_models_with_other_joints_are_not_packed(joint):
    """A tree with any joint other than a one-DoF revolute / prismatic one has no packing, wherever it is;
    the chain to a frame that avoids it still packs when the sizes allow (serial_chain unchanged)."""
    model = pin.Model()
    a = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "a")
    b = model.addJoint(a, joint, pin.SE3(np.eye(3), np.array([0.0, 0.3, 0.0])), "b")
    model.addJointFrame(a)
    model.addJointFrame(b)
    assert kinematic_tree(model) is None
    if model.nq == model.nv:  # (serial_chain refuses any model whose q and v sizes differ)
        assert serial_chain(model, model.getFrameId("a")) is not None
    gm = pin.GeometryModel()
    gm.addGeometryObject(pin.GeometryObject("ball", a, pin.SE3.Identity(), coal.Sphere(0.1)))
    assert cs.robot_spheres(model, gm) is None


# ------------------------------------------------------------------ covers
def _contained(points, spheres):
    """Per point, True when some sphere ``(centre, radius)`` of ``spheres`` holds it."""
    d2 = ((points[:, None, :] - spheres[None, :, :3]) ** 2).sum(axis=2)
    return (d2 <= spheres[None, :, 3] ** 2).any(axis=1)


def _hull_samples(V, triangles, rng, n=3000):
    """Vertices, points on the hull's faces and edges, and points inside (convex combinations)."""
    T = V[triangles]
    w = rng.dirichlet(np.ones(3), size=n)
    faces = np.einsum("nk,nkd->nd", w, T[rng.integers(len(T), size=n)])
    t = rng.uniform(size=(n, 1))
    tri = T[rng.integers(len(T), size=n)]
    edges = tri[:, 0] + t * (tri[:, 1] - tri[:, 0])
    inside = rng.dirichlet(np.ones(4), size=n) @ V[rng.integers(len(V), size=4)]
    return np.concatenate([V, faces, edges, inside])


@pytest.mark.parametrize("name", ["panda", "ur5"])
def test_robot_covers_contain_their_geometry(name):
    """Every point of every robot geometry (hulls: vertices, face and edge points, interior points; boxes:
    corners and random points), placed in its joint frame, lies in one of its cover spheres and in its
    bounding sphere; the long links get spheres far tighter than their bounding sphere."""
    robot = robots.load(name)
    spheres = cs.robot_spheres_of(robot.collision)
    assert spheres is cs.robot_spheres_of(robot.collision)  # built once per collision model
    rng = np.random.default_rng(4)
    kinds = set()
    for g, obj in enumerate(robot.collision.geometry.geometryObjects):
        geo = obj.geometry
        kinds.add(type(geo).__name__)
        if isinstance(geo, coal.Convex):
            V = np.asarray(geo.points())
            tris = np.array([[geo.polygons(i)[k] for k in range(3)] for i in range(geo.num_polygons)])
            local = _hull_samples(V, tris, rng)
        else:
            h = np.asarray(geo.halfSide)
            corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * h
            local = np.concatenate([corners, rng.uniform(-h, h, size=(500, 3))])
        points = local @ obj.placement.rotation.T + obj.placement.translation
        joint, first, end = spheres.geoms[g]
        assert joint == obj.parentJoint
        assert _contained(points, spheres.spheres[first:end]).all(), obj.name
        assert _contained(points, spheres.spheres[g:g + 1]).all(), obj.name
    assert "Convex" in kinds
    if name == "panda":
        link5 = robot.collision.links.index("panda_link5")
        joint, first, end = spheres.geoms[link5]
        assert end - first >= 3
        assert spheres.spheres[first:end, 3].max() < 0.6 * spheres.spheres[link5, 3]


@pytest.mark.parametrize("name", ["panda", "ur5"])
def test_inner_points_lie_inside_their_geometry(name):
    """Every inner point of every robot geometry is inside it by coal's signed distance (a point sphere at it:
    negative distance), in the geometry's frame, and in the joint frame where the packed table has it."""
    robot = robots.load(name)
    spheres = cs.robot_spheres_of(robot.collision)
    req, res = coal.DistanceRequest(), coal.DistanceResult()
    point = coal.Sphere(1e-9)
    total = 0
    for g, obj in enumerate(robot.collision.geometry.geometryObjects):
        local = cs.geometry_inner_points(obj.geometry)
        first, end = spheres.inner_ranges[g]
        placed = local @ obj.placement.rotation.T + obj.placement.translation
        assert np.allclose(spheres.inner[first:end], placed, atol=1e-12)
        for p in local:
            res.clear()
            d = coal.distance(obj.geometry, coal.Transform3s(np.eye(3), np.zeros(3)), point,
                              coal.Transform3s(np.eye(3), p), req, res)
            assert d < 0.0, (obj.name, p, d)
        total += len(local)
    assert total >= len(robot.collision.geometry.geometryObjects)


@pytest.mark.parametrize("geo", [coal.Sphere(0.1), coal.Box(0.2, 0.1, 0.4), coal.Capsule(0.05, 0.3),
                                 coal.Cylinder(0.05, 0.3)])
def test_primitive_inner_points_are_inside(geo):
    for p in cs.geometry_inner_points(geo):
        res = coal.DistanceResult()
        assert coal.distance(geo, coal.Transform3s(), coal.Sphere(1e-9), coal.Transform3s(np.eye(3), p),
                             coal.DistanceRequest(), res) < 0.0


def _primitive_samples(geo, rng, n=4000):
    """Points on and inside a coal primitive, in its frame (the surfaces' extreme points included)."""
    if isinstance(geo, coal.Sphere):
        d = rng.normal(size=(n, 3))
        return geo.radius * d / np.linalg.norm(d, axis=1)[:, None] * rng.uniform(0.0, 1.0, (n, 1)) ** 0.01
    if isinstance(geo, coal.Ellipsoid):
        d = rng.normal(size=(n, 3))
        return np.asarray(geo.radii) * d / np.linalg.norm(d, axis=1)[:, None]
    r, L = geo.radius, geo.halfLength
    phi = rng.uniform(0.0, 2.0 * np.pi, n)
    rho = r * np.sqrt(rng.uniform(0.0, 1.0, n))
    rho[: n // 2] = r  # on the mantle and the rims
    z = rng.uniform(-L, L, n)
    z[: n // 8] = rng.choice([-L, L], n // 8)
    pts = np.column_stack([rho * np.cos(phi), rho * np.sin(phi), z])
    if isinstance(geo, coal.Capsule):
        d = rng.normal(size=(n, 3))
        cap = r * d / np.linalg.norm(d, axis=1)[:, None]
        cap[:, 2] += np.where(cap[:, 2] > 0, L, -L)
        pts = np.concatenate([pts, cap])
    return pts


@pytest.mark.parametrize("geo", [coal.Sphere(0.07), coal.Cylinder(0.04, 0.5), coal.Cylinder(0.2, 0.05),
                                 coal.Capsule(0.03, 0.4), coal.Ellipsoid(0.1, 0.05, 0.2)],
                         ids=["sphere", "long cylinder", "flat cylinder", "capsule", "ellipsoid (AABB)"])
def test_primitive_covers_contain_the_primitive(geo):
    rng = np.random.default_rng(5)
    bounding, cover = cs.geometry_cover(geo)
    points = _primitive_samples(geo, rng)
    assert _contained(points, cover).all() and _contained(points, bounding[None, :]).all()
    if isinstance(geo, coal.Sphere):
        assert cover.shape == (1, 4) and cover[0, 3] == pytest.approx(0.07, abs=1e-8)
    if isinstance(geo, coal.Cylinder):  # k slabs of half length h = L / k: spheres of radius sqrt(r^2 + h^2)
        k = min(cs.MAX_COVER_SPHERES, int(np.ceil(2.0 * geo.halfLength / (cs.SLAB_RATIO * geo.radius))))
        assert len(cover) == k
        assert np.allclose(cover[:, 3], np.hypot(geo.radius, geo.halfLength / k), rtol=0, atol=1e-8)


def test_swept_sphere_radius_inflates_the_cover():
    box = coal.Box(0.1, 0.2, 0.3)
    plain = cs.geometry_cover(box)[1]
    box.setSweptSphereRadius(0.02)
    swept = cs.geometry_cover(box)[1]
    assert np.allclose(swept[:, 3], plain[:, 3] + 0.02)


# ------------------------------------------------------------------ obstacles
def _tetra(tmp_path):
    path = tmp_path / "tet.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
    return path


def test_obstacle_bounds_are_the_shapes_signed_distances(tmp_path):
    """For sphere centres around every obstacle kind: the bound is the shape's closed-form signed distance
    minus the radius (a mesh: its bounding sphere, a lower bound), and the squared test of the certification
    says "clear" exactly when that bound exceeds the tolerance, with the bound minus the tolerance as its
    slack (capped by the margin so far)."""
    rng = np.random.default_rng(6)
    shapes = [Sphere((0.1, 0.2, 0.3), 0.15), Box(_pose((0.3, -0.1, 0.4), _rotation(rng)), (0.2, 0.5, 0.1)),
              Capsule((0.1, 0.1, 0.1), (0.4, -0.2, 0.5), 0.06),
              Cylinder(_pose((0.0, 0.3, 0.2), _rotation(rng)), 0.1, 0.4),
              Mesh(_tetra(tmp_path), _pose((0.2, 0.2, 0.2), _rotation(rng)), scale=0.3)]
    obstacles = np.array([cs.obstacle_row(s.geometry(), s.placement()) for s in shapes])
    assert obstacles[:, cs.KIND].tolist() == [cs.BALL, cs.BOX, cs.CAPSULE, cs.CYLINDER, cs.BALL]
    W = np.zeros((1, 4))
    tol = cs.TOLERANCE
    for o, shape in enumerate(shapes):
        centre = shape.pose[:3, 3]
        for c in centre + rng.normal(scale=0.25, size=(400, 3)):
            W[0, :3], W[0, 3] = c, rng.uniform(0.001, 0.05)
            gap = cs._obstacle_gap(W, 0, obstacles, o)
            if shape.kind == "mesh":  # coal's distance from the ball to the hull (signed_distance is a bound)
                M = shape.placement()
                d = coal.distance(coal.Sphere(W[0, 3]), coal.Transform3s(np.eye(3), c), shape.geometry(),
                                  coal.Transform3s(M.rotation, M.translation), coal.DistanceRequest(),
                                  coal.DistanceResult())
                assert gap <= d + 1e-9
            else:
                assert gap == pytest.approx(float(shape.signed_distance(c)[0]) - W[0, 3], abs=1e-12)
            if abs(gap - tol) > 1e-9:  # the squared test, and the slack it reports when it passes
                slack = cs._obstacle_slack(W, 0, obstacles, o, tol, cs.MARGIN_CAP)
                assert (slack >= 0.0) == (gap > tol)
                if slack >= 0.0:
                    assert slack == pytest.approx(min(gap - tol, cs.MARGIN_CAP), abs=1e-9)
                    assert cs._obstacle_slack(W, 0, obstacles, o, tol, 0.5 * slack) == 0.5 * slack


# ------------------------------------------------------------------ conservativeness against coal
def _near_obstacles(robot, q, rng, k, tmp_path):
    """``k`` spheres, boxes, capsules, cylinders and meshes (1-8 cm) centred near random vertices of the arm's
    collision shapes at ``q``: distances to the arm straddle zero around ``q``."""
    shapes = [s for s in robot.collision_geometry(q) if s["joint"] != 0]
    out = []
    for n in range(k):
        s = shapes[rng.integers(len(shapes))]
        local = s["vertices"][rng.integers(len(s["vertices"]))] if s["kind"] == "convex" else np.zeros(3)
        centre = (s["pose"] @ np.append(local, 1.0))[:3] + rng.normal(scale=0.04, size=3)
        size = rng.uniform(0.01, 0.08)
        R = _rotation(rng)
        kind = n % 5
        if kind == 0:
            out.append(Sphere(centre, size))
        elif kind == 1:
            out.append(Box(_pose(centre, R), rng.uniform(0.02, 0.12, 3)))
        elif kind == 2:
            out.append(Capsule(centre - R[:, 0] * size, centre + R[:, 0] * size, 0.5 * size))
        elif kind == 3:
            out.append(Cylinder(_pose(centre, R), size, rng.uniform(0.02, 0.2)))
        else:
            out.append(Mesh(_tetra(tmp_path), _pose(centre, R), scale=size))
    return out


def _coal_pairs(scene, q, data, gd):
    """Per pair: colliding (pair by pair, no broad phase) and coal's signed distance."""
    pin.computeCollisions(scene.model, data, scene.geometry, gd, q, False)
    hit = np.array([res.isCollision() for res in gd.collisionResults])
    pin.computeDistances(scene.model, data, scene.geometry, gd, q)
    d = np.array([res.min_distance for res in gd.distanceResults])
    return hit, d


def _check_scene(robot, scene, Q):
    """The conservativeness checks of one scene over configurations ``Q``; returns (certified, in
    collision)."""
    pre = scene.precheck()
    assert pre is not None
    arrays = pre[2:4]
    data, gd = scene.model.createData(), pin.GeometryData(scene.geometry)
    for req in gd.collisionRequests:
        req.security_margin = 0.0
    certified = cs.certify(pre, Q)
    assert certified.tolist() == [cs.certify_configuration(*arrays, q, cs.TOLERANCE) for q in Q]
    truth = []
    for q, cert in zip(Q, certified):
        hit, d = _coal_pairs(scene, q, data, gd)
        bounds = cs.pair_lower_bounds(*arrays, q)
        # every bound is below coal's distance (below 0 for a colliding pair)
        assert np.all(bounds <= np.where(hit, 0.0, d) + 1e-6), np.flatnonzero(bounds > np.where(hit, 0.0, d) + 1e-6)
        assert not (cert and hit.any()), "a configuration in collision was certified"
        certain = cs.certainly_colliding(*arrays, q, cs.TOLERANCE)
        assert not (certain and not hit.any()), "a free configuration was found in collision for certain"
        assert not (certain and cert)
        _check_scene.certain += int(certain)
        if np.abs(bounds - cs.TOLERANCE).min() > 1e-9:
            assert cert == bool(np.all(bounds > cs.TOLERANCE))
        truth.append(bool(hit.any()))
    truth = np.array(truth)
    assert [scene.in_collision(q) for q in Q] == truth.tolist()
    for lo in range(0, len(Q), 6):  # paths of six, the answer of each is its first collision
        chunk = list(Q[lo:lo + 6])
        expected = next((k for k, t in enumerate(truth[lo:lo + 6]) if t), -1)
        assert scene.first_collision(chunk) == expected
    return certified, truth


_check_scene.certain = 0  # configurations found in collision for certain (inner points), over the calls


def test_panda_with_obstacles_near_the_arm_is_never_certified_in_collision(tmp_path):
    """Four scenes (table, wall and five obstacles at the arm's surface near a configuration ``q_s``), 300
    configurations each: half around ``q_s`` (grazing contacts), half uniform. Neither verdict of the
    pre-check is ever wrong: certified free is free, in collision for certain is in collision (coal)."""
    robot = robots.load("panda")
    rng = np.random.default_rng(7)
    certified_total = hits_total = 0
    _check_scene.certain = 0
    for _ in range(4):
        q_s = robot.random_q(rng)
        scene = robot.collision_scene(SCENE + _near_obstacles(robot, q_s, rng, 5, tmp_path))
        near = np.clip(q_s + rng.normal(scale=0.05, size=(150, robot.nq)), robot.lower, robot.upper)
        Q = np.concatenate([near, robot.random_q(rng, 150)])
        certified, truth = _check_scene(robot, scene, Q)
        certified_total += int(certified.sum())
        hits_total += int(truth.sum())
    assert 200 < hits_total < 1000 and certified_total > 200  # both answers occur: the checks have substance
    assert _check_scene.certain > 50  # and collisions found for certain


def test_ur5_self_and_obstacles_are_never_certified_in_collision(tmp_path):
    robot = robots.load("ur5")
    rng = np.random.default_rng(8)
    q_s = robot.random_q(rng)
    scene = robot.collision_scene(SCENE[1:] + _near_obstacles(robot, q_s, rng, 5, tmp_path))
    near = np.clip(q_s + rng.normal(scale=0.05, size=(500, robot.nq)), robot.lower, robot.upper)
    certified, truth = _check_scene(robot, scene, np.concatenate([near, robot.random_q(rng, 500)]))
    assert 50 < truth.sum() < 900 and certified.sum() > 100
    self_only = robot.collision_scene([])
    certified, truth = _check_scene(robot, self_only, robot.random_q(rng, 300))
    assert truth.sum() > 10 and certified.sum() > 100


#: Floor of the open scene's certification rate (measured: 93 % of 1000 collision-free random configurations).
OPEN_SCENE_FLOOR = 0.85


def test_open_scene_certification_rate():
    robot = robots.load("panda")
    scene = robot.collision_scene(SCENE)
    Q = robot.random_q(np.random.default_rng(9), 1000)
    data, gd = scene.model.createData(), pin.GeometryData(scene.geometry)
    truth = np.array([pin.computeCollisions(scene.model, data, scene.geometry, gd, q, True) for q in Q])
    certified = cs.certify(scene.precheck(), Q)
    assert not np.any(certified & truth)
    rate = certified[~truth].mean()
    print(f"open scene: {100 * rate:.1f} % of {int((~truth).sum())} collision-free configurations certified")
    assert rate >= OPEN_SCENE_FLOOR


# ------------------------------------------------------------------ integration
def test_scene_checks_share_the_layout_precheck_and_follow_moved_obstacles():
    """Scenes of one layout share its pre-check (robot spheres, pair table) and each certifies with its own
    obstacle poses: a cube moved onto the arm makes the same configuration uncertified (and colliding)."""
    robot = robots.load("panda")
    q = np.array([0.0, 0.3, 0.0, -2.0, 0.0, 2.6, 0.8])
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, q)
    elbow = data.oMi[robot.model.getJointId("panda_joint4")].translation
    away = robot.collision_scene(SCENE + [Box(_pose(elbow + (0.0, 0.0, 0.6)), (0.1, 0.1, 0.1))])
    onto = robot.collision_scene(SCENE + [Box(_pose(elbow), (0.1, 0.1, 0.1))])
    assert away.layout is onto.layout and away.layout.precheck() is onto.layout.precheck()
    layout_check = away.layout.precheck()
    for scene in (away, onto):
        # rows copied from the layout's own obstacles or placed: as packed from scratch
        rows = np.array([cs.obstacle_row(shape.geometry(), shape.placement()) for shape in scene.obstacles])
        floats, ints = cs.pack(layout_check.robot, layout_check.pairs, rows)
        assert np.allclose(scene.precheck()[2], floats, rtol=0, atol=1e-15)
        assert np.array_equal(scene.precheck()[3], ints)
    assert cs.certify(away.precheck(), [q])[0] and not cs.certify(onto.precheck(), [q])[0]
    assert not away.in_collision(q) and onto.in_collision(q)
    assert away.first_collision([q, q]) == -1 and onto.first_collision([q, q]) == 0


def test_unpackable_robots_keep_the_coal_path(monkeypatch):
    """Without a packing (here: forced) the layout has no pre-check and the scene answers through coal alone;
    so with the module's switch off."""
    from kinserve.kinematics import collision_layout

    robot = robots.load("ur5")
    monkeypatch.setattr(cs, "robot_spheres_of", lambda cmodel: None)
    scene = robot.collision_scene([Sphere((0.3, 0.1, 0.2), 0.07)])
    layout = scene.layout
    monkeypatch.setattr(layout, "_precheck", collision_layout._UNBUILT)  # built again, without the packing
    monkeypatch.setattr(scene, "_precheck", collision_layout._UNBUILT)
    assert layout.precheck() is None and scene.precheck() is None
    data, gd = scene.model.createData(), pin.GeometryData(scene.geometry)
    Q = robot.random_q(np.random.default_rng(10), 100)
    truth = [bool(pin.computeCollisions(scene.model, data, scene.geometry, gd, q, True)) for q in Q]
    assert [scene.in_collision(q) for q in Q] == truth and any(truth)
    assert scene.first_collision(list(Q)) == truth.index(True)
    monkeypatch.undo()
    monkeypatch.setattr(collision_layout, "SPHERE_PRECHECK", False)  # the switch: coal alone for new layouts
    monkeypatch.setattr(layout, "_precheck", collision_layout._UNBUILT)
    assert layout.precheck() is None


def test_first_collision_on_threads_matches_serial():
    robot = robots.load("panda")
    scene = robot.collision_scene(SCENE + [Sphere((0.4, 0.0, 0.5), 0.1)])
    paths = list(robot.random_q(np.random.default_rng(11), 600).reshape(100, 6, robot.nq))
    serial = [scene.first_collision(list(p)) for p in paths]
    with ThreadPoolExecutor(4) as pool:
        parallel = list(pool.map(lambda p: scene.first_collision(list(p)), paths))
    assert parallel == serial and len(set(serial)) > 2


def test_inputs_that_are_not_configurations_reach_coal():
    """Wrong sizes and types are not certified: coal answers or raises as it did without the pre-check."""
    robot = robots.load("panda")
    scene = robot.collision_scene(SCENE)
    with pytest.raises((ValueError, RuntimeError)):
        scene.in_collision(np.zeros(6))
    with pytest.raises((ValueError, RuntimeError)):
        scene.first_collision([np.zeros(8)])
    with pytest.raises(Exception):
        scene.in_collision([0.0] * 7)  # a list: Pinocchio's own argument error, as before
    q = np.zeros(7)
    assert scene.in_collision(q.astype(np.float32)) == scene.in_collision(q)
    assert scene.first_collision([]) == -1
    assert scene.first_collision(iter([q, q])) == scene.first_collision([q, q])


def test_precheck_is_built_by_first_collision_or_after_the_first_in_collision_calls():
    """A new layout answers its first PRECHECK_AFTER in_collision calls with coal alone (a process's first
    checks never wait for the build); the next call, or any first_collision, builds it."""
    from kinserve.kinematics import collision_layout

    robot = robots.load("panda")
    Q = robot.random_q(np.random.default_rng(12), collision_layout.PRECHECK_AFTER + 1)
    scene = robot.collision_scene([Sphere((0.5, 0.3, 0.4), 0.0731)])  # a shape of its own: a new layout
    layout = scene.layout
    assert layout.coal_checks == 0
    for q in Q[:-1]:
        scene.in_collision(q)
    assert (layout._precheck is collision_layout._UNBUILT
            and layout.coal_checks == collision_layout.PRECHECK_AFTER)
    scene.in_collision(Q[-1])
    assert (layout._precheck is not collision_layout._UNBUILT
            and scene._precheck is not collision_layout._UNBUILT)
    other = robot.collision_scene([Sphere((0.5, 0.3, 0.4), 0.0732)])
    other.first_collision([Q[0]])
    assert other.layout._precheck is not collision_layout._UNBUILT and other.layout.coal_checks == 0


def test_first_checks_of_a_process_do_not_load_the_precheck():
    """In a fresh interpreter a scene's first in_collision calls are coal's alone - the pre-check module (and
    Numba) is not even imported, so the start checks of a process's first IK solve, inside its time budget, do
    not pay for it - and the first collision-aware solve succeeds (its path check builds the pre-check)."""
    import subprocess
    import sys

    code = (
        "import sys\n"
        "import numpy as np\n"
        "from kinserve import robots, ik\n"
        "robot = robots.load('panda')\n"
        "T = np.eye(4); T[:3, 3] = (0.65, 0.0, -0.05)\n"
        "table = [ik.Box(T, (0.7, 1.2, 0.1))]\n"
        "scene = robot.collision_scene(table)\n"
        "answers = [scene.in_collision(q) for q in robot.random_q(np.random.default_rng(0), 10)]\n"
        "print('kinserve.kinematics.collision_spheres' in sys.modules)\n"
        "q = np.array([0.0, 0.3, 0.0, -2.0, 0.0, 2.6, 0.8])\n"
        "res = ik.solve(robot, robot.fk(q, 'panda_link8'), robot.neutral(), frame='panda_link8',\n"
        "               self_collision=True, obstacles=table, seed=0, max_time=2.0)\n"
        "print(res.success, res.info.get('collision') == 'unconstrained, checked')\n"
        "print('kinserve.kinematics.collision_spheres' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.split() == ["False", "True", "True", "True"]


# ------------------------------------------------------------------ paths: rows certified by displacement
def _world_centres(spheres, q) -> np.ndarray:
    """Every sphere centre of ``spheres`` (a RobotSpheres) in the world at ``q``: the packed tree's forward
    kinematics, then ``oMj * c`` per sphere."""
    X = np.empty((len(spheres.joints) + 1, 12))
    cs.tree_placements(spheres.tree, spheres.joints, q, X)
    out = []
    for g, (row, first, end) in enumerate(spheres.geoms):
        for s in (g, *range(first, end)):
            R, t = X[row, :9].reshape(3, 3), X[row, 9:12]
            out.append(t + R @ spheres.spheres[s, :3])
    return np.array(out)


@pytest.mark.parametrize("name", ["panda", "ur5", "scara", "pr"])
def test_joint_reach_bounds_every_sphere_displacement(name):
    """``sum_k R_k |dq_k|`` bounds how far any sphere centre moves from ``q`` to ``q + dq``, for steps from a
    microradian to the whole joint range, one joint or all at once; and the bound of a typical revolute joint
    is within a factor of ~5 of the largest displacement seen (not vacuous)."""
    robot = robots.load(name)
    spheres = cs.robot_spheres_of(robot.collision)
    assert spheres is not None and spheres.reach.shape == (len(spheres.joints),)
    assert np.all(spheres.reach >= 0.0) and np.all(spheres.reach < cs.UNBOUNDED_REACH)  # 0: nothing below
    rng = np.random.default_rng(11)
    idx = spheres.joints[:, 1]
    ratio = np.zeros(len(idx))
    for _ in range(300):
        q = robot.random_q(rng)
        scale = 10.0 ** rng.uniform(-6, 0)
        if rng.random() < 0.5:  # one joint
            k = rng.integers(len(idx))
            q2 = q.copy()
            q2[idx[k]] = rng.uniform(robot.lower[idx[k]], robot.upper[idx[k]])
        else:
            q2 = np.clip(q + scale * rng.normal(size=robot.nq), robot.lower, robot.upper)
        moved = np.linalg.norm(_world_centres(spheres, q2) - _world_centres(spheres, q), axis=1).max()
        bound = float(np.sum(spheres.reach * np.abs(q2[idx] - q[idx])))
        assert moved <= bound * (1 + 1e-9) + 1e-12
        if rng.random() < 0.5:
            continue
        for k in range(len(idx)):  # a small turn of joint k alone: the tightness of its bound
            q3 = q.copy()
            q3[idx[k]] = min(q[idx[k]] + 1e-3, robot.upper[idx[k]])
            step = q3[idx[k]] - q[idx[k]]
            if step > 0 and spheres.reach[k] > 0.0:
                moved = np.linalg.norm(_world_centres(spheres, q3) - _world_centres(spheres, q), axis=1).max()
                ratio[k] = max(ratio[k], moved / (spheres.reach[k] * step))
    revolute = spheres.joints[:, 0] == 0
    # a wrist's spheres may sit on its axis (the bound counts their distance to the joint's origin): the
    # typical joint, not every one
    moving = revolute & (spheres.reach > 0.0)
    assert np.median(ratio[moving]) > 0.2 and ratio[moving][0] > 0.2, ratio


def _coal_hits(scene, Q) -> np.ndarray:
    data, gd = scene.model.createData(), pin.GeometryData(scene.geometry)
    return np.array([pin.computeCollisions(scene.model, data, scene.geometry, gd, q, True) for q in Q])


def test_first_uncertified_on_converging_paths_matches_every_row_certified(tmp_path):
    """IK-like paths (rows closing in geometrically on an answer near the arm's obstacles, the answer first,
    as the IK checks them): the index ``first_uncertified`` returns - skipping rows close to one it
    certified - is the first row that certification row by row (``certify_configurations``) does not certify,
    and coal finds every row before it free."""
    robot = robots.load("panda")
    rng = np.random.default_rng(12)
    checked = stopped = 0
    for _ in range(3):
        q_s = robot.random_q(rng)
        scene = robot.collision_scene(SCENE + _near_obstacles(robot, q_s, rng, 5, tmp_path))
        pre = scene.precheck()
        floats, ints, tol = pre[2], pre[3], pre[4]
        for _ in range(40):
            answer = np.clip(q_s + rng.normal(scale=0.3, size=robot.nq), robot.lower, robot.upper)
            start = robot.random_q(rng)
            rows = np.array([answer + (start - answer) * 0.5 ** (12 - k) for k in range(13)])
            rows = np.clip(rows, robot.lower, robot.upper)
            k = cs.first_uncertified(floats, ints, rows, 0, tol)
            each = cs.certify_configurations(floats, ints, rows, tol)
            assert k == (len(rows) if each.all() else int(np.argmin(each)))
            assert not _coal_hits(scene, rows[:k]).any()
            checked += k
            stopped += int(k < len(rows))
    assert checked > 300 and stopped > 10, (checked, stopped)  # rows certified, and paths stopped short


def test_first_uncertified_skips_rows_near_a_certified_one():
    """A path of 3000 rows within a micro-radian of each other costs a small fraction of certifying each row:
    the rows after the first are certified by their displacement, without forward kinematics."""
    import time

    robot = robots.load("panda")
    scene = robot.collision_scene(SCENE)
    pre = scene.precheck()
    floats, ints, tol = pre[2], pre[3], pre[4]
    rng = np.random.default_rng(13)
    q = next(q for q in robot.random_q(rng, 50) if cs.certify_configuration(floats, ints, q, tol))
    rows = q + 1e-9 * np.arange(3000)[:, None]
    assert cs.first_uncertified(floats, ints, rows, 0, tol) == 3000 and cs.certify_configurations(
        floats, ints, rows, tol).all()

    def best(fn):
        times = []
        for _ in range(5):
            t0 = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t0)
        return min(times)

    skip = best(lambda: cs.first_uncertified(floats, ints, rows, 0, tol))
    each = best(lambda: cs.certify_configurations(floats, ints, rows, tol))
    assert skip < 0.25 * each, (skip, each)
