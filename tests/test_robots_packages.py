"""kinserve.robots.packages: a ROS-style robot description whose meshes live in another package.

The workspace built here is what a roboticist has: ``ws/src/arm_description``
(package.xml, urdf/arm.urdf) refers to ``package://arm_meshes/meshes/link1.stl``,
a package in a folder named ``meshes_repo`` (so neither a parent folder of the
URDF nor a folder named after the package). The STL is binary, written here.
"""

from __future__ import annotations

import os
import struct
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from kinserve import robots
from kinserve.kinematics.errors import ModelError
from kinserve.robots.packages import (
    AMENT_PREFIX_PATH,
    ROS_PACKAGE_PATH,
    PackageFinder,
    is_within,
    scan_packages,
)
from kinserve.robots.urdf_loader import MissingMeshWarning

ROOT = Path(__file__).resolve().parents[1]

#: Tetrahedron corners (m): its bounding box is [0, 0.1] x [0, 0.2] x [0, 0.3].
CORNERS = np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.2, 0.0], [0.0, 0.0, 0.3]])
FACES = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]


def write_binary_stl(path: Path) -> None:
    """80-byte header, uint32 triangle count, then per triangle: normal, 3 vertices (float32), uint16."""
    path.parent.mkdir(parents=True, exist_ok=True)
    out = bytearray(b"kinserve test tetrahedron".ljust(80, b"\0"))
    out += struct.pack("<I", len(FACES))
    for a, b, c in FACES:
        n = np.cross(CORNERS[b] - CORNERS[a], CORNERS[c] - CORNERS[a])
        n /= np.linalg.norm(n)
        out += struct.pack("<12fH", *n, *CORNERS[a], *CORNERS[b], *CORNERS[c], 0)
    path.write_bytes(bytes(out))


def package_xml(name: str) -> str:
    return ('<?xml version="1.0"?>\n<package '
            f'format="3"><name>{name}</name><version>0.1.0</version></package>\n')


def arm_urdf(mesh_uri: str) -> str:
    link1 = (f'<link name="link1"><visual><geometry><mesh filename="{mesh_uri}"/></geometry></visual>'
             f'<collision><geometry><mesh filename="{mesh_uri}"/></geometry></collision></link>')
    joints = ""
    for i, (parent, child, xyz) in enumerate([("base", "link1", "0 0 0.1"), ("link1", "link2", "0.5 0 0"),
                                              ("link2", "tool", "0.4 0 0")], start=1):
        joints += (f'<joint name="j{i}" type="revolute"><origin xyz="{xyz}"/><parent link="{parent}"/>'
                   f'<child link="{child}"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" '
                   'velocity="1"/></joint>')
    return (f'<?xml version="1.0"?>\n<robot name="arm"><link name="base"/>{link1}<link name="link2"/><link '
            f'name="tool"/>{joints}</robot>\n')


@pytest.fixture
def workspace(tmp_path, monkeypatch):
    """``ws/src/{arm_description, meshes_repo}``; returns (ws/src, urdf path, stl path)."""
    for var in (ROS_PACKAGE_PATH, AMENT_PREFIX_PATH):
        monkeypatch.delenv(var, raising=False)
    src = tmp_path / "ws" / "src"
    desc = src / "arm_description"
    (desc / "urdf").mkdir(parents=True)
    (desc / "package.xml").write_text(package_xml("arm_description"))
    urdf = desc / "urdf" / "arm.urdf"
    urdf.write_text(arm_urdf("package://arm_meshes/meshes/link1.stl"))
    meshes = src / "meshes_repo"
    meshes.mkdir()
    (meshes / "package.xml").write_text(package_xml("arm_meshes"))
    stl = meshes / "meshes" / "link1.stl"
    write_binary_stl(stl)
    robots.clear_cache()
    yield src, urdf, stl
    robots.clear_cache()


def assert_mesh_is_the_stl(robot, stl: Path) -> None:
    """The visual and collision geometry of link1 are the test's tetrahedron, read from ``stl``."""
    for gm in (robot.visual_model, robot.collision_model):
        (g,) = [g for g in gm.geometryObjects if g.name.startswith("link1")]
        assert Path(g.meshPath) == stl.resolve()
        g.geometry.computeLocalAABB()
        np.testing.assert_allclose(g.geometry.aabb_local.min_, CORNERS.min(axis=0), atol=1e-6)
        np.testing.assert_allclose(g.geometry.aabb_local.max_, CORNERS.max(axis=0), atol=1e-6)
        assert g.geometry.num_tris == len(FACES)


def load_quietly(*args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("error", MissingMeshWarning)  # a mesh not found would fail the test
        return robots.load(*args, **kwargs)


# ----------------------------------------------------------------------- finder
def test_scan_reads_package_names_and_does_not_enter_packages_or_hidden_folders(tmp_path):
    (tmp_path / "a" / "nested").mkdir(parents=True)
    (tmp_path / "a" / "package.xml").write_text(package_xml("pkg_a"))
    # inside a package: not a package
    (tmp_path / "a" / "nested" / "package.xml").write_text(package_xml("inner"))
    (tmp_path / ".hidden" / "h").mkdir(parents=True)
    (tmp_path / ".hidden" / "h" / "package.xml").write_text(package_xml("hidden"))
    (tmp_path / "deep" / "x" / "y").mkdir(parents=True)
    (tmp_path / "deep" / "x" / "y" / "package.xml").write_text(package_xml("deep_pkg"))
    assert scan_packages(tmp_path) == {"pkg_a": tmp_path / "a", "deep_pkg": tmp_path / "deep" / "x" / "y"}


def test_finder_search_order_and_conventions(tmp_path):
    (tmp_path / "parent" / "plain").mkdir(parents=True)  # Pinocchio's <dir>/<pkg> convention, no package.xml
    (tmp_path / "itself").mkdir()
    (tmp_path / "itself" / "package.xml").write_text(package_xml("named_pkg"))
    prefix = tmp_path / "install"
    (prefix / "share" / "ament_pkg").mkdir(parents=True)
    ros = tmp_path / "ros"
    (ros / "r" / "package.xml").parent.mkdir(parents=True)
    (ros / "r" / "package.xml").write_text(package_xml("ros_pkg"))
    finder = PackageFinder((tmp_path / "parent", tmp_path / "itself"),
                           environ={ROS_PACKAGE_PATH: str(ros), AMENT_PREFIX_PATH: str(prefix)})
    assert finder.find("plain") == (tmp_path / "parent" / "plain").resolve()
    assert finder.find("named_pkg") == (tmp_path / "itself").resolve()
    assert finder.find("ros_pkg") == (ros / "r").resolve()
    assert finder.find("ament_pkg") == (prefix / "share" / "ament_pkg").resolve()
    assert finder.find("nowhere") is None and finder.find("../parent") is None
    roots = finder.roots()
    assert (ros / "r").resolve() in roots and (prefix / "share").resolve() in roots


def test_is_within_is_lexical_and_follows_symlinks(tmp_path):
    inside = tmp_path / "pkg"
    inside.mkdir()
    assert is_within(inside / "meshes" / "no_such.stl", [inside])
    assert not is_within(inside / ".." / "other.stl", [inside])
    (inside / "link").symlink_to("/etc")
    assert not is_within(inside / "link" / "passwd", [inside])


# ------------------------------------------------------------ loading a workspace
def test_meshes_in_another_package_load_through_package_dirs(workspace):
    src, urdf, stl = workspace
    # a workspace, searched for package.xml
    assert_mesh_is_the_stl(load_quietly(urdf, package_dirs=[src]), stl)
    robots.clear_cache()
    # the package itself
    assert_mesh_is_the_stl(load_quietly(urdf, package_dirs=str(src / "meshes_repo")), stl)


def test_package_dirs_is_an_option_not_a_joint_lock(workspace):
    src, urdf, _ = workspace
    robot = robots.load(urdf, package_dirs=[src], geometry=False)
    assert robot.nq == 3 and robot.joint_names == ["j1", "j2", "j3"]


def test_meshes_load_through_ros_package_path(workspace, monkeypatch):
    src, urdf, stl = workspace
    with pytest.warns(MissingMeshWarning, match="package 'arm_meshes' not found"):
        robots.load(urdf)
    monkeypatch.setenv(ROS_PACKAGE_PATH, f"/no/such/dir{os.pathsep}{src}")
    assert_mesh_is_the_stl(load_quietly(urdf), stl)  # the cache knows the environment changed


def test_meshes_load_through_ament_prefix_path(workspace, monkeypatch, tmp_path):
    _, urdf, _ = workspace
    prefix = tmp_path / "install"
    installed = prefix / "share" / "arm_meshes" / "meshes" / "link1.stl"
    write_binary_stl(installed)
    monkeypatch.setenv(AMENT_PREFIX_PATH, str(prefix))
    assert_mesh_is_the_stl(load_quietly(urdf), installed)


def test_missing_mesh_package_loads_for_kinematics(workspace):
    _, urdf, _ = workspace
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # not even a warning: kinematics never looks at meshes
        robot = robots.load(urdf, geometry=False)
    np.testing.assert_allclose(robot.fk([0, 0, 0])[:3, 3], [0.9, 0, 0.1], atol=1e-12)
    with pytest.warns(MissingMeshWarning, match=r"package://arm_meshes/meshes/link1.stl.*not found"):
        shown = robots.load(urdf, geometry=True)
    assert [type(g.geometry).__name__ for g in shown.visual_model.geometryObjects] == ["Sphere"]
    assert shown.collision_model.ngeoms == 0


def test_file_uri_inside_the_package(workspace):
    src, urdf, stl = workspace
    urdf.write_text(arm_urdf(stl.resolve().as_uri()))
    assert_mesh_is_the_stl(load_quietly(urdf, package_dirs=[src]), stl)


def cli(*args: str) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in (ROS_PACKAGE_PATH, AMENT_PREFIX_PATH)}
    return subprocess.run([sys.executable, "-m", "kinserve.service.cli", *args], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=120)


def test_cli_package_dir_flag(workspace, tmp_path):
    src, urdf, _ = workspace
    page = tmp_path / "arm.html"
    with_flag = cli("view", str(urdf), "--package-dir", str(src), "--html", str(page))
    assert with_flag.returncode == 0, with_flag.stderr
    assert "not found" not in with_flag.stderr and page.stat().st_size > 0
    # without the flag the same command warns (test_meshes_load_through_ros_package_path has the library side)
    # kinematics only: no mesh, no warning, flags accepted
    frames = cli("frames", str(urdf), "--allow-outside")
    assert frames.returncode == 0 and "not found" not in frames.stderr and "link1" in frames.stdout


# ----------------------------------------------------------- untrusted model files
@pytest.mark.parametrize("uri", ["/etc/passwd", "/etc/kinserve-no-such-file",
                                 "package://arm_description/../../../../../../etc/passwd",
                                 "package://arm_description/../../../../../../etc/kinserve-no-such-file",
                                 "file:///etc/passwd", "../../../../../../../../etc/passwd"])
def test_mesh_outside_the_model_folders_is_refused_whether_it_exists_or_not(workspace, uri):
    src, urdf, _ = workspace
    urdf.write_text(arm_urdf(uri))
    with pytest.raises(ModelError) as err:
        robots.load(urdf, package_dirs=[src])
    message = str(err.value)
    assert "outside the folders this model may read from" in message and "allow_outside=True" in message
    # the same message for the existing and the missing file: nothing to learn about the file system
    twin = (uri.replace("passwd", "kinserve-no-such-file") if "passwd" in uri
            else uri.replace("kinserve-no-such-file", "passwd"))
    urdf.write_text(arm_urdf(twin))
    robots.clear_cache()
    with pytest.raises(ModelError) as err2:
        robots.load(urdf, package_dirs=[src])
    assert str(err2.value).replace(twin, uri) == message
    assert robots.load(urdf, geometry=False).nq == 3  # kinematics only: nothing is read, nothing refused


def test_outside_mesh_loads_when_allowed(workspace, tmp_path):
    src, urdf, _ = workspace
    outside = tmp_path / "elsewhere" / "link1.stl"
    write_binary_stl(outside)
    urdf.write_text(arm_urdf(str(outside)))
    with pytest.raises(ModelError, match="outside the folders"):
        robots.load(urdf, package_dirs=[src])
    assert_mesh_is_the_stl(load_quietly(urdf, package_dirs=[src], allow_outside=True), outside)
    robots.clear_cache()
    assert_mesh_is_the_stl(load_quietly(urdf, package_dirs=[src, outside.parent]), outside)
