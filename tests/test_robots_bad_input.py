"""kinserve.robots refuses absurd models and names what was wrong: huge SRDF values, exploding or deep
SRDF group nesting, too many links / DH rows, bad <inertial>, a negative velocity limit, an unusable path."""

from __future__ import annotations

import re
import tracemalloc

import numpy as np
import pytest

from kinserve import robots
from kinserve.kinematics.errors import ModelError, UnknownRobotError
from kinserve.robots.dh import MAX_DH_ROWS
from kinserve.robots.srdf import MAX_GROUP_DEPTH, read_srdf
from kinserve.robots.urdf_loader import MAX_LINKS, MAX_MOVABLE_JOINTS

URDF = """<robot name="two">
  <link name="base"/>
  <link name="a"><inertial><origin xyz="0 0 0.1"/><mass value="1.5"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
  <link name="b"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="j2" type="prismatic"><origin xyz="1 0 0"/><parent link="a"/><child link="b"/>
    <axis xyz="1 0 0"/><limit lower="0" upper="0.5" effort="1" velocity="1"/></joint>
</robot>
"""


pytestmark = pytest.mark.usefixtures("fresh_registry")  # each test parses its models (conftest)


def _srdf(tmp_path, body: str):
    path = tmp_path / "two.srdf"
    path.write_text(f'<?xml version="1.0"?>\n<robot name="two">\n{body}\n</robot>\n')
    return path


# ------------------------------------------------------------------------------------------------ SRDF
@pytest.mark.parametrize("value", ["1e300", "-1e16", "1000001"])
def test_srdf_value_beyond_1e6_is_refused_not_wrapped(tmp_path, value):
    path = _srdf(tmp_path, f'<group_state name="s"><joint name="j1" value="{value}"/></group_state>')
    with pytest.raises(ModelError, match=rf"joint 'j1' value '{value}' must be at most 1e\+06 in magnitude"):
        robots.load(URDF, geometry=False, srdf=path)
    ok = _srdf(tmp_path, '<group_state name="s"><joint name="j1" value="6.5"/></group_state>')
    assert robots.load(URDF, geometry=False, srdf=ok).named_states["s"][0] == pytest.approx(6.5 - 2 * np.pi)


def test_srdf_groups_naming_a_subgroup_twice_do_not_multiply(tmp_path):
    levels = 22  # without deduplication: 2**22 joint entries in the top group's list (> 32 MB); 40 levels
    body = ['<group name="g0"><joint name="j1"/><joint name="j2"/></group>']  # exhausted memory
    body += [f'<group name="g{i}"><group name="g{i - 1}"/><group name="g{i - 1}"/></group>'
             for i in range(1, levels)]
    path = _srdf(tmp_path, "\n".join(reversed(body)))
    robot = robots.load(URDF, geometry=False, srdf=False)
    tracemalloc.start()
    try:
        srdf = read_srdf(path, robot)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert srdf.groups[f"g{levels - 1}"] == ("j1", "j2")
    assert peak < 8 * 2**20


def test_srdf_group_nesting_deeper_than_the_bound_is_refused(tmp_path):
    def chain(depth: int) -> str:
        body = ['<group name="g0"><joint name="j1"/></group>']
        body += [f'<group name="g{i}"><group name="g{i - 1}"/></group>' for i in range(1, depth + 1)]
        return "\n".join(reversed(body))  # outermost first: resolved top-down

    with pytest.raises(ModelError, match=rf"nested more than {MAX_GROUP_DEPTH} subgroups deep"):
        robots.load(URDF, geometry=False, srdf=_srdf(tmp_path, chain(5000)))
    with pytest.raises(ModelError, match=rf"group 'g0' is nested more than {MAX_GROUP_DEPTH} subgroups deep "
                                         rf"\(via 'g{MAX_GROUP_DEPTH + 1}'"):
        robots.load(URDF, geometry=False, srdf=_srdf(tmp_path, chain(MAX_GROUP_DEPTH + 1)))
    robots.clear_cache()
    robot = robots.load(URDF, geometry=False, srdf=_srdf(tmp_path, chain(MAX_GROUP_DEPTH)))
    assert robot.groups[f"g{MAX_GROUP_DEPTH}"] == ("j1",)


# ------------------------------------------------------------------------------------------- model size
def _star(n_links: int) -> str:
    links = "".join(f'<link name="l{i}"/>' for i in range(n_links))
    joints = ('<joint name="j1" type="revolute"><parent link="l0"/><child link="l1"/><axis xyz="0 0 1"/>'
              '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>')
    joints += "".join(f'<joint name="f{i}" type="fixed"><parent link="l0"/><child link="l{i}"/></joint>'
                      for i in range(2, n_links))
    return f'<robot name="star">{links}{joints}</robot>'


def test_urdf_with_too_many_links_is_refused_before_pinocchio():
    with pytest.raises(ModelError, match=rf"has {MAX_LINKS + 1} <link> elements; at most {MAX_LINKS}"):
        robots.load(_star(MAX_LINKS + 1), geometry=False)
    with pytest.raises(ModelError, match=rf"has {10**5} <link> elements"):
        robots.load(_star(10**5), geometry=False)
    assert robots.load(_star(MAX_LINKS), geometry=False).nq == 1  # the largest accepted star loads


def _chain(n_joints: int) -> str:
    links = "".join(f'<link name="l{i}"/>' for i in range(n_joints + 1))
    joints = "".join(f'<joint name="j{i}" type="revolute"><parent link="l{i - 1}"/><child link="l{i}"/>'
                     '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
                     for i in range(1, n_joints + 1))
    return f'<robot name="chain">{links}{joints}</robot>'


def test_urdf_with_too_many_movable_joints_is_refused_before_pinocchio():
    with pytest.raises(ModelError, match=rf"has {MAX_MOVABLE_JOINTS + 1} movable \(non-fixed\) joints; at "
                                         rf"most {MAX_MOVABLE_JOINTS} are accepted"):
        robots.load(_chain(MAX_MOVABLE_JOINTS + 1), geometry=False)
    with pytest.raises(ModelError, match=rf"has {10**4 + 1} <link> elements"):
        robots.load(_chain(10**4), geometry=False)  # crashed inside Pinocchio before
    assert robots.load(_chain(20), geometry=False).nq == 20


def test_dh_table_with_too_many_rows_is_refused():
    rows = np.tile([0.1, 0.3, 0.05, 0.0], (MAX_DH_ROWS + 1, 1))
    with pytest.raises(ModelError, match=rf"at most {MAX_DH_ROWS} rows \(joints\) are accepted, got "
                                         rf"{MAX_DH_ROWS + 1}"):
        robots.from_dh(rows, "R" * (MAX_DH_ROWS + 1))
    with pytest.raises(ModelError, match="at most"):
        robots.from_dh(np.tile(rows[:1], (1000, 1)), "R" * 1000)
    assert robots.from_dh(rows[:3], "RRR", geometry=False).nq == 3


# --------------------------------------------------------------------------------------------- inertial
@pytest.mark.parametrize("old, new, fragment", [
    ('<mass value="1.5"/>', '<mass value="1e300"/>', r"<mass value='1e300'> must be 1 finite number"),
    ('<mass value="1.5"/>', '<mass value="-1"/>', r"<mass value='-1'> must be >= 0 \(kg\)"),
    ('<mass value="1.5"/>', '<mass/>', r"<mass> needs a value= attribute"),
    ('ixx="0.01"', 'ixx="nan"', r"<inertia ixx='nan'> must be 1 finite number"),
    ('izz="0.01"', 'izz="2e6"', r"<inertia izz='2e6'> must be 1 finite number"),
    (' iyz="0"', '', r"<inertia> needs a iyz= attribute"),
    ('<origin xyz="0 0 0.1"/>', '<origin xyz="0 0 inf"/>', r"<origin xyz='0 0 inf'> must be 3 finite"),
])
def test_bad_inertial_is_a_named_error(old, new, fragment):
    assert old in URDF
    with pytest.raises(ModelError, match=r"<inertial> of <link name='a'>: " + fragment):
        robots.load(URDF.replace(old, new, 1), geometry=False)
    assert robots.load(URDF, geometry=False).nq == 2


@pytest.mark.parametrize("attr", ["velocity", "effort"])
def test_negative_velocity_or_effort_limit_names_the_joint(attr):
    bad = URDF.replace(f'{attr}="1"', f'{attr}="-1"', 1)  # the first <limit> is j1's
    assert f'{attr}="-1"' in bad
    with pytest.raises(ModelError, match=rf"<joint name='j1'>: <limit {attr}='-1'> must be >= 0"):
        robots.load(bad, geometry=False)
    assert robots.load(bad.replace(f'{attr}="-1"', f'{attr}="0"'), geometry=False).nq == 2


# ---------------------------------------------------------------------------------------------- paths
def test_overlong_name_is_an_unknown_robot_and_overlong_path_a_model_error():
    with pytest.raises(UnknownRobotError, match="unknown robot"):
        robots.load("x" * 10000)
    for path in ("x" * 10000 + ".urdf", "a/" + "x" * 10000, "x" * 10000 + ".xacro"):
        with pytest.raises(ModelError, match=r"robot model file '.*'\.\.\. \(\d+ characters\) cannot be "
                                             r"opened"):
            robots.load(path)
    with pytest.raises(ModelError, match="robot model file 'nope.urdf' does not exist"):
        robots.load("nope.urdf")


def test_a_file_that_is_not_a_mesh_is_a_model_error_naming_it(tmp_path):
    """A collision mesh coal cannot read: the load reads no mesh and succeeds (kinematics needs none); the
    first use of the collision geometry is a ModelError naming the model and the file, without coal's source
    location, and so is the next (nothing half-read is kept)."""
    (tmp_path / "part.stl").write_text("not a mesh\n")
    (tmp_path / "r.urdf").write_text(
        '<robot name="b"><link name="a"/><link name="b"><collision><geometry><mesh filename="part.stl"/>'
        '</geometry></collision></link><joint name="j" type="revolute"><parent link="a"/><child link="b"/>'
        '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>')
    words = re.escape(f"Could not load resource {tmp_path / 'part.stl'}")
    robot = robots.load(tmp_path / "r.urdf")
    assert robot.fk(np.zeros(1)).shape == (4, 4) and robot.visual_model.ngeoms == 0
    for use in (lambda: robot.in_collision(np.zeros(1)), lambda: robot.collision_model):
        with pytest.raises(ModelError, match=f"r.urdf: cannot build the collision geometry: {words}") as info:
            use()
        assert "From file" not in str(info.value) and "\n" not in str(info.value)


def _cube_stl(half: float) -> str:
    """An ASCII STL of the cube [-half, half]^3 (12 triangles)."""
    v = np.array([[x, y, z] for x in (-half, half) for y in (-half, half) for z in (-half, half)])
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1), (2, 3, 7), (2, 7, 6),
             (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    corners = ("".join(f"vertex {a} {b} {c}\n" for a, b, c in v[list(f)]) for f in faces)
    body = "".join(f"facet normal 0 0 0\nouter loop\n{c}endloop\nendfacet\n" for c in corners)
    return f"solid cube\n{body}endsolid cube\n"


def test_clear_caches_forgets_the_meshes_read(tmp_path):
    """A mesh replaced on disk with its modification time kept is still the one read before (coal's mesh
    cache), until kinserve.clear_caches()."""
    import os

    import kinserve

    mesh, urdf = tmp_path / "cube.stl", tmp_path / "r.urdf"
    mesh.write_text(_cube_stl(0.05))
    urdf.write_text(
        '<robot name="c"><link name="a"/><link name="b"><collision><geometry><mesh filename="cube.stl"/>'
        '</geometry></collision></link><joint name="j" type="revolute"><parent link="a"/><child link="b"/>'
        '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>')

    def extent() -> float:
        kinserve.robots.registry.clear_cache()  # the parsed model: read the file again
        robot = robots.load(urdf)
        return float(np.max(robot.collision_model.geometryObjects[0].geometry.vertices()))

    assert extent() == pytest.approx(0.05)
    stamp = mesh.stat()
    mesh.write_text(_cube_stl(0.2))
    os.utime(mesh, ns=(stamp.st_atime_ns, stamp.st_mtime_ns))
    assert extent() == pytest.approx(0.05)  # cached: same file name, same time
    kinserve.clear_caches()
    assert extent() == pytest.approx(0.2)


@pytest.mark.parametrize("value", ["no", 0, None, float("nan")])
def test_geometry_and_allow_outside_must_be_true_or_false(value):
    """``allow_outside="no"`` let a model read files outside its folders (bool("no") is True); each loader now
    names the flag it was given."""
    from kinserve.kinematics.errors import InputError
    from kinserve.robots import load_urdf

    path = robots.ENTRIES["panda"].path()
    for flag in ("geometry", "allow_outside"):
        with pytest.raises(InputError, match=f"{flag} must be True or False"):
            robots.load("panda", **{flag: value})
        with pytest.raises(InputError, match=f"{flag} must be True or False"):
            load_urdf(path, **{flag: value})
    assert robots.load("panda", geometry=np.bool_(False), allow_outside=np.False_).nq == 7
