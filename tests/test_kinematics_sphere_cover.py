"""Spheres that contain a geometry (kinematics.sphere_cover): covers, bounding spheres, inner points.

* every cover and bounding sphere contains its primitive (points on the surfaces' extreme points and inside);
  a swept-sphere radius inflates them;
* the compiled crossings of a plane equal a NumPy evaluation of every vertex pair; a polytope's slab spheres
  have the radius of the farthest point of the slab's part of the hull (every vertex pair's crossings,
  computed here from scratch), which one of those points attains;
* inner points lie inside their primitive (coal's signed distance).
"""

import itertools
import math

import coal
import numpy as np
import pytest

from kinserve.kinematics import sphere_cover as sc


def _contained(points, spheres):
    """Per point, True when some sphere ``(centre, radius)`` of ``spheres`` holds it."""
    d2 = ((points[:, None, :] - spheres[None, :, :3]) ** 2).sum(axis=2)
    return (d2 <= spheres[None, :, 3] ** 2).any(axis=1)


@pytest.mark.parametrize("geo", [coal.Sphere(0.1), coal.Box(0.2, 0.1, 0.4), coal.Capsule(0.05, 0.3),
                                 coal.Cylinder(0.05, 0.3)])
def test_primitive_inner_points_are_inside(geo):
    for p in sc.geometry_inner_points(geo):
        res = coal.DistanceResult()
        assert coal.distance(geo, coal.Transform3s(), coal.Sphere(1e-9), coal.Transform3s(np.eye(3), p),
                             coal.DistanceRequest(), res) < 0.0


def _primitive_samples(geo, rng, n=4000):
    """Points on and inside a coal primitive, in its frame (the surfaces' extreme points included)."""
    if isinstance(geo, coal.Sphere):
        d = rng.normal(size=(n, 3))
        return geo.radius * d / np.linalg.norm(d, axis=1)[:, None] * rng.uniform(0.0, 1.0, (n, 1)) ** 0.01
    if isinstance(geo, coal.Ellipsoid):
        d = rng.normal(size=(n, 3))
        return np.asarray(geo.radii) * d / np.linalg.norm(d, axis=1)[:, None]
    r, L = geo.radius, geo.halfLength
    phi = rng.uniform(0.0, 2.0 * np.pi, n)
    rho = r * np.sqrt(rng.uniform(0.0, 1.0, n))
    rho[: n // 2] = r  # on the mantle and the rims
    z = rng.uniform(-L, L, n)
    z[: n // 8] = rng.choice([-L, L], n // 8)
    pts = np.column_stack([rho * np.cos(phi), rho * np.sin(phi), z])
    if isinstance(geo, coal.Capsule):
        d = rng.normal(size=(n, 3))
        cap = r * d / np.linalg.norm(d, axis=1)[:, None]
        cap[:, 2] += np.where(cap[:, 2] > 0, L, -L)
        pts = np.concatenate([pts, cap])
    return pts


@pytest.mark.parametrize("geo", [coal.Sphere(0.07), coal.Cylinder(0.04, 0.5), coal.Cylinder(0.2, 0.05),
                                 coal.Capsule(0.03, 0.4), coal.Ellipsoid(0.1, 0.05, 0.2)],
                         ids=["sphere", "long cylinder", "flat cylinder", "capsule", "ellipsoid (AABB)"])
def test_primitive_covers_contain_the_primitive(geo):
    rng = np.random.default_rng(5)
    bounding, cover = sc.geometry_cover(geo)
    points = _primitive_samples(geo, rng)
    assert _contained(points, cover).all() and _contained(points, bounding[None, :]).all()
    if isinstance(geo, coal.Sphere):
        assert cover.shape == (1, 4) and cover[0, 3] == pytest.approx(0.07, abs=1e-8)
    if isinstance(geo, coal.Cylinder):  # k slabs of half length h = L / k: spheres of radius sqrt(r^2 + h^2)
        k = min(sc.MAX_COVER_SPHERES, int(np.ceil(2.0 * geo.halfLength / (sc.SLAB_RATIO * geo.radius))))
        assert len(cover) == k
        assert np.allclose(cover[:, 3], np.hypot(geo.radius, geo.halfLength / k), rtol=0, atol=1e-8)


def test_swept_sphere_radius_inflates_the_cover():
    box = coal.Box(0.1, 0.2, 0.3)
    plain = sc.geometry_cover(box)[1]
    box.setSweptSphereRadius(0.02)
    swept = sc.geometry_cover(box)[1]
    assert np.allclose(swept[:, 3], plain[:, 3] + 0.02)


def test_plane_crossings_equal_every_pair_in_numpy():
    """The compiled loop over the pairs across a plane: the largest squared distance of a crossing from the
    centre, the sum of the crossings and their number, as NumPy computes them pair by pair."""
    rng = np.random.default_rng(21)
    V = rng.normal(size=(60, 3))
    s = V @ np.array([0.3, -0.5, 0.8])
    plane, centre = 0.1, rng.normal(size=3)
    below, above = V[s < plane], V[s > plane]
    out = np.array([0.5, 1.0, 2.0, 3.0, 4.0])  # accumulated onto: the largest, then sums and counts added
    sc.plane_crossings(below, s[s < plane], above, s[s > plane], plane, centre, out)
    crossings = []
    for (b, sb), (a, sa) in itertools.product(zip(below, s[s < plane]), zip(above, s[s > plane])):
        crossings.append(b + (plane - sb) / (sa - sb) * (a - b))
    crossings = np.array(crossings)
    assert np.allclose(crossings @ np.array([0.3, -0.5, 0.8]), plane, atol=1e-12)  # on the plane
    assert out[0] == pytest.approx(max(0.5, ((crossings - centre) ** 2).sum(axis=1).max()), rel=1e-12)
    assert np.allclose(out[1:4], [1.0, 2.0, 3.0] + crossings.sum(axis=0), rtol=1e-12)
    assert out[4] == 4.0 + len(below) * len(above)


def _every_pair_slab_points(V, s, lo, hi):
    """The points of the slab ``lo <= s <= hi`` of the hull of ``V``: its vertices and every vertex pair's
    crossings of its two planes (the reference, built pair by pair)."""
    points = [v for v, sv in zip(V, s) if lo <= sv <= hi]
    for i, j in itertools.combinations(range(len(V)), 2):
        for plane in (lo, hi):
            if (s[i] - plane) * (s[j] - plane) < 0.0:
                points.append(V[i] + (plane - s[i]) / (s[j] - s[i]) * (V[j] - V[i]))
    return np.array(points)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_polytope_slab_spheres_hold_every_pair_crossing_and_no_more(seed):
    """A long random hull (coal's, triangles from its faces): each cover sphere's radius is the distance from
    its centre to the farthest of its slab's points - every vertex pair's crossings, from scratch here -
    padded by PAD; the inner point of each slab is the mean of those points, inside the hull."""
    rng = np.random.default_rng(seed)
    V0 = rng.normal(size=(40, 3)) * [0.05, 0.05, 0.3]
    mesh = coal.BVHModelOBBRSS()
    mesh.beginModel(0, len(V0))
    mesh.addVertices(V0)
    mesh.endModel()
    mesh.buildConvexHull(True, "Qt")
    hull = mesh.convex
    V = np.asarray(hull.points(), dtype=float)
    spheres = sc.geometry_spheres(hull)
    assert len(spheres.cover) >= 3  # the long axis is cut into slabs
    X = V - V.mean(axis=0)
    a = np.linalg.eigh(X.T @ X)[1][:, -1]
    s = X @ a
    lo, hi = s.min(), s.max()
    k = len(spheres.cover)
    planes = lo + (hi - lo) * np.arange(k + 1) / k
    planes[0], planes[-1] = lo, hi
    for m, (ball, point) in enumerate(zip(spheres.cover, spheres.inner)):
        pts = _every_pair_slab_points(V, s, planes[m], planes[m + 1])
        far = math.sqrt(((pts - ball[:3]) ** 2).sum(axis=1).max())
        assert ball[3] == pytest.approx(far + sc.PAD, rel=1e-9, abs=1e-12)
        assert np.allclose(point, pts.mean(axis=0), atol=1e-12)
    assert _contained(V, spheres.bounding[None, :]).all()
    for p in spheres.inner:  # inside the hull: a point sphere there is at a negative distance (coal)
        d = coal.distance(hull, coal.Transform3s(), coal.Sphere(1e-9), coal.Transform3s(np.eye(3), p),
                          coal.DistanceRequest(), coal.DistanceResult())
        assert d < 0.0
