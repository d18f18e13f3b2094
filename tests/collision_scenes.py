"""Shared scene of the collision tests: the issue's Panda table top and wall, pose helpers, obstacles near
the arm and coal's pair-by-pair answer."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from kinserve.kinematics.shapes import Box, Capsule, Cylinder, Mesh, Sphere


def pose(xyz, R=None) -> np.ndarray:
    """A 4x4 pose at ``xyz`` (rotation ``R``, default the identity)."""
    T = np.eye(4)
    T[:3, 3] = xyz
    if R is not None:
        T[:3, :3] = R
    return T


#: The issue's (and the benchmark's) Panda scene: a table top and a wall.
SCENE = [Box(pose((0.65, 0.0, -0.05)), (0.7, 1.2, 0.1)), Box(pose((0.0, -0.6, 0.5)), (1.5, 0.05, 1.0))]


def rotation(rng) -> np.ndarray:
    """A random rotation matrix (roll, pitch, yaw uniform in [-pi, pi])."""
    import pinocchio as pin

    return pin.rpy.rpyToMatrix(*rng.uniform(-np.pi, np.pi, 3))


def tilted_clutter() -> list:
    """A box, a capsule, a cylinder and a ball around the Panda, the box and the cylinder tilted: one obstacle
    of every kind the compiled distances measure."""
    import pinocchio as pin

    return [Box(pose((0.45, 0.1, 0.3), pin.rpy.rpyToMatrix(0.3, 0.2, 0.1)), (0.2, 0.1, 0.4)),
            Capsule((0.3, -0.4, 0.2), (0.5, -0.2, 0.7), 0.05),
            Cylinder(pose((-0.3, 0.35, 0.4), pin.rpy.rpyToMatrix(0.5, 0.0, 0.3)), 0.06, 0.5),
            Sphere((0.0, 0.5, 0.8), 0.1)]


def tetrahedron_file(tmp_path) -> Path:
    """A closed unit tetrahedron mesh (OBJ) in ``tmp_path``."""
    path = tmp_path / "tet.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
    return path


def near_obstacles(robot, q, rng, k, tmp_path) -> list:
    """``k`` spheres, boxes, capsules, cylinders and meshes (1-8 cm) centred near random vertices of the arm's
    collision shapes at ``q``: distances to the arm straddle zero around ``q``."""
    shapes = [s for s in robot.collision_geometry(q) if s["joint"] != 0]
    out = []
    for n in range(k):
        s = shapes[rng.integers(len(shapes))]
        local = s["vertices"][rng.integers(len(s["vertices"]))] if s["kind"] == "convex" else np.zeros(3)
        centre = (s["pose"] @ np.append(local, 1.0))[:3] + rng.normal(scale=0.04, size=3)
        size = rng.uniform(0.01, 0.08)
        R = rotation(rng)
        kind = n % 5
        if kind == 0:
            out.append(Sphere(centre, size))
        elif kind == 1:
            out.append(Box(pose(centre, R), rng.uniform(0.02, 0.12, 3)))
        elif kind == 2:
            out.append(Capsule(centre - R[:, 0] * size, centre + R[:, 0] * size, 0.5 * size))
        elif kind == 3:
            out.append(Cylinder(pose(centre, R), size, rng.uniform(0.02, 0.2)))
        else:
            out.append(Mesh(tetrahedron_file(tmp_path), pose(centre, R), scale=size))
    return out


def fresh_requests(gd):
    """``gd`` (a ``pinocchio.GeometryData``) with every collision request set as a fresh
    ``coal.CollisionRequest``: contact computation on, GJK from its default guess, no security margin.
    Pinocchio's defaults turn contacts off and the cached guess on; coal 3's GJK without contacts reports
    some overlapping hulls free (millimetres deep), and the cached guess makes near-contact answers depend
    on the calls before."""
    import warnings

    import coal

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # enable_cached_gjk_guess: deprecated, still read
        for req in gd.collisionRequests:
            req.security_margin = 0.0
            req.enable_contact = True
            req.gjk_initial_guess = coal.GJKInitialGuess.DefaultGuess
            req.enable_cached_gjk_guess = False
    return gd


def coal_hits(scene, Q) -> np.ndarray:
    """Per configuration of ``Q``: coal's answer pair by pair (no broad phase, no pre-check; fresh
    requests)."""
    import pinocchio as pin

    data, gd = scene.model.createData(), fresh_requests(pin.GeometryData(scene.geometry))
    return np.array([pin.computeCollisions(scene.model, data, scene.geometry, gd, q, True) for q in Q])


def scenes_near_the_arm(robot, rng, tmp_path, count: int = 3):
    """``count`` times ``(q_s, scene, precheck)``: a random configuration ``q_s`` and the scene of ``SCENE``
    plus five obstacles near the arm at ``q_s``."""
    for _ in range(count):
        q_s = robot.random_q(rng)
        scene = robot.collision_scene(SCENE + near_obstacles(robot, q_s, rng, 5, tmp_path))
        yield q_s, scene, scene.precheck()
