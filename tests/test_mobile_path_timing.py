"""Time scaling along paths: limits (speed, acceleration, turn rate), continuity of v and a, rest at the
ends."""

import math

import numpy as np
import pytest

from kinserve.kinematics.errors import InputError
from kinserve.planners.mobile import mall
from kinserve.planners.mobile.path_timing import drive_through, time_scale_path, turn_in_place
from kinserve.planners.mobile.sequencing import plan_waypoints
from kinserve.planners.mobile.smoothing import SmoothPath, polyline_path, smooth_path

LIMITS = dict(v_max=20.0, a_max=10.0, omega_max=0.5, alpha_max=1.0, dt=0.01)


def _arc_path(radius=5.0, angle=math.pi, n=2001):
    th = np.linspace(0, angle, n)
    pts = np.stack([radius * np.sin(th), radius * (1 - np.cos(th))], axis=1)
    s = radius * th
    return SmoothPath(pts, s, th, np.full(n, 1.0 / radius), pts[[0, -1]], "spline",
                      np.array([0.0, s[-1]]), True)


def _check_limits_and_continuity(tr, v_max, a_max, omega_max, dt):
    assert np.abs(tr.v).max() <= v_max * (1 + 1e-9)
    assert np.abs(tr.a).max() <= a_max * (1 + 1e-6)
    assert np.abs(tr.omega).max() <= omega_max * (1 + 1e-6)
    h = np.diff(tr.t).max()
    assert h <= dt + 1e-12
    # continuity: per-sample changes bounded by (rate limit) x step, no jumps
    assert np.abs(np.diff(tr.v)).max() <= a_max * h * 1.01
    jerk = np.abs(np.diff(tr.a)).max() / h
    assert jerk < 10 * a_max / (0.25 * v_max / a_max)
    assert tr.v[0] == 0 and abs(tr.v[-1]) < 1e-12 and abs(tr.a[0]) < 1e-9 and abs(tr.a[-1]) < 1e-9


def test_turn_rate_cap_on_an_arc():
    path = _arc_path(radius=5.0)
    tr = time_scale_path(path, v_max=20.0, a_max=10.0, omega_max=0.5)
    _check_limits_and_continuity(tr, 20.0, 10.0, 0.5, 0.01)
    # on a radius-5 arc the cap omega/kappa = 2.5 binds long before v_max
    assert np.abs(tr.v).max() == pytest.approx(2.5, rel=1e-3)
    # omega = kappa v along the whole arc; the trajectory stays on the arc
    np.testing.assert_allclose(tr.omega, tr.v / 5.0, atol=1e-9)
    np.testing.assert_allclose(np.hypot(tr.x, tr.y - 5.0), 5.0, atol=1e-3)
    # positions integrate the speed
    s = np.concatenate([[0], np.cumsum(0.5 * (tr.v[1:] + tr.v[:-1]) * np.diff(tr.t))])
    assert s[-1] == pytest.approx(path.length, rel=1e-6)


def test_s7_drive_respects_the_limits_and_the_map():
    m = mall.s7_map()
    plan = plan_waypoints(m, mall.s7_waypoints())
    paths = [smooth_path(m, seg.points) for seg in plan.segments]
    tr = drive_through(paths, initial_heading=0.0, **LIMITS)
    _check_limits_and_continuity(tr, LIMITS["v_max"], LIMITS["a_max"], LIMITS["omega_max"], LIMITS["dt"])
    assert m.is_free(tr.points).all()
    # the robot stops at each waypoint
    for w in mall.s7_waypoints()[1:-1]:
        k = np.argmin(np.hypot(tr.x - w[0], tr.y - w[1]))
        assert np.hypot(tr.x[k] - w[0], tr.y[k] - w[1]) < 1e-6 and abs(tr.v[k]) < 1e-9
    assert sum(1 for kind, *_ in tr.phases if kind == "drive") == 5


def test_polyline_corners_become_turns_in_place():
    tr = time_scale_path(polyline_path([[0, 0], [10, 0], [10, 10]]), v_max=2.0, a_max=1.0, omega_max=1.0)
    kinds = [k for k, *_ in tr.phases]
    assert kinds == ["drive", "turn", "drive"]
    turn = [(a, b) for k, a, b in tr.phases if k == "turn"][0]
    during = (tr.t > turn[0]) & (tr.t < turn[1])
    assert np.allclose(tr.x[during], 10) and np.allclose(tr.y[during], 0) and np.all(tr.v[during] == 0)
    assert tr.heading[-1] == pytest.approx(math.pi / 2)


def test_turn_in_place_quintic():
    tr = turn_in_place(1.0, 2.0, 0.0, 3.0, omega_max=1.0, alpha_max=2.0, dt=0.001)
    assert tr.heading[-1] == pytest.approx(3.0)
    assert np.abs(tr.omega).max() <= 1.0 + 1e-9 and tr.omega[0] == 0 and abs(tr.omega[-1]) < 1e-12
    assert np.abs(np.gradient(tr.omega, tr.t)).max() <= 2.0 * 1.01
    # shortest way round
    back = turn_in_place(0, 0, 3.0, -3.0, omega_max=1.0, alpha_max=2.0)
    assert back.heading[-1] - back.heading[0] == pytest.approx(2 * math.pi - 6.0)
    assert turn_in_place(0, 0, 1.0, 1.0 + 2 * math.pi, omega_max=1, alpha_max=1) is None


def test_bad_limits():
    with pytest.raises(InputError, match="omega_max"):
        time_scale_path(_arc_path(), v_max=1.0, a_max=1.0, omega_max=0.0)
