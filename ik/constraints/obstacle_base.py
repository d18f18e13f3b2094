"""Obstacles that contain the robot's base: a bind-time error, not a problem to solve.

The segments fixed to the world (:attr:`.robot_skeleton.RobotSkeleton.base`) cannot move, so an
obstacle (kept clear of the default segments) whose distance to one of them is below the link radius
``rho`` makes every configuration infeasible. The test, cheapest first:

1. the obstacle's bounding ball (:meth:`~kinserve.kinematics.shapes.Shape.bounding_ball`, made with the
   shape) against the ball enclosing the base: farther than the sum of the radii plus ``rho`` - clear;
2. the same ball against each base segment (point-segment distance): farther than its radius plus ``rho`` -
   that segment is clear; for a sphere this is the exact test;
3. a box: every remaining base segment separated from the box grown by ``rho`` (the separating-axis test
   :func:`.clearance_kernel.separated`, in the box's frame ``R^T (x - t)``) - clear;
4. the distance of every remaining base segment: closed form for a capsule (segment-segment); the shape's
   own signed distance at 33 points of the segment otherwise.

A distance below ``rho`` raises :class:`~kinserve.kinematics.errors.InputError` naming the obstacle
and the first base segment it reaches.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from kinserve.ik.constraints.robot_skeleton import Ball, BaseSegment
from kinserve.ik.constraints.segment_distance import segment_segment
from kinserve.kinematics.errors import InputError
from kinserve.kinematics.shapes import Box, Capsule, Shape, Sphere


def check_base(index: int, obstacle: Shape, base: Sequence[BaseSegment], ball: Ball | None,
               link_radius: float) -> None:
    """Raise :class:`InputError` when ``obstacle`` (``obstacles[index]``) comes closer than ``link_radius``
    (m) to a segment of ``base`` (enclosed by ``ball``); module docstring."""
    if not base:
        return
    (ox, oy, oz), rad = obstacle.bounding_ball()
    (cx, cy, cz), R = ball
    if math.sqrt((ox - cx) ** 2 + (oy - cy) ** 2 + (oz - cz) ** 2) > R + rad + link_radius:
        return
    o = (ox, oy, oz)
    near = [s for s in base if point_segment_distance(s.a, s.b, o) - rad < link_radius]
    if not near or isinstance(obstacle, Box) and _box_clear_of(obstacle, near, link_radius):
        return
    if isinstance(obstacle, Sphere):  # the bounding ball is the sphere: the test above is the closed form
        reached = [s.name for s in near]
    else:
        reached = [near[i].name for i in np.flatnonzero(base_distances(obstacle, near) < link_radius)]
    if reached:
        raise InputError(f"obstacles[{index}] ({obstacle!r}) contains the robot base ({reached[0]}); "
                         "the base cannot move out of it")


def _box_clear_of(box: Box, base: Sequence[BaseSegment], link_radius: float) -> bool:
    """True when every base segment is separated from ``box`` grown by ``link_radius`` (separating axes)."""
    from kinserve.ik.constraints.clearance_kernel import separated  # (Numba: loaded when the box needs it)

    R, t = box.pose[:3, :3], box.pose[:3, 3]
    h = box.half_extents
    return all(separated((np.asarray(s.a) - t) @ R, (np.asarray(s.b) - t) @ R, h, link_radius) for s in base)


def base_distances(obstacle: Shape, base: Sequence[BaseSegment]) -> np.ndarray:
    """Distance (m) from ``obstacle`` to each segment of ``base`` (negative inside; sampled for a box,
    cylinder or mesh)."""
    if isinstance(obstacle, Sphere):
        return np.array([point_segment_distance(s.a, s.b, obstacle.center) for s in base]) - obstacle.radius
    A, B = np.array([s.a for s in base], dtype=float), np.array([s.b for s in base], dtype=float)
    if isinstance(obstacle, Capsule):
        _, _, X, Y = segment_segment(A, B, np.broadcast_to(np.asarray(obstacle.a), A.shape),
                                     np.broadcast_to(np.asarray(obstacle.b), A.shape))
        return np.linalg.norm(X - Y, axis=1) - obstacle.radius
    t = np.linspace(0.0, 1.0, 33)[None, :, None]
    pts = (A[:, None] + t * (B - A)[:, None]).reshape(-1, 3)
    return obstacle.signed_distance(pts).reshape(len(A), -1).min(axis=1)


def point_segment_distance(a: Sequence[float], b: Sequence[float], c: Sequence[float]) -> float:
    """Distance from the point ``c`` to the segment ``[a, b]`` (3-sequences of floats; the closed form of
    :func:`.segment_distance.point_segment`)."""
    ax, ay, az = a
    ux, uy, uz = b[0] - ax, b[1] - ay, b[2] - az
    wx, wy, wz = c[0] - ax, c[1] - ay, c[2] - az
    L2 = ux * ux + uy * uy + uz * uz
    s = min(max((wx * ux + wy * uy + wz * uz) / L2, 0.0), 1.0) if L2 > 1e-24 else 0.0
    vx, vy, vz = wx - s * ux, wy - s * uy, wz - s * uz
    return math.sqrt(vx * vx + vy * vy + vz * vz)
