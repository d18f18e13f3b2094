"""JointTrajectory: validation, JSON/CSV round trips, finite-difference velocities."""

import json

import numpy as np
import pytest

from kinserve.kinematics.errors import InputError, ShapeError
from kinserve.planners.joint_trajectory import JointTrajectory, finite_difference_velocities

NAMES = ["j1", "j2", "j3"]


def _traj(with_acc=True):
    t = 0.1 * np.arange(6)
    Q = np.stack([np.sin(t), t**2, np.full_like(t, 0.3)], axis=1)
    V = finite_difference_velocities(Q, t)
    A = np.gradient(V, t, axis=0) if with_acc else None
    return JointTrajectory(NAMES, t, Q, V, A)


@pytest.mark.parametrize("with_acc", [True, False])
def test_json_round_trip(tmp_path, with_acc):
    jt = _traj(with_acc)
    back = JointTrajectory.from_json(jt.to_json())
    for f in ("times", "positions", "velocities"):
        np.testing.assert_array_equal(getattr(back, f), getattr(jt, f))
    assert (back.accelerations is None) == (not with_acc)
    p = jt.save(tmp_path / "traj.json")
    again = JointTrajectory.load(p)
    np.testing.assert_array_equal(again.positions, jt.positions)
    doc = json.loads(p.read_text())
    assert doc["joint_names"] == NAMES and doc["points"][2]["time_from_start"] == pytest.approx(0.2)


def test_csv_round_trip(tmp_path):
    jt = _traj()
    back = JointTrajectory.from_csv(jt.to_csv())
    np.testing.assert_array_equal(back.positions, jt.positions)
    np.testing.assert_array_equal(back.accelerations, jt.accelerations)
    p = jt.save(tmp_path / "traj.csv")
    assert p.read_text().splitlines()[0].startswith("time_from_start,position:j1")
    np.testing.assert_array_equal(JointTrajectory.load(p).times, jt.times)


def test_from_positions_uses_i_dt():
    Q = np.arange(12.0).reshape(4, 3) ** 2
    jt = JointTrajectory.from_positions(NAMES, Q, 0.5)
    np.testing.assert_allclose(jt.times, [0, 0.5, 1.0, 1.5])
    # exact for quadratics: d/dt (2t)^2 ... positions q_k = (k*3 + j)^2 with t = k/2
    t = jt.times
    for j in range(3):
        exact = 2 * (6 * t + j) * 6
        np.testing.assert_allclose(jt.velocities[:, j], exact, atol=1e-9)


def test_finite_differences_zero_ends():
    t = np.linspace(0, 1, 11)
    V = finite_difference_velocities(np.stack([t**2], 1), t, zero_ends=True)
    assert V[0, 0] == 0 and V[-1, 0] == 0
    np.testing.assert_allclose(V[1:-1, 0], 2 * t[1:-1], atol=1e-12)


def test_validation_errors(tmp_path):
    with pytest.raises(InputError, match="strictly increasing"):
        JointTrajectory(NAMES, [0, 0.1, 0.1], np.zeros((3, 3)))
    with pytest.raises(ShapeError, match="positions"):
        JointTrajectory(NAMES, [0, 0.1], np.zeros((2, 2)))
    with pytest.raises(InputError, match="unique"):
        JointTrajectory(["a", "a"], [0.0], np.zeros((1, 2)))
    with pytest.raises(ShapeError, match="velocities"):
        JointTrajectory(NAMES, [0.0], np.zeros((1, 3)), velocities=np.zeros((2, 3)))
    with pytest.raises(InputError, match="malformed"):
        JointTrajectory.from_json("{not json")
    with pytest.raises(InputError, match="time_from_start"):
        JointTrajectory.from_json('{"joint_names": ["a"], "points": [{"positions": [1]}]}')
    with pytest.raises(InputError, match=".json or .csv"):
        _traj().save(tmp_path / "x.txt")
    with pytest.raises(InputError, match="non-numeric"):
        JointTrajectory.from_csv("time_from_start,position:a\n0,abc\n")
