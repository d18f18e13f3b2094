"""S4 clearance: the smallest distance between the arm (and the carried cylinder) and the scene along the
motion.

The scene is a **table top** under the robot and the objects (top face at
``z = 0``, :data:`TABLE_CENTRE`, :data:`TABLE_SIZE`) and the **open box** (a
floor plate and four walls, :func:`box_plates`), all
:class:`kinserve.kinematics.shapes.Box` obstacles. The arm is the Panda's
collision model **without the hand and fingers** (the document's tool is the
flange, see :mod:`.pick_place`): the link hulls of ``panda_link0..7``.
Distances are coal's signed distances (m, negative = penetration) from
:meth:`Robot.distances`; the fixed base on the table is not a pair.

The carried cylinder (radius / height of :mod:`.pick_place`) is a coal cylinder
at its pose of each step between the grasp and the release; its distance to the
scene is reported over the steps strictly between the two (at the grasp it
stands on the table, at the release it is set on the box floor: contact, 0 m).
The grasp event fires at the first step within ``grasp_tolerance`` (1 mm) of
the grasp pose while the flange is still descending, so the carried cylinder
dips by up to that much into the table right after the grasp (measured:
-0.78 mm) - a property of the event model, reported as is.
"""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin

from kinserve.kinematics import se3
from kinserve.kinematics.shapes import Box, Cylinder

#: Table top under the robot and the objects (m): top face at z = 0.
TABLE_CENTRE = (0.35, 0.25, -0.025)
TABLE_SIZE = (1.3, 1.3, 0.05)
#: Links of the arm model used for the clearance (no hand, no fingers).
ARM_LINKS = tuple(f"panda_link{i}" for i in range(8))


def box_plates(centre, size: float, wall: float) -> list[Box]:
    """The open box as five boxes: floor plate and four walls (outer size ``size``, walls ``wall`` thick)."""
    c = np.asarray(centre, dtype=float)
    plates = [Box(se3.pose(p=c + [0, 0, -size / 2 + wall / 2]), (size, size, wall))]
    for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        sx, sy = (wall, size) if dx else (size, wall)
        plates.append(Box(se3.pose(p=c + [dx * (size - wall) / 2, dy * (size - wall) / 2, 0]),
                          (sx, sy, size)))
    return plates


def scene_obstacles(box_centre, box_size: float, box_wall: float) -> list[Box]:
    """The table top followed by the five plates of the open box."""
    return [Box(se3.pose(p=TABLE_CENTRE), TABLE_SIZE), *box_plates(box_centre, box_size, box_wall)]


def arm_only(robot):
    """A copy of ``robot`` whose collision model keeps the links in :data:`ARM_LINKS` only."""
    arm = robot.copy()
    gm = pin.GeometryModel()
    for g in robot.collision_model.geometryObjects:
        if robot.model.frames[g.parentFrame].name in ARM_LINKS:
            gm.addGeometryObject(g)
    arm.collision_model = gm
    arm._collision_holder = [None]  # its own collision model, not the full robot's
    return arm


def cylinder_distance(pose: np.ndarray, radius: float, height: float, obstacles) -> float:
    """Smallest coal distance (m; negative: penetration) of the cylinder of ``radius`` and ``height`` at
    ``pose`` (4x4, axis along its z) to ``obstacles``."""
    cyl = Cylinder(pose, radius, height)
    T = coal.Transform3s(pose[:3, :3], pose[:3, 3])
    req, res = coal.DistanceRequest(), coal.DistanceResult()
    best = np.inf
    for ob in obstacles:
        res.clear()
        d = coal.distance(cyl.geometry(), T, ob.geometry(),
                          coal.Transform3s(ob.pose[:3, :3], ob.pose[:3, 3]), req, res)
        best = min(best, d)
    return float(best)


def motion_clearance(robot, Q: np.ndarray, cylinder_poses: np.ndarray, grasp_step, release_step, *,
                     radius: float, height: float, box_centre, box_size: float, box_wall: float) -> dict:
    """Clearance figures of the motion ``Q`` (see the module docstring), JSON-ready."""
    obstacles = scene_obstacles(box_centre, box_size, box_wall)
    arm = arm_only(robot)
    per_step = np.empty(len(Q))
    pairs = []
    for k, q in enumerate(Q):
        dist = arm.distances(q, obstacles, self_collision=False)
        (a, b), d = min(dist.items(), key=lambda kv: kv[1].distance)
        per_step[k] = d.distance
        pairs.append((a, b))
    k_min = int(per_step.argmin())
    self_free = not any(robot.in_collision(q) for q in Q)
    out = {
        "scene_obstacles": [o.to_dict() for o in obstacles],
        "arm_links": list(ARM_LINKS),
        "min_arm_scene_distance": float(per_step[k_min]),
        "min_arm_scene_distance_step": k_min,
        "min_arm_scene_distance_pair": list(pairs[k_min]),
        "arm_scene_distance": per_step,
        "self_collision_free": bool(self_free),
    }
    if grasp_step is not None and release_step is not None and release_step - grasp_step > 1:
        carried = range(grasp_step + 1, release_step)
        dists = np.array([cylinder_distance(cylinder_poses[k], radius, height, obstacles) for k in carried])
        j = int(dists.argmin())
        out["min_cylinder_scene_distance"] = float(dists[j])
        out["min_cylinder_scene_distance_step"] = grasp_step + 1 + j
    else:
        out["min_cylinder_scene_distance"] = None
        out["min_cylinder_scene_distance_step"] = None
    return out
