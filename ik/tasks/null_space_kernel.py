"""The null space of a wide matrix of full row rank, by a compiled Householder QR (one call).

For ``J`` (``m x n``, ``m < n``), Householder reflections ``H_k = I - 2 v_k v_k^T`` (``|v_k| = 1``) bring
``J^T`` to upper-triangular form: ``H_{m-1} ... H_0 J^T = [R; 0]``, so ``J^T = Q [R; 0]`` with ``Q = H_0 ...
H_{m-1}`` orthogonal. When ``R`` is invertible the last ``n - m`` columns of ``Q`` are an orthonormal basis of
the orthogonal complement of the range of ``J^T``, which is the null space of ``J``. They are ``Q`` applied to
the last ``n - m`` unit vectors, the reflections applied in reverse order.

The certificate that ``R`` is safely invertible (the caller's rank test): ``J`` and ``R`` have the same
singular values, ``|det R| = prod |R_kk| = prod sigma_k <= sigma_min sigma_max^(m-1)`` and ``sigma_max <=
|J|_F = F``, so ``sigma_min >= prod |R_kk| / F^(m-1)``; when that bound exceeds ``tol * max(1, F)`` every
singular value exceeds ``tol * max(1, sigma_max)``. The same test as with LAPACK's ``geqrf``: the reflections
may differ in sign, the space and the certificate do not.

Compiled with an explicit signature through the kernel set of :mod:`kinserve.kinematics.kernel_cache`
(loaded when :mod:`~kinserve.ik.tasks.centring_weights` is imported). Dimensionless.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from kinserve.kinematics.kernel_cache import F2_ANY, compiled, inline

_SIGNATURE = numba.types.Tuple((numba.types.boolean, numba.types.Array(numba.types.float64, 2, "C")))(
    F2_ANY, numba.types.float64)


@inline
def _reflector(A, k, V):
    """Write into column ``k`` of ``V`` the unit vector ``v`` of the reflection that maps ``A[k:, k]`` onto
    ``R_kk e_k`` and return ``R_kk`` (its sign chosen against cancellation in ``v``; ``v`` stays zero when the
    column is zero, and then ``R_kk = 0``)."""
    n = A.shape[0]
    norm2 = 0.0
    for i in range(k, n):
        norm2 += A[i, k] * A[i, k]
    alpha = -math.sqrt(norm2) if A[k, k] >= 0.0 else math.sqrt(norm2)
    vnorm2 = 0.0
    for i in range(k, n):
        V[i, k] = A[i, k] - alpha if i == k else A[i, k]
        vnorm2 += V[i, k] * V[i, k]
    if vnorm2 > 0.0:
        scale = 1.0 / math.sqrt(vnorm2)
        for i in range(k, n):
            V[i, k] *= scale
    return alpha


@inline
def _reflect(V, k, X, first):
    """Apply ``H_k = I - 2 v_k v_k^T`` (column ``k`` of ``V``, zero above row ``k``) to the columns ``first,
    first + 1, ...`` of ``X``, in place."""
    for j in range(first, X.shape[1]):
        s = 0.0
        for i in range(k, X.shape[0]):
            s += V[i, k] * X[i, j]
        s *= 2.0
        for i in range(k, X.shape[0]):
            X[i, j] -= s * V[i, k]


@compiled(_SIGNATURE)
def certified_null_space(J: np.ndarray, tol: float) -> tuple[bool, np.ndarray]:
    """``(True, Z)`` with ``Z`` ``(n, n - m)`` an orthonormal basis of the null space of ``J`` (``m x n``,
    ``0 < m < n``) when the certificate of the module docstring holds; ``(False, empty)`` when it fails (a
    nearly singular ``J``, a non-finite entry) or ``m >= n``."""
    m, n = J.shape
    if m == 0 or m >= n:
        return False, np.zeros((0, 0))
    A = J.T.copy()  # a fresh C array, reduced in place to [R; 0]
    V = np.zeros((n, m))  # column k: the unit vector v_k of H_k
    det = 1.0
    for k in range(m):
        det *= _reflector(A, k, V)
        _reflect(V, k, A, k + 1)
    F = math.sqrt(np.sum(J * J))
    if not (abs(det) > tol * max(1.0, F) * F ** (m - 1)):  # NaN fails too
        return False, np.zeros((0, 0))
    Z = np.zeros((n, n - m))
    for j in range(n - m):
        Z[m + j, j] = 1.0
    for k in range(m - 1, -1, -1):  # Z = H_0 ... H_{m-1} E
        _reflect(V, k, Z, 0)
    return True, Z


__all__ = ["certified_null_space"]
