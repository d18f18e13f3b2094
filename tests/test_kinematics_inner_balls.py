"""The inner balls of the robot geometries (kinserve.kinematics.inner_balls) against independent formulas.

* a convex hull: the radius is the depth of the point in the hull as coal measures it (``coal.distance`` of
  a ball of radius 0 there: minus the penetration depth), and points sampled on every inner ball of the
  Panda's and UR5's hulls are inside the hull (coal again); the balls are not points;
* primitives (box, sphere, cylinder, capsule, with a swept-sphere radius): the radius is the depth of the
  point, ``-signed_distance`` of kinematics.shapes, and points on the ball are inside the shape;
* the corner tetrahedron's radii in closed form.
"""

import coal
import numpy as np
import pytest

from kinserve import robots
from kinserve.kinematics.inner_balls import inner_radii
from kinserve.kinematics.shapes import Box, Capsule, Cylinder, Sphere


def _sphere_points(centre: np.ndarray, radius: float, rng, n: int = 200) -> np.ndarray:
    """``n`` points on the sphere of ``centre`` and ``radius``."""
    d = rng.normal(size=(n, 3))
    return centre + radius * d / np.linalg.norm(d, axis=1, keepdims=True)


def _coal_distance(shape: coal.CollisionGeometry, point: np.ndarray) -> float:
    """coal's signed distance from ``point`` (a ball of radius 0; shape frame) to ``shape``."""
    return coal.distance(coal.Sphere(0.0), coal.Transform3s(np.eye(3), point), shape, coal.Transform3s(),
                         coal.DistanceRequest(), coal.DistanceResult())


@pytest.mark.parametrize("name", ["panda", "ur5"])
def test_hull_inner_balls_are_the_largest_balls_inside_the_hull(name):
    robot = robots.load(name, geometry=False)
    geometry = robot.collision.robot_geometry
    spheres = geometry.spheres
    rng = np.random.default_rng(4)
    hulls = balls = 0
    for g, obj in enumerate(geometry.geometry.geometryObjects):
        shape = obj.geometry
        if not isinstance(shape, coal.Convex):
            continue
        hulls += 1
        first, end = spheres.inner_ranges[g]
        M = obj.placement
        local = (spheres.inner[first:end] - M.translation) @ M.rotation  # back into the geometry's frame
        radii = inner_radii(shape, local)
        assert np.allclose(radii, geometry.inner_radii[first:end], rtol=0, atol=1e-15)
        for p, r in zip(local, radii):
            assert r == pytest.approx(-_coal_distance(shape, p), abs=2e-6)
            assert max(_coal_distance(shape, x) for x in _sphere_points(p, r, rng, 40)) <= 1e-6
            balls += int(r > 0.01)
    assert hulls >= 5 and balls >= hulls  # the balls have substance: at least one per hull above 1 cm


def test_primitive_inner_balls_are_their_points_depth():
    rng = np.random.default_rng(5)
    shapes = [Box(np.eye(4), (0.2, 0.4, 0.1)), Sphere((0.0, 0.0, 0.0), 0.15),
              Cylinder(np.eye(4), 0.1, 0.5), Capsule((0.0, 0.0, -0.2), (0.0, 0.0, 0.2), 0.07)]
    for shape in shapes:
        geometry = shape.geometry()
        points = rng.uniform(-0.2, 0.2, size=(400, 3))
        points = points[shape.signed_distance(points) < 0.0][:50]
        assert len(points) >= 20
        radii = inner_radii(geometry, points)
        np.testing.assert_allclose(radii, -shape.signed_distance(points), rtol=1e-8, atol=1e-8)
        for p, r in zip(points, radii):
            assert shape.signed_distance(_sphere_points(p, r, rng)).max() <= 1e-9
    swept = coal.Box(0.2, 0.2, 0.2)
    swept.setSweptSphereRadius(0.03)
    assert inner_radii(swept, np.zeros((1, 3)))[0] == pytest.approx(0.13, abs=1e-8)
    assert inner_radii(coal.Box(0.2, 0.2, 0.2), np.array([[0.5, 0.0, 0.0]]))[0] == 0.0  # outside: a point


def _tetrahedron_hull() -> coal.Convex:
    """coal's hull (qhull) of the unit corner tetrahedron, as the collision model makes its mesh hulls."""
    bvh = coal.BVHModelOBBRSS()
    bvh.beginModel(4, 4)
    bvh.addVertices(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]))
    bvh.addTriangles(np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]))
    bvh.endModel()
    bvh.buildConvexHull(True, "Qt")
    return bvh.convex


def test_the_corner_tetrahedron_radii():
    """About ``p`` the radius is the distance to its nearest face, ``min(p_x, p_y, p_z, (1 - p_x - p_y -
    p_z) / sqrt(3))``."""
    hull = _tetrahedron_hull()
    p = np.array([[0.1, 0.2, 0.15], [0.3, 0.3, 0.3], [0.05, 0.05, 0.05]])
    expected = np.minimum(p.min(axis=1), (1.0 - p.sum(axis=1)) / np.sqrt(3.0))
    np.testing.assert_allclose(inner_radii(hull, p), expected, rtol=1e-8, atol=1e-9)
