"""Singularity measures of a Jacobian ``J`` (m x n, any shape).

All are computed from the singular values ``sigma_1 >= ... >= sigma_k``,
``k = min(m, n)`` - never from ``det(J)``, which only exists for square ``J``.
A Jacobian mixing linear (m/s) and angular (rad/s) rows mixes units; pass the
rows of one kind (or the task rows of the mechanism) when that matters.

Every function refuses a ``J`` that is not a non-empty 2-D array of finite
numbers (:class:`~.errors.ShapeError` / :class:`~.errors.NonFiniteError`), and
``rank`` / ``is_singular`` a ``tol`` outside ``[0, 1]`` (:func:`check_tol`).
"""

from __future__ import annotations

import numpy as np

from .errors import ShapeError
from .validation import as_matrix, as_nonnegative

#: Largest relative tolerance of :func:`rank` / :func:`is_singular`: ``sigma_min <= sigma_max`` always, so
#: with ``tol >= 1`` everything would count as singular.
MAX_TOL = 1.0


def check_tol(tol: object) -> float:
    """``tol`` as a float if it is a number in ``[0, MAX_TOL]``; else :class:`~.errors.InputError` /
    :class:`~.errors.NonFiniteError` naming ``tol`` (NaN, negative, huge or non-numeric tolerances)."""
    if type(tol) is float and 0.0 <= tol <= MAX_TOL:
        return tol
    return as_nonnegative(tol, "tol", maximum=MAX_TOL)


def _checked(J: object) -> np.ndarray:
    """``J`` as a finite float ``(m, n)`` array with ``m, n >= 1``; else the error naming ``J``."""
    J = as_matrix(J, (-1, -1), "J")
    if 0 in J.shape:
        raise ShapeError(f"J must have at least one row and one column, got shape {J.shape} (no task rows?)")
    return J


def singular_values(J: np.ndarray) -> np.ndarray:
    """Singular values of ``J`` in descending order (length ``min(m, n)``)."""
    return np.linalg.svd(_checked(J), compute_uv=False)


def manipulability(J: np.ndarray) -> float:
    """Yoshikawa's measure ``w = sqrt(det(J J^T)) = prod(sigma_i)`` (m <= n).

    For a tall ``J`` (m > n) this is ``sqrt(det(J^T J))``, the volume of the
    velocity ellipsoid in the reachable subspace.
    """
    return float(np.prod(singular_values(J)))


def condition_number(J: np.ndarray) -> float:
    """``sigma_max / sigma_min``; ``inf`` when ``sigma_min == 0``."""
    s = singular_values(J)
    return float("inf") if s[-1] == 0.0 else float(s[0] / s[-1])


def rank(J: np.ndarray, tol: float = 1e-6) -> int:
    """Numerical rank: number of ``sigma_i > tol * max(1, sigma_1)``; ``tol`` in ``[0, 1]``."""
    tol = check_tol(tol)
    s = singular_values(J)
    return int(np.sum(s > tol * max(1.0, s[0])))


def is_singular(J: np.ndarray, tol: float = 1e-6) -> bool:
    """True when ``J`` has lost rank: ``rank(J, tol) < min(m, n)``; ``tol`` in ``[0, 1]``."""
    J = _checked(J)
    return rank(J, tol) < min(J.shape)
