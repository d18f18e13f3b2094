"""Shapes: signed distances against independent formulas."""

import numpy as np
import pytest

from kinserve.kinematics.errors import InputError
from kinserve.planners.mobile.shapes import Circle, Polygon, Rectangle


def test_rectangle_signed_distance():
    r = Rectangle(0, 0, 4, 2)
    pts = np.array([[2, 1], [0.5, 1], [5, 1], [5, 3], [-3, -4], [2, 2]])
    expected = [-1.0, -0.5, 1.0, np.hypot(1, 1), 5.0, 0.0]
    np.testing.assert_allclose(r.signed_distance(pts[:, 0], pts[:, 1]), expected, atol=1e-12)
    assert r.area == 8


def test_circle_signed_distance():
    c = Circle(1, 1, 2)
    np.testing.assert_allclose(c.signed_distance([1, 4, 1], [1, 1, 3]), [-2, 1, 0], atol=1e-12)
    assert c.area == pytest.approx(4 * np.pi)


def test_polygon_matches_rectangle_and_handles_concavity(rng):
    rect = Rectangle(-1, -2, 3, 1)
    poly = Polygon([(-1, -2), (3, -2), (3, 1), (-1, 1)])
    P = rng.uniform(-5, 5, (500, 2))
    np.testing.assert_allclose(poly.signed_distance(P[:, 0], P[:, 1]),
                               rect.signed_distance(P[:, 0], P[:, 1]), atol=1e-12)
    assert poly.area == pytest.approx(rect.area)
    L = Polygon([(0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2)])  # an L shape
    d = L.signed_distance(np.array([0.5, 1.5, 1.5]), np.array([1.5, 1.5, 0.5]))
    assert d[0] < 0 and d[2] < 0 and d[1] == pytest.approx(0.5)  # nearest: the inner edges y = 1 and x = 1
    assert L.area == pytest.approx(3.0)


def test_bad_shapes():
    with pytest.raises(InputError, match="x_min < x_max"):
        Rectangle(1, 0, 0, 1)
    with pytest.raises(InputError, match="radius"):
        Circle(0, 0, 0)
    with pytest.raises(InputError, match="vertices"):
        Polygon([(0, 0), (1, 1)])
    with pytest.raises(InputError, match="finite"):
        Circle(float("nan"), 0, 1)
