"""Singularity measures of a Jacobian ``J`` (m x n, any shape).

All are computed from the singular values ``sigma_1 >= ... >= sigma_k``,
``k = min(m, n)`` - never from ``det(J)``, which only exists for square ``J``.
A Jacobian mixing linear (m/s) and angular (rad/s) rows mixes units; pass the
rows of one kind (or the task rows of the mechanism) when that matters.
"""

from __future__ import annotations

import numpy as np


def singular_values(J: np.ndarray) -> np.ndarray:
    """Singular values of ``J`` in descending order (length ``min(m, n)``)."""
    return np.linalg.svd(np.asarray(J, dtype=float), compute_uv=False)


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
    """Numerical rank: number of ``sigma_i > tol * max(1, sigma_1)``."""
    s = singular_values(J)
    return int(np.sum(s > tol * max(1.0, s[0] if s.size else 0.0)))


def is_singular(J: np.ndarray, tol: float = 1e-6) -> bool:
    """True when ``J`` has lost rank: ``rank(J, tol) < min(m, n)``."""
    J = np.asarray(J, dtype=float)
    return rank(J, tol) < min(J.shape)
