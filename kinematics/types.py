"""Type aliases for the public signatures: what the API accepts for poses, vectors and matrices.

Poses at the API boundary are 4x4 homogeneous matrices (a NumPy array or
nested lists), ``pinocchio.SE3`` objects, pairs ``(position, quaternion)`` or
7-vectors ``[x, y, z, qx, qy, qz, qw]`` (quaternions scalar last, as Pinocchio
and ROS write them; ``kinserve.pose`` builds a 4x4 from these parts); joint
vectors and other vectors are 1-D sequences of numbers. Everything is validated at run time by
:mod:`kinserve.kinematics.validation`; these aliases only document the types.
"""

from __future__ import annotations

from typing import Union

import pinocchio as pin
from numpy.typing import ArrayLike

#: A pose: a 4x4 homogeneous array-like (rotation block orthonormal, last row 0 0 0 1), a
#: ``pinocchio.SE3``, a pair ``(position [x, y, z], quaternion [qx, qy, qz, qw])`` or a 7-vector
#: ``[x, y, z, qx, qy, qz, qw]`` (see :func:`kinserve.kinematics.validation.as_pose`).
PoseLike = Union[ArrayLike, pin.SE3, tuple[ArrayLike, ArrayLike]]

#: A 1-D sequence of numbers (joint values in rad / m, a twist ``[v; w]``, a point ...).
VectorLike = ArrayLike

#: A 2-D array-like (``(N, n)`` rows of vectors, a matrix).
MatrixLike = ArrayLike

__all__ = ["ArrayLike", "MatrixLike", "PoseLike", "VectorLike"]
