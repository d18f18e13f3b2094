"""Which of many configurations put a link segment inside an obstacle: the batched check of a run's iterates.

For ``K`` configurations the segments' end points come from one compiled forward kinematics
(:func:`.clearance_kernel.skeleton_points`; Pinocchio per configuration when the tree has joints the
kernel does not model). Their sphere, capsule and box pairs are decided in one compiled call
(:func:`.clearance_kernel.violations`: the closed forms of :mod:`.obstacle_distance`, box pairs past a
separating-axis test only, and a segment that meets a box counts as a violation - the penetration depth
is not needed for the verdict). Coal pairs (cylinders, meshes) are checked per configuration where their
lower bound (:func:`.obstacle_distance.coal_lower_bound`) is below the offset: a configuration violates
a pair when ``d - offset < 0``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from types import ModuleType
from typing import TYPE_CHECKING

import coal
import numpy as np
import pinocchio as pin

from kinserve.ik.constraints.obstacle_distance import coal_lower_bound
from kinserve.ik.constraints.obstacle_geometry import segment_core, segment_transform
from kinserve.ik.constraints.obstacle_tables import ObstacleTables

if TYPE_CHECKING:  # annotations only
    from kinserve.ik.constraints.link_capsules import LinkSkeleton
    from kinserve.kinematics.robot import Robot


def skeleton_points_of(links: LinkSkeleton, kernel: ModuleType, robot: Robot,
                       Q: np.ndarray | Sequence[np.ndarray]) -> np.ndarray:
    """World points ``(K, n_points, 3)`` of the skeleton (rows of ``LinkSkeleton.points``) at every
    ``Q[k]``."""
    P = np.empty((len(Q), links.n_points, 3))
    if links.tree is not None:  # forward kinematics of every configuration in one compiled call
        Qa = Q if type(Q) is np.ndarray and Q.flags.c_contiguous else np.array(Q, dtype=float)
        kernel.skeleton_points(*links.tree, *links.point_table, Qa, P)
    else:  # joints the compiled tree does not model: Pinocchio, configuration by configuration
        model, data = robot.model, robot.data
        fk, into = pin.forwardKinematics, links.points_into
        for k, q in enumerate(Q):
            fk(model, data, q)
            into(data, P[k])
    return P


def obstacle_violations(tables: ObstacleTables, kernel: ModuleType, robot: Robot,
                        Q: np.ndarray | Sequence[np.ndarray], first_only: bool = False) -> np.ndarray:
    """``(K,)`` booleans: True where configuration ``Q[k]`` has a negative clearance (module docstring).

    ``first_only``: only the first True entry must be right (coal pairs of later configurations are
    skipped). ``kernel``: :mod:`.clearance_kernel`.
    """
    P = skeleton_points_of(tables.links, kernel, robot, Q)
    bad = np.zeros(len(Q), dtype=bool)
    sph, cap, box = tables.spheres, tables.capsules, tables.boxes
    if sph.seg.size or cap.seg.size or box.seg.size:
        kernel.violations(P, sph.ia, sph.ib, sph.center, sph.r_off2, cap.ia, cap.ib, cap.a, cap.b, cap.r_off,
                          box.ia, box.ib, box.R, box.t, box.h, tables.offset, bad)
    if tables.coal_shapes.seg.size:
        _coal_violations(tables, P, bad, first_only)
    return bad


def _coal_violations(tables: ObstacleTables, P: np.ndarray, bad: np.ndarray, first_only: bool) -> None:
    """``bad[k] = True`` where configuration ``k`` (points ``P[k]``) violates a coal pair."""
    pairs, off = tables.coal_shapes, tables.offset
    K, n = P.shape[0], pairs.seg.size
    A, B = P[:, pairs.ia].reshape(-1, 3), P[:, pairs.ib].reshape(-1, 3)
    lb = coal_lower_bound(A, B, pairs, K)
    request, result = coal.DistanceRequest(), coal.DistanceResult()
    hits = np.flatnonzero(bad)
    first = int(hits[0]) if hits.size and first_only else K  # with first_only: only the first matters
    for r in np.flatnonzero(lb < off).tolist():  # in order of the configuration
        k, p = divmod(r, n)
        if k >= first:
            break
        if bad[k]:
            continue
        ab = B[r] - A[r]
        length = math.sqrt(ab.dot(ab))
        result.clear()
        d = coal.distance(pairs.geometries[p], pairs.transforms[p], segment_core(length),
                          segment_transform(A[r], ab, length), request, result)
        if d - off < 0.0:
            bad[k] = True
            if first_only:
                first = k
