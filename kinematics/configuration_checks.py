"""Collision checks of configurations in order: the sphere pre-check first, coal on the rest.

:func:`collision_check` binds the four C++ calls of one broad-phase check
(forward kinematics, geometry placements, ``BroadPhaseManager.update``,
``collide`` with a reused callback) once; :func:`check_configurations` runs coal
on every configuration the sphere pre-check (:mod:`.scene_precheck`) cannot
decide, in order, and stops at the first collision. Coal checks only the pairs
the spheres do not certify at that configuration (:func:`pair_test`:
``pinocchio.computeCollision`` pair by pair, the narrow phase the broad phase
would run on them with the same requests), or the whole broad phase when more
than :data:`PAIRWISE_MAX` are left; the few pairs an undecided verdict carries
go to the hulls' compiled distances first (:mod:`.hull_verdict`), which decide
most configurations without coal. The answer is coal's alone: a pair the
pre-check or the hulls certify is one coal finds free, and a configuration
either finds in collision for certain is one coal finds in collision.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
import pinocchio as pin

from .precheck_verdicts import COLLIDING, FREE, UNDECIDED, carried_pairs

if TYPE_CHECKING:
    from .scene_precheck import PrecheckArguments


_forward_kinematics = pin.forwardKinematics
_update_placements = pin.updateGeometryPlacements
_compute_collision = pin.computeCollision

#: Most pairs :func:`pair_test` checks one by one; with more, the broad phase checks every pair (its AABB
#: tests are cheaper than that many narrow-phase calls).
PAIRWISE_MAX = 8


class CoalCheck(NamedTuple):
    """The pieces of one broad-phase collision check, bound once (:func:`collision_check`)."""

    model: pin.Model
    data: pin.Data
    geometry: pin.GeometryModel
    geometry_data: pin.GeometryData
    update: Callable[[bool], None]
    collide: Callable[[Any], bool]
    callback: Any


def collision_check(model: pin.Model, data: pin.Data, gm: pin.GeometryModel, gd: pin.GeometryData,
                    bpm: Any) -> CoalCheck:
    """The :class:`CoalCheck` of a broad-phase manager ``bpm`` over ``gm`` / ``gd``.

    Same answer as ``pinocchio.computeCollisions(model, data, bpm, q, True)`` (which runs these four steps
    in C++) without its resolution among Pinocchio's 50 overloads of ``computeCollisions`` on every call; the
    member calls here have 1 to 3 overloads each. The callback (``CollisionCallBackDefault``, stop at the
    first collision) is reset by the manager at the start of every ``collide``.
    """
    return CoalCheck(model, data, gm, gd, bpm.update, bpm.collide, pin.CollisionCallBackDefault(gm, gd, True))


def coal_test(check: CoalCheck) -> Callable[[np.ndarray], bool]:
    """``hits(q)``: coal's answer at ``q`` - forward kinematics, placements, broad phase, narrow phase (first
    hit) - with the pieces of ``check`` bound to local names."""
    model, data, gm, gd, update, collide, callback = check
    fk, place = _forward_kinematics, _update_placements

    def hits(q) -> bool:
        fk(model, data, q)
        place(model, data, gm, gd)
        update(False)
        return collide(callback)

    return hits


def pair_test(check: CoalCheck) -> Callable[[np.ndarray, list[int]], bool]:
    """``hits(q, pairs)``: whether one of the scene pairs ``pairs`` (a list of pair indices, the others
    being certified free) intersects at ``q``: forward kinematics, placements, then
    ``pinocchio.computeCollision`` on each pair (the pair's own request, security margin 0) up to the first
    hit; the broad phase over every pair when there are more than :data:`PAIRWISE_MAX`."""
    model, data, gm, gd, update, collide, callback = check
    fk, place, one = _forward_kinematics, _update_placements, _compute_collision

    def hits(q, pairs) -> bool:
        fk(model, data, q)
        place(model, data, gm, gd)
        if len(pairs) > PAIRWISE_MAX:
            update(False)
            return collide(callback)
        for k in pairs:
            if one(gm, gd, k):
                return True
        return False

    return hits


def _is_stacked(qs: Any) -> bool:
    """Whether ``qs`` is a float ``(N, nq)`` array (rows the pre-check takes in one compiled call)."""
    return type(qs) is np.ndarray and qs.ndim == 2 and qs.dtype == np.float64


def check_configurations(check: CoalCheck, qs: Sequence[np.ndarray] | np.ndarray,
                         precheck: PrecheckArguments | None = None, uncertified: int | None = None) -> int:
    """Index of the first configuration of ``qs`` in collision, taken in order, or -1 (``check``:
    :func:`collision_check`). ``qs``: a float ``(N, nq)`` array or a sequence of float ``(nq,)`` arrays,
    checked by the caller (:meth:`~.collision_scene.CollisionScene.first_collision`: ``nq`` finite numbers
    each).

    With ``precheck`` (the scene's :class:`~.scene_precheck.PrecheckArguments`), the sphere pre-check runs
    first and coal only on the configurations it cannot certify free, in order: a stacked ``(K, nq)`` float
    array in one compiled call; otherwise the first configuration alone (the IK checks its answer first, the
    likeliest to collide: when it does, no array is built), then the rest in one compiled call
    (``first_uncertified``, resumed after an uncertified configuration coal finds free). An uncertified
    configuration goes to ``classify`` first (an inner ball of the robot deep in an obstacle or in another
    link's: in collision, no coal), then to coal on the pairs the spheres leave (:func:`undecided_pairs`,
    :func:`pair_test`); the first configuration's verdict is not asked twice. ``uncertified``: for stacked
    rows, the first row the pre-check cannot certify when the caller has found it already (the rows before
    it are certified).
    """
    if precheck is None:
        coal_hits = coal_test(check)
        return next((k for k, q in enumerate(qs) if coal_hits(q)), -1)
    hits, decide = _hit_test(check, precheck)
    first, floats, ints, tol = precheck.first_uncertified, precheck.floats, precheck.ints, precheck.tolerance
    if _is_stacked(qs):  # rows already stacked: one call
        k = first(floats, ints, qs, 0, tol) if uncertified is None else uncertified
        return _first_hit_after(hits, precheck, qs, qs, k)
    if not len(qs):
        return -1
    verdict = precheck.classify(floats, ints, qs[0], tol)  # in hand: an undecided one goes to coal at once
    if verdict == COLLIDING or (verdict >= UNDECIDED and decide(qs[0], verdict)):
        return 0
    if len(qs) == 1:
        return -1
    Q = np.stack(qs)
    return _first_hit_after(hits, precheck, Q, qs, first(floats, ints, Q, 1, tol))


def undecided_pairs(verdict: int, uncertified_pairs: Callable[..., np.ndarray], floats: np.ndarray,
                    ints: np.ndarray, q: np.ndarray, tol: float) -> list[int]:
    """The scene pairs coal must check at ``q`` after the pre-check's undecided ``verdict``
    (:func:`~.precheck_kernels.classify_configuration`): the ones it carries, else the list of
    ``uncertified_pairs(floats, ints, q, tol)``."""
    if verdict != UNDECIDED:
        return carried_pairs(verdict)
    return uncertified_pairs(floats, ints, q, tol).tolist()


def _hit_test(check: CoalCheck, precheck: PrecheckArguments) -> tuple[Callable[[np.ndarray], bool],
                                                                      Callable[[np.ndarray, int], bool]]:
    """``(hits(q), decide(q, verdict))`` for a configuration the pre-check did not certify: ``hits`` asks the
    pre-check (an inner ball deep in an obstacle or in another link's answers without coal), then coal on the
    pairs the spheres do not certify; ``decide`` is that coal check after the undecided ``verdict`` of
    :func:`~.precheck_kernels.classify_configuration` (its pairs: :func:`undecided_pairs`; the pairs it
    carries go to the hulls' distances first, :func:`~.hull_verdict.hull_verdict`, which may decide the
    configuration, and coal checks only the pairs they leave open)."""
    classify, pairs_of, tol = precheck.classify, precheck.uncertified_pairs, precheck.tolerance
    floats, ints = precheck.floats, precheck.ints
    coal_hits, pair_hits = coal_test(check), pair_test(check)
    hull_verdict, hull_arguments = precheck.hull_verdict, precheck.hull_arguments

    def decide(q, verdict: int) -> bool:
        if verdict > UNDECIDED and hull_verdict is not None:
            verdict = hull_verdict(floats, ints, *hull_arguments, q, verdict, tol)
            if verdict == FREE or verdict == COLLIDING:
                return verdict == COLLIDING
        return pair_hits(q, undecided_pairs(verdict, pairs_of, floats, ints, q, tol))

    def hits(q) -> bool:
        try:
            verdict = classify(floats, ints, q, tol)
        except TypeError:  # not a float vector: coal decides (and raises as before)
            return coal_hits(q)
        if verdict == COLLIDING or verdict == FREE:
            return verdict == COLLIDING
        return decide(q, verdict)

    return hits, decide


def _first_hit_after(hits: Callable[[np.ndarray], bool], precheck: PrecheckArguments, Q: np.ndarray, qs: Any,
                     k: int) -> int:
    """The first row of ``Q`` from ``k`` (the first row the compiled pre-check cannot certify, ``N`` when
    none) on that ``hits``, coal running only on the rows the pre-check cannot certify (``qs[k]`` is the
    configuration handed to coal)."""
    first, floats, ints, tol = precheck.first_uncertified, precheck.floats, precheck.ints, precheck.tolerance
    N = Q.shape[0]
    while k < N:
        if hits(qs[k]):
            return k
        k = first(floats, ints, Q, k + 1, tol)
    return -1


__all__ = ["PAIRWISE_MAX", "CoalCheck", "check_configurations", "coal_test", "collision_check", "pair_test",
           "undecided_pairs"]
