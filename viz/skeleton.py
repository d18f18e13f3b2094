"""A stick-figure visual model for robots that ship no visual geometry.

For every joint ``j`` with parent ``p`` the skeleton has a cylinder from the
origin of ``p`` to the origin of ``j`` (the translation of Pinocchio's
``jointPlacements[j]``, expressed in ``p``'s frame and attached to ``p``) and
a sphere at the origin of ``j``; each frame named in ``frames`` (the tool)
gets a segment from its parent joint and a small sphere. Coal primitives are
used, so Pinocchio's meshcat visualizer draws the skeleton like any URDF
``<cylinder>``/``<sphere>``.
"""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin

#: Segments shorter than this (m) are not drawn (coincident joint origins).
MIN_SEGMENT = 1e-6


def _segment(name: str, parent_joint: int, start: np.ndarray, end: np.ndarray,
             radius: float, color) -> pin.GeometryObject | None:
    """Cylinder from ``start`` to ``end`` (both in the parent joint frame), or None if degenerate."""
    d = np.asarray(end, dtype=float) - np.asarray(start, dtype=float)
    length = float(np.linalg.norm(d))
    if length < MIN_SEGMENT:
        return None
    R = pin.Quaternion.FromTwoVectors(np.array([0.0, 0.0, 1.0]), d / length).toRotationMatrix()
    placement = pin.SE3(R, 0.5 * (np.asarray(start, dtype=float) + np.asarray(end, dtype=float)))
    geom = pin.GeometryObject(name, parent_joint, placement, coal.Cylinder(radius, length))
    geom.meshColor = np.asarray(color, dtype=float)
    return geom


def _ball(name: str, parent_joint: int, center: np.ndarray, radius: float, color) -> pin.GeometryObject:
    geom = pin.GeometryObject(name, parent_joint, pin.SE3(np.eye(3), np.asarray(center, dtype=float)),
                              coal.Sphere(radius))
    geom.meshColor = np.asarray(color, dtype=float)
    return geom


def skeleton_geometry(
    model: pin.Model,
    frames=(),
    radius: float = 0.02,
    link_color=(0.55, 0.6, 0.68, 1.0),
    joint_color=(0.9, 0.55, 0.1, 1.0),
) -> pin.GeometryModel:
    """A ``pinocchio.GeometryModel`` of cylinders (links) and spheres (joints).

    ``radius`` is the link radius in metres (joint spheres are 1.6x larger);
    ``frames`` names extra frames (e.g. the tool) to connect to their parent joint.
    """
    gm = pin.GeometryModel()
    for j in range(1, model.njoints):
        parent = model.parents[j]
        tip = model.jointPlacements[j].translation
        seg = _segment(f"skeleton_link_{model.names[j]}", parent, np.zeros(3), tip, radius, link_color)
        if seg is not None:
            gm.addGeometryObject(seg)
        gm.addGeometryObject(_ball(f"skeleton_joint_{model.names[j]}", j, np.zeros(3),
                                   1.6 * radius, joint_color))
    for fname in frames:
        fid = model.getFrameId(fname)
        if fid >= model.nframes:
            continue
        frame = model.frames[fid]
        p = frame.placement.translation
        seg = _segment(f"skeleton_tool_{fname}", frame.parentJoint, np.zeros(3), p, 0.6 * radius, link_color)
        if seg is not None:
            gm.addGeometryObject(seg)
        gm.addGeometryObject(_ball(f"skeleton_tip_{fname}", frame.parentJoint, p, 1.2 * radius, joint_color))
    return gm
