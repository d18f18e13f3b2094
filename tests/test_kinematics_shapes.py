"""kinematics.shapes: closed-form signed distances against coal, validation, plain-data round trips."""

import pickle
import struct

import coal
import numpy as np
import pytest

from kinserve.kinematics.errors import InputError, ModelError, NonFiniteError, RotationError, ShapeError
from kinserve.kinematics.shapes import Box, Capsule, Cylinder, Mesh, Sphere, as_shape


def random_pose(rng):
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    Q *= np.sign(np.linalg.det(Q))
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = Q, rng.normal(size=3) * 0.3
    return T


@pytest.fixture
def ico_path(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    path = tmp_path / "ico.stl"
    trimesh.creation.icosphere(subdivisions=2, radius=0.2).export(path)
    return path


def shapes(rng, ico_path):
    return [Sphere([0.1, 0.2, 0.3], 0.2), Box(random_pose(rng), [0.3, 0.2, 0.5]),
            Capsule([0, 0, 0], [0.3, 0.1, 0.2], 0.1), Cylinder(random_pose(rng), 0.15, 0.4),
            Mesh(ico_path, random_pose(rng))]


def coal_distance(shape, point):
    """Distance from a point to the shape by coal's GJK (an independent code path)."""
    M = shape.placement()
    req, res = coal.DistanceRequest(), coal.DistanceResult()
    return coal.distance(coal.Sphere(1e-12), coal.Transform3s(np.eye(3), point), shape.geometry(),
                         coal.Transform3s(M.rotation, M.translation), req, res)


def test_outside_distances_equal_coal(rng, ico_path):
    for shape in shapes(rng, ico_path):
        pts = rng.normal(size=(150, 3)) * 0.7
        sd = shape.signed_distance(pts)
        outside = sd > 1e-6
        assert outside.sum() > 50
        ref = np.array([coal_distance(shape, p) for p in pts[outside]])
        if shape.kind == "mesh":  # face planes: a lower bound outside, never above the true distance
            assert np.all(sd[outside] <= ref + 1e-9)
            assert np.max(ref - sd[outside]) < 0.02
        else:
            np.testing.assert_allclose(sd[outside], ref, atol=1e-8)


def test_bounding_ball_contains_the_shape_and_is_tight(rng, ico_path):
    """Every point outside the ball is outside the shape (coal's signed distance), and the shape reaches
    close to the ball: the farthest inside point is at least 80 % of the radius from the centre."""
    for shape in shapes(rng, ico_path):
        c, r = shape.bounding_ball()
        pts = np.asarray(c) + rng.uniform(-2.0 * r, 2.0 * r, size=(20000, 3))
        far = np.linalg.norm(pts - c, axis=1)
        out = far > r
        assert out.sum() > 1000 and np.all(shape.signed_distance(pts[out]) > 0.0), shape.kind
        assert np.all([coal_distance(shape, p) > 0.0 for p in pts[out][:200]])
        inside = shape.signed_distance(pts) <= 0.0
        assert inside.sum() > 20 and far[inside].max() > 0.8 * r, shape.kind
    box = Box(random_pose(rng), [0.3, 0.2, 0.5])
    corner = box.pose[:3, :3] @ (0.5 * np.array([0.3, -0.2, 0.5])) + box.pose[:3, 3]
    # a corner is on it
    assert np.isclose(np.linalg.norm(corner - box.bounding_ball()[0]), box.bounding_ball()[1])


def test_inside_points_are_negative_and_depth_is_exact_for_primitives():
    box = Box(np.eye(4), [0.4, 0.2, 1.0])
    assert box.signed_distance([0.0, 0.0, 0.0])[0] == pytest.approx(-0.1)   # nearest face y = 0.1
    assert box.signed_distance([0.15, 0.05, 0.4])[0] == pytest.approx(-0.05)
    cyl = Cylinder(np.eye(4), 0.1, 1.0)
    assert cyl.signed_distance([0.02, 0.0, 0.48])[0] == pytest.approx(-0.02)
    cap = Capsule([0, 0, 0], [0, 0, 1], 0.1)
    assert cap.signed_distance([0.0, 0.0, 1.05])[0] == pytest.approx(-0.05)
    assert cap.signed_distance([0.0, 0.3, 0.5])[0] == pytest.approx(0.2)
    assert Sphere([1, 1, 1], 0.5).contains([[1, 1, 1.4], [1, 1, 1.6]]).tolist() == [True, False]


def test_round_trips_through_plain_data_and_pickle(rng, ico_path):
    for shape in shapes(rng, ico_path):
        again = as_shape(shape.to_dict())
        assert again == shape
        assert pickle.loads(pickle.dumps(shape)) == shape
        with pytest.raises(AttributeError):
            shape.pose = np.eye(4)


@pytest.mark.parametrize("make, err", [
    (lambda: Sphere([0, 0, 0], 0.0), InputError),
    (lambda: Sphere([0, 0, np.nan], 0.1), NonFiniteError),
    (lambda: Sphere([0, 0], 0.1), ShapeError),
    (lambda: Box(np.eye(4), [0.1, -0.2, 0.3]), InputError),
    (lambda: Box(np.diag([2.0, 1, 1, 1]), [0.1, 0.2, 0.3]), RotationError),
    (lambda: Capsule([0, 0, 0], [0, 0, 1], float("inf")), NonFiniteError),
    (lambda: Cylinder(np.eye(4), 0.1, 0.0), InputError),
    (lambda: Mesh("/nonexistent/file.stl"), InputError),
    (lambda: as_shape({"kind": "torus"}), InputError),
    (lambda: as_shape({"kind": "box", "pose": np.eye(4).tolist()}), InputError),
    (lambda: Sphere([0, 0, 0], 0.1, frames=[]), InputError),
])
def test_bad_shapes_are_named_errors(make, err):
    with pytest.raises(err):
        make()


def test_open_mesh_is_refused(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    box = trimesh.creation.box(extents=[0.1, 0.1, 0.1])
    open_box = trimesh.Trimesh(box.vertices, box.faces[:-2])  # two triangles missing: not closed
    path = tmp_path / "open.stl"
    open_box.export(path)
    with pytest.raises(ModelError, match="closed surface"):
        Mesh(path)


def test_hash_is_of_the_plain_data_computed_once_and_not_pickled():
    a = Box(np.eye(4), (0.1, 0.2, 0.3))
    b = Box(np.eye(4), (0.1, 0.2, 0.3))
    c = Box(np.eye(4), (0.1, 0.2, 0.31))
    assert hash(a) == hash(b) and a == b
    assert hash(a) != hash(c) and a != c
    signed_zero = np.eye(4)
    signed_zero[0, 1] = -0.0  # == 0.0: equal shapes, so equal hashes
    assert Box(signed_zero, (0.1, 0.2, 0.3)) == a and hash(Box(signed_zero, (0.1, 0.2, 0.3))) == hash(a)
    assert hash(Cylinder(np.eye(4), 0.1, 0.2)) != hash(Box(np.eye(4), (0.1, 0.2, 0.2)))
    assert a._hash == hash(a)  # computed with the shape, as are its coal geometry and ball
    assert a._ball == struct.pack("4d", *a.bounding_ball()[0], a.bounding_ball()[1])
    assert not hasattr(a, "_geometry")  # a primitive holds no coal object: each geometry() is a new one
    assert not hasattr(a, "__dict__")  # every field in a slot: one block of memory per shape
    g1, g2 = a.geometry(), a.geometry()
    assert g1 is not g2 and np.allclose(g1.halfSide, [0.05, 0.1, 0.15])
    assert np.allclose(g2.halfSide, g1.halfSide)
    assert "_hash" not in a.__getstate__()  # str hashes differ between processes
    clone = pickle.loads(pickle.dumps(a))
    assert clone._hash == hash(a) and clone == a  # computed again when unpickled
    assert isinstance(clone.geometry(), type(a.geometry())) and clone.bounding_ball() == a.bounding_ball()
    assert {a: 1}[b] == 1


def test_equality_is_the_plain_data_equality(rng, ico_path):
    """``==`` compares one bytes object made with the shape; it answers as comparing ``to_dict()`` does, on
    equal copies, on shapes of other kinds, and on copies with one number changed (sizes, poses, frames), or
    two numbers traded between fields."""
    originals = shapes(rng, ico_path)
    copies = [type(s)(**{k: v for k, v in s.to_dict().items() if k != "kind"}) for s in originals]
    T = random_pose(rng)
    changed = [Sphere([0.1, 0.2, 0.3], 0.2000001), Box(originals[1].pose, [0.3, 0.2, 0.5000001]),
               Capsule([0, 0, 0], [0.3, 0.1, 0.2], 0.1, frames=["tool"]), Cylinder(T, 0.15, 0.4),
               Mesh(ico_path, T), Cylinder(T, 0.4, 0.15), Cylinder(T, 0.15, 0.4, frames=["a", "b"]),
               Cylinder(T, 0.15, 0.4, frames=["a, b"])]
    everything = originals + copies + changed
    for x in everything:
        for y in everything:
            assert (x == y) == (type(x) is type(y) and x.to_dict() == y.to_dict()), (x, y)
    assert all(a == b and hash(a) == hash(b) and a is not b for a, b in zip(originals, copies))
    assert not any(a == b for a, b in zip(originals, changed))
    assert len({changed[3], changed[5], changed[6], changed[7]}) == 4


def test_pose_arrays_are_read_only(rng, ico_path):
    """A shape's arrays cannot be changed in place (its hash, its obstacle row and the scenes built from
    them depend on them)."""
    for shape in shapes(rng, ico_path):
        with pytest.raises(ValueError):
            shape.pose[0, 3] = 1.0
    T = np.eye(4)
    box = Box(T, [0.1, 0.1, 0.1])
    T[0, 3] = 5.0  # the caller's array stays the caller's
    assert box.pose[0, 3] == 0.0


def test_obstacle_rows_and_signatures_are_made_with_the_shape(rng, ico_path):
    """Each shape's pre-check row (made with the shape) holds its rotation row-major, its centre and its
    sizes, written here from the constructor's arguments; the mesh's row is a ball (not exact) that contains
    every hull vertex. Signatures: kind and sizes, not the pose; a mesh is its own. Both survive pickling and
    the row is read-only."""
    from kinserve.kinematics.obstacle_table import BALL, BOX, CAPSULE, CYLINDER, EXACT, KIND

    sphere, box, capsule, cylinder, mesh = shapes(rng, ico_path)
    expected = {
        id(sphere): (np.eye(3), [0.1, 0.2, 0.3], BALL, [0.2, 1.0, 0.0]),
        id(box): (box.pose[:3, :3], box.pose[:3, 3], BOX, [0.15, 0.1, 0.25]),
        id(cylinder): (cylinder.pose[:3, :3], cylinder.pose[:3, 3], CYLINDER, [0.15, 0.2, 0.0]),
    }
    for shape in (sphere, box, cylinder):
        R, t, kind, sizes = expected[id(shape)]
        row = shape.obstacle_row
        assert row.shape == (16,) and not row.flags.writeable
        np.testing.assert_allclose(row[:9], np.asarray(R).ravel(), atol=1e-15)
        np.testing.assert_allclose(row[9:12], t, atol=1e-15)
        assert row[KIND] == kind
        np.testing.assert_allclose(row[13:16], sizes, atol=1e-15)
    row = capsule.obstacle_row
    axis = np.array([0.3, 0.1, 0.2])
    assert row[KIND] == CAPSULE and row[13] == 0.1 and row[14] == pytest.approx(0.5 * np.linalg.norm(axis))
    np.testing.assert_allclose(row[9:12], 0.5 * axis, atol=1e-15)
    np.testing.assert_allclose(row[:9].reshape(3, 3)[:, 2], axis / np.linalg.norm(axis), atol=1e-12)
    row = mesh.obstacle_row
    assert row[KIND] == BALL and row[EXACT] == 0.0
    world = mesh.hull_vertices @ mesh.pose[:3, :3].T + mesh.pose[:3, 3]
    assert np.linalg.norm(world - row[9:12], axis=1).max() <= row[13]
    moved = Box(random_pose(rng), box.size)
    assert moved.signature == box.signature == ("box", (0.3, 0.2, 0.5))
    assert Box(box.pose, (0.3, 0.2, 0.51)).signature != box.signature
    assert Mesh(ico_path).signature != Mesh(ico_path).signature  # its file may change: the object itself
    assert cylinder.signature == ("cylinder", 0.15, 0.4) and sphere.signature == ("sphere", 0.2)
    # the bytes form: equal exactly when the signatures are
    assert moved.signature_key == box.signature_key
    assert Box(box.pose, (0.3, 0.2, 0.5 + 1e-12)).signature_key != box.signature_key
    assert Mesh(ico_path).signature_key != Mesh(ico_path).signature_key
    assert Box(box.pose, (0.2, 0.3, 0.5)).signature_key != box.signature_key != sphere.signature_key
    clone = pickle.loads(pickle.dumps(box))
    assert "obstacle_row" not in box.__getstate__() and "signature_key" not in box.__getstate__()
    assert clone.signature == box.signature and np.array_equal(clone.obstacle_row, box.obstacle_row)
    assert clone.signature_key == box.signature_key
