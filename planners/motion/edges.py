"""Certified edges: a straight joint-space motion ``q_a -> q_b`` proved collision free as a continuous motion.

The bound (:mod:`.reach`): for every checked pair ``p`` of the scene and any two
configurations, ``d_p(q') >= d_p(q) - W[p] . |q' - q|`` (``d_p``: signed distance, m).
On the edge ``q(s) = q_a + s u``, ``u = q_b - q_a``, ``s in [0, 1]``, pair ``p`` changes by
at most ``w_p |s' - s|`` with ``w_p = W[p] . |u|``, so a configuration ``q(s)`` with
(lower bounds of its) distances ``d`` certifies the whole interval ``|s' - s| <= rho``,

    ``rho = min_p (d_p - TOLERANCE) / w_p``  (pairs with ``w_p = 0`` do not move),

on which every pair keeps a distance of at least :data:`~.clearance.TOLERANCE` (m,
above coal's distance error; :meth:`~.clearance.ClearanceOracle.radius`).
**Conservative advancement** from both ends, with look-ahead (:func:`advance`):
``[0, lo]`` and ``[hi, 1]`` are certified; the distances at ``q(s)``, ``s`` a fraction
(:data:`~kinserve.kinematics.motion_kernels.LOOKAHEAD`) of the last ``rho`` beyond
``lo``, advance ``lo`` to ``s + rho`` when ``s - rho <= lo``, those on the other side
move ``hi`` back likewise, until ``lo >= hi``. The intervals join without a gap: each
new end is that of a ball that reaches the interval before it. A configuration closer
than :data:`~.clearance.CLEARANCE_FLOOR` (m) to anything stops the advance and rejects
the edge, as do :data:`MAX_ADVANCES` steps.

Three stages, cheapest first:

1. the scene's broad-phase / sphere pre-check ``in_collision`` at :data:`PROBES`
   interior points rejects most bad edges before any distance is asked;
2. the same advancement on the sphere bounds alone, pair by pair, in one
   compiled call (:func:`~kinserve.kinematics.motion_kernels.motion_hard_pairs`:
   per sphere centre the rate ``sum_k R[s, k] |u_k|`` of
   :func:`~kinserve.kinematics.robot_spheres.sphere_reach`, tighter than the
   geometry's, lowered to the motion's own bound from the centres' distances to
   the joint axes at its two ends
   (:func:`~kinserve.kinematics.motion_kernels.motion_rates`); each pair keeps
   its own certified ends, so a pair far from everything is done in one or two
   evaluations and only the close ones advance in small steps), certifies every
   pair it can; the pairs whose spheres stop (their bound too small to advance)
   are handed over, up to :data:`HARD_PAIRS` of them (:meth:`EdgeCertifier.hard_pairs`);
3. the handed-over pairs alone advance on the distances of the shapes
   themselves (:meth:`EdgeCertifier.certify_pairs`), with the pair rates of the
   stretch they cover (:meth:`EdgeCertifier.stretch_rates`: ``W[p] . |u|`` or,
   lower, the stretch's own bound from the geometries' distances to the joint
   axes at its two ends): in one compiled call on GJK's lower bounds of the
   distances between the convex shapes
   (:func:`~kinserve.kinematics.motion_kernels.advance_on_distances`, the
   algorithm of :func:`advance`; never above the true distance, within a few
   micrometres of coal's), or, for a pair of shapes it does not measure (a
   cylinder of the robot, an obstacle mesh), in :func:`advance` on coal's
   distances. Each stage certifies its pairs over the whole edge, so together
   they certify every pair. When the spheres hand over too many pairs (or the
   scene has none), every pair advances on bounds refined by coal where they
   decide (:meth:`EdgeCertifier.certify_exactly`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from kinserve.kinematics.motion_kernels import (
    ADVANCE_STATE,
    ASK,
    ASKED,
    CERTIFIED,
    NOT_MEASURED,
    PACE_MARGIN,
    PACE_WINDOW,
    REFUSED,
    advance_answer,
    advance_ask,
    advance_begin,
    advance_on_distances,
    geometry_pair_rates,
    motion_hard_pairs,
)

from .clearance import TOLERANCE, Clearance, ClearanceOracle, PairRates, need_of, pair_rates
from .extend_kernel import COLLIDES, END, STEP_FREE, STEP_UNDECIDED, UNCERTAIN, exact_verdict, probe_segment

#: Most advances of one edge (both ends together) before it is rejected.
MAX_ADVANCES = 400
#: Interior points ``s`` probed by the cheap collision check before the advancement.
PROBES = (0.5, 0.25, 0.75)
#: :data:`PROBES` as the compiled probes take them (read-only).
PROBE_FRACTIONS = np.array(PROBES)
PROBE_FRACTIONS.setflags(write=False)
#: Most advances of the sphere advancement of one edge (:meth:`EdgeCertifier.hard_pairs`; an advance
#: evaluates the pairs due at one point, often a few): the pairs still open after them are handed over.
SPHERE_ADVANCES = 1024
#: Most pairs of one edge the spheres hand over to coal's distances (:meth:`EdgeCertifier.hard_pairs`).
HARD_PAIRS = 16
#: The sphere advancement hands over to the exact one at a radius below this (fraction of the edge).
SPHERE_MIN_STEP = 1e-3
#: A waypoint this close (rad, Euclidean) to the straight segment joining its neighbours lies on it
#: (:meth:`EdgeCertifier.on_chord`).
CHORD_TOLERANCE = 1e-12


class EdgeCertifier:
    """Certified straight edges in one scene (see the module docstring).

    ``oracle``: the scene's :class:`~.clearance.ClearanceOracle` (collision tests, pair distances and their
    counts); ``reach``: the scene's ``(P, nq)`` pair reach table (:func:`~.reach.pair_reach`).
    """

    def __init__(self, oracle: ClearanceOracle, reach: np.ndarray) -> None:
        self.oracle = oracle
        self.reach = np.ascontiguousarray(reach, dtype=float)
        #: The distance each pair must keep at a path's end (:func:`~.clearance.need_of`): the pairs no joint
        #: moves keep their distance whatever the motion, they only have to be apart.
        self.end_need = need_of(self.reach.any(axis=1))
        #: The compiled probes' output buffers (:mod:`~.extend_kernel`): verdict codes and the pairs left to
        #: coal at each point, rewritten by every extension step and every :meth:`blocked` (a certifier serves
        #: one planning call, in one thread: ``plan_motion`` makes its own).
        self.codes = np.empty(END + 1 + len(PROBES), dtype=np.int64)
        self.checks = np.empty((1 + len(PROBES), len(oracle.scene.pairs) + 1), dtype=np.int64)
        #: :func:`~kinserve.kinematics.motion_kernels.advance_on_distances`' counts (advances, distances).
        self.counts = np.zeros(2, dtype=np.int64)

    def in_collision(self, q: np.ndarray) -> bool:
        """The scene's collision test at ``q`` (float ``(nq,)``)."""
        return self.oracle.in_collision(q)

    def clearance(self, q: np.ndarray) -> Clearance:
        """The :class:`~.clearance.Clearance` of ``q``."""
        return self.oracle.clearance(q)

    def clear(self, c: Clearance) -> bool:
        """True when every pair of ``c`` that can move is at least the clearance floor apart (and the others
        are apart)."""
        return self.closest_violation(c) < 0

    def closest_violation(self, c: Clearance) -> int:
        """The closest pair of ``c`` that breaks :meth:`clear`, -1 when none does."""
        return self.oracle.floor_violation(c, self.end_need)

    def rates(self, u: np.ndarray) -> PairRates:
        """The :class:`~.clearance.PairRates` of the motion ``q + s u``: per pair, the bound ``W[p] . |u|`` of
        its distance change per unit ``s``."""
        return pair_rates(self.reach @ np.abs(u))

    def room(self, c: Clearance, direction: np.ndarray) -> float:
        """The largest ``t`` such that ``c.q + t' direction`` is certified free for ``|t'| <= t``."""
        return self.oracle.radius(c, self.rates(direction))

    def on_chord(self, q_a: np.ndarray, q_v: np.ndarray, q_b: np.ndarray) -> bool:
        """True when ``q_v`` lies on the straight segment ``q_a -> q_b``, between its ends and within
        :data:`CHORD_TOLERANCE` (rad) of it. With ``q_a -> q_v`` and ``q_v -> q_b`` certified, the segment
        ``q_a -> q_b`` is then certified too: each of its points is within that distance of a point of the
        two edges, so each pair's distance there is at most ``CHORD_TOLERANCE * max_p |W[p]|`` (about
        1e-11 m) below the :data:`~.clearance.TOLERANCE` (1e-5 m) the edges keep (a segment made so and
        joined again adds as much: still below 1e-8 m after a thousand). The runs of RRT-Connect's connect
        steps are such waypoints (rounding aside)."""
        u, w = q_b - q_a, q_v - q_a
        length2 = float(u @ u)
        if length2 <= 0.0:
            return False
        t = float(w @ u) / length2
        if not 0.0 <= t <= 1.0:
            return False
        off = w - t * u
        return float(off @ off) <= CHORD_TOLERANCE * CHORD_TOLERANCE

    def blocked(self, q_a: np.ndarray, q_b: np.ndarray) -> bool:
        """True when the cheap collision test finds one of the :data:`PROBES` points of ``q_a -> q_b`` in
        collision (the edge is then certainly not free): with a sphere pre-check, one compiled call
        (:func:`~.extend_kernel.probe_segment`); the pairs it leaves uncertain are apart when the compiled
        distances say so clearly (:func:`~.extend_kernel.exact_verdict`), else coal tests them, point by
        point."""
        u = q_b - q_a
        oracle = self.oracle
        pre = oracle.precheck
        if pre is None:
            return any(self.in_collision(q_a + s * u) for s in PROBES)
        codes, checks = self.codes, self.checks
        if not probe_segment(pre.floats, pre.ints, q_a, q_b, PROBE_FRACTIONS, pre.tolerance, codes, checks):
            raise RuntimeError("probe_segment: the certifier's buffers do not fit its scene")
        verdicts = codes[END:END + len(PROBES)].tolist()
        oracle.checks += len(PROBES) - verdicts.count(-1)
        if COLLIDES in verdicts:
            return True
        if UNCERTAIN not in verdicts:
            return False
        if self._exact_verdict(q_a, q_b, with_node=False) == STEP_FREE:  # (clear-cut: coal's answer too)
            return False
        return oracle.coal_decides(lambda k: q_a + PROBES[k] * u, verdicts, checks)

    def step_verdict(self, q_near: np.ndarray, q_new: np.ndarray) -> int:
        """The compiled distances' decision about the extension step ``q_near -> q_new`` whose sphere verdicts
        and uncertain pairs are in :attr:`codes` / :attr:`checks` (:func:`~.extend_kernel.exact_verdict`:
        ``q_new`` above :attr:`end_need` and the probe points apart, where the distances are clear-cut),
        :data:`~.extend_kernel.STEP_UNDECIDED` without them."""
        verdict = self._exact_verdict(q_near, q_new, with_node=True)
        self.oracle.checks += verdict != STEP_UNDECIDED
        return verdict

    def _exact_verdict(self, q_a: np.ndarray, q_b: np.ndarray, with_node: bool) -> int:
        """:func:`~.extend_kernel.exact_verdict` on the uncertain points in :attr:`codes` / :attr:`checks`
        (``q_b`` itself first ``with_node``, then the probe points of ``q_a -> q_b``);
        :data:`~.extend_kernel.STEP_UNDECIDED` without a sphere pre-check or hull table."""
        pre = self.oracle.precheck
        if pre is None or pre.hulls is None:
            return STEP_UNDECIDED
        hulls = pre.hulls
        return int(exact_verdict(pre.floats, pre.ints, hulls.points, hulls.geoms, hulls.radius,
                                 pre.table_rows, q_a, q_b, PROBE_FRACTIONS, with_node, self.end_need,
                                 self.codes, self.checks))

    def hard_pairs(self, qa: np.ndarray, qb: np.ndarray) -> np.ndarray | None:
        """The pairs of the scene (indices) the spheres leave to the exact check on ``qa -> qb``
        (:meth:`sphere_stage`'s), None when the spheres do not get there."""
        stage = self.sphere_stage(qa, qb)
        return None if stage is None else stage[0]

    def sphere_stage(self, qa: np.ndarray, qb: np.ndarray) -> tuple[np.ndarray, float, float] | None:
        """``(hard, lo, hi)``: the pairs of the scene (indices) the spheres leave to the exact check on
        ``qa -> qb``, which they certify on ``[0, lo)`` and ``(hi, 1]`` of ``qa + s (qb - qa)`` all the
        same; every other pair is certified over the whole motion on the sphere bounds alone, in one
        compiled call (:func:`~kinserve.kinematics.motion_kernels.motion_hard_pairs`). None when they do
        not get there (no sphere pre-check, or more than :data:`HARD_PAIRS` pairs left): every pair is then
        checked exactly."""
        pre = self.oracle.precheck
        if pre is None:
            return None
        self.oracle.checks += 1
        out = motion_hard_pairs(pre.floats, pre.ints, pre.sphere_reach, pre.pair_reach, qa, qb, TOLERANCE,
                                SPHERE_MIN_STEP, SPHERE_ADVANCES, HARD_PAIRS)
        h = int(out[0])
        return None if h < 0 else (out[4:4 + h].astype(np.int64), float(out[2]), float(out[3]))

    def certify(self, a: Clearance, b: Clearance, *, probe: bool = True,
                max_advances: int = MAX_ADVANCES) -> bool:
        """True when the straight motion ``a.q -> b.q`` is certified collision free (``a``, ``b``: the
        clearances of its ends, refined in place; module docstring). ``probe``: first run the cheap test at
        the :data:`PROBES` points (False when the caller did: :meth:`blocked`). ``max_advances``: an exact
        advancement is rejected after that many advances (both ends together)."""
        if probe and self.blocked(a.q, b.q):
            return False
        stage = self.sphere_stage(a.q, b.q)
        if stage is None:
            return self.certify_exactly(a, b, max_advances)
        hard, lo, hi = stage
        return not len(hard) or self.certify_pairs(a.q, b.q - a.q, hard, max_advances, lo, hi)

    def certify_pairs(self, qa: np.ndarray, u: np.ndarray, pairs: np.ndarray, max_advances: int,
                      lo: float = 0.0, hi: float = 1.0) -> bool:
        """Conservative advancement of ``qa + s u``, ``s`` in ``[lo, hi]``, on the distances of ``pairs``
        (indices) alone: True when those pairs stay apart over that stretch (a pair that moves keeps
        :data:`~.clearance.CLEARANCE_FLOOR` at every point asked, or the motion is rejected). ``[0, lo)`` and
        ``(hi, 1]``: certified for these pairs already (by the spheres); the whole motion by default. The
        points ``lo`` and ``hi`` themselves are the first two asked. The distances are the compiled lower
        bounds of :func:`~kinserve.kinematics.motion_kernels.advance_on_distances` when it measures every
        pair, else coal's (:meth:`~.clearance.ClearanceOracle.step` in :func:`advance`)."""
        if lo >= hi:
            return True
        w = pair_rates(self.stretch_rates(qa, u, pairs, lo, hi))
        oracle = self.oracle
        pre = oracle.precheck
        if pre is not None and pre.hulls is not None:
            counts = self.counts
            counts[:] = 0
            hulls = pre.hulls
            verdict = advance_on_distances(pre.floats, pre.ints, hulls.points, hulls.geoms, hulls.radius,
                                           pre.table_rows[pairs], qa, u, w.need, w.inverse, w.offset, lo, hi,
                                           max_advances, counts)
            if verdict != NOT_MEASURED:
                oracle.checks += int(counts[0])
                oracle.pair_distances += int(counts[1])
                return verdict == CERTIFIED
        step = oracle.step
        ks, need, inverse, offset = pairs.tolist(), w.need.tolist(), w.inverse.tolist(), w.offset.tolist()
        return advance(lambda s: step(qa + s * u, ks, need, inverse, offset), lo, hi, max_advances)

    def stretch_rates(self, qa: np.ndarray, u: np.ndarray, pairs: np.ndarray, lo: float = 0.0,
                      hi: float = 1.0) -> np.ndarray:
        """Per pair of ``pairs`` (indices), a bound (m per unit ``s``) of how fast its distance can change on
        the stretch ``[lo, hi]`` of ``qa + s u``: the smaller of the global ``W[p] . |u|`` and, with a sphere
        pre-check, the stretch's own bound measured at its two ends
        (:func:`~kinserve.kinematics.motion_kernels.geometry_pair_rates`)."""
        rates = self.reach[pairs] @ np.abs(u)
        pre = self.oracle.precheck
        if pre is not None:
            rates = np.minimum(rates, geometry_pair_rates(pre.floats, pre.ints, pre.sphere_reach, qa, qa + u,
                                                          lo, hi, pairs))
        return rates

    def certify_exactly(self, a: Clearance, b: Clearance, max_advances: int) -> bool:
        """Conservative advancement of ``a.q -> b.q`` on every pair: sphere bounds refined by coal where they
        decide (:meth:`~.clearance.ClearanceOracle.radius`), from both ends."""
        u = b.q - a.q
        w = self.rates(u)
        radius = self.oracle.radius
        lo, back = radius(a, w), radius(b, w)
        if lo < 0.0 or back < 0.0:
            return False
        return advance(lambda s: radius(self.clearance(a.q + s * u), w), lo, 1.0 - back, max_advances,
                       lo, back)


def advance(radius_at: Callable[[float], float], lo: float, hi: float, max_advances: int,
            last_lo: float = 0.0, last_hi: float = 0.0) -> bool:
    """Conservative advancement with look-ahead of a motion certified on ``[0, lo]`` and ``[hi, 1]`` of its
    parameter ``s``: True when the two meet within ``max_advances`` calls ``radius_at(s)`` (the radius ``r``
    that certifies ``[s - r, s + r]``, or ``r < 0``: the motion is refused there, and False is returned).

    The advances alternate, from below first. From below, ``s = lo + LOOKAHEAD r_lo`` (at most ``hi``),
    ``r_lo`` the radius of the last ball that extended ``lo`` (``last_lo`` at first): a ball with ``s - r <=
    lo`` extends ``lo`` to ``s + r``; one that does not reach back to ``lo`` is dropped and the next point
    from below is ``lo`` itself. A ball that reaches ``hi`` moves ``hi`` to ``s - r`` as well. From above
    likewise. Each new ``lo`` or ``hi`` is the end of a ball that joins the certified interval before it,
    so ``[0, lo]`` and ``[hi, 1]`` stay certified without a gap.

    A grazing motion closes the stretch ever more slowly: after :data:`PACE_WINDOW` advances, one whose open
    stretch ``hi - lo`` exceeds :data:`PACE_MARGIN` times what the last :data:`PACE_WINDOW` advances closed,
    scaled to the advances left, is refused (False) without spending them.

    The rules are compiled once (:func:`~kinserve.kinematics.motion_kernels.advance_ask` /
    :func:`~kinserve.kinematics.motion_kernels.advance_answer`, the steps of
    :func:`~kinserve.kinematics.motion_kernels.advance_on_distances` too); this loop asks ``radius_at``.
    A NaN radius refuses the motion."""
    state = np.empty(ADVANCE_STATE)
    advance_begin(state, lo, hi, last_lo, last_hi)
    while True:
        step = advance_ask(state, max_advances)
        if step != ASK:
            return step == CERTIFIED
        if advance_answer(state, float(radius_at(float(state[ASKED])))) == REFUSED:
            return False


__all__ = ["CHORD_TOLERANCE", "HARD_PAIRS", "MAX_ADVANCES", "PROBES", "SPHERE_ADVANCES", "SPHERE_MIN_STEP",
           "PACE_MARGIN", "PACE_WINDOW", "EdgeCertifier", "advance"]
