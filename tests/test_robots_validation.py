"""Unusable models raise ModelError naming the file and the element (and line) at fault."""

import math
import re

import numpy as np
import pytest

from kinserve import robots
from kinserve.kinematics.errors import FrameError, ModelError
from kinserve.robots import load_urdf, load_xacro, process_xacro
from kinserve.robots.paths import models_dir
from kinserve.robots.urdf_loader import PLACEHOLDER_RADIUS, MissingMeshWarning

GOOD = """<?xml version="1.0"?>
<robot name="two_link">
  <link name="base"/>
  <link name="l1"/>
  <link name="l2"/>
  <joint name="j1" type="revolute">
    <parent link="base"/>
    <child link="l1"/>
    <axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <joint name="j2" type="revolute">
    <origin xyz="1 0 0" rpy="0 0 0"/>
    <parent link="l1"/>
    <child link="l2"/>
    <axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>
"""


def write(tmp_path, text, name="robot.urdf"):
    path = tmp_path / name
    path.write_text(text)
    return path


def error_of(source, **kwargs):
    with pytest.raises(ModelError) as err:
        load_urdf(source, geometry=False, **kwargs)
    return str(err.value)


def test_good_model_loads(tmp_path):
    assert load_urdf(write(tmp_path, GOOD), geometry=False).nq == 2


def test_malformed_xml_names_file_line_and_column(tmp_path):
    bad = GOOD.replace('<link name="l2"/>', '<link name="l2">')
    path = write(tmp_path, bad)
    msg = error_of(path)
    assert str(path) in msg and "malformed XML" in msg
    assert re.search(r"line \d+, column \d+", msg)
    assert "malformed XML" in error_of(bad)  # as a string too


def test_joint_naming_a_missing_link(tmp_path):
    path = write(tmp_path, GOOD.replace('<child link="l2"/>', '<child link="l3"/>'))
    msg = error_of(path)
    assert str(path) in msg
    assert "'j2'" in msg and "child link 'l3'" in msg and "line 15" in msg
    msg = error_of(write(tmp_path, GOOD.replace('<parent link="l1"/>', '<parent link="link1"/>'), "p.urdf"))
    assert "parent link 'link1'" in msg


def test_missing_mesh_file(tmp_path):
    """A missing mesh: kinematics loads silently; with geometry, a warning naming file, line, link and
    where it looked, and a placeholder sphere instead of the mesh (no collision shape)."""
    text = GOOD.replace(
        '<link name="l1"/>',
        '<link name="l1"><visual><geometry><mesh filename="meshes/arm.stl"/></geometry></visual>'
        '<collision><geometry><mesh filename="meshes/arm.stl"/></geometry></collision></link>',
    )
    path = write(tmp_path, text)
    assert load_urdf(path, geometry=False).nq == 2
    with pytest.warns(MissingMeshWarning) as record:
        robot = load_urdf(path, geometry=True)
    msg = str(record[0].message)
    assert str(path) in msg and "'meshes/arm.stl'" in msg and "'l1'" in msg and "line 4" in msg
    assert str(tmp_path / "meshes" / "arm.stl") in msg  # where it looked
    assert robot.visual_model.ngeoms == 1 and robot.collision_model.ngeoms == 0
    shape = robot.visual_model.geometryObjects[0].geometry
    assert type(shape).__name__ == "Sphere" and shape.radius == PLACEHOLDER_RADIUS
    pkg = text.replace("meshes/arm.stl", "package://example-robot-data/robots/nowhere/arm.stl")
    with pytest.warns(MissingMeshWarning,
                      match="package://example-robot-data/robots/nowhere/arm.stl.*looked in"):
        load_urdf(write(tmp_path, pkg, "pkg.urdf"), geometry=True)


def test_existing_relative_mesh_loads_with_geometry(tmp_path):
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "tri.stl").write_text(
        "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 "
        "0\nendloop\nendfacet\nendsolid t\n"
    )
    text = GOOD.replace(
        '<link name="l1"/>',
        '<link name="l1"><visual><geometry><mesh filename="meshes/tri.stl"/></geometry></visual></link>',
    )
    robot = load_urdf(write(tmp_path, text), geometry=True)
    assert robot.visual_model.ngeoms == 1


def test_nonexistent_path():
    with pytest.raises(ModelError, match="does not exist"):
        load_urdf("/no/such/dir/robot.urdf")
    with pytest.raises(ModelError, match="/no/such/dir/robot.urdf"):
        robots.load("/no/such/dir/robot.urdf")
    with pytest.raises(ModelError, match="does not exist"):
        load_xacro("/no/such/dir/robot.urdf.xacro")


@pytest.mark.parametrize(
    "old, new, fragment",
    [
        ('<link name="l2"/>', '<link name="l1"/>', "duplicate link name 'l1'"),
        ('name="j2"', 'name="j1"', "duplicate joint name 'j1'"),
        ('type="revolute">\n    <origin', 'type="floating">\n    <origin', "type 'floating'"),
        ('type="revolute">\n    <origin', 'type="hinge">\n    <origin', "unknown type 'hinge'"),
        ('<limit lower="-1" upper="1" effort="1" velocity="1"/>\n  </joint>\n</robot>', "</joint>\n</robot>",
         "needs a <limit"),
        ('upper="1" effort="1" velocity="1"/>\n  </joint>\n</robot>',
         'upper="-2" effort="1" velocity="1"/>\n  </joint>\n</robot>', "lower limit -1.0 > upper limit -2.0"),
        ('effort="1" velocity="1"/>\n  </joint>\n</robot>', 'velocity="1"/>\n  </joint>\n</robot>',
         "needs a effort="),
        ('xyz="1 0 0"', 'xyz="1 0"', "must be 3 finite number(s)"),
        ('<axis xyz="0 0 1"/>\n    <limit lower="-1" upper="1" effort="1" velocity="1"/>\n  '
         '</joint>\n</robot>',
         '<axis xyz="0 0 0"/>\n    <limit lower="-1" upper="1" effort="1" velocity="1"/>\n  '
         '</joint>\n</robot>', "axis must be non-zero"),
        ('<child link="l2"/>', '<child link="l1"/>', "child of two joints"),
        ('<link name="l2"/>', '<link name="l2"/><link name="stray"/>', "2 root links"),
        ('<robot name="two_link">',
         '<robot name="two_link" xmlns:xacro="http://www.ros.org/wiki/xacro"><xacro:property name="a" '
         'value="1"/>', "xacro"),
        ('xyz="1 0 0"', 'xyz="${a} 0 0"', "xacro"),
    ],
)
def test_structural_errors_name_the_element(tmp_path, old, new, fragment):
    assert old in GOOD
    path = write(tmp_path, GOOD.replace(old, new))
    msg = error_of(path)
    assert fragment in msg
    assert str(path) in msg


def test_root_must_be_robot():
    assert "root element must be <robot>" in error_of("<model><link name='a'/></model>")


def test_unknown_tip_lists_close_frames(tmp_path):
    with pytest.raises(FrameError, match="Did you mean: l2"):
        load_urdf(write(tmp_path, GOOD), tip="l22", geometry=False)


def test_locking_errors(tmp_path):
    path = write(tmp_path, GOOD)
    msg = error_of(path, locked_joints={"j3": 0.0})
    assert "cannot lock 'j3'" in msg and "['j1', 'j2']" in msg
    assert "outside its limits" in error_of(path, locked_joints={"j1": 2.0})
    assert "needs a number" in error_of(path, locked_joints={"j1": "open"})


# ------------------------------------------------------------------------------ xacro
PLANAR = models_dir() / "planar4r.urdf.xacro"


def test_unknown_xacro_arg_lists_declared_args():
    with pytest.raises(ModelError) as err:
        process_xacro(PLANAR, {"l5": 1.0})
    msg = str(err.value)
    assert str(PLANAR) in msg and "'l5'" in msg
    for declared in ("l1", "l2", "l3", "l4", "limit"):
        assert declared in msg


@pytest.mark.parametrize("value", ["abc", "1.0.0", float("nan"), [1.0]])
def test_unparsable_xacro_arg_value(value):
    with pytest.raises(ModelError) as err:
        process_xacro(PLANAR, {"l2": value})
    assert "'l2'" in str(err.value) and str(PLANAR) in str(err.value)


def test_bad_params_of_builtins_name_the_param():
    with pytest.raises(ModelError, match="'l1'"):
        robots.load("planar4r", l1="long", geometry=False)
    with pytest.raises(ModelError, match=r"unknown xacro arg 'length'.*l1, l2, l3, l4"):
        robots.load("planar4r", length=1.0, geometry=False)
    with pytest.raises(ModelError, match=r"unknown parameter\(s\) \['l1'\].*panda_finger_joint1"):
        robots.load("panda", l1=1.0, geometry=False)
    with pytest.raises(ModelError, match="panda_finger_joint1"):
        robots.load("panda", panda_finger_joint1=0.5, geometry=False)  # outside [0, 0.04]
    with pytest.raises(ModelError, match="no parameters|none"):
        robots.load("ur5", shoulder=1.0, geometry=False)


def test_xacro_required_arg_and_expression_errors(tmp_path):
    path = tmp_path / "r.urdf.xacro"
    path.write_text(
        '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<xacro:arg name="length"/><xacro:arg name="width" default="0.1"/>'
        '<link name="a"/></robot>'
    )
    with pytest.raises(ModelError, match=r"\['length'\] have no default"):
        process_xacro(path)
    path.write_text(
        '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<xacro:arg name="length" default="1"/><xacro:arg name="width" default="0.1"/>'
        '<link name="a"><visual><geometry><box size="$(arg length) ${undefined_thing} '
        '1"/></geometry></visual></link>'
        "</robot>"
    )
    with pytest.raises(ModelError) as err:
        process_xacro(path, {"length": 2})
    assert str(path) in str(err.value) and "undefined_thing" in str(err.value)
    with pytest.raises(ModelError, match="declares: length, width"):
        process_xacro(path, {"height": 1})


def test_xacro_malformed_xml(tmp_path):
    path = tmp_path / "bad.urdf.xacro"
    path.write_text('<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="a"></robot>')
    with pytest.raises(ModelError, match=r"bad.urdf.xacro: malformed XML at line 1"):
        load_xacro(path)


@pytest.mark.parametrize("old,new", [
    ('<origin xyz="1 0 0" rpy="0 0 0"/>', '<origin xyz="1e308 0 0" rpy="0 0 0"/>'),
    ('<origin xyz="1 0 0" rpy="0 0 0"/>', '<origin xyz="1 0 0" rpy="0 2e6 0"/>'),
    ('<limit lower="-1" upper="1" effort="1" velocity="1"/>\n  </joint>\n</robot>',
     '<limit lower="-1e308" upper="1" effort="1" velocity="1"/>\n  </joint>\n</robot>'),
])
def test_model_numbers_beyond_the_input_bound_are_refused_at_load(old, new):
    """A 1e308 origin used to load and make ik.solve raise OverflowError; now the load names it."""
    bad = GOOD.replace(old, new)
    assert bad != GOOD
    with pytest.raises(ModelError, match=r"magnitude <= 1e\+06"):
        load_urdf(bad)


def test_large_but_bounded_model_numbers_load_and_solve_finitely():
    from kinserve import ik

    r = load_urdf(GOOD.replace('<origin xyz="1 0 0" rpy="0 0 0"/>', '<origin xyz="1e5 0 0" rpy="0 0 0"/>'))
    T = r.fk([0.5, 0.2])
    assert T[0, 3] == pytest.approx(1e5 * math.cos(0.5), rel=1e-12)
    res = ik.solve(r, T, relax=("roll", "pitch", "yaw"), max_time=0.2)
    assert np.isfinite(res.position_error)


@pytest.mark.parametrize("robot,params", [("planar4r", {"l1": "1e308"}), ("planar4r", {"l1": 1e7}),
                                          ("scara", {"d3_min": "-1e308"})])
def test_xacro_args_beyond_the_bound_are_refused(robot, params):
    name = next(iter(params))
    with pytest.raises(ModelError, match=rf"xacro arg '{name}'.*1e\+06"):
        robots.load(robot, geometry=False, **params)
