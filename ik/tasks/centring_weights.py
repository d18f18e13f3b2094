"""Joint-limit centring: the secondary objective, strictly below the primary task.

Objective (dimensionless)

    h(q) = 1/2 sum_i w_i ((q_i - m_i) / r_i)^2,     m = (lower + upper) / 2,  r = upper - lower

with weights ``w_i >= 0`` (the ``centring`` argument: one number for every
joint or one per joint). Because the priority is strict, only the *relative*
weights matter; ``0`` switches a joint (or everything) off.

Strict priority means the secondary step may only move in the freedom the
primary task leaves, so it never degrades the task:

* Null-space projection (pseudo-inverse / DLS methods): with the primary
  step ``dq1 = J^+ e`` and an orthonormal basis ``Z`` of the null space of
  ``J``,

      dq = dq1 + Z z,   z = argmin |dq1 + Z z - (m - q)|_W^2,

  where ``m - q`` is the Newton step of ``h`` (its Hessian is ``W``, so the
  unconstrained step is simply ``m - q`` on every weighted joint). For equal
  weights this is the classical ``dq = J^+ e + (I - J^+ J)(m - q)``.
* Second QP level (QP method, :mod:`ik.qp.hierarchy`): with the primary step ``dq1`` and an
  orthonormal basis ``Z`` of the null space of ``J`` (the right singular
  vectors of its zero singular values), solve for ``z``

      min 1/2 |dq1 + Z z - (m - q)|_W^2 + eps/2 |z|^2
      s.t. every hard constraint of the primary stage (limits, spheres) at ``dq = dq1 + Z z``

  so ``J dq = J dq1`` exactly: the task velocity of the primary stage is
  kept and the constraints still hold.

S9 (SCARA, seed 004): relaxing ``yaw`` leaves ``theta4`` free, which goes to
the middle of its range; relaxing ``z`` leaves ``d3`` free, which goes to
0.625 m unless the sphere binds.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from scipy.linalg import get_lapack_funcs

from kinserve.ik.tasks.null_space_kernel import certified_null_space
from kinserve.kinematics.errors import InputError, NonFiniteError
from kinserve.kinematics.validation import MAX_ABS, is_bounded

if TYPE_CHECKING:  # annotations only
    from kinserve.kinematics.robot import Robot
    from kinserve.kinematics.types import VectorLike


def centring_weights(robot: Robot, centring: float | VectorLike | None) -> np.ndarray | None:
    """Per-joint weights ``w / r^2`` (``(nq,)``) or None when centring is off.

    ``centring`` is a number or a sequence of ``nq`` numbers, all finite, ``>= 0`` and at most
    :data:`~kinserve.kinematics.validation.MAX_ABS` (1e6). Joints with a zero range (locked) get weight 0.
    Refused: another shape, text or None entries (:class:`InputError`), NaN, infinite or larger entries
    (:class:`NonFiniteError`), negative entries.
    """
    if centring is None or (type(centring) in (int, float) and centring == 0):
        return None
    if isinstance(centring, (bool, str, bytes, dict)):
        raise InputError(f"centring must be a number or {robot.nq} numbers (one per joint), got {centring!r}")
    try:
        w = (np.asarray(centring, dtype=float) if not isinstance(centring, (int, float))
             else np.full(robot.nq, float(centring)))
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"centring must be a number or {robot.nq} numbers (one per joint), "
                         f"got {centring!r}") from None
    if w.ndim == 0:
        w = np.full(robot.nq, float(w))
    if w.shape != (robot.nq,):
        raise InputError(f"centring must be a number or {robot.nq} numbers (one per joint), "
                         f"got shape {w.shape}")
    if not is_bounded(w):
        raise NonFiniteError(f"centring weights must be finite with magnitude <= {MAX_ABS:g}, "
                             f"got {w.tolist()}")
    if np.any(w < 0):
        raise InputError(f"centring weights must be >= 0, got {w.tolist()}")
    if not np.any(w > 0):
        return None
    r = robot.upper - robot.lower
    out = np.zeros(robot.nq)
    ok = r > 1e-12
    out[ok] = w[ok] / r[ok] ** 2
    return out if np.any(out > 0) else None


def centring_objective(robot: Robot, q: VectorLike, weights: np.ndarray) -> float:
    """``h(q)`` for weights from :func:`centring_weights` (already divided by ``r^2``)."""
    d = np.asarray(q, dtype=float) - robot.middle()
    return 0.5 * float(np.sum(weights * d * d))


_gesdd = get_lapack_funcs(("gesdd",), (np.eye(2),))[0]

#: Singular values below ``RANK_TOL * max(1, sigma_max)`` count as zero.
RANK_TOL = 1e-6


def full_rank_null_space(J: np.ndarray, tol: float = RANK_TOL) -> np.ndarray | None:
    """Orthonormal basis ``(n, n - m)`` of the null space of a wide ``J`` certified of full row rank, or None.

    Householder QR of the transpose, ``J^T = Q [R; 0]``, in one compiled call
    (:func:`~kinserve.ik.tasks.null_space_kernel.certified_null_space`): when ``R`` is invertible the last
    ``n - m`` columns of ``Q`` span the null space of ``J``. Its certificate (``prod |R_ii| / F^(m-1) >
    tol * max(1, F)``, ``F = |J|_F``) guarantees that every singular value exceeds ``tol * max(1,
    sigma_max)``, so :func:`null_space_basis`'s SVD would find rank ``m`` too and the two bases span the same
    space. None when the certificate fails (a nearly singular ``J``: the caller uses the SVD) or ``m >= n``.
    """
    ok, Z = certified_null_space(J, tol)
    return Z if ok else None


def null_space_basis(J: np.ndarray, tol: float = RANK_TOL) -> np.ndarray:
    """Orthonormal basis ``(n, n - rank J)`` of the null space of ``J`` (``m x n``).

    Rank-revealing: rows that are identically zero (a planar arm's ``z``,
    ``roll``, ``pitch`` rows, a SCARA's ``roll`` / ``pitch``) do not use up
    freedom. A wide ``J`` certified of full row rank takes the QR of
    :func:`full_rank_null_space` (a third of the cost); anything else the SVD
    (singular values below ``tol * max(1, sigma_max)`` count as zero). Both give
    an orthonormal basis of the same space, which is all the callers use.
    """
    n = J.shape[1]
    if J.shape[0] == 0:
        return np.eye(n)
    Z = full_rank_null_space(J, tol)
    if Z is not None:
        return Z
    # LAPACK's gesdd directly (what numpy.linalg.svd calls, bit for bit, without its wrapper's overhead)
    _, s, Vt, info = _gesdd(J, compute_uv=1, full_matrices=1)
    if info != 0:  # pragma: no cover - LAPACK failure: the checked path
        _, s, Vt = np.linalg.svd(J, full_matrices=True)
    rank = int(np.sum(s > tol * max(1.0, s[0] if s.size else 0.0)))
    return Vt[rank:].T.copy() if rank < n else np.zeros((n, 0))


def null_space_step(J: np.ndarray, J_pinv: np.ndarray, step: np.ndarray) -> np.ndarray:
    """Projection ``(I - J^+ J) step`` of a joint step onto the null space of ``J``."""
    return step - J_pinv @ (J @ step)


def null_space_correction(Z: np.ndarray, weights: np.ndarray, residual: np.ndarray,
                          eps: float = 1e-9) -> np.ndarray:
    """``Z z`` minimising ``|Z z - residual|_W^2 + eps |z|^2`` (unconstrained second stage).

    ``residual`` is ``(m - q) - dq1``: what the primary step left of the
    secondary step. The result lies in ``span(Z)``, the null space of the task.
    """
    k = Z.shape[1]
    if k == 0:
        return np.zeros(Z.shape[0])
    ZW = Z.T * weights
    z = np.linalg.solve(ZW @ Z + eps * np.eye(k), ZW @ residual)
    return Z @ z


def centring_step(robot: Robot, q: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """The secondary step ``(m - q)`` on weighted joints (0 on joints with weight 0)."""
    return np.where(weights > 0, robot.middle() - q, 0.0)
