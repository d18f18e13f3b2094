"""Bad input to the Robot's queries, the collision scene, shapes and the loaders: kinserve's own errors.

Each test gives a public entry point a bad argument and checks the error type and its message, then a valid
neighbouring argument that must still work (so the check is not too strict). The robot is a small two-link
arm written as URDF text (collision boxes on both links), so nothing here loads a big model.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from kinserve import ik, robots
from kinserve.ik.batch.reachability import reachability_map
from kinserve.kinematics import singularity
from kinserve.kinematics.errors import (
    InputError,
    JointLimitError,
    ModelError,
    NonFiniteError,
    ShapeError,
    SingularityError,
)
from kinserve.kinematics.validation import as_matrix, as_vector

#: The arm's collision / visual element of link ``l2``; the tests put a bad one in its place.
GOOD_L2_GEOMETRY = ('<collision><origin xyz="0.5 0 0" rpy="0 0 0"/><geometry><box size="1 0.1 0.1"/>'
                    '</geometry></collision>')


def arm_urdf(l2_geometry: str = GOOD_L2_GEOMETRY) -> str:
    """Two revolute links; ``j1`` about z, ``j2`` about y (so ``q = [0, pi/2]`` pitches the tool to
    +pi/2: the RPY gimbal lock); ``l1`` and ``l2`` carry collision boxes."""
    return f"""<?xml version="1.0"?>
<robot name="arm">
  <link name="base"/>
  <link name="l1">
    <collision><origin xyz="0.5 0 0"/><geometry><box size="1 0.1 0.1"/></geometry></collision>
  </link>
  <link name="l2">
    {l2_geometry}
  </link>
  <link name="tool"/>
  <joint name="j1" type="revolute">
    <parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/>
  </joint>
  <joint name="j2" type="revolute">
    <origin xyz="1 0 0"/><parent link="l1"/><child link="l2"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/>
  </joint>
  <joint name="tool_joint" type="fixed">
    <origin xyz="1 0 0"/><parent link="l2"/><child link="tool"/>
  </joint>
</robot>
"""


def write(tmp_path, text: str, name: str = "arm.urdf"):
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def arm():
    return robots.load(arm_urdf(), geometry=False, tip="tool")


# ---------------------------------------------------------------- 1. URDF collision / visual geometry
BAD_GEOMETRY = [
    ('<collision><geometry><sphere radius="nan"/></geometry></collision>', r"<sphere radius='nan'>"),
    ('<collision><geometry><sphere radius="-0.2"/></geometry></collision>', r"<sphere radius='-0.2'>"),
    ('<collision><geometry><sphere radius="1e300"/></geometry></collision>', r"<sphere radius='1e300'>"),
    ('<collision><geometry><sphere radius="0"/></geometry></collision>', r"<sphere radius='0'>"),
    ('<collision><geometry><sphere/></geometry></collision>', r"<sphere> needs a radius= attribute"),
    ('<collision><geometry><box size="-0.2 -0.2 -0.2"/></geometry></collision>',
     r"<box size='-0.2 -0.2 -0.2'>"),
    ('<collision><geometry><box size="0.1 0.1"/></geometry></collision>', r"<box size='0.1 0.1'>"),
    ('<collision><geometry><cylinder radius="0.1" length="inf"/></geometry></collision>',
     r"<cylinder length='inf'>"),
    ('<collision><geometry><cylinder radius="0.1"/></geometry></collision>', r"<cylinder> needs a length="),
    ('<collision><origin rpy="0 nan 0"/><geometry><sphere radius="0.1"/></geometry></collision>',
     r"<origin rpy='0 nan 0'>"),
    ('<collision><origin xyz="1e7 0 0"/><geometry><sphere radius="0.1"/></geometry></collision>',
     r"<origin xyz='1e7 0 0'>"),
    ('<collision><geometry><capsule radius="0.1" length="0.2"/></geometry></collision>',
     r"<geometry> must hold exactly one of <box>, <sphere>, <cylinder>, <mesh>, found <capsule>"),
    ('<collision><geometry/></collision>', r"found nothing"),
    ('<collision><origin xyz="0 0 0"/></collision>', r"must hold one <geometry> element, found 0"),
    ('<visual><geometry><sphere radius="-1"/></geometry></visual>', r"<visual> of <link name='l2'>"),
    ('<visual><geometry><mesh filename="m.stl" scale="1 0 1"/></geometry></visual>',
     r"<mesh scale='1 0 1'> must be 3 non-zero numbers"),
    ('<visual><geometry><mesh filename="m.stl" scale="1 nan 1"/></geometry></visual>',
     r"<mesh scale='1 nan 1'> must be 3 finite number"),
]


@pytest.mark.parametrize("geometry, message", BAD_GEOMETRY)
def test_bad_collision_or_visual_geometry_is_a_model_error_naming_link_element_and_attribute(
        tmp_path, geometry, message):
    path = write(tmp_path, arm_urdf(geometry))
    with pytest.raises(ModelError, match=r"arm\.urdf, line \d+: <(collision|visual)> of <link name='l2'>"):
        robots.load(path, geometry=False)
    with pytest.raises(ModelError, match=message):
        robots.load(path, geometry=False)


def test_valid_geometry_loads_and_an_obstacle_on_it_collides(tmp_path):
    sphere = '<collision><origin xyz="0.5 0 0"/><geometry><sphere radius="0.2"/></geometry></collision>'
    robot = robots.load(write(tmp_path, arm_urdf(sphere)), geometry=False, tip="tool")
    centre = robot.fk(robot.neutral(), "l2")[:3, 3] + [0.5, 0.0, 0.0]
    assert robot.in_collision(robot.neutral(), [ik.Sphere(centre, 0.01)], self_collision=False)
    assert robot.min_distance(robot.neutral(), [ik.Sphere(centre, 0.01)], self_collision=False) < 0
    mirrored = '<visual><geometry><mesh filename="m.stl" scale="1 -1 1"/></geometry></visual>'
    path = write(tmp_path, arm_urdf(GOOD_L2_GEOMETRY + mirrored), "m.urdf")
    assert robots.load(path, geometry=False).nq == 2


# ------------------------------------------------------------------ 2. analytic_jacobian singular_tol
@pytest.mark.parametrize("tol, error, message", [
    (float("nan"), NonFiniteError, "singular_tol must be finite"),
    (-1.0, InputError, "singular_tol must be positive, got -1.0"),
    (0.0, InputError, "singular_tol must be positive, got 0.0"),
    (2.0, InputError, "singular_tol must be at most 1, got 2.0"),
    ("x", InputError, "singular_tol must be a number, got 'x'"),
])
def test_analytic_jacobian_refuses_a_bad_singular_tol_at_the_gimbal_lock(arm, tol, error, message):
    q = np.array([0.0, math.pi / 2])
    with pytest.raises(error, match=message):
        arm.analytic_jacobian(q, singular_tol=tol)
    with pytest.raises(SingularityError, match="gimbal lock"):
        arm.analytic_jacobian(q)
    assert np.all(np.isfinite(arm.analytic_jacobian([0.0, 0.3], singular_tol=1e-3)))


# ------------------------------------------------------------ 3. is_singular / within_limits tolerances
@pytest.mark.parametrize("tol, error, message", [
    (float("nan"), NonFiniteError, "tol must be finite"),
    (-1.0, InputError, "tol must be zero or positive, got -1.0"),
    (float("inf"), NonFiniteError, "tol must be finite"),
    (1.5, InputError, "tol must be at most 1, got 1.5"),
    (None, InputError, "tol must be a number, got None"),
])
def test_is_singular_refuses_a_bad_tol(arm, tol, error, message):
    with pytest.raises(error, match=message):
        arm.is_singular([0.0, 0.3], tol=tol)
    with pytest.raises(error, match=message):
        singularity.is_singular(np.eye(2), tol)
    assert arm.is_singular([0.0, 0.3], tol=0.0) is False
    assert singularity.rank(np.diag([1.0, 0.0]), 1e-6) == 1


@pytest.mark.parametrize("tol, error, message", [
    (1e300, NonFiniteError, "tol must be finite with magnitude <= 1e"),
    (float("nan"), NonFiniteError, "tol must be finite"),
    (-1.0, InputError, "tol must be zero or positive, got -1.0"),
    ("a", InputError, "tol must be a number, got 'a'"),
])
def test_within_limits_refuses_a_bad_tol(arm, tol, error, message):
    with pytest.raises(error, match=message):
        arm.within_limits([0.0, 0.0], tol=tol)
    assert arm.within_limits([3.05, 0.0], tol=0.1) is True
    assert arm.within_limits([3.05, 0.0]) is False


# ----------------------------------------------------------------------------------- 4. task axes
@pytest.mark.parametrize("axes, message", [
    ([], r"axes must name at least one task component"),
    ((), r"axes must name at least one task component"),
    (["x", "x"], r"axes names task component 'x' twice"),
    (["yaw", "phi"], r"axes names task component 'yaw' twice"),
    ("xyz", r"axes must be a sequence of task component names .* got the string 'xyz'"),
    (["x", "nope"], r"unknown task component 'nope' in axes"),
    (3, r"axes must be a sequence of task component names .* got int"),
])
def test_singularity_measures_refuse_empty_repeated_or_unknown_axes(arm, axes, message):
    q = [0.0, 0.3]
    for measure in (arm.manipulability, arm.singular_values, arm.condition_number, arm.is_singular):
        with pytest.raises(ShapeError, match=message):
            measure(q, axes=axes)
    assert arm.manipulability(q, axes=["y", "z"]) > 0
    assert arm.condition_number(q, axes=["y", "z"]) < math.inf


def test_singularity_functions_refuse_an_empty_or_non_finite_jacobian():
    with pytest.raises(ShapeError, match=r"J must have at least one row and one column, got shape \(0, 3\)"):
        singularity.condition_number(np.zeros((0, 3)))
    with pytest.raises(NonFiniteError, match="J must hold finite numbers"):
        singularity.manipulability(np.full((2, 2), np.nan))
    assert singularity.condition_number(np.diag([2.0, 1.0])) == pytest.approx(2.0)


# ----------------------------------------------------------------------- 5. check_limits / within_limits q
@pytest.mark.parametrize("q, error, message", [
    ([np.nan, 0.0], NonFiniteError, r"q must hold finite numbers .* bad entries: \[0\]=nan"),
    ([0.0, 0.0, 0.0], ShapeError, r"q must have shape \(2,\), got shape \(3,\)"),
    (None, ShapeError, "q must be a sequence of 2 numbers, got None"),
    ("ab", ShapeError, "q must be a sequence of 2 numbers, got 'ab'"),
])
def test_check_limits_and_within_limits_validate_q(arm, q, error, message):
    with pytest.raises(error, match=message):
        arm.check_limits(q)
    with pytest.raises(error, match=message):
        arm.within_limits(q)
    arm.check_limits([0.0, 1.0])
    with pytest.raises(JointLimitError, match=r"j2=2\.5 not in \[-2, 2\]"):
        arm.check_limits([0.0, 2.5])


# ------------------------------------------------------------------------------------- 6. counts
@pytest.mark.parametrize("rng", [-1, "a", 1.5, float("nan"), True])
def test_random_q_refuses_a_bad_rng(arm, rng):
    with pytest.raises(InputError, match=r"rng must be a numpy.random.Generator, an integer seed"):
        arm.random_q(rng)


@pytest.mark.parametrize("n, message", [
    (-1, "n must be an integer from 0 to 10,000,000, got -1"),
    ("a", "n must be an integer, got 'a'"),
    (10**12, "n must be an integer from 0 to 10,000,000, got 1000000000000"),
    (1.5, "n must be an integer, got 1.5"),
])
def test_random_q_refuses_a_bad_or_unbounded_count(arm, n, message):
    with pytest.raises(InputError, match=message):
        arm.random_q(0, n=n)


def test_random_q_still_takes_seeds_generators_and_counts(arm):
    assert arm.random_q(0).shape == (2,)
    assert arm.random_q(np.random.default_rng(1), n=5).shape == (5, 2)
    assert arm.random_q(None, n=0).shape == (0, 2)
    assert np.array_equal(arm.random_q(3, n=np.int64(4)), arm.random_q(3, n=4))


def test_reachability_map_refuses_an_unbounded_sample_count_before_any_work(arm):
    with pytest.raises(InputError, match=r"samples must be at most 10,000,000 \(one IK solve each\), got "
                                         r"1,000,000,000,000"):
        reachability_map(arm, 10**12, backend="serial")
    with pytest.raises(InputError, match="samples must be a positive integer, got 0"):
        reachability_map(arm, 0, backend="serial")


# ---------------------------------------------------------------------------------- 7. complex q
def test_complex_numbers_are_refused_not_truncated(arm):
    q = np.array([0.1, 0.2]) + 1j
    for call in (lambda: arm.fk(q), lambda: arm.jacobian(q), lambda: arm.check_q(q),
                 lambda: arm.in_collision(q), lambda: as_vector([0.1 + 1j, 0.2], 2)):
        with pytest.raises(ShapeError, match=r"q must hold real numbers, got complex numbers \(dtype"):
            call()
    with pytest.raises(ShapeError, match=r"R must hold real numbers, got complex numbers"):
        as_matrix(np.eye(3) + 0j, (3, 3), "R")
    assert np.allclose(arm.fk(np.array([0.1, 0.2])), arm.fk([0.1, 0.2]))


# --------------------------------------------------------------------------------- 8. self_collision
@pytest.mark.parametrize("flag", ["yes", None, float("nan"), 1])
def test_self_collision_must_be_a_bool(arm, flag):
    q = [0.0, 0.3]
    for call in (arm.in_collision, arm.collisions, arm.distances, arm.min_distance):
        with pytest.raises(InputError, match=r"self_collision must be True or False, got "):
            call(q, self_collision=flag)
    with pytest.raises(InputError, match=r"self_collision must be True or False"):
        arm.collision_scene(self_collision=flag)
    assert arm.in_collision(q, self_collision=False) is False
    assert arm.in_collision(q, self_collision=np.bool_(True)) is False
    assert arm.collision_scene(self_collision=False).self_collision is False


# ----------------------------------------------------------------------------- 9. near / near_distance
@pytest.mark.parametrize("threshold, error, message", [
    (None, InputError, "threshold must be a number, got None"),
    ("a", InputError, "threshold must be a number, got 'a'"),
    (float("nan"), NonFiniteError, "threshold must be finite"),
    (-0.1, InputError, "threshold must be zero or positive, got -0.1"),
])
def test_near_refuses_a_bad_threshold(arm, threshold, error, message):
    scene = arm.collision_scene([ik.Sphere([1.5, 0.0, 0.0], 0.05)])
    with pytest.raises(error, match=message):
        scene.near(threshold, [0.0, 0.0])
    with pytest.raises(error, match=message):
        scene.near_distance(threshold, 0)
    hits = scene.near(0.1, [0.0, 0.0])
    assert hits  # the sphere sits inside l2's box
    assert scene.near_distance(0.1, hits[0]).distance < 0


@pytest.mark.parametrize("k, message", [
    (-1, r"k \(a pair index\) must be an integer from 0 to \d+, got -1"),
    (10**9, r"k \(a pair index\) must be an integer from 0 to \d+, got 1000000000"),
    ("a", r"k \(a pair index\) must be an integer, got 'a'"),
])
def test_near_distance_refuses_a_pair_index_out_of_range(arm, k, message):
    scene = arm.collision_scene([ik.Sphere([1.5, 0.0, 0.0], 0.05)])
    scene.near(0.1, [0.0, 0.0])
    with pytest.raises(InputError, match=message):
        scene.near_distance(0.1, k)
    assert math.isfinite(scene.near_distance(0.1, len(scene) - 1).distance)


def test_a_thread_keeps_a_bounded_number_of_margin_workspaces(arm):
    """Each new ``near`` threshold makes a margin workspace (a GeometryData and a broad phase); a thread keeps
    at most MARGIN_WORKSPACES of them, and a threshold whose workspace was replaced answers as before."""
    from kinserve.kinematics.collision_layout import MARGIN_WORKSPACES

    scene = arm.collision_scene([ik.Sphere([1.5, 0.0, 0.0], 0.05)])
    q = [0.0, 0.0]
    first = scene.near(0.02, q)
    assert first  # (the sphere sits inside l2's box)
    for k in range(3 * MARGIN_WORKSPACES):
        scene.near(0.03 + 0.01 * k, q)
    assert len(scene.layout._threads.margin) == MARGIN_WORKSPACES
    assert 0.02 not in scene.layout._threads.margin
    assert scene.near(0.02, q) == first


@pytest.mark.parametrize("size", [True, "0.1", b"0.1", np.bool_(True)])
def test_shape_sizes_are_numbers_not_text_or_bools(size):
    with pytest.raises(ShapeError, match=r"sphere radius must be a number \(m\), got"):
        ik.Sphere([0.0, 0.0, 0.0], size)
    assert ik.Sphere([0.0, 0.0, 0.0], 0.1).radius == 0.1


# --------------------------------------------------------------------------------------- 10. loaders
def test_load_refuses_package_dirs_that_are_not_folders():
    with pytest.raises(ModelError, match=r"package_dirs must be a folder or a list of folders, got int '3'"):
        robots.load(arm_urdf(), geometry=False, package_dirs=3)
    assert robots.load(arm_urdf(), geometry=False, package_dirs=[]).nq == 2


@pytest.mark.parametrize("time_limit", [1e300, "a", -1, 0, float("nan"), True])
def test_load_refuses_a_bad_time_limit_for_every_model(tmp_path, time_limit):
    message = r"time_limit must be a positive number of seconds, at most 3600 \(None: 20 s\), got "
    with pytest.raises(ModelError, match=message):
        robots.load("planar4r", time_limit=time_limit)  # a xacro built-in
    with pytest.raises(ModelError, match=message):
        robots.load(write(tmp_path, arm_urdf()), geometry=False, time_limit=time_limit)  # a plain URDF
    assert robots.load(write(tmp_path, arm_urdf()), geometry=False, time_limit=5).nq == 2


# ------------------------------------------------------------------------------------------ 11. Mesh
def test_mesh_refuses_a_path_that_is_not_a_path_and_a_bad_scale(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    stl = tmp_path / "cube.stl"
    trimesh.creation.box(extents=(0.1, 0.1, 0.1)).export(stl)
    for path, given in ((None, "None"), (3, "int"), ("", "''")):
        with pytest.raises(InputError, match=rf"mesh path must be a file path \(a non-empty str or "
                                             rf"pathlib.Path\), got {given}"):
            ik.Mesh(path)
    for scale in ("a", None):
        with pytest.raises(ShapeError, match=r"mesh scale must be a positive number or three of them"):
            ik.Mesh(stl, scale=scale)
    with pytest.raises(InputError, match=r"mesh scale must be positive"):
        ik.Mesh(stl, scale=-1)
    assert ik.Mesh(stl, scale=2.0).scale == (2.0, 2.0, 2.0)
    assert ik.Mesh(str(stl), scale=[1, 2, 3]).scale == (1.0, 2.0, 3.0)


def test_shapes_beyond_the_extent_coal_measures_precisely_are_refused():
    """A shape must lie within MAX_EXTENT (1e4 m) of the world origin: beyond, coal misjudges distances by
    centimetres without a word. Within it, a sphere of radius c - 0.2 centred at (c, 0, 0) - nearly the
    half-space x >= 0.2 - and a box filling that half-space give the Panda's links the same distances."""
    from kinserve.kinematics.shapes import MAX_EXTENT

    with pytest.raises(ShapeError, match=r"sphere: a shape must lie within 10000 m of the world origin"):
        ik.Sphere([1e5, 0.0, 0.0], 1e5 - 0.2)
    with pytest.raises(ShapeError, match=r"box: a shape must lie within 10000 m .* reaches 1.5e\+04 m"):
        ik.Box(np.eye(4), (3e4, 1.0, 1.0))
    with pytest.raises(ShapeError, match="cylinder: a shape must lie within"):
        ik.Cylinder(np.diag([1.0, 1.0, 1.0, 1.0]) + np.eye(4, k=3) * 9999.0, 5.0, 1.0)
    panda = robots.load("panda")
    q = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]
    c = MAX_EXTENT / 2 - 1.0
    wall = np.eye(4)
    wall[0, 3] = 0.2 + 50.0
    sphere = {link: d.distance for (link, _), d in
              panda.distances(q, [ik.Sphere([c, 0.0, 0.0], c - 0.2)], self_collision=False).items()}
    box = {link: d.distance for (link, _), d in
           panda.distances(q, [ik.Box(wall, (100.0, 100.0, 100.0))], self_collision=False).items()}
    near = [link for link, d in box.items() if d < 0.5]
    assert len(near) >= 3
    for link in near:
        assert sphere[link] == pytest.approx(box[link], abs=2e-3)


FLAG_NOT_STATED = ["no", "False", 0, 1, 0.0, None, float("nan"), [], [True]]


@pytest.mark.parametrize("value", FLAG_NOT_STATED)
def test_as_flag_takes_true_or_false_only(value):
    """No truthiness: "no", "False" or [True] would each be read as something they do not say."""
    from kinserve.kinematics.validation import as_flag

    with pytest.raises(InputError, match=r"^simplify must be True or False, got "):
        as_flag(value, "simplify")
    assert as_flag(True, "x") is True and as_flag(np.bool_(False), "x") is False


@pytest.mark.parametrize("value", FLAG_NOT_STATED)
def test_check_limits_must_be_true_or_false(arm, value):
    """``check_limits="no"`` checked the limits, and ``check_limits=0`` or None did not, silently; each is now
    an InputError naming check_limits, from every call that takes it. NumPy's bools are flags."""
    q = np.asarray(arm.upper) + 0.1  # beyond every limit
    calls = {"check_q": lambda v: arm.check_q(q, check_limits=v), "fk": lambda v: arm.fk(q, check_limits=v),
             "fk_all": lambda v: arm.fk_all(q, check_limits=v),
             "jacobian": lambda v: arm.jacobian(q, check_limits=v)}
    for name, call in calls.items():
        with pytest.raises(InputError, match="check_limits must be True or False"):
            call(value)
        call(np.bool_(False))
        with pytest.raises(JointLimitError):
            call(np.bool_(True))


@pytest.mark.parametrize("value", ["no", 0, None])
def test_collision_and_file_flags_must_be_true_or_false(tmp_path, value):
    """Five more flags that were read by truthiness: ``CollisionModel.scene(self_collision="no")`` checked the
    robot's own pairs, ``ik.CollisionConstraint`` and ``reachability_map`` the same, and
    ``allow_outside="no"`` let a xacro file or a mesh resolver read files outside the model's folders."""
    from kinserve.robots.mesh_resolver import MeshResolver

    panda = robots.load("panda")
    xacro = tmp_path / "arm.urdf.xacro"
    xacro.write_text('<robot name="a" xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="l"/></robot>')
    ball = ik.Sphere([1.0, 0.0, 0.0], 0.1)
    calls = {"self_collision": [lambda v: panda.collision.scene((), self_collision=v),
                                lambda v: ik.CollisionConstraint([ball], self_collision=v),
                                lambda v: reachability_map(panda, samples=4, resolution=2, self_collision=v)],
             "allow_outside": [lambda v: robots.load_xacro(xacro, allow_outside=v),
                               lambda v: MeshResolver.for_model(tmp_path, allow_outside=v)]}
    for flag, makers in calls.items():
        for call in makers:
            with pytest.raises(InputError, match=f"{flag} must be True or False"):
                call(value)
    assert panda.collision.scene((), self_collision=np.False_).self_collision is False
    assert MeshResolver.for_model(tmp_path, allow_outside=np.True_).allow_outside is True


# ---------------------------------------------------------------- names given as arrays, lists, numbers
REFERENCES = r"'world', 'local_world_aligned', 'local', 'body', 'spatial'"


@pytest.mark.parametrize("method, value, error, message", [
    ("jacobian", [], ShapeError, rf"^reference must be one of {REFERENCES}, got \[\]$"),
    ("jacobian", np.zeros(0), ShapeError, rf"^reference must be one of {REFERENCES}, got array"),
    ("jacobian", np.array(["world"]), ShapeError, r"^reference must be one of .*, got array"),
    ("jacobian", None, ShapeError, r"^reference must be one of .*, got None$"),
    ("jacobian", "globe", ShapeError, r"^reference must be one of .*, got 'globe'$"),
    ("analytic_jacobian", np.zeros(0), ShapeError, r"^rotation must be one of 'rpy', got array"),
    ("analytic_jacobian", ["rpy"], ShapeError, r"^rotation must be one of 'rpy', got \["),
    ("analytic_jacobian", "RPY", ShapeError, r"^rotation must be one of 'rpy', got 'RPY'$"),
    ("detach", np.zeros(0), InputError, r"^detach: name must be a str .*, got array"),
    ("detach", 3, InputError, r"^detach: name must be a str .*, got 3$"),
    ("detach", None, InputError, r"^detach: name must be a str .*, got None$"),
])
def test_reference_rotation_and_detach_names_are_checked_by_type(arm, method, value, error, message):
    """reference=[] was "unhashable type: 'list'", an array NumPy's "truth value of an empty array is
    ambiguous" (np.array(["world"]) was read as "world"), detach(array) compared the array with each name."""
    q = np.array([0.1, 0.2])
    calls = {"jacobian": lambda: arm.jacobian(q, reference=value),
             "analytic_jacobian": lambda: arm.analytic_jacobian(q, rotation=value),
             "detach": lambda: arm.copy().detach(value)}
    with pytest.raises(error, match=message):
        calls[method]()


def test_reference_rotation_and_detach_still_take_their_names(arm):
    q = np.array([0.1, 0.2])
    world = "".join(["wor", "ld"])  # a "world" that is not the interned literal: compared by value
    assert np.array_equal(arm.jacobian(q, reference=world), arm.jacobian(q))
    assert np.array_equal(arm.jacobian(q, reference="local_world_aligned"), arm.jacobian(q))
    assert not np.allclose(arm.jacobian(q, reference="local"), arm.jacobian(q))
    assert arm.analytic_jacobian(q, rotation="rpy").shape == (6, 2)
    carrier = arm.copy().attach("box", ik.Sphere([0.0, 0.0, 0.0], 0.05), "tool")
    assert carrier.detach("box").name == "box" and not carrier.attached
