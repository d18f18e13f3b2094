"""Path smoothing: never enters the inflated obstacles (dense check), keeps the end points, C2 spline."""

import numpy as np
import pytest

from kinserve.kinematics.errors import InputError
from kinserve.planners.mobile import mall
from kinserve.planners.mobile.astar import astar
from kinserve.planners.mobile.maps import OccupancyGrid
from kinserve.planners.mobile.sequencing import plan_waypoints
from kinserve.planners.mobile.shapes import Circle, Rectangle
from kinserve.planners.mobile.smoothing import polyline_path, shortcut, smooth_path


@pytest.fixture(scope="module")
def s7():
    return mall.s7_map()


@pytest.fixture(scope="module")
def s7_plan(s7):
    return plan_waypoints(s7, mall.s7_waypoints())


def _dense_free(grid, pts, step):
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    assert seg.max() <= step + 1e-9  # the samples are dense enough to mean something
    return grid.is_free(pts).all()


def test_s7_smoothed_legs_avoid_the_inflated_obstacles(s7, s7_plan):
    for seg in s7_plan.segments:
        sp = smooth_path(s7, seg.points)
        assert sp.verified and _dense_free(s7, sp.points, s7.resolution / 4)
        # exact check against the shapes, within the raster's resolution
        assert s7.clearance(sp.points).min() >= -s7.resolution
        np.testing.assert_allclose(sp.points[0], seg.points[0], atol=1e-9)
        np.testing.assert_allclose(sp.points[-1], seg.points[-1], atol=1e-9)
        assert sp.length <= seg.length + 1e-6  # smoothing shortens the staircase
        assert sp.s[0] == 0 and np.all(np.diff(sp.s) > 0)


def test_spline_heading_and_curvature_are_continuous(s7, s7_plan):
    sp = smooth_path(s7, s7_plan.segments[1].points)  # the leg that bends around hot-dog stand 1
    assert sp.kind == "spline"
    ds = np.diff(sp.s)
    dh = np.abs(np.diff(np.unwrap(sp.heading)))
    assert np.all(dh <= np.abs(sp.curvature[:-1]).max() * ds * 1.5 + 1e-9)  # |dtheta| <= |kappa| ds
    dk = np.abs(np.diff(sp.curvature))
    assert dk.max() < 0.05  # no curvature jumps at the knots
    # curvature agrees with the heading's rate of change
    np.testing.assert_allclose(np.diff(np.unwrap(sp.heading)) / ds,
                               0.5 * (sp.curvature[1:] + sp.curvature[:-1]), atol=2e-3)


@pytest.mark.parametrize("seed", range(6))
def test_random_maps_stay_free(seed):
    rng = np.random.default_rng(100 + seed)
    shapes = [Rectangle(x, y, x + w, y + h)
              for x, y, w, h in rng.uniform([5, 5, 3, 3], [45, 45, 12, 12], (6, 4))]
    shapes += [Circle(*rng.uniform([5, 5], [45, 45]), rng.uniform(2, 6)) for _ in range(3)]
    g = OccupancyGrid.from_shapes((60, 60), shapes, resolution=1.0, inflation=2.0)
    free = np.argwhere(g.free)
    for _ in range(3):
        a, b = (g.index_to_world(*free[rng.integers(len(free))])[0],
                g.index_to_world(*free[rng.integers(len(free))])[0])
        try:
            p = astar(g, a, b)
        except Exception:
            continue
        sp = smooth_path(g, p.points)
        assert _dense_free(g, sp.points, 0.25)
        np.testing.assert_allclose(sp.points[[0, -1]], [a, b], atol=1e-9)


def test_shortcut_keeps_required_vertices(s7, s7_plan):
    pts = s7_plan.points
    keep = s7_plan.waypoint_index
    idx = shortcut(s7, pts, keep=keep)
    assert set(keep) <= set(idx.tolist())
    assert s7.path_is_free(pts[idx])


def test_polyline_path_stops_at_corners():
    pl = polyline_path([[0, 0], [3, 0], [3, 4]])
    np.testing.assert_allclose(pl.stops, [0, 3, 7])
    assert pl.length == pytest.approx(7) and pl.kind == "polyline"


def test_blocked_input_path_raises(s7):
    with pytest.raises(InputError, match="not free"):
        smooth_path(s7, [[60, 60], [240, 240]])
