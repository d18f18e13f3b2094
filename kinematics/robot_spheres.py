"""The robot's sphere model: spheres fixed in the joint frames that contain every collision geometry.

:func:`robot_spheres` places the spheres of :mod:`.sphere_cover` (bounding sphere,
cover spheres and inner points of each geometry, in the geometry's frame) in the
frame of the joint that carries the geometry (``c_joint = M_geometry c``), beside
the robot's whole kinematic tree (:func:`~.serial_chain.kinematic_tree`), and
bounds how far a change of each joint coordinate moves any sphere centre
(:func:`sphere_reach`). Built once per collision model
(:class:`~.collision_model.CollisionModel`); the compiled pre-check
(:mod:`.precheck_kernels`) moves the spheres to the world with the tree's forward
kinematics.

Units: metres and radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from .serial_chain import REVOLUTE, kinematic_tree
from .sphere_cover import GeometrySpheres, geometry_spheres

#: Stands for an unbounded reach (a prismatic joint without limits below a revolute one): finite, so that a
#: zero change of that joint's coordinate still contributes zero.
UNBOUNDED_REACH = 1e30


@dataclass(frozen=True)
class RobotSpheres:
    """The robot half of the pre-check: its kinematic tree and the spheres of every geometry.

    * ``tree``, ``joints``: :func:`~.serial_chain.kinematic_tree`;
    * ``spheres`` ``(G + S, 4)``: centre in the geometry's joint frame and radius (m); row ``g < G`` is
      geometry ``g``'s bounding sphere, the cover spheres follow;
    * ``geoms`` ``(G, 3)`` integers: the geometry's Pinocchio joint (0 = fixed in the world), first and
      end row of its cover spheres in ``spheres``;
    * ``inner`` ``(I, 3)``: points inside the geometries (:func:`~.sphere_cover.geometry_inner_points`) in
      their joint frames, ``inner_ranges`` ``(G, 2)`` the first and end row of each geometry's;
    * ``reach`` ``(J,)``: per joint, a bound (m per unit of the joint's coordinate) of how far a change of
      that coordinate moves any sphere centre: the largest entry of each column of ``sphere_reach``;
    * ``sphere_reach`` ``(G + S, J)``: the same bound per sphere row (:func:`sphere_reach`);
    * ``geometry_reach`` ``(G, J)``: the same bound per geometry, over its spheres
      (:func:`reach_per_geometry`);
    * ``carrying`` ``(G, J)`` booleans: the joints whose motion moves each geometry
      (:func:`carrying_joints`).
    """

    tree: np.ndarray
    joints: np.ndarray
    spheres: np.ndarray
    geoms: np.ndarray
    inner: np.ndarray
    inner_ranges: np.ndarray
    reach: np.ndarray
    sphere_reach: np.ndarray
    geometry_reach: np.ndarray
    carrying: np.ndarray


def sphere_reach(tree: np.ndarray, joints: np.ndarray, spheres: np.ndarray, geoms: np.ndarray,
                 lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """``R`` ``(S, J)`` for the sphere rows ``spheres`` ``(S, 4)`` of the geometries ``geoms``: changing joint
    ``k``'s coordinate by ``dq`` moves the centre of sphere ``s`` no farther than ``R[s, k] |dq|`` (m),
    whatever the other coordinates; so ``sum_k R[s, k] |q'_k - q_k|`` bounds its displacement between ``q``
    and ``q'`` (change the coordinates one at a time: triangle inequality).

    Revolute ``k``: the centre turns about the joint's axis, which passes through the joint's origin, along
    an arc of radius at most its distance to that origin, itself at most the centre's offset in its own
    joint frame plus the offsets ``|t_m|`` of the joints ``m`` on the path down to that frame (plus the
    largest travel ``max(|lower|, |upper|)`` of a prismatic joint on it; :data:`UNBOUNDED_REACH` without
    limits). Prismatic ``k``: everything below translates by exactly ``|dq|``: ``R[s, k] = 1``. Joints that
    do not carry the sphere: 0. ``lower``, ``upper``: the model's limits, indexed by the joints'
    configuration index (``joints[:, 1]``).
    """
    reach = np.zeros((len(spheres), len(joints)))
    for g in range(len(geoms)):
        row = int(geoms[g, 0])  # the geometry's joint (placement row; 0 = the world)
        rows = np.array([g, *range(int(geoms[g, 1]), int(geoms[g, 2]))])
        offset = np.linalg.norm(spheres[rows, :3], axis=1)
        while row > 0:
            k = row - 1
            if joints[k, 0] != REVOLUTE:
                reach[rows, k] = 1.0
                travel = max(abs(float(lower[joints[k, 1]])), abs(float(upper[joints[k, 1]])))
                offset = offset + (travel if math.isfinite(travel) else UNBOUNDED_REACH)
            else:
                reach[rows, k] = offset
            offset = offset + float(np.linalg.norm(tree[k, 9:12]))
            row = int(joints[k, 2])
    return np.minimum(reach, UNBOUNDED_REACH)


def reach_per_geometry(reach: np.ndarray, geoms: np.ndarray) -> np.ndarray:
    """``(G, J)``: per geometry of ``geoms``, the largest :func:`sphere_reach` ``reach`` ``(S, J)`` over its
    bounding sphere's and cover spheres' rows: no centre of the geometry's spheres moves farther than
    ``sum_k R[g, k] |dq_k|``."""
    out = np.zeros((len(geoms), reach.shape[1]))
    for g in range(len(geoms)):
        out[g] = reach[[g, *range(int(geoms[g, 1]), int(geoms[g, 2]))]].max(axis=0)
    return out


def carrying_joints(joints: np.ndarray, geoms: np.ndarray) -> np.ndarray:
    """Boolean ``(G, J)``: the joints (tree rows) on the path from each geometry's joint to the root, those
    whose motion moves the geometry."""
    carrying = np.zeros((len(geoms), len(joints)), dtype=bool)
    for g in range(len(geoms)):
        row = int(geoms[g, 0])
        while row > 0:
            carrying[g, row - 1] = True
            row = int(joints[row - 1, 2])
    return carrying


def _moved(spheres: np.ndarray, placement: pin.SE3) -> np.ndarray:
    """Spheres ``(n, 4)`` moved by ``placement`` (centres; radii unchanged)."""
    out = spheres.copy()
    out[:, :3] = spheres[:, :3] @ placement.rotation.T + placement.translation
    return out


def _ranges(counts: list[int], start: int = 0) -> np.ndarray:
    """``(G, 2)`` first and end rows of consecutive blocks of ``counts`` rows from row ``start``."""
    ends = start + np.cumsum(np.asarray(counts, dtype=np.int64), dtype=np.int64)
    return np.column_stack([ends - np.asarray(counts, dtype=np.int64), ends]).reshape(-1, 2)


def robot_spheres(model: pin.Model, geometry: pin.GeometryModel,
                  covers: list[GeometrySpheres] | None = None) -> RobotSpheres | None:
    """The :class:`RobotSpheres` of a model and its collision ``GeometryModel``; None when the tree has other
    joints than one-DoF revolute / prismatic ones or a cover is not finite (e.g. a half-space).

    ``covers``: the :func:`~.sphere_cover.geometry_spheres` of each geometry when the caller has them.
    """
    packed = kinematic_tree(model)
    if packed is None:
        return None
    objects = list(geometry.geometryObjects)
    covers = [geometry_spheres(g.geometry) for g in objects] if covers is None else covers
    G = len(objects)
    bounds = [_moved(c.bounding[None, :], g.placement)[0] for g, c in zip(objects, covers)]
    moved = [_moved(c.cover, g.placement) for g, c in zip(objects, covers)]
    spheres = np.concatenate([np.array(bounds).reshape(-1, 4), *moved]) if G else np.zeros((0, 4))
    inner = [c.inner @ g.placement.rotation.T + g.placement.translation if len(c.inner) else c.inner
             for g, c in zip(objects, covers)]
    points = np.concatenate(inner).reshape(-1, 3) if G else np.zeros((0, 3))
    if not (np.all(np.isfinite(spheres)) and np.all(np.isfinite(points))):
        return None
    joints = np.array([int(g.parentJoint) for g in objects], dtype=np.int64).reshape(-1, 1)
    geoms = np.column_stack([joints, _ranges([len(c) for c in moved], G)]) if G else np.zeros((0, 3), int)
    tree, tree_joints = packed
    rows = sphere_reach(tree, tree_joints, spheres, geoms, model.lowerPositionLimit, model.upperPositionLimit)
    per_geometry = reach_per_geometry(rows, geoms)
    reach = per_geometry.max(axis=0) if G else np.zeros(len(tree_joints))
    inner_ranges = _ranges([len(p) for p in inner])
    return RobotSpheres(tree, tree_joints, np.ascontiguousarray(spheres), np.ascontiguousarray(geoms),
                        np.ascontiguousarray(points), np.ascontiguousarray(inner_ranges), reach,
                        np.ascontiguousarray(rows), per_geometry, carrying_joints(tree_joints, geoms))


__all__ = ["UNBOUNDED_REACH", "RobotSpheres", "carrying_joints", "reach_per_geometry", "robot_spheres",
           "sphere_reach"]
