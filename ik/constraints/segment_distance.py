"""Closed-form distances between segments and points, vectorised over many pairs.

Point-segment: for the segment ``[a, b]`` and the point ``c`` the closest
point is ``x = a + s (b - a)`` with

    s = clamp((c - a).(b - a) / |b - a|^2, 0, 1)

(``s = 0`` for a degenerate segment). Segment-segment (Ericson, *Real-Time
Collision Detection*, 5.1.9): for ``[p1, q1]`` and ``[p2, q2]`` with
``d1 = q1 - p1``, ``d2 = q2 - p2``, ``r = p1 - p2``, ``a = d1.d1``,
``e = d2.d2``, ``b = d1.d2``, ``c = d1.r``, ``f = d2.r``, the closest
parameters of the infinite lines are ``s = (b f - c e) / (a e - b^2)``,
``t = (b s + f) / e``; ``s`` is clamped to ``[0, 1]``, ``t`` recomputed and
clamped, and ``s`` recomputed from the clamped ``t`` (``s = clamp((b t - c) / a)``).
Parallel segments (``a e - b^2 ~ 0``) take ``s = 0``; a point-like second segment takes
``s = clamp(-c / a)``. Every function works on
``(P, 3)`` arrays (one row per pair) with no Python loop.
"""

from __future__ import annotations

import numpy as np

_EPS = 1e-18


def _dot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", u, v)


def point_segment(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(s, x)``: parameter ``(P,)`` and closest point ``(P, 3)`` of each segment ``[a_i, b_i]`` to ``c_i``."""
    ab = b - a
    L2 = _dot(ab, ab)
    num = _dot(c - a, ab)
    s = np.divide(num, L2, out=np.zeros_like(num), where=L2 > _EPS)
    np.clip(s, 0.0, 1.0, out=s)
    return s, a + s[:, None] * ab


def segment_segment(p1: np.ndarray, q1: np.ndarray, p2: np.ndarray,
                    q2: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(s, t, x, y)``: closest points ``x = p1 + s d1`` and ``y = p2 + t d2`` of each pair of segments."""
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a, e, f = _dot(d1, d1), _dot(d2, d2), _dot(d2, r)
    b, c = _dot(d1, d2), _dot(d1, r)
    den = a * e - b * b
    s = np.divide(b * f - c * e, den, out=np.zeros_like(den), where=den > _EPS * np.maximum(a * e, 1.0))
    np.clip(s, 0.0, 1.0, out=s)
    t = np.divide(b * s + f, e, out=np.zeros_like(e), where=e > _EPS)
    t_clamped = np.clip(t, 0.0, 1.0)
    redo = t_clamped != t
    if redo.any():
        s_new = np.divide(b * t_clamped - c, a, out=np.zeros_like(a), where=a > _EPS)
        np.clip(s_new, 0.0, 1.0, out=s_new)
        s = np.where(redo, s_new, s)
    t = t_clamped
    point2 = e <= _EPS  # the second segment is a point: closest point of the first segment to it
    if point2.any():
        s_pt = np.clip(np.divide(-c, a, out=np.zeros_like(a), where=a > _EPS), 0.0, 1.0)
        s = np.where(point2, s_pt, s)
    return s, t, p1 + s[:, None] * d1, p2 + t[:, None] * d2
