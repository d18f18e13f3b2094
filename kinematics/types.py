"""Type aliases for the public signatures: what the API accepts for poses, vectors and matrices.

Poses at the API boundary are 4x4 homogeneous matrices (a NumPy array or
nested lists) or ``pinocchio.SE3`` objects; joint vectors and other vectors
are 1-D sequences of numbers. Everything is validated at run time by
:mod:`kinserve.kinematics.validation`; these aliases only document the types.
"""

from __future__ import annotations

from typing import Union

import pinocchio as pin
from numpy.typing import ArrayLike

#: A 4x4 homogeneous transform: array-like (rotation block orthonormal, last row 0 0 0 1) or a
#: ``pinocchio.SE3``.
PoseLike = Union[ArrayLike, pin.SE3]

#: A 1-D sequence of numbers (joint values in rad / m, a twist ``[v; w]``, a point ...).
VectorLike = ArrayLike

#: A 2-D array-like (``(N, n)`` rows of vectors, a matrix).
MatrixLike = ArrayLike

__all__ = ["ArrayLike", "MatrixLike", "PoseLike", "VectorLike"]
