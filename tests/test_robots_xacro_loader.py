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
        '<link name="a"/><xacro:if value="$(arg flag)"><link name="extra_${$(arg n) * '
        '2}"/></xacro:if></robot>'
    )
    assert "extra_6" in process_xacro(path, {"flag": True, "n": 3})
    assert "extra" not in process_xacro(path)


# ------------------------------------------------------------ untrusted xacro files
XACRO_HEAD = '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'


def test_time_limit_stops_a_runaway_expression_without_blocking_other_loads(tmp_path):
    """``${10**10**8}`` never returns in-process; the xacro process is killed at the limit and other
    expansions run meanwhile (no lock is held): one finishes while the runaway still runs. (No stopwatch:
    the limit, 6 s, is some 15 times what the other expansion takes here; 20 s more only guard a hang.)"""
    import threading
    import time

    import pytest

    from kinserve.kinematics.errors import ModelError

    path = tmp_path / "bomb.urdf.xacro"
    path.write_text(XACRO_HEAD + '<link name="a${10**10**8}"/></robot>')
    errors = []

    def expand_bomb():
        try:
            process_xacro(path, time_limit=limit)
        except ModelError as exc:
            errors.append(exc)

    limit = 6.0
    start = time.monotonic()
    worker = threading.Thread(target=expand_bomb)
    worker.start()
    time.sleep(0.3)
    assert 'upper="0.8"' in process_xacro(SCARA, {"d3_max": 0.8})
    assert worker.is_alive() and not errors  # done while the runaway expansion still runs
    worker.join(limit + 20.0)
    elapsed = time.monotonic() - start
    assert not worker.is_alive() and len(errors) == 1
    assert "longer than 6 s" in str(errors[0]) and str(path) in str(errors[0])
    assert elapsed >= limit  # stopped at its limit, not before
    with pytest.raises(ModelError, match="time_limit"):
        process_xacro(SCARA, time_limit=float("nan"))


def test_memory_cap(tmp_path):
    import pytest

    from kinserve.kinematics.errors import ModelError

    path = tmp_path / "big.urdf.xacro"
    path.write_text(XACRO_HEAD + '<link name="${len(\'a\' * 10**11)}"/></robot>')
    with pytest.raises(ModelError, match="out of memory"):
        process_xacro(path, time_limit=10)


def test_text_of_included_or_loaded_files_never_appears_in_errors(tmp_path):
    import pytest

    from kinserve.kinematics.errors import ModelError

    secret = tmp_path / "secret.xacro"
    secret.write_text(XACRO_HEAD + '<link name="${token_h7q2_do_not_show}"/></robot>')
    plain = tmp_path / "notes.txt"
    plain.write_text("password: hunter2_k9x\n")
    yaml_file = tmp_path / "conf.yaml"
    yaml_file.write_text("key: [unclosed hunter3_m4z\n")
    cases = {
        "expression in an include": f'<xacro:include filename="{secret}"/>',
        "include of a text file": f'<xacro:include filename="{plain}"/>',
        "yaml load": f'<xacro:property name="c" value="${{xacro.load_yaml(\'{yaml_file}\')}}"/><link '
                     'name="${c}"/>',
    }
    for what, body in cases.items():
        path = tmp_path / "top.urdf.xacro"
        path.write_text(XACRO_HEAD + body + "</robot>")
        with pytest.raises(ModelError) as err:
            process_xacro(path)
        message = str(err.value)
        assert str(path) in message and "not shown" in message, what
        for token in ("token_h7q2", "hunter2_k9x", "hunter3_m4z", "password"):
            assert token not in message, (what, message)


def test_find_resolves_through_package_dirs(tmp_path):
    import pytest

    from kinserve.kinematics.errors import ModelError

    parts = tmp_path / "ws" / "parts_repo"
    (parts / "urdf").mkdir(parents=True)
    (parts / "package.xml").write_text('<package format="3"><name>arm_parts</name></package>')
    (parts / "urdf" / "link.xacro").write_text(
        XACRO_HEAD + '<xacro:macro name="arm_link" params="n"><link name="${n}"/></xacro:macro></robot>')
    top = tmp_path / "desc" / "arm.urdf.xacro"
    top.parent.mkdir()
    top.write_text(
        XACRO_HEAD + '<xacro:include filename="$(find arm_parts)/urdf/link.xacro"/>'
        '<xacro:arm_link n="base"/><xacro:arm_link n="tip"/>'
        '<joint name="j" type="prismatic"><parent link="base"/><child link="tip"/><axis xyz="1 0 0"/>'
        '<limit lower="0" upper="1" effort="1" velocity="1"/></joint></robot>')
    with pytest.raises(ModelError, match="not shown|arm_parts"):
        load_xacro(top, geometry=False)
    robot = load_xacro(top, package_dirs=[tmp_path / "ws"], geometry=False)
    assert robot.joint_names == ["j"] and robot.task_axes == ("x",)


def test_files_outside_the_model_folders_are_refused_whether_they_exist_or_not(tmp_path):
    import pytest

    from kinserve.kinematics.errors import ModelError

    top = tmp_path / "desc" / "top.urdf.xacro"
    top.parent.mkdir()
    templates = [
        '<xacro:include filename="{}"/><link name="a"/>',
        '<xacro:property name="c" value="${{xacro.load_yaml(\'{}\')}}"/><link name="${{c}}"/>',
    ]
    for template in templates:
        messages = {}
        for target in ("/etc/passwd", "/etc/kinserve-no-such-file", "../../../../../../../etc/passwd"):
            top.write_text(XACRO_HEAD + template.format(target) + "</robot>")
            with pytest.raises(ModelError) as err:
                process_xacro(top)
            messages[target] = str(err.value).replace(target, "TARGET")
        assert len(set(messages.values())) == 1, messages
        message = next(iter(messages.values()))
        assert "outside the folders this model may read from" in message and "root:" not in message
    # a file beside the model is fine, and allow_outside lets a trusted model read anywhere
    outside = tmp_path / "elsewhere" / "part.xacro"
    outside.parent.mkdir()
    outside.write_text(XACRO_HEAD + '<link name="from_elsewhere"/></robot>')
    top.write_text(XACRO_HEAD + f'<xacro:include filename="{outside}"/></robot>')
    with pytest.raises(ModelError, match="outside the folders"):
        process_xacro(top)
    assert "from_elsewhere" in process_xacro(top, allow_outside=True)
    assert "from_elsewhere" in process_xacro(top, package_dirs=[outside.parent])
