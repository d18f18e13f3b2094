"""kinserve.robots.srdf: named states and groups, checked against the SRDF text; every bad entry is a named
error."""

from __future__ import annotations

import math
import re
import warnings

import numpy as np
import pytest

from kinserve import robots
from kinserve.kinematics.errors import ModelError
from kinserve.robots.paths import erd_file
from kinserve.robots.srdf import SrdfWarning, find_srdf, read_srdf

URDF = """<robot name="slider">
  <link name="base"/><link name="a"/><link name="b"/><link name="c"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="j2" type="prismatic"><origin xyz="1 0 0"/><parent link="a"/><child link="b"/>
    <axis xyz="1 0 0"/><limit lower="0" upper="0.5" effort="1" velocity="1"/></joint>
  <joint name="j3" type="revolute"><origin xyz="0.3 0 0"/><parent link="b"/><child link="c"/>
    <axis xyz="0 0 1"/><limit lower="0.5" upper="6" effort="1" velocity="1"/></joint>
</robot>
"""

SRDF = """<?xml version="1.0"?>
<robot name="slider">
  <group name="arm"><chain base_link="base" tip_link="c"/></group>
  <group name="wrist"><link name="c"/></group>
  <group name="both"><group name="wrist"/><joint name="j1"/></group>
  <group_state name="ready" group="arm">
    <joint name="j1" value="0.25"/><joint name="j2" value="0.4"/><joint name="j3" value="1.5"/>
  </group_state>
  <group_state name="wrist_out" group="wrist"><joint name="j3" value="-1.5707"/></group_state>
</robot>
"""


pytestmark = pytest.mark.usefixtures("fresh_registry")  # each test parses its models (conftest)


def test_panda_named_state_matches_the_srdf_file_text():
    srdf = erd_file("panda_description/srdf/panda.srdf")
    text = srdf.read_text()
    block = re.search(r'<group_state name="default" '
                      r'group="arm_and_hand">(.*?)</group_state>', text, re.S).group(1)
    values = {m[0]: float(m[1]) for m in re.findall(r'<joint name="([^"]+)" value="([^"]+)"', block)}
    panda = robots.load("panda", geometry=False)
    assert panda.srdf_path == str(srdf)
    q = panda.named_states["default"]
    assert q.shape == (7,)
    assert q.tolist() == [values[f"panda_joint{i}"] for i in range(1, 8)]  # the locked finger is not in q
    assert panda.groups["arm"] == tuple(f"panda_joint{i}" for i in range(1, 8))
    assert panda.groups["hand"] == ()  # its only joint is locked
    assert panda.groups["arm_and_hand"] == panda.groups["arm"]
    assert panda.within_limits(q)


def test_states_groups_and_whole_turns(tmp_path):
    path = tmp_path / "slider.srdf"
    path.write_text(SRDF)
    robot = robots.load(URDF, geometry=False, srdf=path)
    np.testing.assert_array_equal(robot.named_states["ready"], [0.25, 0.4, 1.5])
    # j3 is limited to [0.5, 6]: -1.5707 is the same angle as -1.5707 + 2 pi; j1, j2 stay at neutral()
    np.testing.assert_allclose(robot.named_states["wrist_out"], [0.0, 0.0, -1.5707 + 2 * math.pi], atol=1e-15)
    assert robot.groups == {"arm": ("j1", "j2", "j3"), "wrist": ("j3",), "both": ("j1", "j3")}
    with pytest.raises(ValueError):
        robot.named_states["ready"][0] = 1.0  # shared by every copy: read-only
    assert robots.load(URDF, geometry=False).named_states == {}  # a string has no SRDF beside it


def test_srdf_found_beside_the_urdf_in_the_example_robot_data_layout(tmp_path):
    (tmp_path / "slider_description" / "urdf").mkdir(parents=True)
    (tmp_path / "slider_description" / "srdf").mkdir()
    urdf = tmp_path / "slider_description" / "urdf" / "slider_robot.urdf"
    urdf.write_text(URDF)
    assert find_srdf(urdf) is None and robots.load(urdf, geometry=False).named_states == {}
    srdf = tmp_path / "slider_description" / "srdf" / "slider.srdf"
    srdf.write_text(SRDF)
    robots.clear_cache()
    assert find_srdf(urdf) == srdf
    assert set(robots.load(urdf, geometry=False).named_states) == {"ready", "wrist_out"}
    assert robots.load(urdf, geometry=False, srdf=False).named_states == {}


@pytest.mark.parametrize("old, new, fragment", [
    ('<joint name="j2" value="0.4"/>', '<joint name="j22" value="0.4"/>',
     r"line 7: joint 'j22' is not a joint of the URDF. Did you mean: j2"),
    ('value="0.4"', 'value="fast"', r"line 7: joint 'j2' value 'fast' must be one number"),
    ('value="0.4"', 'value="nan"', r"joint 'j2' value 'nan' must be finite"),
    ('value="0.4"', 'value="0.9"',
     r"line 7: <group_state name='ready'>: joint 'j2' = 0.9 is outside its limits \[0.0, 0.5\]"),
    ('group="arm">', 'group="legs">',
     r"line 6: <group_state name='ready'> names group 'legs', which is not defined"),
    ('<group name="wrist"/>', '<group name="wirst"/>',
     r"line 5: subgroup 'wirst' is not defined. Did you mean: wrist"),
    ('tip_link="c"', 'tip_link="cc"', r"line 3: <chain> link 'cc' is not a link of the URDF"),
    ('<link name="c"/></group>', '<link name="c"></group>', r"malformed XML at line \d+"),
])
def test_bad_srdf_entries_are_named_errors(tmp_path, old, new, fragment):
    assert old in SRDF
    path = tmp_path / "bad.srdf"
    path.write_text(SRDF.replace(old, new, 1))
    robot = robots.load(URDF, geometry=False)
    with pytest.raises(ModelError, match=fragment) as err:
        read_srdf(path, robot)
    assert str(path) in str(err.value)
    with pytest.raises(ModelError, match=fragment):
        robots.load(URDF, geometry=False, srdf=path)  # asked for: an error


def test_unusable_srdf_found_beside_a_model_is_a_warning_not_a_failure(tmp_path):
    urdf = tmp_path / "slider.urdf"
    urdf.write_text(URDF)
    (tmp_path / "slider.srdf").write_text(SRDF.replace('"j2" value="0.4"', '"j9" value="0.4"'))
    with pytest.warns(SrdfWarning, match="'j9' is not a joint"):
        robot = robots.load(urdf, geometry=False)
    assert robot.nq == 3 and robot.named_states == {}


def test_every_builtin_loads_without_srdf_warnings():
    with warnings.catch_warnings():
        warnings.simplefilter("error", SrdfWarning)
        for name in robots.ENTRIES:
            robot = robots.load(name, geometry=False)
            for q in robot.named_states.values():
                assert robot.within_limits(q)


def test_named_states_are_read_only_and_travel_with_a_pickled_robot():
    import pickle

    panda = robots.load("panda", geometry=False)
    with pytest.raises(TypeError, match="read-only"):
        panda.named_states["mine"] = panda.neutral()
    again = pickle.loads(pickle.dumps(panda))
    assert again.named_states.keys() == panda.named_states.keys() and again.groups == panda.groups
    np.testing.assert_array_equal(again.named_states["default"], panda.named_states["default"])
    assert pickle.loads(pickle.dumps(robots.load("panda", geometry=False, srdf=False))).named_states == {}
