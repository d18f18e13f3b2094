"""Regression: the turn-rate cap of planners.mobile.time_scale_path holds at curvature peaks between its grid
nodes.

The speed profile is built on a grid every 0.05 along the path; the path's
curvature is piecewise linear between *its own* samples, so a sharp peak at a
sample that falls between two grid nodes used to be under-estimated (linear
interpolation at the nodes) and ``|omega| = |kappa| v`` exceeded ``omega_max``.
"""

import numpy as np

from kinserve.planners.mobile.path_timing import time_scale_path
from kinserve.planners.mobile.smoothing import SmoothPath


def _straight_path_with_kappa_spike(s_peak: float, kappa_peak: float) -> SmoothPath:
    s = np.union1d(np.linspace(0.0, 10.0, 41), [s_peak])
    kappa = np.where(np.isclose(s, s_peak), kappa_peak, 0.0)
    pts = np.c_[s, np.zeros_like(s)]
    return SmoothPath(pts, s, np.zeros_like(s), kappa, pts[[0, -1]], "spline", np.array([0.0, 10.0]), True)


def test_turn_rate_cap_holds_at_a_curvature_peak_between_grid_nodes():
    # grid nodes at 5.00 and 5.05; the interpolated curvature there is ~48 and ~42, the peak is 50
    path = _straight_path_with_kappa_spike(5.0123, 50.0)
    tr = time_scale_path(path, v_max=1.0, a_max=1.0, omega_max=1.0, dt=0.01)
    # independent: omega = kappa(s) v with kappa read off the path's samples at the trajectory's s
    s = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(tr.x), np.diff(tr.y)))])
    omega = np.interp(s, path.s, path.curvature) * tr.v
    assert np.max(np.abs(omega)) <= 1.0 + 1e-6
    assert np.max(np.abs(tr.omega)) <= 1.0 + 1e-6
    assert abs(s[-1] - 10.0) < 1e-6
