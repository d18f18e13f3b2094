"""The sphere-only path of obstacle avoidance: clearances, normals and damper rows in few array passes.

When every pair is a sphere on a rigid segment (``ObstacleTables.sphere_only``), a step needs per pair
the clearance ``c = |x - o| - (r + offset)`` and the unit normal ``n = (x - o) / |x - o|`` at the witness
point ``x`` (:func:`sphere_geometry`), then the velocity-damper rows ``g^T dq >= -xi c`` of the pairs
within the influence distance (:func:`sphere_rows`). With ``V = x - o = d n`` the witness point is
``x = o + V``, so ``x x n = o x n``: the moment arm of every row is the sphere centre, a constant, and
the row is

    g^T = n^T [I, -[o]x] J = n^T J_v + (o x n)^T J_w

(``J``: Pinocchio's WORLD joint Jacobians ``data.J``), masked by the support of the segment's joint.
Both steps are one compiled call each (:func:`.clearance_kernel.sphere_geometry`,
:func:`.clearance_kernel.sphere_rows`) when the robot's tree is packed for the kernels, NumPy otherwise.
"""

from __future__ import annotations

from types import ModuleType
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from kinserve.ik import numpy_fast
from kinserve.ik.constraints.obstacle_tables import ObstacleTables

if TYPE_CHECKING:  # annotations only
    import pinocchio as pin

_EPS = 1e-12
_INF = np.full(4096, np.inf)
_INF.flags.writeable = False  # a constant: the upper bounds of up to 4096 damper rows (read-only views)
_einsum = numpy_fast.einsum
_clip = numpy_fast.clip
_min = np.minimum.reduce
_matmul = np.matmul
_sqrt = np.sqrt
_fmax = np.fmax


class SphereGeometry(NamedTuple):
    """Per sphere pair at one configuration: clearances ``c`` (m), unit normals ``V`` (rows, from the centre
    to the witness point) and ``near``, the pairs that give rows (``c < influence``, a defined normal)."""

    c: np.ndarray
    V: np.ndarray
    near: np.ndarray


def upper_bounds(k: int) -> np.ndarray:
    """``(k,)`` infinite upper bounds of damper rows (a read-only view of a constant when ``k <= 4096``)."""
    return _INF[:k] if k <= _INF.shape[0] else np.full(k, np.inf)


def sphere_geometry(tables: ObstacleTables, kernel: ModuleType, data: pin.Data, q: np.ndarray,
                    influence: float) -> SphereGeometry:
    """The :class:`SphereGeometry` of every sphere pair at ``q`` (module docstring): one compiled call from
    ``q``, or - when the tree has joints the kernel does not model - NumPy after forward kinematics in
    ``data``. ``kernel``: :mod:`.clearance_kernel`."""
    links, sph = tables.links, tables.spheres
    n = sph.seg.shape[0]
    if links.tree is not None:
        c, V, near = np.empty(n), np.empty((n, 3)), np.empty(n, dtype=bool)
        kernel.sphere_geometry(*links.tree, *links.point_table, q, sph.ia, sph.ib, sph.center, sph.inv_len2,
                               sph.r_off, influence, c, V, near)
        return SphereGeometry(c, V, near)
    X = links.points(data).take(sph.iab, 0)  # both ends of every pair in one gather (cheaper than indexing)
    A = X[:n]
    AB = X[n:] - A
    AC = sph.center - A
    s = _einsum("ij,ij->i", AC, AB) * sph.inv_len2
    _clip(s, 0.0, 1.0, out=s)
    V = s[:, None] * AB
    V -= AC  # x - o
    d = _sqrt(_einsum("ij,ij->i", V, V))
    c = d - sph.r_off
    near = c < influence
    if _min(d) > _EPS:
        V /= d[:, None]  # unit normals
    else:  # a witness at a sphere's centre has no direction: no row for it
        near &= d > _EPS
        V /= _fmax(d, _EPS)[:, None]
    return SphereGeometry(c, V, near)


def sphere_rows(tables: ObstacleTables, kernel: ModuleType, data: pin.Data, geometry: SphereGeometry,
                gain: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(G, lower, upper)``: the damper rows ``G dq >= -gain c`` of the ``near`` pairs of ``geometry``
    (after ``computeJointJacobians`` in ``data``; module docstring)."""
    sph = tables.spheres
    c, V, near = geometry
    if tables.links.tree is not None:  # the rows of the near pairs in one compiled call
        G = np.empty((c.shape[0], data.J.shape[1]))
        k = kernel.sphere_rows(V, sph.center, data.J, sph.support, near, G)
        return G[:k], -gain * c.compress(near), upper_bounds(k)
    # row p: n^T [I, -[o]x] J masked by the support of the segment's joint; computed for every pair (a few
    # more rows of small products), then the far pairs are dropped
    if sph.blocks is not None:
        # per sphere k once: M_k = W_k J (3 x nv, the Jacobian of a point at o_k moved by every joint), then
        # the rows of its block n^T M_k in one batched product (the same sums as (n^T W) J, grouped otherwise)
        K, n_seg = sph.blocks
        M = sph.W_blocks.dot(data.J)
        G = _matmul(V.reshape(K, n_seg, 3), M.reshape(K, 3, -1)).reshape(c.shape[0], -1)
    else:
        G = _einsum("pi,pij->pj", V, sph.W).dot(data.J)
    G *= sph.support
    G, c = G.compress(near, 0), c.compress(near)
    return G, -gain * c, upper_bounds(c.shape[0])
