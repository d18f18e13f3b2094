"""The hulls' verdict on the pairs the sphere pre-check leaves to coal (compiled, Numba): free, in
collision, or fewer pairs for coal.

The sphere pre-check (:func:`~.precheck_kernels.classify_configuration`) certifies a pair when a lower
bound of its distance exceeds :data:`~.precheck_kernels.TOLERANCE`. Its bounds come from spheres that
contain the geometries, so near an obstacle they are loose, and an undecided verdict carries the pairs it
could not certify (at most :data:`~.precheck_verdicts.PACKED_PAIRS`) for coal. :func:`hull_verdict`
measures those pairs on the exact shapes instead, with :mod:`.convex_distance`'s GJK between a robot
geometry's core and an obstacle's or another geometry's (the iteration stops as soon as it knows on which
side of the tolerance the distance lies):

* **free** - GJK's lower bound of the distance, less the radii the cores are grown by, exceeds the
  tolerance: the pair is free on the hull model, as one the spheres certify. A lower bound never exceeds
  the true distance, and coal's distances on these shapes are exact to about 1e-6 m, ten times below the
  tolerance, so coal finds the pair free. Every carried pair free: the configuration is free;
* **in collision** - GJK ends with a tetrahedron of the cores' Minkowski difference around the origin, and
  the origin's distance to its faces (a lower bound of how deep the cores overlap,
  :func:`~.convex_distance.enclosed_depth`) exceeds the tolerance: coal finds the pair in collision (the
  rule of the pre-check's inner balls), and the configuration is in collision;
* otherwise the pair stays open, and the verdict carries the open pairs - only those - for coal. So do the
  pairs the compiled distances do not measure (a robot geometry without a core, an obstacle
  :func:`~.convex_distance.obstacle_radius` refuses).

docs/benchmarks.md measures how many configurations this decides and what it costs. Units: metres and
radians.
"""

from __future__ import annotations

import numba
import numpy as np

from .convex_distance import enclosed_depth, pair_distance_bounds
from .kernel_cache import F1, F1_ANY, F2, I1, I2, compiled
from .kernel_primitives import tree_placements_into
from .precheck_kernels import unpack
from .precheck_verdicts import COLLIDING, FREE, PAIR_BITS, UNDECIDED

_t = numba.types
_VERDICT_SIGNATURE = _t.int64(F1, I1, F2, I2, F1, I1, F1_ANY, _t.int64, _t.float64)


@compiled(_VERDICT_SIGNATURE)
def hull_verdict(floats: np.ndarray, ints: np.ndarray, points: np.ndarray, hull_geoms: np.ndarray,
                 radius: np.ndarray, table_rows: np.ndarray, q: np.ndarray, verdict: int, tol: float) -> int:
    """The hulls' verdict at ``q`` on the pairs an undecided ``verdict`` of
    :func:`~.precheck_kernels.classify_configuration` carries (``floats``, ``ints``: the scene's packed
    pre-check, :mod:`.precheck_packing`; ``points, hull_geoms, radius``: the robot's
    :class:`~.hull_table.HullTable`; ``table_rows``: the pair table's row of each scene pair; ``tol``, m):
    :data:`~.precheck_verdicts.COLLIDING` as soon as the cores of a carried pair overlap by more than ``tol``
    (GJK's enclosing tetrahedron, :func:`~.convex_distance.enclosed_depth`), else
    :data:`~.precheck_verdicts.FREE` when the distance lower bound of each carried pair exceeds ``tol``,
    else the verdict carrying only the pairs neither test decides, in the same order and packing. Any other
    verdict (free, in collision, or undecided without pairs), a ``q`` without one entry per joint, a hull
    table without one row per robot geometry and a carried pair outside the scene return ``verdict``
    unchanged."""
    tree, joints, spheres, geoms, pairs, obstacles = unpack(floats, ints)
    n = joints.shape[0]
    if verdict <= UNDECIDED or q.shape[0] != n or hull_geoms.shape[0] != geoms.shape[0]:
        return verdict
    X = np.empty((n + 1, 12))
    tree_placements_into(tree, joints, q, X)
    S, T, guess = np.empty((4, 3)), np.empty((7, 3)), np.empty(3)
    mask = (1 << PAIR_BITS) - 1
    code, k, rest = UNDECIDED, 0, verdict >> 2
    while rest:
        s = (rest & mask) - 1
        rest >>= PAIR_BITS
        if s < 0 or s >= table_rows.shape[0]:
            return verdict
        p = table_rows[s]
        guess[:] = 0.0  # (GJK's default start: measured no slower than one from the spheres' centres)
        lower, _ = pair_distance_bounds(points, hull_geoms, radius, pairs, obstacles, p, X, S, T, guess, tol,
                                        tol)
        if lower > tol:
            continue
        if lower == lower and guess[0] == 0.0 and guess[1] == 0.0 and guess[2] == 0.0 \
                and enclosed_depth(S) > tol:  # (measured, and GJK ended enclosing the origin)
            return COLLIDING  # the cores overlap by more than tol (growing them only deepens it)
        code |= (s + 1) << (2 + PAIR_BITS * k)  # (NaN: a pair the compiled distances do not measure)
        k += 1
    return FREE if k == 0 else code


__all__ = ["hull_verdict"]
