"""kinserve.robots refuses absurd models and names what was wrong: huge SRDF values, exploding or deep
SRDF group nesting, too many links / DH rows, bad <inertial>, a negative velocity limit, an unusable path;
DH tables and loader options of the wrong kind (task_axes, tip, package_dirs, ...), read_srdf's robot."""

from __future__ import annotations

import re
import tracemalloc

import numpy as np
import pytest

from kinserve import robots
from kinserve.kinematics.errors import (
    FrameError,
    InputError,
    ModelError,
    NonFiniteError,
    ShapeError,
    UnknownRobotError,
)
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


# ------------------------------------------------------------------------------------------ DH tables
ROWS = np.array([[0.0, np.pi / 2, 0.3, 0.0], [0.4, 0.0, 0.0, 0.0], [0.3, 0.0, 0.0, 0.0]])
NON_ORTHONORMAL = np.eye(4)
NON_ORTHONORMAL[0, 1] = 0.2
FAR_TOOL = np.eye(4)
FAR_TOOL[:2, 3] = 1e6  # a bounded pose, but the drawn segment to it is 1.41e6 m long


@pytest.mark.parametrize("args, error, message", [
    ((0.1, 0.2, "no", 0.4), InputError, r"^d must be a number, got 'no'"),
    ((np.nan, 0.2, 0.3, 0.4), NonFiniteError, r"^a must be finite with magnitude <= 1e\+06, got nan"),
    ((0.1, 1e300, 0.3, 0.4), NonFiniteError, r"^alpha must be finite with magnitude <= 1e\+06, got 1e\+300"),
    ((0.1, 0.2, 0.3, None), InputError, r"^theta must be a number, got None"),
    ((0.1, 0.2, 0.3, True), InputError, r"^theta must be a number, got True"),
])
def test_dh_matrix_takes_four_finite_numbers(args, error, message):
    with pytest.raises(error, match=message):
        robots.dh_matrix(*args)
    A = robots.dh_matrix(0.1, 0.2, 0.3, np.float64(0.4))
    assert A.dtype == np.float64 and A[2, 3] == 0.3


@pytest.mark.parametrize("kwargs, error, message", [
    (dict(q=[np.nan, 0, 0]), NonFiniteError,
     r"^q must hold finite numbers with magnitude <= 1e\+06; bad entries: \[0\]=nan"),
    (dict(q=[1e300, 0, 0]), NonFiniteError, r"^q must hold finite numbers .*\[0\]=1e\+300"),
    (dict(q=[0, 0]), ShapeError, r"^q must have shape \(3,\)"),
    (dict(base=NON_ORTHONORMAL), ModelError, r"^DH table: base: rotation block is not a rotation matrix"),
    (dict(base="no"), ModelError, r"^DH table: base must be a pose"),
    (dict(tool="no"), ModelError, r"^DH table: tool must be a pose"),
    (dict(rows=ROWS * [1, 1, 1, np.nan]), ModelError, r"^DH table: rows: entry row 1, column theta is nan"),
])
def test_dh_fk_checks_its_arguments_as_from_dh_does(kwargs, error, message):
    args = {"rows": ROWS, "joint_types": "RRR", "q": [0.1, 0.2, 0.3], **kwargs}
    with pytest.raises(error, match=message) as fk_error:
        robots.dh_fk(**args)
    if error is ModelError:  # the table, base and tool: the one check from_dh makes too
        del args["q"]
        with pytest.raises(ModelError) as dh_error:
            robots.from_dh(**args, geometry=False)
        assert str(dh_error.value) == str(fk_error.value)
    robot = robots.from_dh(ROWS, "RRR", base=np.eye(4), geometry=False)
    np.testing.assert_allclose(robots.dh_fk(ROWS, "RRR", [0.1, 0.2, 0.3], base=np.eye(4)),
                               robot.fk([0.1, 0.2, 0.3]), atol=1e-12)


@pytest.mark.parametrize("kwargs, message", [
    (dict(velocity=-1.0), r"^DH table: velocity must be >= 0 \(the URDF <limit velocity=>\), got \[-1.0"),
    (dict(effort=[1.0, -2.0, 1.0]), r"^DH table: effort must be >= 0"),
    (dict(rows=np.full((3, 4), 1e300)), r"^DH table: rows: entry row 1, column a is 1e\+300; entries must be "
                                        r"finite with magnitude <= 1e\+06"),
    (dict(rows=ROWS * [1, 1, 1e7, 1]), r"^DH table: rows: entry row 1, column d is 3000000.0"),
    (dict(lower=[-1.0] * 3, upper=[1e300] * 3), r"^DH table: upper: entry 1 is 1e\+300"),
    (dict(effort=[1.0, 1e7, 1.0]), r"^DH table: effort: entry 2 is 10000000.0"),
    (dict(radius=1e6), r"^DH table: radius must be at most 333333"),
    (dict(tool=FAR_TOOL), r"^DH table \(generated URDF\), line \d+: <collision> of <link name='link3'>: "
                          r"<cylinder length='1414213.56'> must be 1 positive number"),
])
def test_dh_to_urdf_refuses_what_from_dh_refuses(kwargs, message):
    """dh_to_urdf wrote URDF text that from_dh then refused (or, for a negative velocity, that every loader
    refuses); both now refuse it with the same message naming the argument."""
    args = {"rows": ROWS, "joint_types": "RRR", **kwargs}
    with pytest.raises(ModelError, match=message) as text_error:
        robots.dh_to_urdf(**args)
    with pytest.raises(ModelError) as robot_error:
        robots.from_dh(**args, geometry=False)
    assert str(robot_error.value) == str(text_error.value)
    fine = robots.from_dh(ROWS, "RRR", [-1.0] * 3, [1e6] * 3, velocity=0.0, effort=[1, 2, 3], radius=3e5,
                          geometry=False)
    assert fine.upper.tolist() == [1e6] * 3 and 'velocity="0"' in fine.source


@pytest.mark.parametrize("kwargs, message", [
    (dict(effort=None), r"^DH table: effort must be a number or an array of numbers, got None"),
    (dict(velocity=None), r"^DH table: velocity must be a number or an array of numbers, got None"),
    (dict(velocity="1"), r"^DH table: velocity must be a number or an array of numbers, got '1'"),
    (dict(joint_names=0), r"^DH table: joint_names must be a list of 3 names \(one per row\), got 0"),
    (dict(joint_names="abc"), r"^DH table: joint_names must be a list of 3 names \(one per row\), got 'abc'"),
    (dict(joint_names=["a", "link1", "c"]), r"^DH table: joint_names must be unique and differ from the "
                                            r"generated names"),
    (dict(radius="no"), r"^DH table: radius must be a number, got 'no'"),
    (dict(radius=True), r"^DH table: radius must be a number, got True"),
    (dict(radius=-0.1), r"^DH table: radius must be positive, got -0.1"),
])
def test_dh_options_of_the_wrong_kind_are_named(kwargs, message):
    for build in (robots.dh_to_urdf, lambda **k: robots.from_dh(**k, geometry=False)):
        with pytest.raises(ModelError, match=message):
            build(rows=ROWS, joint_types="RRR", **kwargs)
    robot = robots.from_dh(ROWS, "RRR", joint_names=("a", "b", "c"), radius=0.01, geometry=False)
    assert robot.joint_names == ["a", "b", "c"]


@pytest.mark.parametrize("lower, upper, message", [
    (True, [1, 1, 1], r"^DH table: lower must be a number or an array of numbers, got True"),
    ([-1, -1, -1], "1", r"^DH table: upper must be a number or an array of numbers, got '1'"),
    ([-1, -1, -1], [1, np.nan, 1], r"^DH table: upper: entry 2 is nan"),
    pytest.param([-1, -1, -1], 10**400, r"^DH table: upper: .*an integer too large for a float",
                 id="10**400"),
])
def test_check_dh_table_limits_are_numbers(lower, upper, message):
    with pytest.raises(ModelError, match=message):
        robots.check_dh_table(ROWS, "RRR", lower=lower, upper=upper)
    assert robots.check_dh_table(ROWS, "RRR", lower=-1, upper=[1, 1, 1])[2].tolist() == [-1.0] * 3


# ------------------------------------------------------------------------------------- loader options
def _loaders(tmp_path):
    """Each loader with its model: robots.load (built-in and URDF text), load_urdf, load_xacro, from_dh."""
    (tmp_path / "two.urdf").write_text(URDF)
    xacro = robots.ENTRIES["planar4r"].path()
    return {
        "load": lambda **k: robots.load("planar4r", **k),
        "load text": lambda **k: robots.load(URDF, geometry=False, **k),
        "load_urdf": lambda **k: robots.load_urdf(tmp_path / "two.urdf", geometry=False, **k),
        "load_xacro": lambda **k: robots.load_xacro(xacro, geometry=False, **k),
        "from_dh": lambda **k: robots.from_dh(ROWS, "RRR", geometry=False, **k),
    }


@pytest.mark.parametrize("task_axes, message", [
    (0, r"^task_axes must be a sequence of task component names .* got int"),
    (3.5, r"^task_axes must be a sequence of task component names .* got float"),
    (b"x,y", r"^task_axes must be a sequence of task component names .* got the string b'x,y'"),
    (["x", "x"], r"^task_axes names task component 'x' twice"),
    ("x, w", r"^unknown task component 'w' in task_axes"),
    ([], r"^task_axes must name at least one task component"),
])
def test_task_axes_are_checked_by_every_loader(tmp_path, task_axes, message):
    for name, load in _loaders(tmp_path).items():
        with pytest.raises(ShapeError, match=message):
            load(task_axes=task_axes)
    loaders = _loaders(tmp_path)
    assert loaders["load_urdf"](task_axes="x, phi").task_axes == ("x", "yaw")
    assert loaders["from_dh"](task_axes=["x", "y", "z"]).task_axes == ("x", "y", "z")


@pytest.mark.parametrize("tip", [0, np.zeros(0), b"tool", ["tool"]])
def test_tip_must_be_a_frame_name(tmp_path, tip):
    """``tip=0`` was read as "no tip" by robots.load (the built-in's 'tool'); an empty array raised NumPy's
    truth-value error."""
    for name, load in _loaders(tmp_path).items():
        if name == "from_dh":
            continue  # its tool frame is tip_name
        with pytest.raises(InputError, match=r"^tip must be None or the name of a frame \(a str\), got "):
            load(tip=tip)
    with pytest.raises(FrameError, match=r"unknown frame 'nope' for robot 'planar4r'"):
        robots.load("planar4r", tip="nope")
    assert robots.load("planar4r", tip="link2").tip == "link2"


@pytest.mark.parametrize("option, value, error, message", [
    ("locked_joints", 0, ModelError, r"^locked_joints must be a mapping joint name -> value, got int"),
    ("locked_joints", [], ModelError, r"^locked_joints must be a mapping joint name -> value, got list"),
    ("name", np.nan, InputError, r"^name must be a str or None, got nan"),
    ("name", 3, InputError, r"^name must be a str or None, got 3"),
    ("description", None, InputError, r"^description must be a str, got None"),
])
def test_urdf_and_xacro_loader_options_of_the_wrong_kind(tmp_path, option, value, error, message):
    loaders = _loaders(tmp_path)
    for name in ("load_urdf", "load_xacro"):
        with pytest.raises(error, match=message):
            loaders[name](**{option: value})
    robot = loaders["load_urdf"](name="mine", description="two joints", locked_joints={"j2": 0.1})
    assert (robot.name, robot.description, robot.nq) == ("mine", "two joints", 1)


@pytest.mark.parametrize("package_dirs, message", [
    (["{tmp}/missing"], r"^package_dirs: '.*/missing' is not a folder"),
    ("no", r"^package_dirs: 'no' is not a folder"),
    (["{tmp}/two.urdf"], r"^package_dirs: '.*/two.urdf' is not a folder"),
    (0, r"^package_dirs must be a folder or a list of folders, got int '0'"),
    ([0], r"^package_dirs: 0 is not a folder"),
])
def test_package_dirs_are_checked_alike_by_every_loader(tmp_path, monkeypatch, package_dirs, message):
    """load_urdf and load_xacro took folders that do not exist (and raised TypeError for 0), where
    robots.load refused them; all share robots.load's check now."""
    monkeypatch.chdir(tmp_path)  # (no folder named "no" here)
    if isinstance(package_dirs, list) and isinstance(package_dirs[0], str):
        package_dirs = [package_dirs[0].format(tmp=tmp_path)]
    loaders = _loaders(tmp_path)
    xacro = robots.ENTRIES["planar4r"].path()
    for call in (loaders["load"], loaders["load text"], loaders["load_urdf"], loaders["load_xacro"],
                 lambda **k: robots.process_xacro(xacro, **k)):
        with pytest.raises(ModelError, match=message):
            call(package_dirs=package_dirs)
    assert loaders["load_urdf"](package_dirs=tmp_path).nq == 2
    assert loaders["load_urdf"](package_dirs=[str(tmp_path)]).nq == 2


# ----------------------------------------------------------------------------------------- read_srdf
@pytest.mark.parametrize("source, robot, message", [
    ("<robot name='two'/>", "panda", r"^robot must be a kinserve Robot \(robots.load\(...\)\), got 'panda' "
                                     r"\(robots.load\('panda'\) loads it\)"),
    ("<robot name='two'/>", None, r"^robot must be a kinserve Robot \(robots.load\(...\)\), got None"),
    ("ROBOT", "<robot name='two'/>", r"^read_srdf takes \(source, robot\): the SRDF path or XML text first, "
                                     r"then the loaded Robot; got source=Robot 'two', .* - swapped\?"),
    ("two", "two.srdf", r"^read_srdf takes \(source, robot\).* - swapped\?"),
])
def test_read_srdf_wants_a_robot_second(source, robot, message):
    two = robots.load(URDF, geometry=False)
    source = two if source == "ROBOT" else source
    with pytest.raises(InputError, match=message):
        read_srdf(source, robot)
    srdf = read_srdf("<robot name='two'><group name='arm'><joint name='j1'/></group></robot>", two)
    assert srdf.groups == {"arm": ("j1",)}
