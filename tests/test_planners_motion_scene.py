"""MoveIt planning scenes and motion requests in YAML (planners/motion/scene_yaml.py)."""

import math
import tarfile

import numpy as np
import pytest

from kinserve import robots
from kinserve.kinematics.errors import InputError
from kinserve.kinematics.se3 import matrix_from_rpy
from kinserve.kinematics.shapes import Box, Capsule, Cylinder, Sphere
from kinserve.planners.motion.scene_yaml import (
    MotionRequest,
    joint_vector,
    read_motion_request,
    read_planning_scene,
    write_planning_scene,
)

from shared_data import MBM_DATASET

DATASET = MBM_DATASET


def _pose(xyz, rpy=(0.0, 0.0, 0.0)):
    T = np.eye(4)
    T[:3, :3] = matrix_from_rpy(*rpy)
    T[:3, 3] = xyz
    return T


def _shapes():
    return [Box(_pose([0.5, -0.2, 0.3], [0.1, -0.4, 2.0]), [0.1, 0.2, 0.3]),
            Box(_pose([0.0, 0.0, -0.02]), [2.0, 2.0, 0.04]),
            Cylinder(_pose([0.3, 0.4, 0.5], [1.2, 0.3, -0.7]), radius=0.05, length=0.4),
            Sphere([0.1, 0.7, 0.9], 0.12)]


def test_round_trip_shapes_yaml_shapes():
    shapes = _shapes()
    back = read_planning_scene(write_planning_scene(shapes))
    assert [type(s) for s in back] == [type(s) for s in shapes]
    for a, b in zip(shapes, back):
        da, db = a.to_dict(), b.to_dict()
        assert da.keys() == db.keys()
        assert da.pop("kind") == db.pop("kind")
        for key in da:
            np.testing.assert_allclose(np.asarray(db[key], float), np.asarray(da[key], float), atol=1e-12)
    # poses without rotation travel exactly (the quaternion of the identity is exact)
    assert back[1] == shapes[1] and back[3] == shapes[3]
    # the signed distance of the shapes read back agrees at random points
    pts = np.random.default_rng(0).uniform(-1.0, 1.0, size=(200, 3))
    for a, b in zip(shapes, back):
        np.testing.assert_allclose(b.signed_distance(pts), a.signed_distance(pts), atol=1e-12)


def test_object_pose_composes_with_primitive_poses():
    # an object pose rotated 90 degrees about z, moved by (1, 0, 0); the primitive 0.5 m along its local x
    text = """
world:
  collision_objects:
    - id: shelf
      pose: {position: {x: 1.0, y: 0.0, z: 0.0}, orientation: {x: 0.0, y: 0.0, z: 0.7071067811865476,
             w: 0.7071067811865476}}
      primitives: [{type: box, dimensions: [0.2, 0.4, 0.6]}, {type: 2, dimensions: [0.1]}]
      primitive_poses:
        - {position: [0.5, 0.0, 0.0], orientation: [0, 0, 0, 1]}
        - {position: [0.0, 0.5, 0.0]}
"""
    box, ball = read_planning_scene(text)
    np.testing.assert_allclose(box.pose[:3, 3], [1.0, 0.5, 0.0], atol=1e-12)
    np.testing.assert_allclose(box.pose[:3, :3], [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-12)
    assert box.size == (0.2, 0.4, 0.6)
    np.testing.assert_allclose(ball.center, [0.5, 0.0, 0.0], atol=1e-12)
    assert ball.radius == 0.1


def test_cylinder_is_height_then_radius_along_local_z():
    text = ("world: {collision_objects: [{id: can, primitives: [{type: cylinder, dimensions: [0.3, 0.05]}], "
            "primitive_poses: [{position: [0, 0, 1], orientation: [0, 0, 0, 1]}]}]}")
    (can,) = read_planning_scene(text)
    assert isinstance(can, Cylinder) and can.length == 0.3 and can.radius == 0.05
    # a point on the axis 0.15 m above the centre is on the top face; one 0.05 m off the axis on the side
    np.testing.assert_allclose(can.signed_distance([[0, 0, 1.15], [0.05, 0, 1.0]]), [0.0, 0.0], atol=1e-12)


def _one_object(body: str) -> str:
    return f"world:\n  collision_objects:\n    - id: thing\n{body}"


def _prim(primitive: str, pose: str = "{position: [0, 0, 0]}") -> str:
    return f"      primitives: [{primitive}]\n      primitive_poses: [{pose}]\n"


@pytest.mark.parametrize("body, words", [
    ("      meshes: [{triangles: [], vertices: []}]\n      mesh_poses: [{position: [0, 0, 0]}]\n",
     ["'thing'", "meshes"]),
    (_prim("{type: cone, dimensions: [0.1, 0.1]}"), ["'thing'", "cone"]),
    (_prim("{type: box, dimensions: [0.1, 0.1]}"), ["'thing'", "dimensions", "3 numbers"]),
    ("      primitives: [{type: box, dimensions: [0.1, 0.1, 0.1]}]\n      primitive_poses: []\n",
     ["'thing'", "same length"]),
    (_prim("{type: box, dimensions: [0.1, 0.1, 0.1]}", "{position: [0, 0, 0], orientation: [0, 0, 0, 0]}"),
     ["'thing'", "unit quaternion"]),
    (_prim("{type: box, dimensions: [0.1, -0.1, 0.1]}"), ["'thing'", "positive"]),
    (_prim("{type: sphere, dimensions: [abc]}"), ["'thing'", "numbers"]),
    (_prim("{type: box, dimensions: [0.1, 0.1, 0.1]}", "{position: [0, 0]}"), ["'thing'", "position"]),
])
def test_unsupported_or_malformed_objects_are_named(body, words):
    with pytest.raises(InputError) as info:
        read_planning_scene(_one_object(body))
    for w in words:
        assert w in str(info.value)


def test_octomap_is_refused():
    text = "world:\n  collision_objects: []\n  octomap:\n    octomap: {resolution: 0.02, data: [1, 2, 3]}\n"
    with pytest.raises(InputError, match="octomap"):
        read_planning_scene(text)


@pytest.mark.parametrize("text, words", [
    ("world: {collision_objects: [{id: a, primitives: [", ["not valid YAML", "line"]),
    ("- just\n- a list\n", ["mapping"]),
    ("world: {collision_objects: {id: a}}\n", ["collision_objects", "list"]),
    ("world: {collision_objects: [7]}\n", ["collision_objects[0]", "mapping"]),
])
def test_malformed_yaml_raises_input_error(text, words):
    with pytest.raises(InputError) as info:
        read_planning_scene(text)
    for w in words:
        assert w in str(info.value)


def test_missing_file_is_an_input_error(tmp_path):
    with pytest.raises(InputError, match="cannot be read"):
        read_planning_scene(tmp_path / "absent.yaml")
    with pytest.raises(InputError, match="cannot be read"):
        read_motion_request(str(tmp_path / "absent.yaml"))


def test_writing_a_capsule_is_refused():
    with pytest.raises(InputError, match=r"shapes\[1\].*Capsule"):
        write_planning_scene([Sphere([0, 0, 0], 0.1), Capsule([0, 0, 0], [0, 0, 1], 0.1)])


REQUEST = """
group_name: arm
start_state:
  joint_state:
    name: [j2, j1, finger]
    position: [0.2, -0.1, 0.04]
goal_constraints:
  - joint_constraints:
      - {joint_name: j1, position: 0.5}
      - {position: -0.25, joint_name: j2}
"""


def test_read_motion_request():
    req = read_motion_request(REQUEST)
    assert req == MotionRequest({"j2": 0.2, "j1": -0.1, "finger": 0.04}, {"j1": 0.5, "j2": -0.25}, "arm")


@pytest.mark.parametrize("text, words", [
    ("start_state: {joint_state: {name: [a, b], position: [1]}}\ngoal_constraints: [{joint_constraints: "
     "[{joint_name: a, position: 0}]}]", ["position", "2 numbers"]),
    ("start_state: {joint_state: {name: [a], position: [1]}}\ngoal_constraints: []", ["goal_constraints"]),
    ("start_state: {joint_state: {name: [a], position: [1]}}\ngoal_constraints: [{joint_constraints: "
     "[{position: 0}]}]", ["joint_constraints[0]", "joint_name"]),
    ("start_state: {joint_state: {name: [a], position: [1]}}\ngoal_constraints: [{position_constraints: "
     "[{link_name: hand}]}]", ["pose goal"]),
    ("goal_constraints: [{joint_constraints: [{joint_name: a, position: 0}]}]", ["start_state"]),
])
def test_malformed_requests(text, words):
    with pytest.raises(InputError) as info:
        read_motion_request(text)
    for w in words:
        assert w in str(info.value)


def test_joint_vector_ignores_extra_names_and_names_missing_joints():
    robot = robots.load("planar4r", geometry=False)
    values = {name: 0.1 * (k + 1) for k, name in enumerate(robot.joint_names)}
    q = joint_vector(robot, {**values, "finger": 0.04})
    np.testing.assert_allclose(q, [0.1 * (k + 1) for k in range(robot.nq)])
    del values[robot.joint_names[2]]
    with pytest.raises(InputError, match=robot.joint_names[2]) as info:
        joint_vector(robot, values, "start")
    assert "start" in str(info.value)


@pytest.fixture(scope="module")
def dataset_files(tmp_path_factory):
    archive = DATASET / "panda" / "problems.tar.bz2"
    if not archive.exists():
        pytest.skip(f"MotionBenchMaker dataset not found at {DATASET}")
    out = tmp_path_factory.mktemp("mbm")
    names = ["problems/cage_panda/scene0001.yaml", "problems/cage_panda/request0001.yaml",
             "problems/table_pick_panda/scene0001.yaml"]
    with tarfile.open(archive, "r:bz2") as tar:
        for name in names:
            tar.extract(tar.getmember(name), out, filter="data")
    return out / "problems"


def test_real_scene_of_the_dataset(dataset_files):
    raw = (dataset_files / "cage_panda" / "scene0001.yaml").read_text()
    cage = read_planning_scene(dataset_files / "cage_panda" / "scene0001.yaml")
    assert len(cage) == raw.count("type: box") == 8 and all(isinstance(s, Box) for s in cage)
    cube = cage[0]  # Cube1: 7 cm box, rotated about z by -2 * asin(0.03996...)
    np.testing.assert_allclose(cube.size, [0.07] * 3)
    np.testing.assert_allclose(cube.pose[:3, 3],
                               [0.7444402652852363, -0.1411031622851692, 0.2599367587044526])
    yaw = math.atan2(cube.pose[1, 0], cube.pose[0, 0])
    assert yaw == pytest.approx(-2 * math.asin(0.03996434360673529), abs=1e-12)
    table = read_planning_scene(str(dataset_files / "table_pick_panda" / "scene0001.yaml"))
    kinds = {type(s) for s in table}
    assert Cylinder in kinds and Box in kinds


def test_real_request_of_the_dataset(dataset_files):
    req = read_motion_request(dataset_files / "cage_panda" / "request0001.yaml")
    assert req.group == "panda_arm"
    assert len(req.start) == 9 and len(req.goal) == 7
    model = DATASET / "panda"
    robot = robots.load(model / "panda.urdf", package_dirs=[model], geometry=False, srdf=False)
    np.testing.assert_allclose(joint_vector(robot, req.start, "start"),
                               [0, -0.785, 0, -2.356, 0, 1.571, 0.785])
    assert joint_vector(robot, req.goal, "goal")[4] == 2.8973
