"""planners.mobile.footprint: a rotated square footprint's reach into obstacles, against closed forms."""

import math

import numpy as np
import pytest

from kinserve.kinematics.errors import InputError, ShapeError
from kinserve.planners.mobile import Circle, Polygon, Rectangle, footprint_outline, footprint_penetration

HALF_DIAG = 10 * math.sqrt(2)


def test_outline_has_the_corners_and_dense_edges():
    out = footprint_outline(20.0, 10.0, 0.5)
    np.testing.assert_allclose(out[:4], [[10, 5], [-10, 5], [-10, -5], [10, -5]])
    assert np.all(np.abs(out[:, 0]) <= 10 + 1e-12) and np.all(np.abs(out[:, 1]) <= 5 + 1e-12)
    on_edge = np.isclose(np.abs(out[:, 0]), 10) | np.isclose(np.abs(out[:, 1]), 5)
    assert on_edge.all() and len(out) == 4 + 2 * (40 - 1) + 2 * (20 - 1)


@pytest.mark.parametrize("heading", [math.pi / 4, 0.3, 1.1, -2.0])
def test_corner_into_a_wall_rectangle_and_circle_match_closed_forms(heading):
    """A 20 x 20 square whose centre is d = 10 from an obstacle: a corner reaches the closed-form depth."""
    # wall x >= 100 as a big rectangle; centre 10 to its left
    wall = Rectangle(100, -500, 600, 500, "wall")
    pen = footprint_penetration([[90.0, 0.0]], [heading], [wall], length=20.0)
    c, s = abs(math.cos(heading)), abs(math.sin(heading))
    reach_x = 10 * (c + s)  # the corners' largest x offset for this heading
    assert pen.depth == pytest.approx(max(0.0, reach_x - 10), abs=1e-12)
    assert pen.shape == "wall" and pen.point[0] == pytest.approx(90 + reach_x)
    # circle of radius 30, centre 40 + 10 sqrt(2) - 3 away along the corner's diagonal: depth 3 exactly
    disc = Circle(0.0, 0.0, 30.0, "disc")
    d = 30.0 + HALF_DIAG - 3.0
    ang = heading + math.pi / 4  # direction of the (10, 10) corner
    centre = [-d * math.cos(ang), -d * math.sin(ang)]  # the corner points at the disc centre
    pen = footprint_penetration([centre], [heading], [disc], length=20.0)
    assert pen.depth == pytest.approx(3.0, abs=1e-9)


def test_axis_aligned_footprint_padded_by_half_the_width_only_touches():
    box = Rectangle(0, 0, 40, 40, "box")
    path = np.c_[np.linspace(-20, 60, 81), np.full(81, -10.0)]  # centre 10 below the box, along it
    pen = footprint_penetration(path, np.zeros(81), [box], length=20.0)
    assert pen.depth == 0.0 and pen.index is None and pen.poses_in_contact == 0
    assert pen.per_shape == {"box": 0.0}


def test_turning_in_place_between_samples_is_swept():
    """Two samples at one point, headings 0 then 90 deg: both axis-aligned, yet the turn passes 45 deg."""
    pen = footprint_penetration([[10.0, 50.0], [10.0, 50.0]], [0.0, math.pi / 2], [], length=20.0,
                                bounds=(0, 0, 100, 100))
    # headings every <= 2 deg: the 45 deg pose is missed by at most 1 deg, the reach by 10 sqrt 2 (1 - cos 1
    # deg)
    tol = HALF_DIAG * (1 - math.cos(math.radians(1.0))) + 1e-9
    assert HALF_DIAG - 10 - tol <= pen.depth <= HALF_DIAG - 10 and pen.shape == "walls" and pen.index == 1
    assert abs(pen.pose[2] - math.pi / 4) < math.radians(2.0)
    # without the turn (one sample per heading at different points far from the walls): nothing
    pen = footprint_penetration([[50.0, 50.0], [50.0, 50.0]], [0.0, math.pi / 2], [], length=20.0,
                                bounds=(0, 0, 100, 100))
    assert pen.depth == 0.0


def test_polygon_obstacle_and_deepest_point():
    tri = Polygon([(0, 0), (30, 0), (0, 30)], "triangle")
    # a heading-0 square centred at (-5, 10) overlaps the triangle by 5 along x: its right edge at x = 5
    pen = footprint_penetration([[-5.0, 10.0]], [0.0], [tri], length=20.0)
    # deepest outline point of the right edge x = 5, y in [0, 20], inside the triangle: distance to x = 0 is
    # 5, to the hypotenuse (x + y = 30)/sqrt 2 is (25 - y)/sqrt 2 >= 5 for y <= 17.9, to y = 0 is y: best 5 at
    # y in [5, 17.9]
    assert pen.depth == pytest.approx(5.0, abs=1e-9)


def test_bad_input():
    with pytest.raises(ShapeError, match="path"):
        footprint_penetration(np.zeros((3, 3)), np.zeros(3), [], length=20.0)
    with pytest.raises(ShapeError, match="heading"):
        footprint_penetration(np.zeros((3, 2)), np.zeros(2), [], length=20.0)
    with pytest.raises(InputError, match="finite"):
        footprint_penetration([[np.nan, 0.0]], [0.0], [], length=20.0)
    with pytest.raises(InputError, match="length"):
        footprint_penetration([[0.0, 0.0]], [0.0], [], length=-1.0)
    with pytest.raises(InputError, match="shapes"):
        footprint_penetration([[0.0, 0.0]], [0.0], [(0, 0, 1, 1)], length=20.0)
