"""kinserve.robots.registry: names, paths and URDF strings in; Robots with the right joints and tips out."""

import math
from pathlib import Path

import numpy as np
import pytest

from kinserve import robots
from kinserve.kinematics import Robot
from kinserve.kinematics.errors import UnknownRobotError
from kinserve.robots.paths import erd_file, models_dir

#: name -> (nq, tip) expected for every built-in robot (from the model files, not from the registry).
EXPECTED = {
    "planar4r": (4, "tool"),
    "youbot": (5, "tool"),
    "pr": (2, "tool"),
    "scara": (4, "tool"),
    "panda": (7, "panda_hand"),
    "ur3": (6, "tool0"),
    "ur5": (6, "tool0"),
    "ur10": (6, "tool0"),
    "xarm7": (7, "link_eef"),
    "kinova": (6, "j2s6s200_end_effector"),
    "z1": (6, "gripperStator"),
    "so100": (5, "gripper"),
    "so101": (5, "gripper_frame_link"),
    "talos_left_arm": (6, "wrist_left_ft_tool_link"),
    "baxter": (14, "left_gripper"),
    "baxter_left": (7, "left_gripper"),
    "baxter_right": (7, "right_gripper"),
    "finger_edu": (3, "finger_tip_link"),
    "twodof": (2, "Tip"),
    "double_pendulum": (2, "link2"),
}

TWO_LINK = """<robot name="two_link">
  <link name="base"/><link name="l1"/><link name="l2"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><origin xyz="0.7 0 0"/><parent link="l1"/><child link="l2"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
</robot>"""


def test_available_lists_every_robot_with_a_description():
    names = robots.available()
    assert list(names) == list(EXPECTED)
    assert all(isinstance(d, str) and d and "\n" not in d for d in names.values())
    assert "l1, l2, l3, l4" in names["planar4r"]


@pytest.mark.parametrize("name", list(EXPECTED))
def test_every_builtin_loads_with_expected_joints_and_tip(name):
    robot = robots.load(name, geometry=False)
    nq, tip = EXPECTED[name]
    assert isinstance(robot, Robot) and robot.name == name
    assert robot.nq == nq and robot.tip == tip
    assert tip in robot.frame_names
    assert np.all(robot.lower < robot.upper)
    T = robot.fk(robot.random_q(0))
    assert T.shape == (4, 4) and np.all(np.isfinite(T))


def test_panda_has_flange_and_hand():
    panda = robots.load("panda", geometry=False)
    assert panda.joint_names == [f"panda_joint{i}" for i in range(1, 8)]
    q = panda.random_q(3)
    T8, Th = panda.fk(q, "panda_link8"), panda.fk(q, "panda_hand")
    # the hand is the flange turned by -45 deg about its z axis (Franka URDF)
    np.testing.assert_allclose(T8[:3, 3], Th[:3, 3], atol=1e-12)
    c = math.cos(-math.pi / 4)
    np.testing.assert_allclose(T8[:3, :3].T @ Th[:3, :3],
                               [[c, -math.sin(-math.pi / 4), 0],
                                [math.sin(-math.pi / 4), c, 0], [0, 0, 1]], atol=1e-9)


def test_continuous_joints_become_bounded_revolute():
    kinova = robots.load("kinova", geometry=False)
    for i in (0, 3, 5):  # j2s6s200_joint_1, _4, _6 are continuous in the URDF
        assert kinova.lower[i] == -robots.CONTINUOUS_LIMIT and kinova.upper[i] == robots.CONTINUOUS_LIMIT


def test_unknown_name_lists_known_names():
    with pytest.raises(UnknownRobotError) as err:
        robots.load("pnda")
    msg = str(err.value)
    assert "'pnda'" in msg and "Did you mean: panda" in msg
    for name in EXPECTED:
        assert name in msg
    with pytest.raises(ValueError):  # UnknownRobotError is an InputError (ValueError)
        robots.load("no_such_robot")


def test_load_by_path(tmp_path):
    ur5_path = erd_file("ur_description/urdf/ur5_robot.urdf")
    by_name = robots.load("ur5", geometry=False)
    for source in (ur5_path, str(ur5_path)):
        robot = robots.load(source, tip="tool0", geometry=False)
        assert robot.nq == 6
        q = robot.random_q(4)
        np.testing.assert_allclose(robot.fk(q), by_name.fk(q), atol=1e-14)
    # xacro path with args, and URDF path with a locked joint
    arm = robots.load(models_dir() / "planar4r.urdf.xacro", tip="tool", l1=2.0, geometry=False)
    np.testing.assert_allclose(arm.fk(np.zeros(4))[:3, 3], [3.8, 0, 0], atol=1e-14)
    path = tmp_path / "two.urdf"
    path.write_text(TWO_LINK)
    locked = robots.load(path, j2=math.pi / 2, tip="l2", geometry=False)
    assert locked.nq == 1
    np.testing.assert_allclose(locked.fk([0.0])[:3, :3], [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-14)


def test_load_urdf_string():
    robot = robots.load(TWO_LINK, tip="l2", geometry=False)
    assert robot.nq == 2 and robot.name == "two_link" and robot.source == TWO_LINK
    q = np.array([0.3, -0.2])
    np.testing.assert_allclose(robot.fk(q)[:3, 3], [0.7 * math.cos(0.3), 0.7 * math.sin(0.3), 0], atol=1e-14)


def test_builtin_params_change_the_model():
    default = robots.load("planar4r", geometry=False)
    longer = robots.load("planar4r", l1=1.5, l4="0.5", geometry=False)
    np.testing.assert_allclose(default.fk(np.zeros(4))[:3, 3], [2.8, 0, 0], atol=1e-14)
    np.testing.assert_allclose(longer.fk(np.zeros(4))[:3, 3], [3.4, 0, 0], atol=1e-14)
    assert robots.parameters("planar4r")["l1"] == 1.0
    assert robots.parameters("panda") == {"panda_finger_joint1": 0.0, "panda_finger_joint2": 0.0}
    closed = robots.load("panda", geometry=False)
    opened = robots.load("panda", panda_finger_joint1=0.04, panda_finger_joint2=0.04, geometry=False)
    q = closed.random_q(5)
    np.testing.assert_allclose(opened.fk(q), closed.fk(q), atol=1e-14)  # the hand does not move
    gap = opened.fk(q, "panda_leftfinger")[:3, 3] - closed.fk(q, "panda_leftfinger")[:3, 3]
    np.testing.assert_allclose(np.linalg.norm(gap), 0.04, atol=1e-12)


def test_cache_returns_independent_robots_sharing_the_model():
    a = robots.load("ur5", geometry=False)
    b = robots.load("ur5", geometry=False)
    assert a is not b and a.data is not b.data
    assert a.model is b.model  # parsed once
    qa, qb = a.random_q(1), b.random_q(2)
    Ta = a.fk(qa).copy()
    b.fk(qb)
    np.testing.assert_array_equal(a.data.oMf[a.frame_id(a.tip)].homogeneous, Ta)  # b did not touch a's Data
    c = robots.load("ur5", tip="wrist_3_link", geometry=False)
    assert c.tip == "wrist_3_link" and a.tip == "tool0"


def test_geometry_is_built_when_asked():
    ur5 = robots.load("ur5")
    assert ur5.visual_model is not None and ur5.visual_model.ngeoms >= 6
    for g in ur5.visual_model.geometryObjects:
        assert Path(g.meshPath).is_file()
    scara = robots.load("scara")
    assert scara.visual_model.ngeoms >= 8  # primitives: column, drums, links, quill, tool
    assert robots.load("ur5", geometry=False).visual_model is None


def test_youbot_is_the_shipped_file():
    robot = robots.load("youbot", geometry=False)
    assert robot.source == (models_dir() / "youbot.urdf").read_text()
    assert robot.joint_names == [f"arm_joint_{i}" for i in range(1, 6)]


# --------------------------------------------- names, options and parameters (issue 12)
def test_names_ignore_case_and_suggestions_ignore_case():
    assert robots.load("UR5", geometry=False).name == "ur5"
    assert robots.load(" Panda ", geometry=False).name == "panda"
    assert robots.canonical_name("FINGER_EDU") == "finger_edu"
    with pytest.raises(UnknownRobotError, match="'UR55'. Did you mean: ur5"):
        robots.load("UR55")
    from kinserve.kinematics.errors import FrameError

    with pytest.raises(FrameError, match=r"Did you mean: panda_link8.*`kinserve frames ROBOT` lists all 26"):
        robots.load("panda", geometry=False).fk(np.zeros(7), "PANDA_LINK8")


def test_options_and_parameters_never_share_a_namespace(tmp_path):
    from kinserve.kinematics.errors import ModelError

    path = tmp_path / "two.urdf"
    path.write_text(TWO_LINK)
    # an option is an option, a near-miss of one is named as such (not taken for a joint lock)
    assert robots.load(path, package_dirs=[tmp_path], geometry=False).nq == 2
    with pytest.raises(ModelError, match=r"unknown option 'package_dir'.*did you mean package_dirs="):
        robots.load(path, package_dir=[tmp_path])
    # parameters in params= (any name, even one spelled like an option) or, for short, as keywords
    by_params = robots.load(path, params={"j2": 0.5}, tip="l2", geometry=False)
    by_keyword = robots.load(path, j2=0.5, tip="l2", geometry=False)
    by_locks = robots.load(path, locks={"j2": 0.5}, tip="l2", geometry=False)
    for robot in (by_params, by_keyword, by_locks):
        assert robot.nq == 1
        np.testing.assert_allclose(robot.fk([0.2]), by_params.fk([0.2]), atol=1e-15)
    with pytest.raises(ModelError, match="both"):
        robots.load(path, params={"j2": 0.5}, j2=0.5)
    with pytest.raises(ModelError, match="package_dirs: .* is not a folder"):
        robots.load(path, package_dirs=[tmp_path / "nope"])
    # locks= also after a xacro expansion, next to its args
    arm = robots.load("planar4r", params={"l1": 2.0}, locks={"joint4": 0.5}, geometry=False)
    assert arm.nq == 3
    np.testing.assert_allclose(arm.fk(np.zeros(3)),
                               robots.load("planar4r", l1=2.0, geometry=False).fk([0, 0, 0, 0.5]), atol=1e-14)


def test_neutral_is_the_zero_pose_clipped_into_the_limits():
    """The documented choice: neutral() = clip(0, lower, upper); middle() = (lower + upper) / 2."""
    for name in ("panda", "scara", "pr", "kinova"):
        robot = robots.load(name, geometry=False)
        np.testing.assert_array_equal(robot.neutral(), np.clip(np.zeros(robot.nq), robot.lower, robot.upper))
        np.testing.assert_array_equal(robot.middle(), 0.5 * (robot.lower + robot.upper))
    panda = robots.load("panda", geometry=False)
    assert panda.neutral()[3] == panda.upper[3] < 0  # joint 4's range excludes 0: the nearest limit
    assert "clip(0, lower, upper)" in Robot.neutral.__doc__
