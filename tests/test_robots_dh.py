"""kinserve.robots.dh: DH table -> URDF -> Robot, checked against a DH product written independently here."""

import math

import numpy as np
import pytest

from kinserve.kinematics.errors import ModelError
from kinserve.robots import dh_to_urdf, from_dh, load_urdf
from kinserve.robots.dh import check_dh_table, dh_fk


def Rz(t):
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def Rx(t):
    c, s = math.cos(t), math.sin(t)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def Tz(d):
    T = np.eye(4)
    T[2, 3] = d
    return T


def Tx(a):
    T = np.eye(4)
    T[0, 3] = a
    return T


def chain(rows, types, q, base=np.eye(4)):
    """Poses of DH frames 0..n: base * prod Rz(theta) Tz(d) Tx(a) Rx(alpha), q added to theta or d."""
    frames = [base]
    for (a, alpha, d, theta), kind, qi in zip(rows, types, q):
        theta, d = (theta + qi, d) if kind == "R" else (theta, d + qi)
        frames.append(frames[-1] @ Rz(theta) @ Tz(d) @ Tx(a) @ Rx(alpha))
    return frames


def random_pose(rng):
    w = rng.normal(size=3)
    angle = np.linalg.norm(w)
    k = w / angle
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    T = np.eye(4)
    T[:3, :3] = np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K
    T[:3, 3] = rng.uniform(-1, 1, 3)
    return T


@pytest.fixture(scope="module")
def table():
    rng = np.random.default_rng(7)
    rows = np.column_stack([rng.uniform(-0.5, 0.5, 6), rng.uniform(-math.pi, math.pi, 6),
                            rng.uniform(-0.5, 0.5, 6), rng.uniform(-math.pi, math.pi, 6)])
    types = "RRPRRP"
    lower = np.array([-3.0, -2.0, -0.2, -1.0, -2.5, 0.1])
    upper = np.array([3.0, 2.5, 0.4, 1.5, 2.5, 0.6])
    return rows, types, lower, upper, random_pose(rng), random_pose(rng)


def test_from_dh_equals_dh_product(table):
    rows, types, lower, upper, base, tool = table
    robot = from_dh(rows, types, lower, upper, name="mixed", base=base, tool=tool, geometry=False)
    assert robot.nq == 6 and robot.tip == "tool"
    np.testing.assert_allclose(robot.lower, lower)
    np.testing.assert_allclose(robot.upper, upper)
    for q in robot.random_q(np.random.default_rng(1), n=120):
        frames = chain(rows, types, q, base)
        for i, F in enumerate(frames):
            np.testing.assert_allclose(robot.fk(q, f"link{i}"), F, atol=1e-12)
        np.testing.assert_allclose(robot.fk(q), frames[-1] @ tool, atol=1e-12)
        np.testing.assert_allclose(dh_fk(rows, types, q, base, tool), frames[-1] @ tool, atol=1e-12)


def test_revolute_offset_is_added_to_theta_and_prismatic_offset_to_d():
    rows = [(0.0, 0.0, 0.0, 0.3), (0.0, 0.0, 0.2, 0.0)]
    robot = from_dh(rows, "RP", [-1, 0], [1, 1], geometry=False)
    T = robot.fk([0.1, 0.5])
    np.testing.assert_allclose(T[:3, :3], Rz(0.4)[:3, :3], atol=1e-14)
    np.testing.assert_allclose(T[:3, 3], [0, 0, 0.7], atol=1e-14)


def test_dh_urdf_saved_and_reloaded_gives_the_same_model(table, tmp_path):
    rows, types, lower, upper, base, tool = table
    robot = from_dh(rows, types, lower, upper, name="mixed", base=base, tool=tool)
    assert robot.source == dh_to_urdf(rows, types, lower, upper, name="mixed", base=base, tool=tool)
    path = tmp_path / "mixed.urdf"
    path.write_text(robot.source)
    again = load_urdf(path, tip="tool")
    assert again.joint_names == robot.joint_names == [f"joint{i}" for i in range(1, 7)]
    assert again.frame_names == robot.frame_names
    np.testing.assert_array_equal(again.lower, robot.lower)
    np.testing.assert_array_equal(again.upper, robot.upper)
    for q in robot.random_q(np.random.default_rng(2), n=20):
        for frame in robot.frame_names:
            np.testing.assert_array_equal(again.fk(q, frame), robot.fk(q, frame))


def test_every_generated_link_on_the_chain_has_a_visual(table):
    rows, types, lower, upper, base, tool = table
    robot = from_dh(rows, types, lower, upper, base=base, tool=tool)
    parents = {robot.model.frames[g.parentFrame].name for g in robot.visual_model.geometryObjects}
    for i in range(1, 7):
        assert f"joint{i}_link" in parents  # the joint drum / block
    assert "link0" in parents and "tool" in parents


def test_joint_names_and_tip_name():
    robot = from_dh([(1, 0, 0, 0), (1, 0, 0, 0)], "RR", joint_names=["shoulder", "elbow"], tip_name="hand",
                    geometry=False)
    assert robot.joint_names == ["shoulder", "elbow"]
    assert robot.tip == "hand"
    np.testing.assert_allclose(robot.fk([math.pi / 2, 0])[:3, 3], [0, 2, 0], atol=1e-14)


def test_default_limits_revolute_pi():
    robot = from_dh([(1, 0, 0, 0)], geometry=False)
    assert robot.lower[0] == -math.pi and robot.upper[0] == math.pi


@pytest.mark.parametrize(
    "kwargs, fragment",
    [
        (dict(rows=[(1, 0, 0)]), "shape"),
        (dict(rows=[]), "shape"),
        (dict(rows=[(1, 0, float("nan"), 0)]), "row 1, column d"),
        (dict(rows=[(1, 0, 0, 0), (1, 0, float("inf"), 0)]), "row 2, column d"),
        (dict(rows=[(1, 0, 0, 0)], joint_types="X"), "R (revolute) or P"),
        (dict(rows=[(1, 0, 0, 0)] * 2, joint_types="R"), "1 letters for 2 rows"),
        (dict(rows=[(1, 0, 0, 0)] * 2, joint_types="RP"), "prismatic joint(s) [2] need explicit"),
        (dict(rows=[(1, 0, 0, 0)] * 2, lower=[0, 1], upper=[1, 0]), "lower > upper for joint(s) [2]"),
        (dict(rows=[(1, 0, 0, 0)] * 2, lower=[0, 0, 0], upper=[1, 1, 1]), "lower must have 2 entries"),
        (dict(rows=[(1, 0, 0, 0)], base=np.diag([1.0, 1.0, 2.0, 1.0])), "base"),
        (dict(rows=[(1, 0, 0, 0)], tool=np.eye(3)), "tool"),
        (dict(rows=[(1, 0, 0, 0)], tip_name="link1"), "collides"),
        (dict(rows=[(1, 0, 0, 0)], name="bad name"), "name"),
        (dict(rows=[(1, 0, 0, 0)] * 2, joint_names=["a", "a"]), "unique"),
    ],
)
def test_table_validation(kwargs, fragment):
    with pytest.raises(ModelError) as err:
        dh_to_urdf(**kwargs)
    assert fragment in str(err.value)
    with pytest.raises(ModelError):
        from_dh(**kwargs)


def test_check_dh_table_normalises():
    rows, types, lo, hi = check_dh_table([1, 0, 0, 0], "r")
    assert rows.shape == (1, 4) and types == "R"
    assert lo.tolist() == [-math.pi] and hi.tolist() == [math.pi]
