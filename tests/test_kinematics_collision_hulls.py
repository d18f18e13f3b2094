"""Convex hulls of collision meshes (kinematics.mesh_hulls): coal's, scipy's when coal cannot hold one, named
refusals; checked against closed forms (a prism's volume and distances) and against coal's own hull."""

import coal
import numpy as np
import pinocchio as pin
import pytest

from kinserve.kinematics import Robot, Sphere, errors, mesh_hulls
from kinserve.kinematics.collision_model import CollisionModel


def prism(n: int, radius: float = 0.1, height: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
    """A prism over a regular ``n``-gon (z in [0, ``height``]): vertices ``(2n, 3)``, triangles (fan caps)."""
    a = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    ring = np.column_stack([radius * np.cos(a), radius * np.sin(a)])
    V = np.vstack([np.column_stack([ring, np.zeros(n)]), np.column_stack([ring, np.full(n, height)])])
    T = [t for i in range(n) for t in ((i, (i + 1) % n, n + (i + 1) % n), (i, n + (i + 1) % n, n + i))]
    T += [t for i in range(1, n - 1) for t in ((0, i + 1, i), (n, n + i, n + i + 1))]
    return V, np.array(T)


def bvh(V: np.ndarray, T: np.ndarray) -> coal.BVHModelOBBRSS:
    mesh = coal.BVHModelOBBRSS()
    mesh.beginModel(len(T), len(V))
    mesh.addVertices(np.asarray(V, dtype=float))
    mesh.addTriangles(np.asarray(T, dtype=np.int64))
    mesh.endModel()
    return mesh


def ngon_area(n: int, radius: float) -> float:
    return 0.5 * n * radius ** 2 * np.sin(2.0 * np.pi / n)


def distance(a, b, placement_b: coal.Transform3s) -> float:
    return coal.distance(a, coal.Transform3s(), b, placement_b, coal.DistanceRequest(), coal.DistanceResult())


def write_stl(path, V: np.ndarray, T: np.ndarray) -> None:
    lines = ["solid m"]
    for tri in T:
        corners = [f"vertex {x:.17g} {y:.17g} {z:.17g}" for x, y, z in V[tri]]
        lines += ["facet normal 0 0 0", "outer loop", *corners, "endloop", "endfacet"]
    path.write_text("\n".join(lines + ["endsolid m", ""]))


def urdf_with_mesh(mesh_path) -> str:
    return f"""<robot name="meshy">
  <link name="base"><collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
  <link name="plate"><collision><origin xyz="0 0 0.5"/>
    <geometry><mesh filename="{mesh_path}"/></geometry></collision></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="plate"/><axis xyz="1 0 0"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
</robot>"""


# ------------------------------------------------------------------ the strip triangulation
@pytest.mark.parametrize("n", [3, 4, 5, 8, 300, 701])
def test_strip_triangulation_covers_the_polygon_with_few_neighbours(n):
    a = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    P = np.column_stack([np.cos(a), np.sin(a), np.zeros(n)])
    loop = np.random.default_rng(n).permutation(n)  # any labels: the loop is the order given
    P = P[np.argsort(loop)]
    tri = mesh_hulls.strip_triangulation(loop)
    assert tri.shape == (n - 2, 3)
    areas = 0.5 * np.linalg.norm(np.cross(P[tri[:, 1]] - P[tri[:, 0]], P[tri[:, 2]] - P[tri[:, 0]]), axis=1)
    assert areas.sum() == pytest.approx(ngon_area(n, 1.0), rel=1e-12)  # no overlap, no gap (all convex)
    assert np.all(areas > 0.0)
    assert mesh_hulls.max_neighbours(tri, n) <= 4
    sides = {tuple(sorted(e)) for t in tri.tolist() for e in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))}
    assert all(tuple(sorted((loop[k], loop[(k + 1) % n]))) in sides for k in range(n))  # the boundary is kept


# ------------------------------------------------------------------ the fallback
def test_a_fan_coal_cannot_hold_gets_scipys_hull():
    n, radius, height = 600, 0.1, 0.05
    V, T = prism(n, radius, height)
    mesh = bvh(V, T)
    with pytest.raises(RuntimeError, match="Too many neighbors"):  # why the fallback exists
        bvh(V, T).buildConvexHull(True, "Qt")
    hull, cause = mesh_hulls.mesh_hull(mesh, "the prism")
    assert "Too many neighbors" in cause and "From file" not in cause
    assert hull.num_points == 2 * n
    assert hull.computeVolume() == pytest.approx(ngon_area(n, radius) * height, rel=1e-9)  # outward triangles
    polygons = np.array([[hull.polygons(i)[k] for k in range(3)] for i in range(hull.num_polygons)])
    assert mesh_hulls.max_neighbours(polygons, hull.num_points) <= 8  # the fan gave one vertex 599
    ball = coal.Sphere(0.01)
    # closed forms: above the cap centre, and out along a vertex direction (vertex 0 is at (radius, 0, 0))
    for gap in (0.002, 0.03, 0.4):
        up = coal.Transform3s(np.eye(3), np.array([0.0, 0.0, height + 0.01 + gap]))
        side = coal.Transform3s(np.eye(3), np.array([radius + 0.01 + gap, 0.0, 0.5 * height]))
        assert distance(hull, ball, up) == pytest.approx(gap, abs=1e-6)
        assert distance(hull, ball, side) == pytest.approx(gap, abs=1e-6)
    inside = coal.Transform3s(np.eye(3), np.array([0.05, 0.02, 0.02]))
    request, result = coal.CollisionRequest(), coal.CollisionResult()
    assert coal.collide(hull, coal.Transform3s(), ball, inside, request, result)


def test_scipys_hull_answers_as_coals_own():
    V, T = prism(90, 0.08, 0.2)
    V = V + np.random.default_rng(3).normal(scale=1e-3, size=V.shape)  # not only flat facets
    own = bvh(V, T)
    own.buildConvexHull(True, "Qt")
    ours = mesh_hulls.qhull_convex(V)
    assert ours.num_points == own.convex.num_points
    assert ours.computeVolume() == pytest.approx(own.convex.computeVolume(), rel=1e-9)
    rng = np.random.default_rng(4)
    box = coal.Box(0.05, 0.02, 0.1)
    for _ in range(200):
        R = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        R *= np.sign(np.linalg.det(R))
        M = coal.Transform3s(R, rng.normal(scale=0.15, size=3))
        d_own, d_ours = distance(own.convex, box, M), distance(ours, box, M)
        assert d_ours == pytest.approx(d_own, abs=1e-6) or (d_own < 0 and d_ours < 0)


def test_a_flat_mesh_is_refused_by_name_without_asking_coal():
    V = np.random.default_rng(0).random((30, 3))
    V[:, 2] = 0.25  # coal's qhull would crash the process on these
    mesh = bvh(V, [[0, 1, 2]])
    with pytest.raises(errors.ModelError, match=r"the plate: no convex hull: nearly flat.*span no volume"):
        mesh_hulls.mesh_hull(mesh, "the plate")
    thin = V.copy()
    thin[:, 2] += np.random.default_rng(1).random(30) * 1e-9  # thin, not flat: scipy's qhull makes it
    hull, cause = mesh_hulls.mesh_hull(bvh(thin, [[0, 1, 2]]), "thin")
    assert "nearly flat" in cause and hull.computeVolume() > 0.0


def test_too_few_vertices_are_named():
    with pytest.raises(errors.ModelError, match="the tip has 3 vertices"):
        mesh_hulls.mesh_hull(bvh(np.eye(3), [[0, 1, 2]]), "the tip")


# ------------------------------------------------------------------ through the collision model
def _model_and_geometry(urdf: str):
    model = pin.buildModelFromXML(urdf)
    return model, pin.buildGeomFromUrdfString(model, urdf, pin.GeometryType.COLLISION)


def test_collision_model_names_its_fallback_meshes(tmp_path, monkeypatch):
    monkeypatch.setenv("KINSERVE_CACHE_DIR", str(tmp_path / "cache"))
    path = tmp_path / "fan.stl"
    write_stl(path, *prism(400, 0.1, 0.05))
    urdf = urdf_with_mesh(path)
    model, _ = _model_and_geometry(urdf)
    robot = Robot(model, name="meshy", source=urdf)
    cmodel = robot.collision
    (fallback,) = cmodel.hull_fallbacks
    assert fallback.link == "plate" and fallback.mesh_file == str(path)
    assert "Too many neighbors" in fallback.cause
    assert cmodel.hull_volume_ratio[fallback.geometry] == pytest.approx(1.0, abs=1e-9)  # a convex mesh
    # the plate (0.5 m up, radius 0.1) clears the 0.1 m box at every angle; its hull is what coal checks
    assert all(robot.in_collision([q]) is False for q in np.linspace(-3.0, 3.0, 13))
    # the plate spans z in [0.5, 0.55] at q = 0: a ball of radius 0.05 at z = 0.7 is 0.1 m above it
    assert robot.min_distance([0.0], [Sphere((0.0, 0.0, 0.7), 0.05)]) == pytest.approx(0.1, abs=1e-6)
    assert robot.in_collision([0.0], [Sphere((0.0, 0.0, 0.6), 0.06)]) is True


def test_collision_model_refuses_a_flat_mesh_naming_file_and_link(tmp_path, monkeypatch):
    monkeypatch.setenv("KINSERVE_CACHE_DIR", str(tmp_path / "cache"))
    path = tmp_path / "flat.stl"
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float) * 0.1
    write_stl(path, V, np.array([[0, 1, 2], [0, 2, 3]]))
    urdf = urdf_with_mesh(path)
    model, geometry = _model_and_geometry(urdf)
    with pytest.raises(errors.ModelError) as info:
        CollisionModel(model, geometry, model.lowerPositionLimit, model.upperPositionLimit, name="meshy")
    message = str(info.value)
    assert "link 'plate'" in message and str(path) in message and "span no volume" in message
    robot = Robot(model, name="meshy", source=urdf)
    with pytest.raises(errors.ModelError, match="link 'plate'"):
        robot.in_collision([0.0])
