"""Every URDF example-robot-data ships loads (kinematics only) or raises a ModelError naming file and cause.

The walk is the load step only (``geometry=False``: no mesh file is read, so
the 69 files take seconds); the collision models are another module's test.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest
from lxml import etree

from kinserve import robots
from kinserve.kinematics.errors import ModelError
from kinserve.robots.paths import example_robot_data_package_dir as erd_share_dir

#: The files that cannot be kinserve robots, with a fragment of the cause their ModelError must name.
REFUSED = {
    "alex_description/urdf/alex_psyonic_hands.urdf": "mimics joint 'index_q1', which is not defined",
    "hector_description/robots/quadrotor_base.urdf": "has no movable joint",
    "iris_description/robots/iris.urdf": "must be 1 finite number(s) with magnitude",
    "iris_description/robots/iris_simple.urdf": "has no movable joint",
    "ur_description/urdf/ur3.urdf": "defines no <link>",
}

MOVABLE = ("revolute", "continuous", "prismatic")


def movable_joints(path: Path) -> int:
    """Joints of a URDF that move (read with lxml, independently of the loader)."""
    root = etree.parse(str(path)).getroot()
    return sum(1 for j in root.findall("joint") if j.get("type") in MOVABLE)


def test_every_example_robot_data_urdf_loads_or_names_its_cause():
    share = erd_share_dir()
    robots_dir = share / "example-robot-data" / "robots"
    files = sorted(robots_dir.rglob("*.urdf"))
    assert len(files) == 69
    loaded, refused = [], {}
    robots.clear_cache()
    for path in files:
        name = path.relative_to(robots_dir).as_posix()
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # SRDF warnings: not what this test is about
                robot = robots.load(path, package_dirs=[share], geometry=False)
        except ModelError as exc:  # anything else (a raw Pinocchio / lxml error) fails the test
            refused[name] = str(exc)
            continue
        assert robot.nq == movable_joints(path), name  # every moving joint is a coordinate (nq == nv)
        assert robot.resolve_meshes is not None, name  # a later collision build uses the load's resolver
        loaded.append(name)
    robots.clear_cache()
    assert sorted(refused) == sorted(REFUSED) and len(loaded) == 64
    for name, cause in REFUSED.items():
        assert str(robots_dir / name) in refused[name] and cause in refused[name], refused[name]


@pytest.mark.parametrize("name", ["panda_description/urdf/panda.urdf", "ur_description/urdf/ur5_robot.urdf"])
def test_erd_packages_resolve_through_the_share_folder_without_package_dirs(name):
    """ERD's own files find their package://example-robot-data/... meshes by the folder holding them."""
    robots.clear_cache()
    robot = robots.load(erd_share_dir() / "example-robot-data" / "robots" / name, geometry=False)
    text = robot.resolve_meshes(robot.source)
    assert "package://" not in text.split("<collision", 1)[1]
