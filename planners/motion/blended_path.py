"""``BlendedPath``: a certified polyline with its corners rounded inside certified balls, for time scaling.

A waypoint path ``w_0 .. w_{k-1}`` has a corner at each inner waypoint, where a
time-optimal parameterisation must stop (infinite curvature). Each corner ``w``
with incoming and outgoing unit directions ``e_in``, ``e_out`` is replaced by the
quadratic Bezier curve from ``p1 = w - delta e_in`` to ``p2 = w + delta e_out`` with
control point ``w`` (tangent to both segments: the path is C1).

**Why the blend is collision free**: with (lower bounds of) the pair distances ``D``
at ``w`` and the reach table ``W`` (:mod:`.reach`), every ``q`` of the convex set
``C = {q : W[p] . |q - w| <= D_p - TOLERANCE for all p}`` keeps every pair apart
(``d_p(q) >= D_p - W[p] . |q - w|``). Along a unit direction ``e``, ``w + t e`` stays in
``C`` for ``|t| <= room(e) = min_p (D_p - TOLERANCE) / (W[p] . |e|)``
(:meth:`~.edges.EdgeCertifier.room`). ``delta`` is at most the room along ``e_in``
and along ``e_out``, so ``p1`` and ``p2`` lie in ``C`` (:func:`blend_lengths`); the
curve lies in the triangle ``p1, w, p2`` (a Bezier curve lies in the convex hull
of its control points), hence in ``C``, and so does the chord between any two of
its points. The straight parts are pieces of the certified segments.

Parameterised by ``s`` (rad): unit speed on the straight parts; on a blend of
``2 delta`` in ``s``, ``q(sigma) = p1 + e_in sigma + c sigma^2 / 2`` with
``c = (e_out - e_in) / (2 delta)``, so every piece has the form
``q = A + E sigma + C sigma^2 / 2`` (``sigma = s - s0``), ``q_s = E + C sigma``,
``q_ss = C``. ``breaks`` are the ``s`` where pieces meet. The call
``path(s, order)`` follows toppra's geometric path protocol (``dof``,
``path_interval``).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from kinserve.kinematics.errors import InputError

#: Largest part of a segment a blend may take at either end (blends never overlap).
BLEND_FRACTION = 0.5
#: Share of the certified room a blend uses.
BLEND_SAFETY = 0.99
#: Turns (rad, angle between ``e_in`` and ``e_out``) below which a corner is left as it is.
MIN_TURN = 1e-9
#: Straight parts shorter than this (rad) between two blends are dropped (rounding leftovers).
MIN_PIECE = 1e-12


def distinct_points(points: np.ndarray) -> np.ndarray:
    """Indices of the waypoints ``(k, nq)`` that differ from the one before (the first always)."""
    return np.flatnonzero(np.concatenate([[True], np.linalg.norm(np.diff(points, axis=0), axis=1) > 1e-12]))


def corner_directions(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit directions ``(k - 2, nq)`` into and out of each inner waypoint of ``points`` (distinct
    consecutive waypoints)."""
    seg = np.diff(points, axis=0)
    unit = seg / np.linalg.norm(seg, axis=1)[:, None]
    return unit[:-1], unit[1:]


def blend_lengths(points: np.ndarray, room: np.ndarray) -> np.ndarray:
    """``delta`` ``(k,)`` per waypoint (0 at the ends and at straight corners): at most
    :data:`BLEND_FRACTION` of each adjacent segment and :data:`BLEND_SAFETY` of ``room[i]``, the certified
    room of inner waypoint ``i`` along both of its directions (module docstring; ``room[0]``, ``room[-1]``
    unused)."""
    k = len(points)
    delta = np.zeros(k)
    if k < 3:
        return delta
    lengths = np.linalg.norm(np.diff(points, axis=0), axis=1)
    e_in, e_out = corner_directions(points)
    turning = np.linalg.norm(e_out - e_in, axis=1) >= MIN_TURN
    inner = np.minimum(np.minimum(lengths[:-1], lengths[1:]) * BLEND_FRACTION, BLEND_SAFETY * room[1:-1])
    delta[1:-1] = np.where(turning, np.maximum(inner, 0.0), 0.0)
    return delta


class BlendedPath:
    """Waypoints ``(k, nq)`` (distinct consecutive points) with corner blends ``delta`` ``(k,)`` (rad; see
    the module docstring). ``delta = 0`` everywhere gives the polyline itself (corners kept)."""

    def __init__(self, points: ArrayLike, delta: ArrayLike) -> None:
        W = np.asarray(points, dtype=float)
        d = np.asarray(delta, dtype=float)
        seg = np.diff(W, axis=0)
        lengths = np.linalg.norm(seg, axis=1)
        E = seg / lengths[:, None]
        starts, dirs, curv, sizes = [], [], [], []
        for i in range(len(W) - 1):
            if i > 0 and d[i] > 0.0:  # the blend at waypoint i
                starts.append(W[i] - d[i] * E[i - 1])
                dirs.append(E[i - 1])
                curv.append((E[i] - E[i - 1]) / (2.0 * d[i]))
                sizes.append(2.0 * d[i])
            straight = lengths[i] - d[i] - d[i + 1]
            if straight > MIN_PIECE:  # blends that meet leave no straight part (or one of rounding size)
                starts.append(W[i] + d[i] * E[i])
                dirs.append(E[i])
                curv.append(np.zeros(W.shape[1]))
                sizes.append(straight)
        self.points = W
        self.delta = d
        self.starts, self.directions = np.array(starts), np.array(dirs)
        self.curvatures = np.array(curv)
        self.breaks = np.concatenate([[0.0], np.cumsum(sizes)])
        #: Number of pieces (straight parts and blends).
        self.n_pieces = len(sizes)

    @property
    def dof(self) -> int:
        """Number of joints."""
        return self.points.shape[1]

    @property
    def path_interval(self) -> np.ndarray:
        """``[0, S]``: the range of ``s`` (rad)."""
        return np.array([0.0, float(self.breaks[-1])])

    @property
    def length(self) -> float:
        """``S`` (rad): the length of the blended path."""
        return float(self.breaks[-1])

    def __call__(self, s: ArrayLike, order: int = 0) -> np.ndarray:
        """``q`` (order 0), ``q_s`` (1) or ``q_ss`` (2) at ``s`` (scalar -> ``(nq,)``, ``(n,)`` ->
        ``(n, nq)``)."""
        ss = np.asarray(s, dtype=float)
        flat = np.atleast_1d(ss)
        k = np.clip(np.searchsorted(self.breaks, flat, side="right") - 1, 0, self.n_pieces - 1)
        sigma = (flat - self.breaks[k])[:, None]
        if order == 0:
            out = self.starts[k] + self.directions[k] * sigma + 0.5 * self.curvatures[k] * sigma ** 2
        elif order == 1:
            out = self.directions[k] + self.curvatures[k] * sigma
        elif order == 2:
            out = self.curvatures[k].copy()
        else:
            raise InputError(f"order must be 0, 1 or 2, got {order!r}")
        return out[0] if ss.ndim == 0 else out


__all__ = ["BLEND_FRACTION", "BLEND_SAFETY", "MIN_PIECE", "MIN_TURN", "BlendedPath", "blend_lengths",
           "corner_directions", "distinct_points"]
