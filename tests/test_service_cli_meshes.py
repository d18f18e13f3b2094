"""End to end: the `kinserve` CLI finds a ROS package's meshes the way `robots.load` does.

A package made here (``my_pkg/package.xml``, ``urdf/robot.urdf``, ``meshes/link.stl``,
see :mod:`ros_package`) whose URDF names its meshes ``package://my_pkg/...``:
``kinserve collide`` and ``kinserve reach --self-collision`` (which load the robot
for kinematics and build its collision model later) find them without
``--package-dir``, from the folder holding the URDF; a copy of the URDF outside
the package finds them through ``$ROS_PACKAGE_PATH`` from another working
directory, and without it fails with a message saying how to add the folder.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from kinserve.robots.packages import AMENT_PREFIX_PATH, ROS_PACKAGE_PATH

from ros_package import CLEARANCE_AT_ZERO, Q_COLLIDING, make_package

#: The console script of this interpreter's environment (``.venv/bin/kinserve``).
KINSERVE = Path(sys.executable).with_name("kinserve")


def kinserve(*args: str, cwd: Path, ros_package_path: Path | None = None) -> subprocess.CompletedProcess:
    """Run ``kinserve ARGS`` in ``cwd`` with no ROS variables, except ``$ROS_PACKAGE_PATH`` when given."""
    env = {k: v for k, v in os.environ.items() if k not in (ROS_PACKAGE_PATH, AMENT_PREFIX_PATH)}
    env["MPLBACKEND"] = "Agg"
    if ros_package_path is not None:
        env[ROS_PACKAGE_PATH] = str(ros_package_path)
    command = [str(KINSERVE)] if KINSERVE.is_file() else [sys.executable, "-m", "kinserve.service.cli"]
    return subprocess.run([*command, *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=300)


def q_arg(q) -> list[str]:
    return ["--q", ",".join(repr(float(v)) for v in q)]


def assert_collide_answers(urdf: Path, cwd: Path, ros_package_path: Path | None = None) -> None:
    """``kinserve collide`` at q = 0 (clear by CLEARANCE_AT_ZERO) and at Q_COLLIDING (base / l2 collide)."""
    clear = kinserve("collide", str(urdf), *q_arg([0, 0]), "--json", cwd=cwd,
                     ros_package_path=ros_package_path)
    assert clear.returncode == 0, clear.stderr
    answer = json.loads(clear.stdout)
    assert answer["in_collision"] is False and sorted(answer["closest_pair"]) == ["base", "l2"]
    assert answer["min_distance"] == pytest.approx(CLEARANCE_AT_ZERO, abs=1e-5)
    hit = kinserve("collide", str(urdf), *q_arg(Q_COLLIDING), "--json", "--fail-on-collision", cwd=cwd,
                   ros_package_path=ros_package_path)
    assert hit.returncode == 1, hit.stderr
    answer = json.loads(hit.stdout)
    assert answer["in_collision"] is True and [sorted(p) for p in answer["pairs"]] == [["base", "l2"]]


@pytest.fixture
def package(tmp_path):
    return make_package(tmp_path / "ws")


def test_collide_finds_the_packages_own_meshes_without_package_dir(package, tmp_path):
    assert_collide_answers(package.urdf, cwd=tmp_path)
    # a relative path from the package folder itself
    assert_collide_answers(Path("urdf") / "robot.urdf", cwd=package.package)


def test_reach_with_self_collision_finds_the_meshes_without_package_dir(package, tmp_path):
    """Serial backend (the check is the collision build, not the pool; a worker's copy of the robot
    rebuilds the same model: test_robots_mesh_resolver.test_the_robot_keeps_the_search_path_of_its_load)."""
    stem = tmp_path / "reach"
    out = kinserve("reach", str(package.urdf), "--self-collision", "--samples", "12", "--resolution", "2",
                   "--backend", "serial", "--max-time", "0.02", "--out", str(stem),
                   cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert "self-collision" in out.stdout and "could not be found" not in out.stderr
    data = np.load(stem.with_suffix(".npz"))
    assert data["counts"].sum() == 12 and data["reached"].shape == (12,)


def test_ros_package_path_from_another_working_directory(package, tmp_path):
    outside = tmp_path / "elsewhere" / "robot.urdf"  # not inside my_pkg: its folders do not find the package
    outside.parent.mkdir()
    shutil.copy(package.urdf, outside)
    cwd = tmp_path / "somewhere_else"
    cwd.mkdir()
    assert_collide_answers(outside, cwd=cwd, ros_package_path=package.workspace)
    failed = kinserve("collide", str(outside), cwd=cwd)
    assert failed.returncode == 2 and failed.stdout == ""
    message = failed.stderr
    assert message.startswith("error: ") and message.count("\n") == 1  # one line, no traceback
    for part in ("package://my_pkg/meshes/link.stl", "could not be found", "package 'my_pkg' not found",
                 "package_dirs=", "--package-dir", "$ROS_PACKAGE_PATH"):
        assert part in message, part
    with_flag = kinserve("collide", str(outside), "--package-dir", str(package.workspace), "--json", cwd=cwd)
    assert (with_flag.returncode == 0
            and json.loads(with_flag.stdout)["in_collision"] is False), with_flag.stderr


def test_view_html_draws_the_packages_meshes_without_package_dir(package, tmp_path):
    page = tmp_path / "robot.html"
    out = kinserve("view", str(package.urdf), "--collision", "--html", str(page), cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert "could not be found" not in out.stderr and page.stat().st_size > 0
