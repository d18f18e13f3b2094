"""Pair distances at a configuration, asked of coal only where they decide a certificate.

A :class:`Clearance` holds, for one configuration ``q``, a lower bound ``distance[p]``
(m) of every checked pair's signed distance and whether it is coal's exact value
(``exact[p]``). It starts with the bounds of the scene's sphere pre-check
(:func:`kinserve.kinematics.precheck_kernels.pair_lower_bounds`, one compiled call:
spheres fixed in the joint frames that contain every robot geometry, against each
other and against the obstacles' exact point distances; a positive bound is a
true lower bound, a negative one says nothing) - or with every exact distance,
from one ``pinocchio.computeDistances``, when the scene has no pre-check - and is
refined in place, pair by pair, by :meth:`ClearanceOracle.radius`.

``radius(c, rates)`` (the :class:`PairRates` of ``w``): the largest ``|ds|`` such that
every pair keeps at least :data:`TOLERANCE` when pair ``p``'s distance changes by at
most ``w[p] |ds|``,
``rho = min_p (d_p - TOLERANCE) / w_p``, computed as if every distance were exact:
it refines the pairs whose bound would decide ``rho`` (smallest bound-based
``rho`` first, a few at a time) until the smallest one is exact; the other
pairs' bounds already give a larger ``rho``, and exact distances are at least their
bounds, so the answer equals the all-exact one. Pairs whose bound is below
:data:`CLEARANCE_FLOOR` are refined first; ``rho = -1`` when the exact distance of a
pair that moves is (a pair that does not move, ``w_p = 0``, keeps its distance:
it only has to be apart).

Coal's distances are those of the scene's ``GeometryModel`` (the robot's convex
collision model, the obstacles at their poses and the checked pairs), computed on
the oracle's own ``pinocchio.Data`` / ``GeometryData``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np
import pinocchio as pin

from kinserve.kinematics.collision_layout import default_gjk_start
from kinserve.kinematics.precheck_kernels import TOLERANCE, pair_lower_bounds

from .extend_kernel import UNCERTAIN

#: Smallest clearance (m) from which a motion may advance; closer configurations reject it.
CLEARANCE_FLOOR = 1e-4
# TOLERANCE (m, the sphere pre-check's): the distance kept in reserve against the error of coal's distances;
# a certified interval keeps every pair at least this far apart, on the spheres and on coal's distances alike.
#: Pairs refined together by :meth:`ClearanceOracle.radius` per round.
REFINE_BATCH = 4

_compute_distance = pin.computeDistance


class PairRates(NamedTuple):
    """The pair rates of one motion and what :meth:`ClearanceOracle.radius` derives from them, once.

    ``rates`` ``(P,)``: pair ``p``'s distance changes by at most ``rates[p] |ds|`` (m); ``inverse``:
    ``1 / rates`` (0 where a pair does not move); ``offset``: 0, or ``inf`` where a pair does not move
    (so ``(d - TOLERANCE) * inverse + offset`` is every pair's ``rho``); ``need``: the distance each pair
    must keep (m): :data:`CLEARANCE_FLOOR` where it moves, the smallest positive float where not (it only
    has to be apart); ``moving``: whether any pair moves.
    """

    rates: np.ndarray
    inverse: np.ndarray
    offset: np.ndarray
    need: np.ndarray
    moving: bool


def pair_rates(rates: np.ndarray) -> PairRates:
    """The :class:`PairRates` of ``rates`` ``(P,)`` (m per unit of the motion's parameter)."""
    moving = rates > 0.0
    inverse = np.divide(1.0, rates, out=np.zeros_like(rates), where=moving)
    return PairRates(rates, inverse, np.where(moving, 0.0, np.inf), need_of(moving), bool(moving.any()))


def need_of(moving: np.ndarray) -> np.ndarray:
    """The distance each pair must keep (m): :data:`CLEARANCE_FLOOR` where ``moving``, else the smallest
    positive float."""
    return np.where(moving, CLEARANCE_FLOOR, np.finfo(float).tiny)


class Clearance:
    """Configuration ``q`` ``(nq,)``, lower bounds ``distance`` ``(P,)`` (m) of its pair distances and the
    mask ``exact`` ``(P,)`` of those that are coal's values (refined in place).

    Given ``distance`` (and ``exact``: all False when omitted), or ``bounds``: the function that makes the
    first bounds from ``q``, called on the first read of ``distance`` or ``exact`` - most configurations a
    planner meets (tree nodes off the path, shortcut ends) are certified without them, on the motion
    certificates' own bounds (:mod:`.edges`).
    """

    __slots__ = ("q", "_distance", "_exact", "_bounds")

    def __init__(self, q: np.ndarray, distance: np.ndarray | None = None, exact: np.ndarray | None = None,
                 bounds: Callable[[np.ndarray], np.ndarray] | None = None) -> None:
        if distance is None and bounds is None:
            raise ValueError("Clearance: give its distances or the function that makes them")
        self.q = q
        self._distance = distance
        self._exact = exact if exact is not None or distance is None else np.zeros(len(distance), dtype=bool)
        self._bounds = bounds

    def _make(self) -> None:
        self._distance = self._bounds(self.q)
        self._exact = np.zeros(len(self._distance), dtype=bool)

    @property
    def distance(self) -> np.ndarray:
        """Lower bounds ``(P,)`` (m) of the pair distances (coal's exact values where :attr:`exact`)."""
        if self._distance is None:
            self._make()
        return self._distance

    @property
    def exact(self) -> np.ndarray:
        """``(P,)``: True where :attr:`distance` is coal's value."""
        if self._distance is None:
            self._make()
        return self._exact


class ClearanceOracle:
    """Collision tests and pair distances of one scene (module docstring), counted.

    ``checks``: configurations asked (collision tests, clearances and the points of the motion
    certificates' advances); ``distance_checks``: clearances made; ``pair_distances``: pair distances
    computed (coal's, and the compiled ones of the motion certificates).
    """

    def __init__(self, scene: Any) -> None:
        self.scene = scene
        self.n_pairs = len(scene.pairs)
        #: The scene's pre-check arguments (:class:`~kinserve.kinematics.scene_precheck.PrecheckArguments`)
        #: or None: exact distances only.
        self.precheck = scene.precheck() if self.n_pairs else None
        self.model = scene.model
        self.geometry = scene.geometry
        #: The oracle's own coal workspace (the scene's per-thread ones serve its other queries): no other
        #: call can move the placements between a clearance and its refinement. Its forward kinematics run on
        #: the thread's shared ``pinocchio.Data`` right before it places the geometries, in the same call
        #: (a ``Data`` of its own cost 44 MB per plan on TIAGo dual: nv^3 tensors).
        self.data = scene.layout.thread_data()
        self.geometry_data = pin.GeometryData(scene.geometry)
        default_gjk_start(self.geometry_data.distanceRequests)  # same q, same distances
        self.checks = 0
        self.distance_checks = 0
        self.pair_distances = 0
        self._placed: Clearance | None = None  # whose placements ``data`` / ``geometry_data`` hold

    def in_collision(self, q: np.ndarray) -> bool:
        """The scene's collision test at ``q`` (float ``(nq,)``)."""
        self.checks += 1
        return bool(self.scene.in_collision(q))

    def coal_decides(self, point: Callable[[int], np.ndarray], verdicts: list[int],
                     checks: np.ndarray) -> bool:
        """Whether coal finds one of the points the sphere pre-check left uncertain in collision: point ``k``
        is ``point(k)``, its verdict ``verdicts[k]`` (:data:`~.extend_kernel.UNCERTAIN` for those asked, in
        order) and row ``k`` of ``checks`` the pairs to check there (count first; the others are certified
        free at that point): :func:`~.extend_kernel.step_into` and
        :func:`~.extend_kernel.probe_segment`'s answers."""
        pair_hits = self.scene.workspace().pair_hits
        for k, verdict in enumerate(verdicts):
            if verdict == UNCERTAIN and pair_hits(point(k), checks[k, 1:1 + checks[k, 0]].tolist()):
                return True
        return False

    def keeps(self, q: np.ndarray, pairs: np.ndarray, need: np.ndarray) -> bool:
        """True when coal's distance at ``q`` of each pair of ``pairs`` (scene indices) is at least
        ``need[pair]`` (m; :func:`need_of`): a pair in collision (negative distance) does not keep it. The
        pairs a node's sphere bounds leave below the clearance floor (:func:`~.extend_kernel.step_into`).
        :meth:`step`'s test with rates 0 (its radius is then 0 when every pair keeps its need)."""
        ks = pairs.tolist()
        zeros = [0.0] * len(ks)
        return self.step(q, ks, [float(need[k]) for k in ks], zeros, zeros) >= 0.0

    def clearance(self, q: np.ndarray) -> Clearance:
        """The :class:`Clearance` of ``q``: sphere bounds, made on its first read (:meth:`sphere_bounds`),
        or every exact distance without a sphere model."""
        q = np.array(q, dtype=float)
        if self.precheck is not None:
            return Clearance(q, bounds=self.sphere_bounds)
        self.checks += 1
        self.distance_checks += 1
        if not self.n_pairs:
            return Clearance(q, np.zeros(0), np.zeros(0, dtype=bool))
        self._place(q)
        self._placed = None
        pin.computeDistances(self.geometry, self.geometry_data)
        self.pair_distances += self.n_pairs
        d = np.fromiter((r.min_distance for r in self.geometry_data.distanceResults), float, self.n_pairs)
        return Clearance(q, d, np.ones(self.n_pairs, dtype=bool))

    def sphere_bounds(self, q: np.ndarray) -> np.ndarray:
        """The sphere pre-check's lower bounds ``(P,)`` (m) of the pair distances at ``q``
        (:func:`~kinserve.kinematics.precheck_kernels.pair_lower_bounds`): a :class:`Clearance`'s first
        bounds. Counted as a clearance made."""
        self.checks += 1
        self.distance_checks += 1
        return pair_lower_bounds(self.precheck.floats, self.precheck.ints, q)

    def _place(self, q: np.ndarray) -> None:
        pin.forwardKinematics(self.model, self.data, q)
        pin.updateGeometryPlacements(self.model, self.data, self.geometry, self.geometry_data)

    def refine(self, c: Clearance, pairs: np.ndarray) -> None:
        """Replace the bounds of ``pairs`` (indices) in ``c`` by coal's exact distances."""
        if self._placed is not c:
            self._place(c.q)
            self._placed = c
        for k in pairs:
            c.distance[k] = pin.computeDistance(self.geometry, self.geometry_data, int(k)).min_distance
            c.exact[k] = True
        self.pair_distances += len(pairs)

    def step(self, q: np.ndarray, pairs: list[int], need: list[float], inverse: list[float],
             offset: list[float]) -> float:
        """The certified radius ``min_j (d_j - TOLERANCE) * inverse[j] + offset[j]`` at ``q`` of ``pairs``
        (pair indices) from coal's distances ``d_j`` (m), or -1 when one is below ``need[j]``: one advance of
        :meth:`~.edges.EdgeCertifier.certify_pairs` (per pair ``j``: the :class:`PairRates` entries, as
        lists; a few pairs: plain floats, no array per call)."""
        self.checks += 1
        self._place(q)
        self._placed = None
        gm, gd = self.geometry, self.geometry_data
        rho = float("inf")
        for j, k in enumerate(pairs):
            d = _compute_distance(gm, gd, k).min_distance
            self.pair_distances += 1
            if d < need[j]:
                return -1.0
            r = (d - TOLERANCE) * inverse[j] + offset[j]
            if r < rho:
                rho = r
        return rho

    def floor_violation(self, c: Clearance, need: np.ndarray) -> int:
        """Index of the closest pair of ``c`` below the distance it must keep, ``need`` ``(P,)`` (m; see
        :class:`PairRates`), -1 when none is. The bounds below ``need`` are refined first."""
        low = c.distance < need
        if low.any():
            inexact = np.flatnonzero(low & ~c.exact)
            if len(inexact):
                self.refine(c, inexact)
            bad = np.flatnonzero(c.distance < need)
            if len(bad):
                return int(bad[np.argmin(c.distance[bad])])
        return -1

    def radius(self, c: Clearance, rates: PairRates) -> float:
        """``rho`` of ``c`` for the pair rates ``rates`` (module docstring): ``-1`` when a pair is below the
        distance it must keep, ``inf`` when no pair moves."""
        if self.floor_violation(c, rates.need) >= 0:
            return -1.0
        if not rates.moving:
            return float("inf")
        rho = (c.distance - TOLERANCE) * rates.inverse + rates.offset
        while True:
            k = int(np.argmin(rho))
            if c.exact[k]:
                return float(rho[k])
            exact_best = float(np.min(np.where(c.exact, rho, np.inf)))
            batch = np.flatnonzero((rho < exact_best) & ~c.exact)
            if len(batch) > REFINE_BATCH:  # the smallest ones
                batch = batch[np.argpartition(rho[batch], REFINE_BATCH - 1)[:REFINE_BATCH]]
            self.refine(c, batch)
            if np.any(c.distance[batch] < rates.need[batch]):
                return -1.0
            rho[batch] = (c.distance[batch] - TOLERANCE) * rates.inverse[batch] + rates.offset[batch]


__all__ = ["CLEARANCE_FLOOR", "REFINE_BATCH", "TOLERANCE", "Clearance", "ClearanceOracle", "PairRates",
           "need_of", "pair_rates"]
