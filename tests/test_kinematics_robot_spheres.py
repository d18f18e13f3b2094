"""The robot's sphere model (kinematics.robot_spheres) against Pinocchio and coal.

* models with other joints than one-DoF revolute / prismatic ones have none;
* every geometry of the Panda and the UR5 (hulls, boxes) lies in its cover spheres and in its bounding
  sphere, placed in its joint frame; its inner points lie inside it;
* the joint reach bounds every sphere centre's displacement and is not vacuous;
* the sphere model is built with the collision model, and with it the compiled pre-check is loaded.
"""

import subprocess
import sys

import coal
import numpy as np
import pinocchio as pin
import pytest

from kinserve import robots
from kinserve.kinematics import precheck_kernels as pk
from kinserve.kinematics import sphere_cover as sc
from kinserve.kinematics.robot_spheres import UNBOUNDED_REACH, RobotSpheres, robot_spheres
from kinserve.kinematics.serial_chain import kinematic_tree, serial_chain


@pytest.mark.parametrize("joint", [pin.JointModelFreeFlyer(), pin.JointModelRUBZ(),
                                   pin.JointModelSphericalZYX(), pin.JointModelPlanar()])
def test_models_with_other_joints_are_not_packed(joint):
    """A tree with any joint other than a one-DoF revolute / prismatic one has no packing, wherever it is;
    the chain to a frame that avoids it still packs when the sizes allow (serial_chain unchanged)."""
    model = pin.Model()
    a = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "a")
    b = model.addJoint(a, joint, pin.SE3(np.eye(3), np.array([0.0, 0.3, 0.0])), "b")
    model.addJointFrame(a)
    model.addJointFrame(b)
    assert kinematic_tree(model) is None
    if model.nq == model.nv:  # (serial_chain refuses any model whose q and v sizes differ)
        assert serial_chain(model, model.getFrameId("a")) is not None
    gm = pin.GeometryModel()
    gm.addGeometryObject(pin.GeometryObject("ball", a, pin.SE3.Identity(), coal.Sphere(0.1)))
    assert robot_spheres(model, gm) is None


def _contained(points, spheres):
    """Per point, True when some sphere ``(centre, radius)`` of ``spheres`` holds it."""
    d2 = ((points[:, None, :] - spheres[None, :, :3]) ** 2).sum(axis=2)
    return (d2 <= spheres[None, :, 3] ** 2).any(axis=1)


def _hull_samples(V, triangles, rng, n=3000):
    """Vertices, points on the hull's faces and edges, and points inside (convex combinations)."""
    T = V[triangles]
    w = rng.dirichlet(np.ones(3), size=n)
    faces = np.einsum("nk,nkd->nd", w, T[rng.integers(len(T), size=n)])
    t = rng.uniform(size=(n, 1))
    tri = T[rng.integers(len(T), size=n)]
    edges = tri[:, 0] + t * (tri[:, 1] - tri[:, 0])
    inside = rng.dirichlet(np.ones(4), size=n) @ V[rng.integers(len(V), size=4)]
    return np.concatenate([V, faces, edges, inside])


@pytest.mark.parametrize("name", ["panda", "ur5"])
def test_robot_covers_contain_their_geometry(name):
    """Every point of every robot geometry (hulls: vertices, face and edge points, interior points; boxes:
    corners and random points), placed in its joint frame, lies in one of its cover spheres and in its
    bounding sphere; the long links get spheres far tighter than their bounding sphere."""
    robot = robots.load(name)
    spheres = robot.collision.spheres
    assert isinstance(spheres, RobotSpheres) and robot.collision.robot_geometry.spheres is spheres
    rng = np.random.default_rng(4)
    kinds = set()
    for g, obj in enumerate(robot.collision.geometry.geometryObjects):
        geo = obj.geometry
        kinds.add(type(geo).__name__)
        if isinstance(geo, coal.Convex):
            V = np.asarray(geo.points())
            tris = np.array([[geo.polygons(i)[k] for k in range(3)] for i in range(geo.num_polygons)])
            local = _hull_samples(V, tris, rng)
        else:
            h = np.asarray(geo.halfSide)
            corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * h
            local = np.concatenate([corners, rng.uniform(-h, h, size=(500, 3))])
        points = local @ obj.placement.rotation.T + obj.placement.translation
        joint, first, end = spheres.geoms[g]
        assert joint == obj.parentJoint
        assert _contained(points, spheres.spheres[first:end]).all(), obj.name
        assert _contained(points, spheres.spheres[g:g + 1]).all(), obj.name
    assert "Convex" in kinds
    if name == "panda":
        link5 = robot.collision.links.index("panda_link5")
        joint, first, end = spheres.geoms[link5]
        assert end - first >= 3
        assert spheres.spheres[first:end, 3].max() < 0.6 * spheres.spheres[link5, 3]


@pytest.mark.parametrize("name", ["panda", "ur5"])
def test_inner_points_lie_inside_their_geometry(name):
    """Every inner point of every robot geometry is inside it by coal's signed distance (a point sphere at it:
    negative distance), in the geometry's frame, and in the joint frame where the packed table has it."""
    robot = robots.load(name)
    spheres = robot.collision.spheres
    req, res = coal.DistanceRequest(), coal.DistanceResult()
    point = coal.Sphere(1e-9)
    total = 0
    for g, obj in enumerate(robot.collision.geometry.geometryObjects):
        local = sc.geometry_inner_points(obj.geometry)
        first, end = spheres.inner_ranges[g]
        placed = local @ obj.placement.rotation.T + obj.placement.translation
        assert np.allclose(spheres.inner[first:end], placed, atol=1e-12)
        for p in local:
            res.clear()
            d = coal.distance(obj.geometry, coal.Transform3s(np.eye(3), np.zeros(3)), point,
                              coal.Transform3s(np.eye(3), p), req, res)
            assert d < 0.0, (obj.name, p, d)
        total += len(local)
    assert total >= len(robot.collision.geometry.geometryObjects)


def _world_centres(spheres, q) -> np.ndarray:
    """Every sphere centre of ``spheres`` (a RobotSpheres) in the world at ``q``: the packed tree's forward
    kinematics, then ``oMj * c`` per sphere."""
    X = np.empty((len(spheres.joints) + 1, 12))
    pk.tree_placements(spheres.tree, spheres.joints, q, X)
    out = []
    for g, (row, first, end) in enumerate(spheres.geoms):
        for s in (g, *range(first, end)):
            R, t = X[row, :9].reshape(3, 3), X[row, 9:12]
            out.append(t + R @ spheres.spheres[s, :3])
    return np.array(out)


@pytest.mark.parametrize("name", ["panda", "ur5", "scara", "pr"])
def test_joint_reach_bounds_every_sphere_displacement(name):
    """``sum_k R_k |dq_k|`` bounds how far any sphere centre moves from ``q`` to ``q + dq``, for steps from a
    microradian to the whole joint range, one joint or all at once; and the bound of a typical revolute joint
    is within a factor of ~5 of the largest displacement seen (not vacuous)."""
    robot = robots.load(name)
    spheres = robot.collision.spheres
    assert spheres is not None and spheres.reach.shape == (len(spheres.joints),)
    assert np.all(spheres.reach >= 0.0) and np.all(spheres.reach < UNBOUNDED_REACH)  # 0: nothing below
    rng = np.random.default_rng(11)
    idx = spheres.joints[:, 1]
    ratio = np.zeros(len(idx))
    for _ in range(300):
        q = robot.random_q(rng)
        scale = 10.0 ** rng.uniform(-6, 0)
        if rng.random() < 0.5:  # one joint
            k = rng.integers(len(idx))
            q2 = q.copy()
            q2[idx[k]] = rng.uniform(robot.lower[idx[k]], robot.upper[idx[k]])
        else:
            q2 = np.clip(q + scale * rng.normal(size=robot.nq), robot.lower, robot.upper)
        moved = np.linalg.norm(_world_centres(spheres, q2) - _world_centres(spheres, q), axis=1).max()
        bound = float(np.sum(spheres.reach * np.abs(q2[idx] - q[idx])))
        assert moved <= bound * (1 + 1e-9) + 1e-12
        if rng.random() < 0.5:
            continue
        for k in range(len(idx)):  # a small turn of joint k alone: the tightness of its bound
            q3 = q.copy()
            q3[idx[k]] = min(q[idx[k]] + 1e-3, robot.upper[idx[k]])
            step = q3[idx[k]] - q[idx[k]]
            if step > 0 and spheres.reach[k] > 0.0:
                moved = np.linalg.norm(_world_centres(spheres, q3) - _world_centres(spheres, q), axis=1).max()
                ratio[k] = max(ratio[k], moved / (spheres.reach[k] * step))
    revolute = spheres.joints[:, 0] == 0
    # a wrist's spheres may sit on its axis (the bound counts their distance to the joint's origin): the
    # typical joint, not every one
    moving = revolute & (spheres.reach > 0.0)
    assert np.median(ratio[moving]) > 0.2 and ratio[moving][0] > 0.2, ratio


def test_the_sphere_model_and_the_compiled_precheck_come_with_the_collision_model():
    """In a fresh interpreter, building a robot's collision model builds its sphere model and loads the
    compiled pre-check (the kernels of every scene of the model), and no scene query imports anything."""
    code = (
        "import sys\n"
        "from kinserve import robots\n"
        "robot = robots.load('ur5')\n"
        "cm = robot.collision\n"
        "print('kinserve.kinematics.precheck_kernels' in sys.modules, cm.spheres is not None)\n"
        "loaded = set(sys.modules)\n"
        "scene = robot.collision_scene([])\n"
        "print(scene.precheck() is not None, scene.first_collision(robot.random_q(0, 5)) >= -1)\n"
        "print(sorted(set(sys.modules) - loaded))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.split() == ["True", "True", "True", "True", "[]"]


@pytest.mark.parametrize("name", ["panda", "pr"])
def test_sphere_reach_bounds_each_sphere_displacement(name):
    """``sum_k R[s, k] |dq_k|`` bounds how far sphere ``s``'s centre moves from ``q`` to ``q + dq`` (each
    sphere against its own bound, not the largest one); ``reach`` is the largest entry of each column; the
    joints that do not carry a geometry have zero rates for its spheres, and ``carrying`` says which those
    are; ``geometry_reach`` is the largest rate over each geometry's spheres."""
    robot = robots.load(name)
    spheres = robot.collision.spheres
    R = spheres.sphere_reach
    G = len(spheres.geoms)
    assert R.shape == (len(spheres.spheres), len(spheres.joints))
    assert np.allclose(spheres.reach, R.max(axis=0))
    for g in range(G):
        rows = [g, *range(int(spheres.geoms[g, 1]), int(spheres.geoms[g, 2]))]
        assert np.all(R[np.ix_(rows, np.flatnonzero(~spheres.carrying[g]))] == 0.0)
        assert np.array_equal(spheres.geometry_reach[g], R[rows].max(axis=0))
    idx = spheres.joints[:, 1]
    rng = np.random.default_rng(17)
    for _ in range(200):
        q = robot.random_q(rng)
        q2 = np.clip(q + 10.0 ** rng.uniform(-6, 0) * rng.normal(size=robot.nq), robot.lower, robot.upper)
        moved = np.linalg.norm(_world_centres(spheres, q2) - _world_centres(spheres, q), axis=1)
        order = [s for g in range(G) for s in (g, *range(int(spheres.geoms[g, 1]), int(spheres.geoms[g, 2])))]
        bound = R[order] @ np.abs(q2[idx] - q[idx])
        assert np.all(moved <= bound * (1 + 1e-9) + 1e-12)
