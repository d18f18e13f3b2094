"""Via-point trajectories: pass through the vias, continuity of q, qd, qdd checked numerically."""

import numpy as np
import pytest

from kinserve.kinematics.errors import InputError, ShapeError
from kinserve.planners.joint_trajectory import JointTrajectory
from kinserve.planners.via_points import via_point_trajectory

VIAS = np.array([[0.0, 0.0, 1.0], [1.0, 2.0, 0.5], [3.0, 1.0, 0.5], [2.0, -1.0, 2.0], [2.5, 0.0, 0.0]])
TIMES = np.array([0.0, 1.0, 2.5, 3.0, 4.2])


@pytest.mark.parametrize("method", ["cubic_spline", "quintic"])
def test_passes_vias_and_rests_at_ends(method):
    tr = via_point_trajectory(VIAS, TIMES, method=method)
    q, qd, qdd = tr.evaluate(TIMES)
    np.testing.assert_allclose(q, VIAS, atol=1e-12)
    np.testing.assert_allclose(qd[[0, -1]], 0.0, atol=1e-12)


@pytest.mark.parametrize("method", ["cubic_spline", "quintic"])
def test_velocity_and_acceleration_continuous_at_vias(method):
    tr = via_point_trajectory(VIAS, TIMES, method=method)
    eps = 1e-7
    for tv in TIMES[1:-1]:
        left = tr.evaluate(tv - eps)
        right = tr.evaluate(tv + eps)
        for k, (lf, rt) in enumerate(zip(left, right)):
            # a jump would show as O(1); continuity leaves O(eps * next derivative)
            assert np.abs(lf - rt).max() < 1e-4, (method, tv, k)
    # derivatives are the derivatives (central differences inside segments and across vias)
    t = np.linspace(0.05, 4.15, 37)
    h = 1e-5
    q_p, qd_p, _ = tr.evaluate(t + h)
    q_m, qd_m, _ = tr.evaluate(t - h)
    _, qd, qdd = tr.evaluate(t)
    np.testing.assert_allclose(qd, (q_p - q_m) / (2 * h), atol=1e-5)
    np.testing.assert_allclose(qdd, (qd_p - qd_m) / (2 * h), atol=1e-4)


def test_quintic_via_velocity_heuristic():
    # component 0 rises then falls around via 2 (local max) -> zero velocity there
    tr = via_point_trajectory(VIAS, TIMES, method="quintic")
    _, qd, _ = tr.evaluate(TIMES[2])
    assert qd[0] == 0.0
    # component 0 at via 1: slopes 1/1 and 2/1.5 agree in sign -> their mean
    assert tr.evaluate(TIMES[1])[1][0] == pytest.approx(0.5 * (1.0 + 2.0 / 1.5))


def test_times_from_limits_and_sampling_to_joint_trajectory():
    tr = via_point_trajectory(VIAS, v_max=1.0, a_max=2.0)
    assert tr.times[0] == 0.0 and np.all(np.diff(tr.times) > 0)
    jt = tr.to_joint_trajectory(0.05, ["a", "b", "c"])
    assert isinstance(jt, JointTrajectory)
    np.testing.assert_allclose(jt.positions[-1], VIAS[-1], atol=1e-12)
    np.testing.assert_allclose(jt.times[1] - jt.times[0], 0.05)


def test_bad_inputs():
    with pytest.raises(InputError, match="strictly increasing"):
        via_point_trajectory(VIAS, [0, 1, 1, 2, 3])
    with pytest.raises(ShapeError, match="times"):
        via_point_trajectory(VIAS, [0, 1, 2])
    with pytest.raises(ShapeError, match="at least 2"):
        via_point_trajectory(VIAS[:1], [0.0])
    with pytest.raises(InputError, match="v_max and a_max"):
        via_point_trajectory(VIAS)
    with pytest.raises(InputError, match="method"):
        via_point_trajectory(VIAS, TIMES, method="bezier")
