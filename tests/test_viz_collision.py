"""Scene.for_robot(..., collision=True): the collision shapes and obstacles are drawn, colliding bodies
highlighted."""

import numpy as np
import pinocchio as pin
import pytest

from kinserve import ik, robots
from kinserve.kinematics.errors import InputError
from kinserve.viz import colors
from kinserve.viz.collision_drawing import CLEAR_COLOR, COLLIDING_COLOR, OBSTACLE_COLOR, draw_shape
from kinserve.viz.scene import Scene

Q_DOWN = [0.0, 1.5, 0.0, -0.5, 0.0, 1.0, 0.0]


def _table():
    T = np.eye(4)
    T[:3, 3] = (0.65, 0.0, -0.05)
    return ik.Box(T, (0.7, 1.2, 0.1))


def _color(scene, name):
    return scene.object(name)["object"]["materials"][0]["color"]


def test_collision_shapes_drawn_at_their_poses_with_colliding_links_highlighted():
    panda = robots.load("panda")
    table, far = _table(), ik.Sphere((3.0, 3.0, 3.0), 0.1)
    scene = Scene.for_robot(panda, Q_DOWN, collision=True, obstacles=[table, far])
    gm = panda.collision.geometry
    data = panda.model.createData()
    pin.forwardKinematics(panda.model, data, np.array(Q_DOWN))
    hit = {n for pair in panda.collisions(Q_DOWN, [table, far]) for n in pair}
    assert "panda_hand" in hit and "obstacle[0]:box" in hit
    for g, link in zip(gm.geometryObjects, panda.collision.links):
        path = f"panda_collision/{g.name}"
        assert scene.object(path) is not None
        expected = (data.oMi[g.parentJoint] * g.placement).homogeneous
        assert np.allclose(scene.transform(path), expected, atol=1e-9)
        want = COLLIDING_COLOR if link in hit else CLEAR_COLOR
        assert _color(scene, path) == colors.to_int(want)
    assert _color(scene, "obstacles/0") == colors.to_int(COLLIDING_COLOR)
    assert _color(scene, "obstacles/1") == colors.to_int(OBSTACLE_COLOR)
    # a collision-free configuration: nothing red
    free = Scene.for_robot(panda, panda.neutral(), collision=True, obstacles=[table])
    assert all(_color(free, f"panda_collision/{g.name}") == colors.to_int(CLEAR_COLOR)
               for g in gm.geometryObjects)


def test_primitive_robot_and_default_scene_without_collision():
    scara = robots.load("scara")
    scene = Scene.for_robot(scara, collision=True)
    assert {p.rsplit("/", 1)[1] for p in scene.paths()
            if "/scara_collision/" in p} == set(scara.collision.geometry_names)
    assert not any("_collision" in p for p in Scene.for_robot(scara).paths())


def test_unknown_shape_kind_is_an_error():
    with pytest.raises(InputError, match="cannot draw a shape of kind 'torus'"):
        draw_shape(Scene(), "x", {"kind": "torus"}, "red")
