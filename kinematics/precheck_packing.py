"""The packed arguments of the compiled pre-check: one float array and one integer array per scene.

A compiled call pays per array argument, so the kernels of
:mod:`.precheck_kernels` take everything they read in two flat arrays
(:func:`pack`; the kernels' ``_unpack`` gives the arrays back as views, no copy):

* ``floats``: ``tree`` ``(J, 15)``, ``reach`` ``(J,)``, ``spheres`` ``(S, 4)`` (the
  robot's spheres, then its inner balls: inner points with their radii), ``obstacles``
  ``(O, 16)`` (:mod:`.obstacle_table`), row-major, in turn;
* ``ints``: ``(J, S, G, P, O)``, then ``joints`` ``(J, 3)``, ``geoms`` ``(G, 5)``
  (joint, first and end cover row, first and end inner point row), ``pairs``
  ``(P, 4)`` (robot geometry, other geometry or obstacle index, pair kind, index
  of the pair in the scene).

The obstacle rows come last, so the robot half is packed once per layout and a
scene appends its obstacles' rows (:attr:`~.shapes.Shape.obstacle_row`, made with each shape).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .robot_spheres import RobotSpheres


class PackedArrays(NamedTuple):
    """The two arguments of every pre-check kernel (module docstring)."""

    floats: np.ndarray
    ints: np.ndarray


def pack(robot: RobotSpheres, pairs: np.ndarray, obstacles: np.ndarray,
         inner_radii: np.ndarray | None = None) -> PackedArrays:
    """The kernels' two arguments for the robot's spheres ``robot``, the pair table ``pairs`` ``(P, 4)`` and
    the obstacle table ``obstacles`` ``(O, 16)`` (module docstring); ``inner_radii`` ``(I,)``: the radius (m)
    of the ball inside its geometry about each inner point (:mod:`.inner_balls`; None: 0, points)."""
    n_spheres = len(robot.spheres)
    radii = np.zeros(len(robot.inner)) if inner_radii is None else np.asarray(inner_radii, dtype=float)
    rows = np.concatenate([robot.spheres, np.column_stack([robot.inner, radii])])
    geoms = np.column_stack([robot.geoms, robot.inner_ranges + n_spheres]).astype(np.int64)
    obstacles = np.asarray(obstacles, dtype=float)
    sizes = [len(robot.joints), len(rows), len(robot.geoms), len(pairs), len(obstacles)]  # J, S, G, P, O
    floats = np.concatenate([robot.tree.ravel(), robot.reach, rows.ravel(), obstacles.ravel()])
    ints = np.concatenate([np.array(sizes, dtype=np.int64), robot.joints.ravel(), geoms.ravel(),
                           np.asarray(pairs, dtype=np.int64).ravel()])
    return PackedArrays(floats, ints)


__all__ = ["PackedArrays", "pack"]
