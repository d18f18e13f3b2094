"""kinserve.robots.urdf_loader: continuous joints, joint locking, package dirs, the source round trip."""

import math

import numpy as np
import pinocchio as pin
import pytest

from kinserve.kinematics.errors import ModelError
from kinserve.robots import load_urdf
from kinserve.robots.paths import erd_file, example_robot_data_package_dir

PANDA = "panda_description/urdf/panda.urdf"
KINOVA = "kinova_description/robots/kinova.urdf"


def test_locked_joints_match_pinocchio_reduced_model():
    """Locking by rewriting the URDF gives the kinematics of pinocchio.buildReducedModel."""
    path = erd_file(PANDA)
    full = pin.buildModelFromUrdf(str(path))
    q_lock = pin.neutral(full)
    ids = [full.getJointId("panda_finger_joint1"), full.getJointId("panda_finger_joint2")]
    q_lock[full.joints[ids[0]].idx_q] = 0.03
    q_lock[full.joints[ids[1]].idx_q] = 0.01
    reduced = pin.buildReducedModel(full, ids, q_lock)
    robot = load_urdf(path, locked_joints={"panda_finger_joint1": 0.03, "panda_finger_joint2": 0.01},
                      geometry=False)
    assert robot.nq == reduced.nq == 7
    data = reduced.createData()
    bodies = [f.name for f in reduced.frames if f.type == pin.FrameType.BODY]
    for q in robot.random_q(np.random.default_rng(0), n=20):
        pin.framesForwardKinematics(reduced, data, q)
        for name in bodies:
            np.testing.assert_allclose(robot.fk(q, name),
                                       data.oMf[reduced.getFrameId(name)].homogeneous, atol=1e-12)


def test_continuous_joint_equals_unbounded_revolute():
    """A continuous joint turned revolute (+-2 pi) moves exactly like Pinocchio's (cos q, sin q) joint."""
    path = erd_file(KINOVA)
    raw = pin.buildModelFromUrdf(str(path))
    assert raw.nq == 9 and raw.nv == 6  # three continuous joints
    robot = load_urdf(path, tip="j2s6s200_end_effector", geometry=False)
    assert robot.nq == 6
    data = raw.createData()
    fid = raw.getFrameId("j2s6s200_end_effector")
    for q in robot.random_q(np.random.default_rng(1), n=20):
        q_raw = []
        for jid in range(1, raw.njoints):
            v = q[raw.joints[jid].idx_v]
            q_raw += [math.cos(v), math.sin(v)] if raw.joints[jid].nq == 2 else [v]
        pin.framesForwardKinematics(raw, data, np.array(q_raw))
        np.testing.assert_allclose(robot.fk(q), data.oMf[fid].homogeneous, atol=1e-12)


def test_source_round_trip_and_package_dirs():
    robot = load_urdf(erd_file(KINOVA), tip="j2s6s200_end_effector", geometry=False)
    assert 'type="continuous"' not in robot.source
    assert str(example_robot_data_package_dir()) in robot.package_dirs
    again = load_urdf(robot.source, tip="j2s6s200_end_effector", package_dirs=robot.package_dirs,
                      geometry=True)
    q = robot.random_q(2)
    np.testing.assert_array_equal(again.fk(q), robot.fk(q))
    assert again.visual_model.ngeoms > 0 and again.collision_model.ngeoms > 0


def test_unchanged_urdf_keeps_its_text():
    path = erd_file("ur_description/urdf/ur5_robot.urdf")
    assert load_urdf(path, geometry=False).source == path.read_text()


def test_package_uri_resolved_through_an_ancestor_directory(tmp_path):
    """package://mypkg/... resolves for a URDF that lives inside a directory named mypkg."""
    pkg = tmp_path / "mypkg"
    (pkg / "urdf").mkdir(parents=True)
    (pkg / "meshes").mkdir()
    (pkg / "meshes" / "tri.stl").write_text(
        "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 "
        "0\nendloop\nendfacet\nendsolid t\n"
    )
    urdf = pkg / "urdf" / "r.urdf"
    urdf.write_text(
        '<robot name="r"><link name="a"/><link name="b"><visual><geometry>'
        '<mesh filename="package://mypkg/meshes/tri.stl"/></geometry></visual></link>'
        '<joint name="j" type="prismatic"><parent link="a"/><child link="b"/><axis xyz="1 0 0"/>'
        '<limit lower="0" upper="1" effort="1" velocity="1"/></joint></robot>'
    )
    robot = load_urdf(urdf)
    assert robot.visual_model.ngeoms == 1
    assert str(tmp_path) in robot.package_dirs
    np.testing.assert_allclose(robot.fk([0.25])[:3, 3], [0.25, 0, 0])


def test_lock_prismatic_and_revolute_with_origin(tmp_path):
    """The locked origin is origin * motion: check against the hand-composed transform."""
    text = (
        '<robot name="r"><link name="a"/><link name="b"/><link name="c"/>'
        '<joint name="p" type="prismatic"><origin xyz="0.1 0.2 0.3" rpy="0.3 -0.2 0.1"/><parent '
        'link="a"/><child link="b"/><axis xyz="0 1 1"/><limit lower="-1" upper="1" effort="1" '
        'velocity="1"/></joint><joint name="r" type="revolute"><origin xyz="0 0 1" rpy="0 0.5 0"/><parent '
        'link="b"/><child link="c"/><axis xyz="1 0 0"/><limit lower="-2" upper="2" effort="1" '
        'velocity="1"/></joint></robot>'
    )
    free = load_urdf(text, geometry=False)
    locked = load_urdf(text, locked_joints={"p": 0.4}, tip="c", geometry=False)
    assert locked.nq == 1 and locked.joint_names == ["r"]
    for v in (-1.5, 0.0, 0.7):
        np.testing.assert_allclose(locked.fk([v], "c"), free.fk([0.4, v], "c"), atol=1e-14)
    with pytest.raises(ModelError, match="outside its limits"):
        load_urdf(text, locked_joints={"p": 1.5}, geometry=False)
