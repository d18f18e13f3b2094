"""Carried objects (robot.attach / detach) against independent code: the object's world pose composed here
from Pinocchio's frame placement, and its collisions and distances decided pair by pair by coal on a
GeometryModel built in this test from the URDF and SRDF (test_kinematics_collision's), never by kinserve's
collision model, sphere pre-check or broad phase."""

from __future__ import annotations

import pickle
import threading

import coal
import numpy as np
import pinocchio as pin
import pytest
from test_kinematics_collision import _independent

import kinserve
from kinserve import ik, robots
from kinserve.kinematics import errors
from kinserve.kinematics.shapes import Box, Capsule, Cylinder, Mesh, Sphere

from collision_scenes import pose, tetrahedron_file

URDF = "panda_description/urdf/panda.urdf"
SRDF = "panda_description/srdf/panda.srdf"
LOCKED = ("panda_finger_joint1", "panda_finger_joint2")

#: The carried box of most tests: 12 x 8 x 20 cm, its own pose and its pose in the frame both rotated and
#: shifted, so that a wrong composition order moves it.
BOX = Box(pose((0.0, 0.03, 0.04), pin.rpy.rpyToMatrix(0.0, 0.0, 0.4)), (0.14, 0.08, 0.3))
IN_FRAME = pose((0.01, 0.02, 0.06), pin.rpy.rpyToMatrix(0.3, 0.0, 0.0))
FRAME = "panda_hand_tcp"


def coal_geometry(shape) -> coal.CollisionGeometry:
    """coal's primitive of a kinserve shape, built here from its fields (not from ``shape.geometry()``)."""
    if shape.kind == "box":
        return coal.Box(*shape.size)
    if shape.kind == "sphere":
        return coal.Sphere(shape.radius)
    if shape.kind == "cylinder":
        return coal.Cylinder(shape.radius, shape.length)
    raise AssertionError(shape.kind)


def _transform(T: np.ndarray) -> coal.Transform3s:
    return coal.Transform3s(np.array(T[:3, :3]), np.array(T[:3, 3]))


class Independent:
    """The Panda (URDF hulls, SRDF pairs), box / sphere obstacles and carried shapes, checked by coal pair by
    pair. A carried shape is ``(name, shape, frame, pose_in_frame, touch_links)``."""

    def __init__(self, obstacles=()) -> None:
        self.obstacles = list(obstacles)
        self.model, self.geom = _independent("panda", URDF, SRDF, LOCKED, scene=self.obstacles)
        self.data, self.gdata = self.model.createData(), pin.GeometryData(self.geom)
        self.n_robot = self.geom.ngeoms - len(self.obstacles)
        self.names = [self.model.frames[g.parentFrame].name for g in self.geom.geometryObjects[:self.n_robot]]
        self.names += [f"obstacle[{k}]:{ob.kind}" for k, ob in enumerate(self.obstacles)]

    def world_pose(self, q, carried) -> np.ndarray:
        """``fk(q, frame) @ pose_in_frame @ shape.pose``, with Pinocchio's own frame placement."""
        _, shape, frame, in_frame, _ = carried
        pin.forwardKinematics(self.model, self.data, q)
        oMf = pin.updateFramePlacement(self.model, self.data, self.model.getFrameId(frame)).homogeneous
        return oMf @ in_frame @ shape.pose

    def _joint(self, frame: str) -> int:
        return int(self.model.frames[self.model.getFrameId(frame)].parentJoint)

    def _others(self, carried, self_collision: bool):
        """``(index, name)`` of the geometries the carried shape is checked against."""
        joint, touch = self._joint(carried[2]), set(carried[4])
        for i, g in enumerate(self.geom.geometryObjects):
            if i >= self.n_robot:
                yield i, self.names[i]
            elif self_collision and g.parentJoint != joint and self.names[i] not in touch:
                yield i, self.names[i]

    def pairs(self, q, carried=(), self_collision: bool = True) -> set[frozenset]:
        """Every colliding pair at ``q`` as a set of frozensets of names (links, obstacles, carried)."""
        pin.computeCollisions(self.model, self.data, self.geom, self.gdata, q, False)
        n_self = sum(1 for cp in self.geom.collisionPairs if cp.second < self.n_robot)
        out = set()
        for k, cp in enumerate(self.geom.collisionPairs):
            if (self_collision or k >= n_self) and self.gdata.collisionResults[k].isCollision():
                out.add(frozenset((self.names[cp.first], self.names[cp.second])))
        placed = [(c, coal_geometry(c[1]), _transform(self.world_pose(q, c))) for c in carried]
        req = coal.CollisionRequest()
        for n, (c, g, tf) in enumerate(placed):
            for i, name in self._others(c, self_collision):
                res = coal.CollisionResult()
                if coal.collide(g, tf, self.geom.geometryObjects[i].geometry,
                                _transform(self.gdata.oMg[i].homogeneous), req, res):
                    out.add(frozenset(("attached:" + c[0], name)))
            for c2, g2, tf2 in placed[n + 1:] if self_collision else ():
                if self._joint(c[2]) != self._joint(c2[2]) and coal.collide(g, tf, g2, tf2, req,
                                                                           coal.CollisionResult()):
                    out.add(frozenset(("attached:" + c[0], "attached:" + c2[0])))
        return out

    def distances(self, q, carried) -> dict[str, float]:
        """``{other name: signed distance}`` of one carried shape to everything it is checked against."""
        pin.updateGeometryPlacements(self.model, self.data, self.geom, self.gdata, q)
        g, tf = coal_geometry(carried[1]), _transform(self.world_pose(q, carried))
        out = {}
        for i, name in self._others(carried, True):
            res = coal.DistanceResult()
            d = coal.distance(g, tf, self.geom.geometryObjects[i].geometry,
                              _transform(self.gdata.oMg[i].homogeneous), coal.DistanceRequest(), res)
            out[name] = min(out.get(name, np.inf), float(d))
        return out


def _names(pairs) -> set[frozenset]:
    return {frozenset(p) for p in pairs}


@pytest.fixture
def panda():
    return robots.load("panda")


def _near_box_scene(robot, rng, n: int, m: int) -> tuple[list, np.ndarray]:
    """``n`` boxes and spheres (4-14 cm) each near the carried box at one random configuration, and ``m``
    configurations around those (normal, 0.25 rad): the carried box's answers straddle contact."""
    anchors = robot.random_q(rng, n)
    out = []
    for k, q in enumerate(anchors):
        centre = robot.attached_poses(q)["box"][:3, 3] + rng.normal(scale=0.05, size=3)
        size = rng.uniform(0.04, 0.14)
        R = pin.rpy.rpyToMatrix(*rng.uniform(-np.pi, np.pi, 3))
        out.append(Sphere(centre, 0.5 * size) if k % 2 else Box(pose(centre, R), rng.uniform(0.04, 0.14, 3)))
    near = anchors[rng.integers(n, size=m)] + rng.normal(scale=0.25, size=(m, robot.nq))
    return out, np.clip(near, robot.lower, robot.upper)


def test_world_pose_is_frame_pose_times_pose_in_frame_times_shape_pose(panda):
    panda.attach("box", BOX, FRAME, IN_FRAME)
    ref = Independent()
    carried = ("box", BOX, FRAME, IN_FRAME, ())
    geometry = {s["link"]: s for s in panda.collision_geometry(panda.neutral())}
    assert geometry["attached:box"]["kind"] == "box"
    assert np.allclose(geometry["attached:box"]["size"], BOX.size)
    for q in panda.random_q(np.random.default_rng(1), 20):
        expected = ref.world_pose(q, carried)
        assert np.allclose(panda.attached_poses(q)["box"], expected, atol=1e-12)
        # the collision model's geometry sits there too (what coal is given, not only what is reported)
        assert np.allclose({s["link"]: s for s in panda.collision_geometry(q)}["attached:box"]["pose"],
                           expected, atol=1e-12)
    # the composition order matters here: the other orders put the box elsewhere
    q = panda.neutral()
    oMf = panda.fk(q, FRAME)
    assert not np.allclose(oMf @ BOX.pose @ IN_FRAME, panda.attached_poses(q)["box"], atol=1e-3)
    obj = panda.attached["box"]
    assert obj.frame == FRAME and obj.touch_links == ("panda_hand",)  # the link the tcp frame belongs to
    assert not obj.placement.flags.writeable and not obj.pose_in_frame.flags.writeable


def test_queries_agree_with_independent_coal_on_random_configurations(panda):
    rng = np.random.default_rng(2)
    panda.attach("box", BOX, FRAME, IN_FRAME)
    obstacles, near = _near_box_scene(panda, rng, 6, 120)
    ref = Independent(obstacles)
    carried = [("box", BOX, FRAME, IN_FRAME, panda.attached["box"].touch_links)]
    scene = panda.collision_scene(obstacles)
    pre = scene.precheck()
    assert pre is not None
    Q = np.concatenate([panda.random_q(rng, 160), near])
    box_hits = {"obstacle": 0, "link": 0, "free": 0}
    certified = 0
    for q in Q:
        expected = ref.pairs(q, carried)
        got = _names(panda.collisions(q, obstacles))
        assert got == expected, q.tolist()
        assert panda.in_collision(q, obstacles) == bool(expected)
        assert panda.in_collision(q) == any(not any(n.startswith("obstacle") for n in p) for p in expected)
        # the sphere pre-check never certifies a configuration coal finds colliding
        if pre.certify(pre.floats, pre.ints, q, pre.tolerance):
            certified += 1
            assert not expected, q.tolist()
        box = {n for p in expected if "attached:box" in p for n in p} - {"attached:box"}
        box_hits["obstacle"] += any(n.startswith("obstacle") for n in box)
        box_hits["link"] += any(n.startswith("panda") for n in box)
        box_hits["free"] += not box
    # every kind of answer occurs, so the comparison can fail either way
    assert min(box_hits.values()) >= 20, box_hits
    assert certified >= 20
    # batch form (the IK's and planner's): the first colliding row
    first = scene.first_collision(Q[:40])
    expected_first = next((k for k, q in enumerate(Q[:40]) if ref.pairs(q, carried)), -1)
    assert first == expected_first


def test_distances_and_min_distance_see_the_box(panda):
    rng = np.random.default_rng(3)
    panda.attach("box", BOX, FRAME, IN_FRAME)
    obstacles = _near_box_scene(panda, rng, 2, 0)[0]
    ref = Independent(obstacles)
    carried = ("box", BOX, FRAME, IN_FRAME, panda.attached["box"].touch_links)
    signs = set()
    for q in panda.random_q(rng, 40):
        got = panda.distances(q, obstacles)
        expected = ref.distances(q, carried)
        ours = {(set(k) - {"attached:box"}).pop(): d for k, d in got.items() if "attached:box" in k}
        assert set(ours) == set(expected)
        for name, d in expected.items():
            assert ours[name].distance == pytest.approx(d, abs=1e-5), name
            signs.add(d < 0)
            w = ours[name]
            assert np.allclose(w.point_b - w.point_a, w.distance * w.normal, atol=1e-6)
        smallest = panda.min_distance(q, obstacles)  # (GJK's tolerance: a few 1e-7 m between queries)
        assert smallest == pytest.approx(min(d.distance for d in got.values()), abs=1e-5)
        assert smallest <= min(expected.values()) + 1e-5
    assert signs == {True, False}


def _overlapping_pose(robot, frame: str, link: str) -> np.ndarray:
    """The pose in ``frame`` of ``link``'s origin at the neutral configuration."""
    q = robot.neutral()
    return np.linalg.inv(robot.fk(q, frame)) @ robot.fk(q, link)


def test_touch_links_same_body_and_two_objects(panda):
    q = panda.neutral()
    assert not panda.collisions(q)
    ball = Sphere((0.0, 0.0, 0.0), 0.03)
    at_link6 = _overlapping_pose(panda, "panda_link7", "panda_link6")
    # a ball on link 7 placed inside link 6: reported against link 6, which moves relative to it
    a = panda.copy().attach("ball", ball, "panda_link7", at_link6)
    assert ("panda_link6", "attached:ball") in a.collisions(q)
    # named as a touch link, link 6 is never reported; the default touch link is the frame's own link
    assert a.attached["ball"].touch_links == ("panda_link7",)
    b = panda.copy().attach("ball", ball, "panda_link7", at_link6, touch_links=["panda_link6", "panda_link5"])
    assert not any("attached:ball" in p for p in b.collisions(q))
    assert not b.in_collision(q)
    # the hand shares link 7's joint: a ball inside the hand, carried by link 7, is never reported
    in_hand = _overlapping_pose(panda, "panda_link7", "panda_hand")
    c = panda.copy().attach("ball", ball, "panda_link7", in_hand)
    assert not c.in_collision(q) and "attached:ball" in c.collision.links
    # two objects on different bodies are checked against each other; on one body, not
    d = panda.copy().attach("a", ball, "panda_link7", at_link6, touch_links=["panda_link6", "panda_link5"])
    d.attach("b", ball, "panda_link5", _overlapping_pose(panda, "panda_link5", "panda_link6"),
             touch_links=["panda_link6", "panda_link7"])
    assert _names(d.collisions(q)) == {frozenset(("attached:a", "attached:b"))}
    e = panda.copy().attach("a", ball, "panda_link7", at_link6, touch_links=["panda_link6", "panda_link5"])
    in_link6 = _overlapping_pose(panda, "panda_hand", "panda_link6")
    e.attach("b", Sphere((0.0, 0.0, 0.0), 0.02), "panda_hand", in_link6, ("panda_link6", "panda_link5"))
    assert not e.in_collision(q)
    # against an obstacle without self-collision: still checked (a ball held 30 cm beside link 7)
    f = panda.copy().attach("ball", ball, "panda_link7", pose((0.0, 0.3, 0.0)))
    near = [Sphere(f.attached_poses(q)["ball"][:3, 3] + (0.0, 0.0, 0.05), 0.03)]
    assert f.collisions(q, near, self_collision=False) == [("attached:ball", "obstacle[0]:sphere")]
    assert not panda.in_collision(q, near, self_collision=False)


def test_detach_restores_and_other_robots_are_unchanged(panda):
    rng = np.random.default_rng(4)
    obstacles = [Box(pose((0.5, 0.0, 0.3)), (0.1, 0.3, 0.05))]
    Q = panda.random_q(rng, 100)
    bare = [panda.collisions(q, obstacles) for q in Q]
    earlier_copy = panda.copy()
    panda.attach("box", BOX, FRAME, IN_FRAME)
    carried = [panda.collisions(q, obstacles) for q in Q]
    assert carried != bare and sum("attached:box" in str(p) for p in carried) >= 5
    # another load of the same (cached) model, an earlier copy: bare answers, bare model
    other = robots.load("panda")
    assert other.model is panda.model and not other.attached and not earlier_copy.attached
    assert [other.collisions(q, obstacles) for q in Q] == bare
    assert [earlier_copy.collisions(q, obstacles) for q in Q] == bare
    assert other.collision is other.bare_collision is panda.bare_collision
    # a later copy and a pickled robot carry the box; attaching to the copy does not reach back
    later = panda.copy()
    clone = pickle.loads(pickle.dumps(panda))
    assert [later.collisions(q, obstacles) for q in Q] == carried
    assert [clone.collisions(q, obstacles) for q in Q] == carried
    later.attach("ball", Sphere((0.0, 0.0, 0.0), 0.05), "panda_link4")
    assert "ball" not in panda.attached and "attached:ball" not in panda.collision.links
    # clear_caches forgets caches, not carried objects
    kinserve.clear_caches(panda)
    assert [panda.collisions(q, obstacles) for q in Q] == carried
    assert not robots.load("panda").attached
    obj = panda.detach("box")
    assert obj.name == "box" and not panda.attached
    assert panda.collision is panda.bare_collision
    assert [panda.collisions(q, obstacles) for q in Q] == bare


def test_unpickled_robot_builds_its_model_in_any_thread(panda):
    """The first query of an unpickled carrying robot builds the bare model, then the one with the object,
    under one build lock (taking it twice deadlocked)."""
    panda.attach("box", BOX, FRAME, IN_FRAME)
    clone = pickle.loads(pickle.dumps(panda))
    q = panda.neutral()
    out = []
    worker = threading.Thread(target=lambda: out.append(clone.collisions(q)), daemon=True)
    worker.start()
    worker.join(120.0)
    assert not worker.is_alive(), "the first query after unpickling never returned"
    assert out == [panda.collisions(q)]
    assert clone.attached["box"].to_dict() == panda.attached["box"].to_dict()


def test_threads_each_carrying_on_their_own_copy_do_not_see_each_other(panda):
    shared = panda
    Q = panda.random_q(np.random.default_rng(5), 60)
    barrier = threading.Barrier(2)
    seen, errs = {}, []

    def work(name, size):
        try:
            robot = shared.copy()
            barrier.wait()
            robot.attach(name, Box(np.eye(4), (size, size, 0.3)), FRAME)
            barrier.wait()  # both attached before either queries
            names = {n for q in Q for p in robot.collisions(q) for n in p if n.startswith("attached:")}
            seen[name] = (names, set(robot.attached))
        except BaseException as exc:  # pragma: no cover - reported below
            errs.append(exc)

    threads = [threading.Thread(target=work, args=(n, s)) for n, s in (("left", 0.1), ("right", 0.12))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errs, errs
    assert seen["left"] == ({"attached:left"}, {"left"})
    assert seen["right"] == ({"attached:right"}, {"right"})
    assert not shared.attached and not any("attached" in str(shared.collisions(q)) for q in Q)


@pytest.mark.parametrize("kwargs, words", [
    (dict(name="box"), ["'box'", "already attached"]),
    (dict(name=""), ["name", "non-empty"]),
    (dict(frame="no_such_frame"), ["no_such_frame"]),
    (dict(frame="panda_link0"), ["panda_link0", "fixed to the world"]),
    (dict(touch_links=["panda_link5", "gripper"]), ["touch link", "'gripper'"]),
    (dict(shape="mesh"), ["mesh"]),
    (dict(shape={"kind": "cone"}), ["shape"]),
    (dict(pose_in_frame=pose((np.nan, 0.0, 0.0))), ["pose_in_frame"]),
    (dict(pose_in_frame=np.diag([1.0, 2.0, 1.0, 1.0])), ["pose_in_frame"]),
    (dict(pose_in_frame=np.eye(3)), ["pose_in_frame"]),
])
def test_bad_input_raises_input_error_naming_the_problem(panda, tmp_path, kwargs, words):
    panda.attach("box", BOX, FRAME)
    args = dict(name="cup", shape=Cylinder(np.eye(4), 0.04, 0.1), frame=FRAME, pose_in_frame=None,
                touch_links=None)
    args.update(kwargs)
    if args["shape"] == "mesh":
        args["shape"] = Mesh(tetrahedron_file(tmp_path), scale=0.05)
    with pytest.raises(errors.InputError) as info:
        panda.attach(**args)
    for word in words:
        assert word in str(info.value), str(info.value)
    assert set(panda.attached) == {"box"}  # nothing half-attached
    with pytest.raises(errors.InputError, match="'cup'"):
        panda.detach("cup")


def test_every_primitive_kind_is_carried(panda):
    q = panda.neutral()
    point = (panda.fk(q, FRAME) @ np.array([0.0, 0.0, 0.06, 1.0]))[:3]  # 6 cm beyond the fingertips
    for shape in (Sphere((0.0, 0.0, 0.05), 0.04), Capsule((0.0, -0.1, 0.05), (0.0, 0.1, 0.05), 0.03),
                  Cylinder(pose((0.0, 0.0, 0.05)), 0.04, 0.2), Box(pose((0.0, 0.0, 0.05)), (0.1, 0.1, 0.1))):
        robot = panda.copy().attach("thing", shape, FRAME)
        ahead = [Sphere(point, 0.01)]  # inside each shape, clear of the bare hand
        assert robot.in_collision(q, ahead) and not panda.in_collision(q, ahead), shape.kind
        assert ("attached:thing", "obstacle[0]:sphere") in robot.collisions(q, ahead)


def test_carrying_reuses_the_bare_models_spheres_and_equals_a_model_built_whole(panda):
    """Attaching computes the carried objects' sphere covers, inner radii and viewer data only (the robot's
    are its bare model's); the result equals the sphere model and inner radii computed from nothing over the
    whole geometry, and the viewer data lists every geometry, the carried ones last."""
    import dataclasses

    from kinserve.kinematics.inner_balls import robot_inner_radii
    from kinserve.kinematics.robot_spheres import robot_spheres

    robot = panda.copy().attach("box", BOX, FRAME, IN_FRAME)
    robot.attach("ball", Sphere((0.0, 0.0, 0.05), 0.04), "panda_link5")
    cm, bare = robot.collision, panda.collision
    whole = robot_spheres(cm.model, cm.geometry)
    for f in dataclasses.fields(whole):
        assert np.array_equal(getattr(cm.spheres, f.name), getattr(whole, f.name)), f.name
    radii = robot_inner_radii(cm.geometry, whole.inner, whole.inner_ranges)
    assert np.array_equal(cm.robot_geometry.inner_radii, radii) and len(radii) > len(
        bare.robot_geometry.inner_radii)
    assert np.any(radii[len(bare.robot_geometry.inner_radii):] > 0.0)  # the box and ball hold inner balls
    data = cm.shape_data()
    assert len(data) == cm.geometry.ngeoms == len(bare.shape_data()) + 2
    assert [d["name"] for d in data[-2:]] == ["attached:box", "attached:ball"]
    assert data[-2]["kind"] == "box" and np.allclose(data[-2]["size"], BOX.size)
    assert data[-1]["kind"] == "sphere" and data[-1]["radius"] == pytest.approx(0.04)


def _free_targets(robot, carrying, rng, n: int) -> list:
    """``n`` configurations where the bare arm is free and the carried bar hits the arm, none of its links
    0-2 (near the base the hand's pose may leave the bar no way out)."""
    out = []
    while len(out) < n:
        q = robot.random_q(rng)
        pairs = [p for p in carrying.collisions(q) if "attached:bar" in p]
        if robot.in_collision(q) or not pairs or any(p[0] in ("panda_link0", "panda_link1", "panda_link2")
                                                      for p in pairs):
            continue
        out.append(q)
    return out


def test_ik_with_self_collision_keeps_the_carried_object_free(panda):
    bar = Box(np.eye(4), (0.06, 0.5, 0.06))
    carrying = panda.copy().attach("bar", bar, FRAME)
    ref = Independent()
    carried = [("bar", bar, FRAME, np.eye(4), carrying.attached["bar"].touch_links)]
    for q in _free_targets(panda, carrying, np.random.default_rng(7), 3):
        T = panda.fk(q, "panda_hand")
        plain = ik.solve(panda, T, q, iteration_budget=300, seed=1)
        assert plain.success and ref.pairs(plain.q, carried)  # the bare answer: the bar inside the arm
        res = ik.solve(carrying, T, q, self_collision=True, iteration_budget=3000, seed=1)
        assert res.success, res.message
        assert not ref.pairs(res.q, carried), res.q.tolist()
        assert np.allclose(panda.fk(res.q, "panda_hand"), T, atol=1e-3)


def test_ik_obstacles_alone_see_the_carried_object(panda):
    """``obstacles=`` without ``self_collision``: with something carried, the collision model decides."""
    bar = Box(np.eye(4), (0.04, 0.4, 0.04))
    carrying = panda.copy().attach("bar", bar, FRAME)
    T = pose((0.5, 0.0, 0.35), np.diag([1.0, -1.0, -1.0]))
    kw = dict(frame=FRAME, relax="yaw", iteration_budget=2000, seed=1)
    first = ik.solve(panda, T, panda.neutral(), **kw)
    end = carrying.attached_poses(first.q)["bar"]
    ball = [Sphere(end[:3, 3] + 0.17 * end[:3, 1], 0.04)]  # at one end of the bar
    ref = Independent(ball)
    carried = [("bar", bar, FRAME, np.eye(4), ())]
    plain = ik.solve(panda, T, panda.neutral(), obstacles=ball, **kw)
    assert plain.success and ref.pairs(plain.q, carried, self_collision=False)  # only the arm kept clear
    res = ik.solve(carrying, T, panda.neutral(), obstacles=ball, **kw)
    assert res.success, res.message
    assert not ref.pairs(res.q, carried, self_collision=False)
    # relaxing yaw let the bar turn away from the ball, the rest of the pose is held
    assert np.allclose(panda.fk(res.q, FRAME)[:3, 3], T[:3, 3], atol=1e-3)
