"""Distances of the (obstacle, link segment) pairs of an :class:`~.obstacle_tables.ObstacleTables`.

For every pair the clearance is ``c = d(segment, obstacle) - offset`` (m; ``offset`` = link radius +
required margin), ``d`` the Euclidean distance (negative when they overlap), with - on request - the
witness point ``x = (1 - s) A + s B`` on the segment ``[A, B]`` and the unit normal ``N`` from the
obstacle to ``x`` (zero where it is undefined):

* sphere (centre ``o``, radius ``r``): the point-segment closed form, ``d = |x - o| - r``;
* capsule (core ``[p, q]``, radius ``r``): the segment-segment closed form, ``d = |x - y| - r``;
* box (pose ``(R, t)``, half extents ``h``): the exact closed form
  :func:`.segment_distance.segment_box` on the segment in the box's frame ``a = R^T (A - t)``, normal
  ``N = R (x - y) / d``; a segment that meets the box gets coal's signed (penetration) distance;
* cylinder, mesh: coal's GJK/EPA distance between the shape and the segment's capsule core. Two lower
  bounds come first - the distance to a bounding sphere and the largest gap between the segment's and the
  shape's extents along the shape's own axes (separating axes) - and pairs whose bound is beyond the
  cutoff keep it (no coal call).

Closed forms are evaluated for all pairs of a kind at once (NumPy). With ``min_only`` only the smallest
clearance must be exact: box and coal pairs are visited in increasing order of their lower bound and the
visit stops once the bound reaches the smallest distance found (the others keep their bound).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, NamedTuple

import coal
import numpy as np

from kinserve.ik import numpy_fast
from kinserve.ik.constraints.obstacle_geometry import coal_transform, segment_core, segment_transform
from kinserve.ik.constraints.obstacle_tables import (
    BoxPairs,
    CapsulePairs,
    CoalPairs,
    ObstacleTables,
    SpherePairs,
)
from kinserve.ik.constraints.segment_distance import (
    point_segment,
    segment_box,
    segment_box_distance,
    segment_segment,
)

if TYPE_CHECKING:  # annotations only
    import pinocchio as pin

    from kinserve.ik.constraints.link_capsules import LinkSkeleton

#: Up to this many box pairs get their exact distance on floats (segment_box_distance), more at once on
#: arrays.
SCALAR_PAIRS = 12
_EPS = 1e-12
_einsum = numpy_fast.einsum
_clip = numpy_fast.clip
_matmul = np.matmul
_sqrt = np.sqrt
_fmax = np.fmax


class KindPairs(NamedTuple):
    """The pairs of one kind: distances ``d`` (m, before the offset) and, with witness points, the pairs'
    segments ``seg``, parameters ``s``, unit normals ``N`` and segment ends ``A``, ``B`` (else None)."""

    d: np.ndarray
    seg: np.ndarray | None = None
    s: np.ndarray | None = None
    N: np.ndarray | None = None
    A: np.ndarray | None = None
    B: np.ndarray | None = None


class PairWitnesses(NamedTuple):
    """Every pair in the order of the clearance vector: clearances ``c`` (m), segments, witness parameters,
    unit normals (rows) and segment ends (rows, world, m)."""

    c: np.ndarray
    seg: np.ndarray
    s: np.ndarray
    N: np.ndarray
    A: np.ndarray
    B: np.ndarray


class Penetration(NamedTuple):
    """coal's answer for a segment core and a shape: signed distance (m), normal, nearest point on the
    core."""

    distance: float
    normal: np.ndarray
    point: np.ndarray


def pair_clearances(tables: ObstacleTables, data: pin.Data, witness: bool, cutoff: float = math.inf,
                    min_only: bool = False) -> np.ndarray | PairWitnesses:
    """Clearances ``(m,)`` of every pair after forward kinematics in ``data`` (module docstring), or with
    ``witness`` the :class:`PairWitnesses`.

    Box and coal pairs whose lower bound is at least ``cutoff`` (m, clearance) keep that bound (no witness);
    ``min_only``: only the smallest entry must be exact.
    """
    P = tables.links.points(data)
    far = cutoff + tables.offset
    parts = []
    if tables.spheres.seg.size:
        parts.append(sphere_pairs(P, tables.spheres, witness))
    if tables.capsules.seg.size:
        parts.append(capsule_pairs(P, tables.capsules, witness))
    if tables.boxes.seg.size:
        if min_only and not witness:
            parts.append(KindPairs(box_min(P, tables.boxes, _smallest(parts))))
        else:
            parts.append(box_pairs(P, tables.boxes, witness, far))
    if tables.coal_shapes.seg.size:
        best = _smallest(parts) if min_only else None
        parts.append(coal_pairs(tables.links, data, P, tables.coal_shapes, far, best, witness))
    return _assembled(parts, tables.offset, witness)


def _smallest(parts: list[KindPairs]) -> float:
    return float(min((p.d.min() for p in parts if p.d.size), default=math.inf))


def _assembled(parts: list[KindPairs], offset: float, witness: bool) -> np.ndarray | PairWitnesses:
    """The kinds' pairs in one clearance vector (and witness arrays)."""
    if not parts:
        c = np.zeros(0)
    else:
        c = (parts[0].d if len(parts) == 1 else np.concatenate([p.d for p in parts])) - offset
    if not witness:
        return c
    if not parts:
        return PairWitnesses(c, np.zeros(0, dtype=int), np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3)),
                             np.zeros((0, 3)))
    if len(parts) == 1:
        return PairWitnesses(c, *parts[0][1:])
    cat = np.concatenate
    return PairWitnesses(c, *(cat([p[f] for p in parts]) for f in range(1, 6)))


def unit(V: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Rows of ``V`` divided by ``d`` (zero rows where ``d`` is 0: no defined direction)."""
    out = np.zeros_like(V)
    np.divide(V, d[:, None], out=out, where=d[:, None] > _EPS)
    return out


def inverse_length2(AB: np.ndarray) -> np.ndarray:
    """``1 / |b - a|^2`` per row of ``AB = b - a`` (0 for a point-like segment)."""
    L2 = _einsum("ij,ij->i", AB, AB)
    out = np.zeros_like(L2)
    np.divide(1.0, L2, out=out, where=L2 > 1e-24)
    return out


def sphere_pairs(P: np.ndarray, spheres: SpherePairs, witness: bool) -> KindPairs:
    """Sphere pairs: ``x = a + s (b - a)``, ``s = clamp((o - a).(b - a) / |b - a|^2, 0, 1)``,
    ``d = |x - o| - r``."""
    A = P[spheres.ia]
    AB = P[spheres.ib] - A
    AC = spheres.center - A
    inv = spheres.inv_len2 if spheres.inv_len2 is not None else inverse_length2(AB)
    s = _einsum("ij,ij->i", AC, AB) * inv
    _clip(s, 0.0, 1.0, out=s)
    V = s[:, None] * AB - AC  # x - o
    d = _sqrt(_einsum("ij,ij->i", V, V))
    if not witness:
        return KindPairs(d - spheres.radius)
    return KindPairs(d - spheres.radius, spheres.seg, s, unit(V, d), A, A + AB)


def capsule_pairs(P: np.ndarray, capsules: CapsulePairs, witness: bool) -> KindPairs:
    """Capsule pairs: the closest points ``x``, ``y`` of segment and core, ``d = |x - y| - r``."""
    A, B = P[capsules.ia], P[capsules.ib]
    s, _, X, Y = segment_segment(A, B, capsules.a, capsules.b)
    V = X - Y
    d = _sqrt(_einsum("ij,ij->i", V, V))
    if not witness:
        return KindPairs(d - capsules.radius)
    return KindPairs(d - capsules.radius, capsules.seg, s, unit(V, d), A, B)


def box_gap(a: np.ndarray, b: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Lower bound on the distance from segments ``[a, b]`` to boxes ``|y| <= h`` (their frames;
    ``(..., 3)``).

    The largest gap between the segment's and the box's extents along the box's axes (a
    separating axis): ``max_i max(min(a_i, b_i) - h_i, -h_i - max(a_i, b_i))``.
    """
    return np.maximum(np.minimum(a, b) - h, -h - np.maximum(a, b)).max(axis=-1)


def box_local(P: np.ndarray, boxes: BoxPairs) -> tuple[np.ndarray, np.ndarray]:
    """``(a, b)``: the box pairs' segment ends in their boxes' frames, ``R^T (x - t)``.

    ``P`` holds the skeleton's points, ``(points, 3)`` or ``(K, points, 3)``; every point is moved into every
    box's frame at once (one small product per box and configuration) and the pairs' ends are picked out.
    """
    L = _matmul(P[..., None, :, :] - boxes.box_t, boxes.box_R)  # (..., boxes, points, 3)
    L = L.reshape(L.shape[:-3] + (-1, 3)).take(boxes.iab_boxes, -2)  # (..., 2 pairs, 3): a's then b's
    n = boxes.row.shape[0]
    return L[..., :n, :], L[..., n:, :]


def box_pairs(P: np.ndarray, boxes: BoxPairs, witness: bool, far: float = math.inf) -> KindPairs:
    """Box pairs: closed-form distances (:func:`segment_box`), normals ``N = R (x - y) / d``.

    Pairs whose separating-axis bound (:func:`box_gap`, ``<= d``) is at least ``far`` (m) keep that bound,
    with ``s = 0`` and ``N = 0`` (no row). A segment that meets its box gets coal's signed distance (the
    penetration depth, negative) and normal instead.
    """
    A, B = P[boxes.ia], P[boxes.ib]
    a, b = box_local(P, boxes)
    d, s, near = _box_closed_form(a, b, boxes.h, far)
    N = None
    if witness:
        x = a + s[:, None] * (b - a)
        V = x - _clip(x, -boxes.h, boxes.h)  # x - y (0 for the pairs left at their bound: s = 0 ... no row)
        if near is not None:
            V[~near] = 0.0
        N = _einsum("pij,pj->pi", boxes.R, V)
        N /= _fmax(d, _EPS)[:, None]
    for r in np.flatnonzero(d <= 0.0).tolist():  # inside: the penetration depth from coal
        pen = box_penetration(boxes, r, A[r], B[r])
        d[r] = pen.distance
        if witness:
            N[r] = pen.normal
            ab = B[r] - A[r]
            s[r] = min(max(float((pen.point - A[r]).dot(ab)) / max(float(ab.dot(ab)), 1e-24), 0.0), 1.0)
    return KindPairs(d, boxes.seg, s, N, A, B) if witness else KindPairs(d)


def _box_closed_form(a: np.ndarray, b: np.ndarray, h: np.ndarray,
                     far: float) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """``(d, s, near)``: exact distances of the pairs whose bound is below ``far`` (the others: the bound,
    ``s = 0``); ``near`` the mask of the exact ones, None when all are."""
    near = None
    if far < math.inf:
        gap = box_gap(a, b, h)
        near = gap < far
        if 2 * np.count_nonzero(near) > near.shape[0]:
            near = None  # mostly near: one pass over all pairs costs less than picking them out
    if near is None:
        d, s, idx = np.empty(len(a)), np.empty(len(a)), None
    else:
        d, s, idx = gap, np.zeros(len(gap)), np.flatnonzero(near)
    n_exact = len(a) if idx is None else idx.size
    if n_exact > SCALAR_PAIRS:
        sel = slice(None) if idx is None else idx
        s[sel], d[sel] = segment_box(a[sel], b[sel], h[sel])[:2]
    elif n_exact:  # a few pairs: the same closed form on floats (less fixed cost than the arrays)
        al, bl, hl = a.tolist(), b.tolist(), h.tolist()
        for p in (range(n_exact) if idx is None else idx.tolist()):
            s[p], d[p] = segment_box_distance(al[p], bl[p], hl[p])
    return d, s, near


def box_penetration(boxes: BoxPairs, r: int, a: np.ndarray, b: np.ndarray) -> Penetration:
    """coal's signed distance between box pair ``r``'s box and the core of the segment ``[a, b]`` (world); the
    box's coal geometry is made for the query (a segment inside a box is rare: the tables keep none)."""
    ab = b - a
    length = math.sqrt(ab.dot(ab))
    res = coal.DistanceResult()
    ob = boxes.shapes[r]
    d = coal.distance(ob.geometry(), coal_transform(ob.pose), segment_core(length),
                      segment_transform(a, ab, length), coal.DistanceRequest(), res)
    return Penetration(d, np.array(res.normal), np.array(res.getNearestPoint2()))


def box_min(P: np.ndarray, boxes: BoxPairs, best: float) -> np.ndarray:
    """Distances of the box pairs where only the smallest (and the others' lower bounds) must be right.

    Pairs are visited in increasing order of their separating-axis bound (:func:`box_gap`) and get their
    exact distance until the bound reaches the smallest distance found (``best``: e.g. the sphere pairs'
    smallest); the others keep their bound, so ``min`` is exact.
    """
    h = boxes.h
    a, b = box_local(P, boxes)
    c = box_gap(a, b, h)
    order = np.argsort(c, kind="stable").tolist()
    al, bl, hl, lb = a.tolist(), b.tolist(), h.tolist(), c.tolist()
    for p in order:
        if lb[p] >= best:
            break
        d = segment_box_distance(al[p], bl[p], hl[p])[1]
        if d <= 0.0:  # the segment meets the box: coal's penetration depth
            d = box_penetration(boxes, p, P[boxes.ia[p]], P[boxes.ib[p]]).distance
        c[p] = d
        if d < best:
            best = d
    return c


def coal_lower_bound(A: np.ndarray, B: np.ndarray, pairs: CoalPairs, K: int = 1) -> np.ndarray:
    """Lower bounds (m) on the coal pairs' distances for ``K`` stacked copies of the pairs (rows of ``A``,
    ``B``).

    The larger of the distance from the segment to the shape's bounding sphere and the largest gap between
    the segment's and the shape's extents along the shape's own axes (separating axes).
    """
    tile = (lambda x: x) if K == 1 else (lambda x: np.tile(x, (K,) + (1,) * (x.ndim - 1)))
    centre, R = tile(pairs.center), tile(pairs.R)
    _, X = point_segment(A, B, centre)
    lb = np.linalg.norm(X - centre, axis=1) - tile(pairs.bound)
    a = _einsum("pi,pij->pj", A - centre, R)
    b = _einsum("pi,pij->pj", B - centre, R)
    gap = np.maximum(np.minimum(a, b) - tile(pairs.hi), tile(pairs.lo) - np.maximum(a, b)).max(axis=1)
    return np.maximum(lb, gap, out=lb)


def core_distance(pairs: CoalPairs, p: int, oMi: list, a: np.ndarray, b: np.ndarray,
                  request: coal.DistanceRequest, result: coal.DistanceResult) -> float:
    """coal's distance (m) between pair ``p``'s shape and its segment's core ``[a, b]`` (world); a rigid
    segment's core is placed from its joint's placement ``oMi[j]``. ``result`` holds the witnesses
    afterwards."""
    core = pairs.cores[p]
    if core is not None:
        geom, tf = core.geometry, coal.Transform3s(oMi[core.joint] * core.placement)
    else:
        ab = b - a
        length = math.sqrt(ab.dot(ab))
        geom, tf = segment_core(length), segment_transform(a, ab, length)
    result.clear()
    return coal.distance(pairs.geometries[p], pairs.transforms[p], geom, tf, request, result)


def coal_pairs(links: LinkSkeleton, data: pin.Data, P: np.ndarray, pairs: CoalPairs, far: float,
               best: float | None = None, witness: bool = True) -> KindPairs:
    """Coal pairs: exact distances where the lower bound is below ``far`` (m), the bound elsewhere.

    ``best`` (a distance already known, e.g. the closed-form pairs' smallest): only the smallest distance is
    wanted - the pairs are visited in increasing order of their lower bound until the bound reaches the
    smallest distance found (the others keep their bound). ``c.min()`` is then the same as with every pair
    computed.
    """
    A, B = P[pairs.ia], P[pairs.ib]
    n = pairs.seg.shape[0]
    lb = coal_lower_bound(A, B, pairs)
    c, s, N, X = lb.copy(), np.zeros(n), np.zeros((n, 3)), np.zeros((n, 3))
    request, result = coal.DistanceRequest(), coal.DistanceResult()
    oMi = links.joint_placements(data)  # (of the data just read by points())
    todo = np.flatnonzero(lb < far)
    if best is not None and todo.size > 1:
        todo = todo[np.argsort(lb[todo], kind="stable")]
    done = []
    for p in todo.tolist():
        if best is not None and lb[p] >= best:
            break
        done.append(p)
        c[p] = core_distance(pairs, p, oMi, A[p], B[p], request, result)
        X[p] = result.getNearestPoint2()
        N[p] = result.normal
        if best is not None and c[p] < best:
            best = c[p]
    if done:
        AB = B[done] - A[done]
        L2 = _einsum("ij,ij->i", AB, AB)
        num = _einsum("ij,ij->i", X[done] - A[done], AB)
        s[done] = np.clip(np.divide(num, L2, out=np.zeros_like(num), where=L2 > 1e-24), 0.0, 1.0)
    return KindPairs(c, pairs.seg, s, N, A, B) if witness else KindPairs(c)
