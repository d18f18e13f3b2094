"""Occupancy grids: rasterisation against the analytic clearance, raster rule, distance field."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from kinserve.kinematics.errors import InputError, ShapeError
from kinserve.planners.mobile.maps import OccupancyGrid
from kinserve.planners.mobile.shapes import Circle, Polygon, Rectangle

SHAPES = (Rectangle(10, 10, 20, 15, "box"), Circle(30, 30, 5, "disc"),
          Polygon([(40, 5), (48, 5), (44, 14)], name="tri"))


@pytest.fixture(scope="module")
def grid():
    return OccupancyGrid.from_shapes((0, 0, 50, 40), SHAPES, resolution=0.5, inflation=2.0)


def test_lattice_and_free_equal_analytic_clearance(grid):
    assert grid.shape == (81, 101)
    X, Y = np.meshgrid(grid.xs, grid.ys)
    clr = grid.clearance(np.stack([X.ravel(), Y.ravel()], 1)).reshape(grid.shape)
    np.testing.assert_array_equal(grid.free, clr >= -1e-9)
    # hand checks: inflated box edge at x = 8 (free, touching), inside at x = 8.5
    assert grid.is_free([8.0, 12.0])[0] and not grid.is_free([8.5, 12.0])[0]
    # walls: border clearance defaults to the inflation
    assert not grid.is_free([1.5, 20])[0] and grid.is_free([2.0, 20])[0]


def test_world_index_round_trip(grid):
    i, j = grid.world_to_index([[3.0, 4.5], [49.9, 0.2]])
    np.testing.assert_array_equal(i, [9, 0])
    np.testing.assert_array_equal(j, [6, 100])
    np.testing.assert_allclose(grid.index_to_world(i, j), [[3.0, 4.5], [50.0, 0.0]])
    assert grid.on_lattice([[3.0, 4.5], [3.1, 4.5]]).tolist() == [True, False]


def test_raster_rule_between_lattice_points(grid):
    # a point is free iff its (up to 4) surrounding lattice points are free
    rng = np.random.default_rng(0)
    P = rng.uniform([0, 0], [50, 40], (3000, 2))
    u, v = P[:, 0] / 0.5, P[:, 1] / 0.5
    expect = (grid.free[np.floor(v).astype(int), np.floor(u).astype(int)]
              & grid.free[np.ceil(v).astype(int), np.floor(u).astype(int)]
              & grid.free[np.floor(v).astype(int), np.ceil(u).astype(int)]
              & grid.free[np.ceil(v).astype(int), np.ceil(u).astype(int)])
    np.testing.assert_array_equal(grid.is_free(P), expect)
    assert not grid.is_free([[-0.1, 5], [51, 5]]).any()  # outside the map


def test_distance_field_is_euclidean_distance_to_blocked(grid):
    D = grid.distance_field()
    blocked = np.argwhere(~grid.free)
    # outside the map counts as blocked: add a ring of points around the lattice
    ny, nx = grid.shape
    ring = [(i, -1) for i in range(-1, ny + 1)] + [(i, nx) for i in range(-1, ny + 1)]
    ring += [(-1, j) for j in range(nx)] + [(ny, j) for j in range(nx)]
    tree = cKDTree(np.vstack([blocked, ring]))
    free = np.argwhere(grid.free)
    d, _ = tree.query(free)
    np.testing.assert_allclose(D[grid.free], 0.5 * d, atol=1e-9)
    assert np.all(D[~grid.free] == 0)


def test_path_checks(grid):
    assert grid.segment_is_free([3, 3], [3, 30])
    assert not grid.segment_is_free([3, 12], [25, 12])  # through the inflated box
    assert grid.path_is_free([[3, 3], [3, 30], [5, 35]])
    assert grid.first_blocked([[3, 3], [15, 12]]) == 1


def test_bad_inputs():
    with pytest.raises(InputError, match="bounds"):
        OccupancyGrid.from_shapes((0, 0, -1, 5))
    with pytest.raises(InputError, match="resolution"):
        OccupancyGrid.from_shapes((10, 10), resolution=0)
    with pytest.raises(InputError, match="shapes\\[0\\]"):
        OccupancyGrid.from_shapes((10, 10), ["box"])
    with pytest.raises(InputError, match="inflation"):
        OccupancyGrid.from_shapes((10, 10), inflation=-1)
    g = OccupancyGrid.from_shapes((10, 10))
    with pytest.raises(ShapeError, match="points"):
        g.is_free([1, 2, 3])
