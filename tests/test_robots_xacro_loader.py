"""kinserve.robots.xacro_loader: declared args, substitution, and loading a parametric model."""

import numpy as np

from kinserve.robots import declared_args, load_xacro, process_xacro
from kinserve.robots.paths import models_dir

SCARA = models_dir() / "scara.urdf.xacro"


def test_declared_args_with_defaults():
    args = declared_args(SCARA)
    assert args["a1"] == "0.5" and args["base_z"] == "1.0" and args["d3_min"] == "0.25"
    assert set(args) >= {"a1", "a2", "base_z", "d3_min", "d3_max", "theta4_limit"}


def test_args_are_substituted():
    text = process_xacro(SCARA, {"d3_max": 0.8, "base_z": "1.25"})
    assert 'upper="0.8"' in text
    assert 'xyz="0 0 1.25"' in text


def test_loaded_model_follows_args():
    robot = load_xacro(SCARA, args={"a1": 0.4, "a2": 0.3, "base_z": 2.0}, tip="tool", geometry=False)
    np.testing.assert_allclose(robot.fk([0, 0, 0.5, 0])[:3, 3], [0.7, 0, 1.5], atol=1e-14)
    assert robot.source.lstrip().startswith("<?xml")


def test_bool_and_int_values_are_accepted(tmp_path):
    path = tmp_path / "r.urdf.xacro"
    path.write_text(
        '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<xacro:arg name="n" default="2"/><xacro:arg name="flag" default="false"/>'
        '<link name="a"/><xacro:if value="$(arg flag)"><link name="extra_${$(arg n) * 2}"/></xacro:if></robot>'
    )
    assert "extra_6" in process_xacro(path, {"flag": True, "n": 3})
    assert "extra" not in process_xacro(path)
