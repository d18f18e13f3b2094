"""Boustrophedon coverage: S8 covers >= 95 % of the free floor; the coverage measure checked by brute
force."""

import numpy as np
import pytest

from kinserve.kinematics.errors import InputError
from kinserve.planners.mobile import mall
from kinserve.planners.mobile.coverage import (
    boustrophedon_coverage,
    coverable_pixels,
    decompose,
    lane_intervals,
    swept_coverage,
)
from kinserve.planners.mobile.maps import OccupancyGrid
from kinserve.planners.mobile.shapes import Rectangle


@pytest.fixture(scope="module")
def s8():
    m = mall.s8_map()
    return m, boustrophedon_coverage(m, mall.S8_START, lane_spacing=mall.S8_LANE_SPACING)


def test_s8_coverage(s8):
    m, r = s8
    assert r.covered_fraction >= 0.95, r.summary()
    assert r.path_is_free and m.path_is_free(r.path, 0.5)
    np.testing.assert_allclose(r.path[0], mall.S8_START)
    assert r.length == pytest.approx(np.linalg.norm(np.diff(r.path, axis=0), axis=1).sum())
    # every lane the robot can stand on is used: 24 lanes at y = 10, 30, ..., 470
    assert r.n_lanes == 24 and r.n_uturns > 20
    assert sorted(r.visit_order) == list(range(len(r.cells)))
    # a lower bound on the length: every lane interval is driven (minus the turn radius at each end)
    lanes = lane_intervals(m, 10.0, 20.0)
    assert r.length >= sum(max(0.0, iv.x1 - iv.x0 - 20.0) for lane in lanes for iv in lane)


def test_detours_avoid_the_padded_obstacles(s8):
    m, r = s8
    for shape in mall.S8_PADDED_OBSTACLES + mall.S8_NO_GO:
        assert shape.signed_distance(r.path[:, 0], r.path[:, 1]).min() >= -m.resolution


def test_swept_coverage_against_brute_force(s8):
    m, r = s8
    rng = np.random.default_rng(0)
    ny, nx = m.shape
    pix = rng.integers(0, [ny - 1, nx - 1], size=(400, 2))
    P, H = r.path, r.heading
    # the measure resamples the path every 0.5, i.e. within 0.25 of a path point with that point's heading:
    # a pixel well inside a footprint is covered, a pixel well outside all of them is not
    for i, j in pix:
        d = np.array([j + 0.5, i + 0.5]) - P
        u = np.cos(H) * d[:, 0] + np.sin(H) * d[:, 1]
        v = -np.sin(H) * d[:, 0] + np.cos(H) * d[:, 1]
        cheb = np.maximum(np.abs(u), np.abs(v)).min()
        if cheb <= 10 - 0.3:
            assert r.covered[i, j], (i, j, cheb)
        elif cheb > 10 + 0.3:
            assert not r.covered[i, j], (i, j, cheb)


def test_coverable_pixels_brute_force():
    g = OccupancyGrid.from_shapes((30, 20), [Rectangle(8, 5, 14, 12)], resolution=1.0, inflation=2.0)
    cov = coverable_pixels(g, 4.0)
    free = np.argwhere(g.free)[:, ::-1].astype(float)  # (x, y) lattice points
    for i in range(cov.shape[0]):
        for j in range(cov.shape[1]):
            c = np.array([j + 0.5, i + 0.5])
            assert cov[i, j] == bool(np.any(np.abs(free - c).max(axis=1) <= 2.0))


def test_open_room_is_covered_fully():
    g = OccupancyGrid.from_shapes((100, 60), [], resolution=1.0, border_clearance=5.0)
    r = boustrophedon_coverage(g, (5, 5), lane_spacing=10.0)
    assert len(r.cells) == 1 and r.covered_fraction > 0.98
    # axis-aligned square footprint swept along straight lanes: the covered area is exact there
    one = swept_coverage(g, np.array([[20.0, 30.0], [60.0, 30.0]]), np.zeros(2), 10.0)
    assert one.sum() == 50 * 10


def test_decomposition_splits_at_an_obstacle():
    g = OccupancyGrid.from_shapes((100, 60), [Rectangle(40, 20, 60, 40)], resolution=1.0,
                                  border_clearance=5.0)
    cells = decompose(lane_intervals(g, 5.0, 10.0))
    # below, left, right, above the block
    assert len(cells) == 4
    r = boustrophedon_coverage(g, (5, 5), lane_spacing=10.0)
    assert r.covered_fraction > 0.95 and r.path_is_free


def test_bad_inputs(s8):
    m, _ = s8
    with pytest.raises(InputError, match="start"):
        boustrophedon_coverage(m, (240, 240), lane_spacing=20)
    with pytest.raises(InputError, match="lane_spacing"):
        boustrophedon_coverage(m, (10, 10), lane_spacing=0)
