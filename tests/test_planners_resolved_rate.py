"""Resolved-rate control on the PR robot (S5): the run table, singularity reports, circle following."""

import math

import numpy as np
import pinocchio as pin
import pytest

from kinserve.kinematics import Robot
from kinserve.kinematics.errors import InputError, ShapeError
from kinserve.planners.resolved_rate import (
    damped_pseudo_inverse,
    follow_circle,
    resolved_rate,
    track_reference,
)

# (v, q_init = [d1, theta2 in degrees], n, dt) - SCENARIOS.md S5
S5_RUNS = [
    ([2, 0], [1, 0], 50, 0.2), ([0.2, 4], [1, 0], 25, 0.2), ([0.2, 4], [1, 0], 25, 1),
    ([0.2, 4], [1, 0], 25, 0.5), ([0.2, 4], [1, 0], 25, 0.75), ([1, 4], [1, 0], 15, 0.75),
    ([4, 4], [1, 0], 15, 0.75), ([4, 4], [1, 0], 35, 0.75), ([4, 4], [1, 90], 35, 0.75),
    ([0.2, 0.2], [1, 45], 35, 0.75), ([0.5, 1], [1, 45], 35, 0.75),
]
# (centre, radius, n, dt)
S5_CIRCLES = [([1, 0.25], 0.2, 5000, 0.001), ([1, 0.5], 0.5, 5000, 0.001), ([1, 0.5], 0.5, 5000, 0.01),
              ([1, 0.3], 0.3, 5000, 0.001)]


def _pr_from_pinocchio(d2=1.0):
    m = pin.Model()
    j1 = m.addJoint(0, pin.JointModelPX(), pin.SE3.Identity(), "d1")
    j2 = m.addJoint(j1, pin.JointModelRZ(), pin.SE3.Identity(), "theta2")
    m.lowerPositionLimit = np.array([-25.0, -math.pi])
    m.upperPositionLimit = np.array([25.0, math.pi])
    m.addFrame(pin.Frame("tool", j2, 0, pin.SE3(np.eye(3), np.array([d2, 0.0, 0.0])), pin.FrameType.OP_FRAME))
    return Robot(m, tip="tool", name="pr", task_axes=("x", "y"))


@pytest.fixture(scope="module")
def pr():
    try:
        from kinserve import robots

        return robots.load("pr")
    except Exception:  # robots/ not available: the same mechanism built directly
        return _pr_from_pinocchio()


@pytest.fixture(scope="module")
def d2(pr):
    return float(np.linalg.norm(pr.fk(np.zeros(2))[:3, 3]))


def _q(qi):
    return np.array([qi[0], math.radians(qi[1])])


def test_model_is_the_seed_pr_robot(pr, d2):
    # T = Tx(d1) Rz(theta2) Tx(d2); J = [[1, -d2 s], [0, d2 c]]
    q = np.array([0.7, 0.4])
    p = pr.fk(q)[:2, 3]
    np.testing.assert_allclose(p, [0.7 + d2 * math.cos(0.4), d2 * math.sin(0.4)], atol=1e-12)
    J = pr.jacobian(q)[:2]
    np.testing.assert_allclose(J, [[1, -d2 * math.sin(0.4)], [0, d2 * math.cos(0.4)]], atol=1e-12)


def test_run_1_follows_the_line_exactly(pr):
    v, qi, n, dt = S5_RUNS[0]
    res = resolved_rate(pr, v, _q(qi), n, dt)
    x0 = pr.fk(_q(qi))[:2, 3]
    np.testing.assert_allclose(res.positions, x0 + np.outer(res.times, v), atol=1e-10)
    assert not res.events and res.max_error < 1e-10


def test_small_steps_follow_v_in_the_well_conditioned_region(pr):
    res = resolved_rate(pr, [0.2, 0.1], _q([1, 10]), 50, 0.01)
    assert not res.events
    assert res.max_error < 1e-4  # Euler drift O(dt^2) per step
    closed = resolved_rate(pr, [0.2, 0.1], _q([1, 10]), 50, 0.01, closed_loop=True)
    assert closed.max_error < res.max_error


@pytest.mark.parametrize("damping", ["adaptive", 0.0])
@pytest.mark.parametrize("run", range(len(S5_RUNS)))
def test_table_runs_either_follow_or_report(pr, run, damping):
    v, qi, n, dt = S5_RUNS[run]
    res = resolved_rate(pr, v, _q(qi), n, dt, damping=damping)
    assert len(res.times) == n + 1 and np.all(np.isfinite(res.q))
    # never silently garbage: a run that leaves the line reports why
    assert res.max_error < 1e-9 or res.events, res.summary()
    assert [e.step for e in res.events] == sorted(e.step for e in res.events)


def test_singular_start_is_reported_at_step_0(pr):
    v, qi, n, dt = S5_RUNS[8]  # theta2 = 90 degrees
    assert qi[1] == 90
    for damping in ("adaptive", 0.0):
        res = resolved_rate(pr, v, _q(qi), n, dt, damping=damping)
        ev = res.events[0]
        assert ev.step == 0 and ev.kind == "low_manipulability" and ev.value < 1e-9
        assert res.manipulability[0] < 1e-9
    stopped = resolved_rate(pr, v, _q(qi), n, dt, stop_on_singularity=True)
    assert stopped.stopped_early and len(stopped.times) == 1


def test_damping_bounds_the_joint_rates_near_the_singularity(pr):
    v, qi, n, dt = S5_RUNS[1]  # y rises towards the workspace boundary y = d2
    plain = resolved_rate(pr, v, _q(qi), n, dt, damping=0.0)
    damped = resolved_rate(pr, v, _q(qi), n, dt, damping="adaptive", lambda_max=0.1, sigma_threshold=0.05)
    fixed = resolved_rate(pr, v, _q(qi), n, dt, damping=0.2)
    assert any(e.kind == "joint_rate" for e in plain.events)
    assert np.linalg.norm(plain.joint_rates, axis=1).max() > 10 * np.linalg.norm(v) / 0.05
    assert np.linalg.norm(damped.joint_rates, axis=1).max() <= np.linalg.norm(v) / 0.05 + 1e-9
    assert np.linalg.norm(fixed.joint_rates, axis=1).max() <= np.linalg.norm(v) / (2 * 0.2) + 1e-9
    assert any(e.kind == "low_manipulability" for e in damped.events)


def _circle_start(centre, radius, d2):
    x, y = centre[0] + radius, centre[1]
    th = math.asin(y / d2)
    return np.array([x - d2 * math.cos(th), th])


@pytest.mark.parametrize("case", range(len(S5_CIRCLES)))
def test_circle_closed_loop_beats_open_loop(pr, d2, case):
    centre, radius, n, dt = S5_CIRCLES[case]
    q0 = _circle_start(centre, radius, d2)
    open_ = follow_circle(pr, centre, radius, q0, n, dt, closed_loop=False)
    closed = follow_circle(pr, centre, radius, q0, n, dt, closed_loop=True)
    assert closed.errors[0] < 1e-12 and open_.errors[0] < 1e-12
    assert closed.max_error < open_.max_error
    assert closed.rms_error < open_.rms_error
    # the reference really is the circle at 1 rad/s
    np.testing.assert_allclose(np.linalg.norm(closed.reference - centre, axis=1), radius, atol=1e-12)
    if centre[1] + radius < d2 - 0.05:  # circle strictly inside the workspace
        assert closed.max_error < 1e-6 and not closed.events


def test_larger_dt_spirals_further(pr, d2):
    # S5 13a/13b: same circle, dt 0.001 vs 0.01 at 1 rad/s; here on the circle inside the workspace
    centre, radius, n, _ = S5_CIRCLES[0]
    q0 = _circle_start(centre, radius, d2)
    fine = follow_circle(pr, centre, radius, q0, n, 0.001, closed_loop=False)
    coarse = follow_circle(pr, centre, radius, q0, 500, 0.01, closed_loop=False)
    # after the same angle (5 rad) the Euler drift (O(dt) per unit time) is ~10x larger
    assert coarse.errors[-1] > 5 * fine.errors[-1]


def test_damped_pseudo_inverse_formulas(rng):
    J = rng.normal(size=(2, 4))
    np.testing.assert_allclose(damped_pseudo_inverse(J)[0], np.linalg.pinv(J), atol=1e-12)
    lam = 0.3
    np.testing.assert_allclose(damped_pseudo_inverse(J, lam)[0],
                               J.T @ np.linalg.inv(J @ J.T + lam**2 * np.eye(2)), atol=1e-12)


def test_track_reference_with_callable(pr):
    x0 = pr.fk(_q([1, 20]))[:2, 3]
    res = track_reference(pr, lambda t: (x0 + [0.1 * t, 0.0], [0.1, 0.0]), _q([1, 20]), 20, 0.05)
    assert res.closed_loop and res.max_error < 1e-6


def test_bad_inputs(pr):
    q0 = _q([1, 0])
    with pytest.raises(ShapeError, match="velocity"):
        resolved_rate(pr, [1, 2, 3], q0, 5, 0.1)
    with pytest.raises(InputError, match="dt"):
        resolved_rate(pr, [1, 0], q0, 5, 0.0)
    with pytest.raises(InputError, match="n"):
        resolved_rate(pr, [1, 0], q0, -1, 0.1)
    with pytest.raises(InputError, match="roll"):
        resolved_rate(pr, [1, 0], q0, 5, 0.1, axes=("x", "roll"))
    with pytest.raises(InputError, match="damping"):
        resolved_rate(pr, [1, 0], q0, 5, 0.1, damping="lots")
    with pytest.raises(InputError, match="radius"):
        follow_circle(pr, [1, 0], -0.1, q0, 10, 0.01)
