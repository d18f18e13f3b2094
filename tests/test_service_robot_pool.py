"""kinserve.service.robot_pool: built-in names only (any case), parameters never taken for options."""

from __future__ import annotations

import pytest

from kinserve.kinematics.errors import ModelError, UnknownRobotError
from kinserve.robots.paths import models_dir
from kinserve.service.robot_pool import RobotPool


def test_names_ignore_case_and_share_one_model():
    pool = RobotPool()
    a, b = pool.get("PANDA"), pool.get("panda")
    assert a is b and a.name == "panda" and a.visual_model is None


@pytest.mark.parametrize("name", ["/etc/passwd", str(models_dir() / "planar4r.urdf.xacro"), "../robots/models/pr.urdf.xacro",
                                  '<robot name="x"><link name="a"/></robot>'])
def test_paths_and_xml_from_the_network_are_unknown_robots(name):
    with pytest.raises(UnknownRobotError, match="Known robots: planar4r") as err:
        RobotPool().get(name)
    assert "path" not in str(err.value)  # no hint the service would read files


@pytest.mark.parametrize("params", [{"geometry": True}, {"package_dirs": "/"}, {"allow_outside": True}, {"srdf": "/etc/passwd"}])
def test_request_parameters_are_model_parameters_never_loader_options(params):
    with pytest.raises(ModelError, match="unknown parameter"):
        RobotPool().get("panda", params)
    with pytest.raises(ModelError, match="unknown xacro arg"):
        RobotPool().get("planar4r", params)
