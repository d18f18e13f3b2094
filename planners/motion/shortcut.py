"""Path simplification: random shortcuts, partial (one-joint) shortcuts, corner cutting and vertex removal,
all certified.

A path is its waypoints ``Q`` ``(k, nq)`` with the :class:`~.clearance.Clearance` of
each (:class:`~.edges.EdgeCertifier`); its length is the joint-space length
``sum_i |Q[i+1] - Q[i]|`` (rad, Euclidean). Every new segment is certified, and a
piece of a certified segment is certified, so the path stays certified.

* **Shortcut** (Geraerts & Overmars 2007): two arc-length positions ``t1 < t2``
  drawn uniformly on different segments; the stretch between their points is
  replaced by the straight segment when that is shorter and certified.
* **Partial shortcut**: the same draw and one joint ``j``; on the stretch, joint
  ``j`` is replaced by its linear interpolation (in arc length) between the two
  points, the other joints keep their path; kept when shorter and every new
  segment is certified (stretches of at most :data:`PARTIAL_MAX_VERTICES` inner
  waypoints).
* **Corner cutting** (a smoothing pass): each inner waypoint ``Q[i]`` in turn moves
  to the midpoint of its neighbours, ``(Q[i-1] + Q[i+1]) / 2`` (``Q[i-1]`` as already
  moved), when that shortens the path by at least :data:`CORNER_MIN_GAIN` and both new
  segments are certified. The path then runs straight where the
  corner was, as if the waypoint had been dropped, but as two segments, each with its
  own certificate: a straight run that grazes an obstacle too long for one
  certificate of at most :data:`SHORTCUT_ADVANCES` advances may pass as two, and the
  next corner is cut from the midpoint, a shorter cut than from the waypoint before.
* **Vertex removal**: each inner waypoint in turn is dropped when the segment that
  joins its neighbours is certified (it is never longer); a waypoint on that segment
  already (the runs of RRT-Connect's connect steps) without a new certificate.

A new segment whose certificate needs more than :data:`SHORTCUT_ADVANCES`
advances (one that grazes an obstacle) is given up, like one in collision.

The draws come from the ``numpy.random.Generator`` passed in; the work is bounded
by counts of attempts, not by the clock.
"""

from __future__ import annotations

from bisect import bisect_right
from typing import NamedTuple

import numpy as np

from .clearance import Clearance
from .edges import EdgeCertifier

#: Random shortcut attempts.
SHORTCUT_ATTEMPTS = 40
#: Partial (one joint) shortcut attempts.
PARTIAL_ATTEMPTS = 6
#: Attempts in a row without a gain after which a series of attempts stops.
FRUITLESS = 10
#: Most inner waypoints of a stretch a partial shortcut rewrites.
PARTIAL_MAX_VERTICES = 4
#: Smallest length gain (rad) for which a shortcut is tried.
MIN_GAIN = 1e-6
#: Smallest length gain (rad) for which a corner is cut: a smaller one is not worth its two certificates.
CORNER_MIN_GAIN = 1e-3
#: Most advances of the certificate of one new segment (:meth:`~.edges.EdgeCertifier.certify`): a
#: segment that grazes an obstacle needs many; the simplifier gives it up instead.
SHORTCUT_ADVANCES = 24


class CertifiedPath(NamedTuple):
    """Waypoints ``points`` ``(k, nq)`` and the :class:`~.clearance.Clearance` of each."""

    points: np.ndarray
    clearances: list[Clearance]


def path_length(points: np.ndarray) -> float:
    """Joint-space length ``sum_i |Q[i+1] - Q[i]|`` (rad, Euclidean) of waypoints ``(k, nq)``."""
    Q = np.asarray(points, dtype=float)
    return float(np.linalg.norm(np.diff(Q, axis=0), axis=1).sum()) if len(Q) > 1 else 0.0


def _arc(points: np.ndarray) -> np.ndarray:
    """Cumulative arc length ``(k,)`` at the waypoints (0 first)."""
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])


def _segment(arc: list[float], t: float) -> int:
    """Segment ``i`` holding arc length ``t`` (``arc``: :func:`_arc` as a list): the last waypoint at or
    before ``t``, clamped to the segments."""
    return min(max(bisect_right(arc, t) - 1, 0), len(arc) - 2)


def _point_at(points: np.ndarray, arc: list[float], i: int, t: float) -> np.ndarray:
    """The point at arc length ``t`` on segment ``i``."""
    length = arc[i + 1] - arc[i]
    f = 0.0 if length <= 0.0 else (t - arc[i]) / length
    return points[i] + f * (points[i + 1] - points[i])


def _draw(path: CertifiedPath, rng: np.random.Generator):
    """Two positions on different segments: ``(i, qa, t1, j, qb, t2, arc)``, or None."""
    arc = _arc(path.points)
    t1, t2 = sorted((rng.random(2) * arc[-1]).tolist())
    at = arc.tolist()
    i, j = _segment(at, t1), _segment(at, t2)
    if i == j:
        return None
    return i, _point_at(path.points, at, i, t1), t1, j, _point_at(path.points, at, j, t2), t2, arc


def _splice(path: CertifiedPath, i: int, j: int, points: list, clearances: list) -> CertifiedPath:
    """``path`` with the waypoints after ``i`` up to ``j`` replaced by ``points``."""
    Q = np.concatenate([path.points[:i + 1], np.array(points), path.points[j + 1:]])
    return CertifiedPath(Q, path.clearances[:i + 1] + list(clearances) + path.clearances[j + 1:])


def try_shortcut(path: CertifiedPath, certifier: EdgeCertifier, rng: np.random.Generator) -> CertifiedPath:
    """One random shortcut attempt (module docstring): the new path, or ``path`` unchanged."""
    drawn = _draw(path, rng)
    if drawn is None:
        return path
    i, qa, t1, j, qb, t2, _ = drawn
    if (t2 - t1) - float(np.linalg.norm(qb - qa)) < MIN_GAIN or certifier.blocked(qa, qb):
        return path
    ca, cb = certifier.clearance(qa), certifier.clearance(qb)
    if not certifier.certify(ca, cb, probe=False, max_advances=SHORTCUT_ADVANCES):
        return path
    return _splice(path, i, j, [qa, qb], [ca, cb])


def try_partial_shortcut(path: CertifiedPath, certifier: EdgeCertifier,
                         rng: np.random.Generator) -> CertifiedPath:
    """One partial (one joint) shortcut attempt (module docstring): the new path, or ``path`` unchanged."""
    drawn = _draw(path, rng)
    joint = int(rng.integers(path.points.shape[1]))
    if drawn is None:
        return path
    i, qa, t1, j, qb, t2, arc = drawn
    if j - i > PARTIAL_MAX_VERTICES:
        return path
    inner = path.points[i + 1:j + 1].copy()
    inner[:, joint] = qa[joint] + (arc[i + 1:j + 1] - t1) / (t2 - t1) * (qb[joint] - qa[joint])
    stretch = np.concatenate([[qa], inner, [qb]])
    if (t2 - t1) - path_length(stretch) < MIN_GAIN:
        return path
    if any(certifier.blocked(a, b) for a, b in zip(stretch[:-1], stretch[1:])):
        return path
    clear = [certifier.clearance(q) for q in stretch]
    if not all(certifier.certify(a, b, probe=False, max_advances=SHORTCUT_ADVANCES)
               for a, b in zip(clear[:-1], clear[1:])):
        return path
    return _splice(path, i, j, list(stretch), clear)


def remove_vertices(path: CertifiedPath, certifier: EdgeCertifier) -> CertifiedPath:
    """Drop each inner waypoint, first to last, whose neighbours are joined by a certified segment: one on
    the segment already (:meth:`~.edges.EdgeCertifier.on_chord`: its two certified edges are that segment)
    without a new certificate."""
    Q, C = list(path.points), list(path.clearances)
    k = 1
    while k < len(Q) - 1:
        if certifier.on_chord(Q[k - 1], Q[k], Q[k + 1]) \
                or certifier.certify(C[k - 1], C[k + 1], max_advances=SHORTCUT_ADVANCES):
            del Q[k], C[k]
        else:
            k += 1
    return CertifiedPath(np.array(Q), C)


def cut_corners(path: CertifiedPath, certifier: EdgeCertifier) -> CertifiedPath:
    """Corner cutting (module docstring): each inner waypoint, first to last, moves to the midpoint of its
    neighbours (the one before it as already moved) when that shortens the path by at least
    :data:`CORNER_MIN_GAIN` and both new segments are certified. Never longer than ``path``, with the same
    ends."""
    Q, C = list(path.points), list(path.clearances)
    for i in range(1, len(Q) - 1):
        a, v, b = Q[i - 1], Q[i], Q[i + 1]
        c = 0.5 * (a + b)
        gain = float(np.linalg.norm(v - a) + np.linalg.norm(b - v) - np.linalg.norm(b - a))
        if gain < CORNER_MIN_GAIN or certifier.blocked(a, c) or certifier.blocked(c, b):
            continue
        cc = certifier.clearance(c)
        if (certifier.clear(cc)
                and certifier.certify(C[i - 1], cc, probe=False, max_advances=SHORTCUT_ADVANCES)
                and certifier.certify(cc, C[i + 1], probe=False, max_advances=SHORTCUT_ADVANCES)):
            Q[i], C[i] = c, cc
    return CertifiedPath(np.array(Q), C)


def _attempts(path: CertifiedPath, attempt, certifier: EdgeCertifier, rng: np.random.Generator,
              count: int) -> CertifiedPath:
    """Up to ``count`` calls ``attempt(path, certifier, rng)``, stopping after :data:`FRUITLESS` in a row that
    change nothing or when the path is one segment."""
    idle = 0
    for _ in range(count):
        if len(path.points) <= 2 or idle >= FRUITLESS:
            break
        new = attempt(path, certifier, rng)
        idle = idle + 1 if new is path else 0
        path = new
    return path


def simplify_path(path: CertifiedPath, certifier: EdgeCertifier, rng: np.random.Generator) -> CertifiedPath:
    """Vertex removal and corner cutting, :data:`SHORTCUT_ATTEMPTS` shortcuts, :data:`PARTIAL_ATTEMPTS`
    partial shortcuts (each series stops after :data:`FRUITLESS` attempts in a row without a gain), then
    corner cutting again; never longer than ``path``, with the same ends. (No last vertex removal: after the
    corner cutting it gains little length for its certificates of long segments.)"""
    path = cut_corners(remove_vertices(path, certifier), certifier)
    path = _attempts(path, try_shortcut, certifier, rng, SHORTCUT_ATTEMPTS)
    path = _attempts(path, try_partial_shortcut, certifier, rng, PARTIAL_ATTEMPTS)
    return cut_corners(path, certifier)


__all__ = ["CORNER_MIN_GAIN", "FRUITLESS", "MIN_GAIN", "PARTIAL_ATTEMPTS", "PARTIAL_MAX_VERTICES",
           "SHORTCUT_ADVANCES", "SHORTCUT_ATTEMPTS", "CertifiedPath", "cut_corners",
           "path_length", "remove_vertices", "simplify_path", "try_partial_shortcut", "try_shortcut"]
