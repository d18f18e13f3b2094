"""kinserve.kinematics.task_axes: task rows detected from the joint axes; singularities on those rows.

Singular values are checked against an independent Jacobian: a closed form
for the planar arm, central differences of a hand-written forward kinematics
for the spatial 3-joint arm, both decomposed with numpy's SVD.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from kinserve import robots
from kinserve.kinematics.errors import ShapeError
from kinserve.kinematics.task_axes import TASK_AXES, detect_task_axes

ROOT = Path(__file__).resolve().parents[1]


def chain_urdf(joints) -> str:
    """URDF of a serial chain: ``joints`` = [(type, axis "x y z", origin xyz "x y z")], tool after the
    last."""
    links = "".join(f'<link name="l{i}"/>' for i in range(len(joints) + 1))
    body = ""
    for i, (kind, axis, xyz) in enumerate(joints):
        lo, hi = (-3, 3) if kind == "revolute" else (0, 1)
        body += (f'<joint name="j{i + 1}" type="{kind}"><origin xyz="{xyz}"/><parent link="l{i}"/><child '
                 f'link="l{i + 1}"/><axis xyz="{axis}"/><limit lower="{lo}" upper="{hi}" effort="1" '
                 'velocity="1"/></joint>')
    return (f'<robot name="chain">{links}<link name="tool"/>{body}'
            f'<joint name="tool_joint" type="fixed"><origin xyz="0.4 0 0"/><parent link="l{len(joints)}"/>'
            '<child link="tool"/></joint></robot>')


PLANAR_3R = chain_urdf([("revolute", "0 0 1", "0 0 0"), ("revolute", "0 0 1", "1.0 0 0"),
                        ("revolute", "0 0 1", "0.8 0 0")])
PLANAR_LENGTHS = (1.0, 0.8, 0.4)  # joint-to-joint distances and the tool offset

# base yaw about z, shoulder and elbow about y: the 3-link arm
SPATIAL_3R = chain_urdf([("revolute", "0 0 1", "0 0 0.1"), ("revolute", "0 1 0", "0 0 0.3"),
                         ("revolute", "0 1 0", "0.5 0 0")])


def planar_jacobian(q) -> np.ndarray:
    """Closed-form 3x3 Jacobian (rows x, y, yaw) of the planar 3R arm."""
    angles = np.cumsum(q)
    points = [np.zeros(2)]
    for length, a in zip(PLANAR_LENGTHS, angles):
        points.append(points[-1] + length * np.array([np.cos(a), np.sin(a)]))
    end = points[-1]
    return np.array([[-(end - p)[1] for p in points[:3]], [(end - p)[0] for p in points[:3]],
                     [1.0, 1.0, 1.0]])


def rot(axis: str, a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return {"y": np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
            "z": np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])}[axis]


def spatial_position(q) -> np.ndarray:
    """Tool position of SPATIAL_3R, written out by hand."""
    elbow = np.array([0.5, 0, 0]) + rot("y", q[2]) @ np.array([0.4, 0, 0])
    return np.array([0, 0, 0.1]) + rot("z", q[0]) @ (np.array([0, 0, 0.3]) + rot("y", q[1]) @ elbow)


def spatial_position_jacobian(q, h=1e-6) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    cols = [(spatial_position(q + h * e) - spatial_position(q - h * e)) / (2 * h) for e in np.eye(3)]
    return np.column_stack(cols)


def numpy_rank_deficient(J, tol=1e-6) -> bool:
    s = np.linalg.svd(J, compute_uv=False)
    return bool(np.sum(s > tol * max(1.0, s[0])) < min(J.shape))


pytestmark = pytest.mark.usefixtures("fresh_registry")  # each test parses its models (conftest)


def test_planar_arm_gets_x_y_yaw_and_its_singularities_match_an_independent_svd():
    arm = robots.load(PLANAR_3R, geometry=False)
    assert arm.task_axes == ("x", "y", "yaw")
    rng = np.random.default_rng(0)
    configurations = [[0.3, 0.0, 0.0], [0.3, 0.4, 0.0], [-1.0, 0.0, np.pi],
                      [0.2, 0.7, -1.1]] + list(rng.uniform(-3, 3, (10, 3)))
    for q in configurations:
        J = planar_jacobian(q)
        np.testing.assert_allclose(arm.singular_values(q), np.linalg.svd(J, compute_uv=False), atol=1e-12)
        assert arm.is_singular(q) == numpy_rank_deficient(J)
    assert arm.is_singular([0.3, 0.0, 0.0]) and not arm.is_singular([0.3, 0.4, 0.0])
    # the six-row measure is wrong for a planar arm with more joints than its 3 task rows
    four = robots.load(chain_urdf([("revolute", "0 0 1", "0 0 0")] + [("revolute", "0 0 1", "0.5 0 0")] * 3),
                       geometry=False)
    assert four.task_axes == ("x", "y", "yaw")
    assert (not four.is_singular([0.1, 0.5, -0.3, 0.2])
            and four.is_singular([0.1, 0.5, -0.3, 0.2], axes=TASK_AXES))


def test_three_joint_spatial_arm_uses_position_rows_and_is_singular_stretched():
    arm = robots.load(SPATIAL_3R, geometry=False)
    assert arm.task_axes == ("x", "y", "z")
    assert "position rows" in detect_task_axes(arm.model).reason
    for q in ([0.3, 0.4, 0.0], [0.3, 0.4, 0.9], [1.2, -0.5, np.pi], [0.0, 1.0, -0.6]):
        Jp = spatial_position_jacobian(q)
        np.testing.assert_allclose(arm.singular_values(q), np.linalg.svd(Jp, compute_uv=False), atol=1e-8)
        assert arm.is_singular(q) == numpy_rank_deficient(Jp)
    assert arm.is_singular([0.3, 0.4, 0.0])  # elbow stretched
    assert not arm.is_singular([0.3, 0.4, 0.0], axes=TASK_AXES)  # what all six rows said before
    assert not arm.is_singular([0.3, 0.4, 0.9])


@pytest.mark.parametrize("joints, expected", [
    # SCARA: two revolute about z, prismatic along z, revolute about z
    ([("revolute", "0 0 1", "0 0 1"), ("revolute", "0 0 1", "0.5 0 0"), ("prismatic", "0 0 -1", "0.5 0 0"),
      ("revolute", "0 0 1", "0 0 0")], ("x", "y", "z", "yaw")),
    # planar PR arm: slide along x then turn about z
    ([("prismatic", "1 0 0", "0 0 0"), ("revolute", "0 0 1", "0 0 0")], ("x", "y", "yaw")),
    # a double pendulum about x
    ([("revolute", "1 0 0", "0 0 0"), ("revolute", "1 0 0", "0 0 -1")], ("y", "z", "roll")),
    # a gantry
    ([("prismatic", "1 0 0", "0 0 0"), ("prismatic", "0 1 0", "0 0 0")], ("x", "y")),
    # five joints, spatial: all rows, rank at most 5
    ([("revolute", "0 0 1", "0 0 0.1"), ("revolute", "0 1 0", "0 0 0.3"), ("revolute", "0 1 0", "0.5 0 0"),
      ("revolute", "1 0 0", "0.3 0 0"), ("revolute", "0 1 0", "0.1 0 0")], TASK_AXES),
])
def test_detected_axes(joints, expected):
    assert robots.load(chain_urdf(joints), geometry=False).task_axes == expected


def test_plane_not_normal_to_a_world_axis_falls_back_and_says_so():
    tilted = robots.load(chain_urdf([("revolute", "0 1 1", "0 0 0"), ("revolute", "0 1 1", "0.5 0 0")]),
                         geometry=False)
    detected = detect_task_axes(tilted.model)
    assert detected.axes == ("x", "y", "z") and "not normal to a world axis" in detected.reason


def test_five_joint_reason_names_the_rank():
    five = robots.load("so100", geometry=False)
    assert "rank at most 5" in detect_task_axes(five.model).reason


def test_task_axes_can_be_set_when_loading():
    arm = robots.load(SPATIAL_3R, geometry=False, task_axes="x,y,z,roll,pitch,yaw")
    assert arm.task_axes == TASK_AXES and not arm.is_singular([0.3, 0.4, 0.0])
    assert robots.load("planar4r", geometry=False, task_axes=("x", "y", "phi")).task_axes == ("x", "y", "yaw")
    # the cached model is unchanged
    assert robots.load(SPATIAL_3R, geometry=False).task_axes == ("x", "y", "z")
    with pytest.raises(ShapeError, match="'w'"):
        robots.load(SPATIAL_3R, geometry=False, task_axes=("x", "w"))


def test_cli_jacobian_flags_the_stretched_arm_and_takes_axes(tmp_path):
    path = tmp_path / "arm3.urdf"
    path.write_text(SPATIAL_3R)
    env = dict(os.environ, MPLBACKEND="Agg")

    def run(*extra):
        out = subprocess.run([sys.executable, "-m", "kinserve.service.cli", "jacobian", str(path), "--q",
                              "0.3", "0.4", "0", *extra], cwd=ROOT, env=env, capture_output=True,
                             text=True, timeout=120)
        assert out.returncode == 0, out.stderr
        return out.stdout

    text = run()
    assert "SINGULAR" in text and "task axes x, y, z (detected" in text
    six = json.loads(run("--axes", "x,y,z,roll,pitch,yaw", "--json"))
    assert (six["singular"] is False and six["task_axes"] == list(TASK_AXES)
            and six["task_axes_origin"] == "given with --axes")
