"""Shared scene of the collision tests: the issue's Panda table top and wall, and a pose helper."""

from __future__ import annotations

import numpy as np

from kinserve.kinematics.shapes import Box


def pose(xyz, R=None) -> np.ndarray:
    """A 4x4 pose at ``xyz`` (rotation ``R``, default the identity)."""
    T = np.eye(4)
    T[:3, 3] = xyz
    if R is not None:
        T[:3, :3] = R
    return T


#: The issue's (and the benchmark's) Panda scene: a table top and a wall.
SCENE = [Box(pose((0.65, 0.0, -0.05)), (0.7, 1.2, 0.1)), Box(pose((0.0, -0.6, 0.5)), (1.5, 0.05, 1.0))]
