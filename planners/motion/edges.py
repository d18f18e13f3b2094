"""Certified edges: a straight joint-space motion ``q_a -> q_b`` proved collision free as a continuous motion.

The bound (:mod:`.reach`): for every checked pair ``p`` of the scene and any two
configurations, ``d_p(q') >= d_p(q) - W[p] . |q' - q|`` (``d_p``: signed distance, m).
On the edge ``q(s) = q_a + s u``, ``u = q_b - q_a``, ``s in [0, 1]``, pair ``p`` changes by
at most ``w_p |s' - s|`` with ``w_p = W[p] . |u|``, so a configuration ``q(s)`` with
(lower bounds of its) distances ``d`` certifies the whole interval ``|s' - s| <= rho``,

    ``rho = min_p (d_p - TOLERANCE) / w_p``  (pairs with ``w_p = 0`` do not move),

on which every pair keeps a distance of at least :data:`~.clearance.TOLERANCE` (m,
above coal's distance error; :meth:`~.clearance.ClearanceOracle.radius`).
**Conservative advancement** from both ends: ``[0, lo]`` and ``[hi, 1]`` are
certified; the distances at ``q(lo)`` advance ``lo`` by their ``rho``, those at
``q(hi)`` move ``hi`` back, until ``lo >= hi``. The intervals join without a gap:
each new point is the end of the interval before it. A configuration closer than
:data:`~.clearance.CLEARANCE_FLOOR` (m) to anything stops the advance and rejects
the edge, as do :data:`MAX_ADVANCES` steps.

Cheap first: the scene's broad-phase / sphere pre-check ``in_collision`` at
:data:`PROBES` interior points rejects most bad edges before any distance is asked.
"""

from __future__ import annotations

import numpy as np

from .clearance import Clearance, ClearanceOracle, PairRates, need_of, pair_rates

#: Most advances of one edge (both ends together) before it is rejected.
MAX_ADVANCES = 400
#: Interior points ``s`` probed by the cheap collision check before the advancement.
PROBES = (0.5, 0.25, 0.75)


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

    def blocked(self, q_a: np.ndarray, q_b: np.ndarray) -> bool:
        """True when the cheap collision test finds one of the :data:`PROBES` points of ``q_a -> q_b`` in
        collision (the edge is then certainly not free)."""
        u = q_b - q_a
        return any(self.in_collision(q_a + s * u) for s in PROBES)

    def certify(self, a: Clearance, b: Clearance, *, probe: bool = True,
                max_advances: int = MAX_ADVANCES) -> bool:
        """True when the straight motion ``a.q -> b.q`` is certified collision free (``a``, ``b``: the
        clearances of its ends, refined in place). ``probe``: first run the cheap test at the
        :data:`PROBES` points the ends do not certify (False when the caller did: :meth:`blocked`).
        ``max_advances``: the edge is rejected after that many advances (both ends together)."""
        u = b.q - a.q
        w = self.rates(u)
        radius = self.oracle.radius
        lo, back = radius(a, w), radius(b, w)
        if lo < 0.0 or back < 0.0:
            return False
        hi = 1.0 - back
        if lo >= hi:
            return True
        if probe and any(lo < s < hi and self.in_collision(a.q + s * u) for s in PROBES):
            return False
        for _ in range((max_advances + 1) // 2):
            step = radius(self.clearance(a.q + lo * u), w)
            if step < 0.0:
                return False
            lo += step
            if lo >= hi:
                return True
            step = radius(self.clearance(a.q + hi * u), w)
            if step < 0.0:
                return False
            hi -= step
            if lo >= hi:
                return True
        return False


__all__ = ["MAX_ADVANCES", "PROBES", "EdgeCertifier"]
