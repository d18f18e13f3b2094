"""kinserve.robots.mesh_resolver: one search order for every load; a later build finds what the load found."""

from __future__ import annotations

import os
import pickle
import shutil

import numpy as np
import pytest
from lxml import etree

from kinserve import robots
from kinserve.kinematics.errors import ModelError
from kinserve.robots.mesh_resolver import MeshResolver, MissingMeshWarning
from kinserve.robots.packages import AMENT_PREFIX_PATH, ROS_PACKAGE_PATH
from kinserve.robots.paths import example_robot_data_package_dir

from ros_package import CLEARANCE_AT_ZERO, Q_COLLIDING, make_package, package_xml, robot_urdf, write_cube_stl


@pytest.fixture(autouse=True)
def no_ros_environment(monkeypatch):
    for var in (ROS_PACKAGE_PATH, AMENT_PREFIX_PATH):
        monkeypatch.delenv(var, raising=False)
    robots.clear_cache()
    yield
    robots.clear_cache()


def hull_vertices(robot) -> dict[str, np.ndarray]:
    """``{geometry name: sorted hull vertices (world frame at q = 0)}`` of the robot's collision model."""
    out = {}
    for shape in robot.collision_geometry(np.zeros(robot.nq)):
        verts = np.asarray(shape["vertices"]) @ shape["pose"][:3, :3].T + shape["pose"][:3, 3]
        out[shape["name"]] = verts[np.lexsort(verts.T[::-1])]
    return out


# ----------------------------------------------------------------- search order
def test_search_order_package_dirs_then_model_folders_then_ros_package_path_then_erd(tmp_path, monkeypatch):
    """One package name in four places: each place wins exactly when the ones before it do not have it."""
    given = tmp_path / "given" / "dup"  # Pinocchio's <dir>/<pkg> convention
    model_pkg = tmp_path / "dup"  # the model's own package
    (model_pkg / "urdf").mkdir(parents=True)
    (model_pkg / "package.xml").write_text(package_xml("dup"))
    ros = tmp_path / "ros" / "somewhere"
    ros.mkdir(parents=True)
    (ros / "package.xml").write_text(package_xml("dup"))
    given.mkdir(parents=True)
    monkeypatch.setenv(ROS_PACKAGE_PATH, str(tmp_path / "ros"))
    inside, outside = model_pkg / "urdf", tmp_path / "elsewhere"
    uri = "package://dup/m.stl"
    assert MeshResolver.for_model(inside, [tmp_path / "given"]).candidates(uri) == [given.resolve() / "m.stl"]
    assert MeshResolver.for_model(inside).candidates(uri) == [model_pkg.resolve() / "m.stl"]
    assert MeshResolver.for_model(outside).candidates(uri) == [ros.resolve() / "m.stl"]
    monkeypatch.delenv(ROS_PACKAGE_PATH)
    assert MeshResolver.for_model(outside).candidates(uri) == []
    erd = "package://example-robot-data/robots/panda_description/meshes/visual/link0.dae"
    share = example_robot_data_package_dir()
    assert MeshResolver.for_model(outside).resolve(erd) == share / erd[len("package://"):]


def test_a_package_xml_naming_the_package_beats_a_nearer_folder_named_like_it(tmp_path):
    real = tmp_path / "checkout"  # folder name != package name: only its package.xml says it is my_pkg
    (real / "my_pkg" / "urdf").mkdir(parents=True)
    (real / "package.xml").write_text(package_xml("my_pkg"))
    resolver = MeshResolver.for_model(real / "my_pkg" / "urdf")
    assert resolver.candidates("package://my_pkg/meshes/a.stl") == [real.resolve() / "meshes" / "a.stl"]
    assert resolver.package_dirs() == [real.resolve()]  # not named after its package: the folder itself
    plain = tmp_path / "plain" / "other_pkg" / "urdf"  # no package.xml anywhere: the folder name decides
    plain.mkdir(parents=True)
    named = MeshResolver.for_model(plain)
    assert named.candidates("package://other_pkg/x.stl") == [plain.parent.resolve() / "x.stl"]
    assert named.package_dirs() == [plain.parent.parent.resolve()]  # Pinocchio's <dir>/<pkg>


# --------------------------------------------------------- the load and later
def test_a_kinematics_only_load_builds_the_collision_model_from_the_files_a_full_load_reads(tmp_path):
    pkg = make_package(tmp_path)
    full = robots.load(pkg.urdf)
    later = robots.load(pkg.urdf, geometry=False)
    assert later.collision_model is None and str(tmp_path.resolve()) in later.package_dirs
    a, b = hull_vertices(full), hull_vertices(later)
    assert sorted(a) == sorted(b) and len(a) == 3
    for name in a:
        np.testing.assert_allclose(a[name], b[name], atol=1e-12)
    # the base cube is the STL scaled by 2: its hull's corners are +-0.1 m
    (base,) = [v for n, v in b.items() if n.startswith("base")]
    np.testing.assert_allclose(np.abs(base), 0.1, atol=1e-6)
    assert later.min_distance(np.zeros(2)) == pytest.approx(CLEARANCE_AT_ZERO, abs=1e-6)
    assert later.in_collision(Q_COLLIDING) and not later.in_collision(np.zeros(2))


def test_the_robot_keeps_the_search_path_of_its_load(tmp_path, monkeypatch):
    """Meshes found through $ROS_PACKAGE_PATH at load time are found by a later build after the variable,
    the working directory and the process (a pickled copy) have changed."""
    pkg = make_package(tmp_path / "ws")
    model = tmp_path / "elsewhere" / "robot.urdf"  # outside the package: only $ROS_PACKAGE_PATH finds my_pkg
    model.parent.mkdir()
    shutil.copy(pkg.urdf, model)
    monkeypatch.setenv(ROS_PACKAGE_PATH, str(pkg.workspace))
    robot = robots.load(model, geometry=False)
    monkeypatch.delenv(ROS_PACKAGE_PATH)
    monkeypatch.chdir(tmp_path)
    copy = pickle.loads(pickle.dumps(robot))
    assert copy.collision_model is None and copy.in_collision(Q_COLLIDING)
    assert robot.min_distance(np.zeros(2)) == pytest.approx(CLEARANCE_AT_ZERO, abs=1e-6)


def test_could_not_be_found_names_every_way_to_add_a_folder(tmp_path):
    pkg = make_package(tmp_path / "ws")
    model = tmp_path / "elsewhere" / "robot.urdf"
    model.parent.mkdir()
    shutil.copy(pkg.urdf, model)
    robot = robots.load(model, geometry=False)  # nothing read yet: no error, no warning
    with pytest.raises(ModelError) as err:
        robot.in_collision(np.zeros(2))
    message = str(err.value)
    for part in ("package://my_pkg/meshes/link.stl", "could not be found", "package 'my_pkg' not found",
                 "package_dirs=", "--package-dir", "$ROS_PACKAGE_PATH", str(model.parent.resolve()),
                 "2 more collision mesh(es)"):
        assert part in message, part
    assert robots.load(model, geometry=False, package_dirs=[pkg.workspace]).in_collision(Q_COLLIDING)


def test_a_missing_file_in_a_found_package_says_where_it_looked(tmp_path):
    pkg = make_package(tmp_path)
    pkg.urdf.write_text(robot_urdf(l1_uri="package://my_pkg/meshes/gone.stl"))
    with pytest.warns(MissingMeshWarning, match="could not be found") as record:
        loaded = robots.load(pkg.urdf)
    assert str(pkg.package.resolve() / "meshes" / "gone.stl") in str(record[0].message)
    assert loaded.collision_model.ngeoms == 2  # l1's shape left out
    # the load left l1 out with a warning; a later build (a pickled copy) leaves it out too
    copy = pickle.loads(pickle.dumps(loaded))
    assert copy.collision_model is None and len(copy.collision.geometry_names) == 2
    with pytest.raises(ModelError, match=r"gone\.stl.*could not be found.*--package-dir"):
        robots.load(pkg.urdf, geometry=False).in_collision(np.zeros(2))  # never warned: an error


def test_a_later_build_refuses_files_outside_the_model_folders(tmp_path):
    pkg = make_package(tmp_path / "ws")
    outside = tmp_path / "other" / "cube.stl"
    write_cube_stl(outside)
    pkg.urdf.write_text(robot_urdf(uri=str(outside)))
    robot = robots.load(pkg.urdf, geometry=False)  # kinematics only: nothing read, nothing refused
    with pytest.raises(ModelError, match="outside the folders this model may read from"):
        robot.in_collision(np.zeros(2))
    allowed = robots.load(pkg.urdf, geometry=False, allow_outside=True)
    assert allowed.min_distance(np.zeros(2)) == pytest.approx(CLEARANCE_AT_ZERO, abs=1e-6)


def test_xacro_and_built_in_robots_keep_their_resolver(tmp_path):
    pkg = make_package(tmp_path)
    xacro = pkg.package / "urdf" / "robot.urdf.xacro"
    xacro.write_text(pkg.urdf.read_text().replace('<robot name="my_bot">',
                                                  '<robot name="my_bot" '
                                                  'xmlns:xacro="http://www.ros.org/wiki/xacro">'))
    robot = robots.load(xacro, geometry=False)
    assert robot.resolve_meshes is not None and robot.in_collision(Q_COLLIDING)
    panda = robots.load("panda", geometry=False)
    resolved = etree.fromstring(panda.resolve_meshes(panda.source).encode())
    files = [m.get("filename") for m in resolved.iterfind("link/collision/geometry/mesh")]
    given = etree.fromstring(panda.source.encode()).findall("link/collision/geometry/mesh")
    assert len(files) == len(given) > 5 and all(os.path.isabs(f) and os.path.isfile(f) for f in files)
    assert "package://" in panda.source  # the robot's own text keeps its URIs
