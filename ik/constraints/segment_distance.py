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
``s = clamp(-c / a)``.

Segment-box (a box centred at the origin of its own frame, half extents
``h``; the segment ``x(s) = a + s u``, ``u = b - a``, in that frame): the
squared distance

    f(s) = sum_i max(|x_i(s)| - h_i, 0)^2

is a convex, piecewise-quadratic function of ``s``; its derivative
``f'(s) / 2 = sum_i u_i phi_i(x_i(s))``, ``phi_i(x) = x - clamp(x, -h_i, h_i)``,
is non-decreasing and linear between the breakpoints ``s = (+-h_i - a_i) / u_i``.
Evaluating ``f'`` at ``0``, ``1`` and the breakpoints in between (sorted) brackets
its zero, and the linear interpolation between the bracketing points *is* the
zero: the minimiser ``s*`` is exact (``s* = 0`` when ``f'(0) > 0``, ``1`` when
``f'(1) <= 0``). The closest box point is ``y = clamp(x(s*), -h, h)`` and the
distance ``|x(s*) - y|`` (0 when the segment meets the box: the penetration
depth needs another method, e.g. coal's EPA). Every function works on
``(P, 3)`` arrays (one row per pair) with no Python loop.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from kinserve.ik import numpy_fast

_EPS = 1e-18
_c_einsum = numpy_fast.einsum


def _dot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Row-wise dot products of ``(P, 3)`` arrays."""
    return _c_einsum("ij,ij->i", u, v)


def point_segment(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(s, x)``: parameter ``(P,)`` and closest point ``(P, 3)`` of each segment ``[a_i, b_i]`` to
    ``c_i``."""
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


_TINY = 1e-300
_uclip = numpy_fast.clip
_fmin, _fmax = np.fmin, np.fmax


def segment_box(a: np.ndarray, b: np.ndarray,
                h: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(s, d, x, y)``: distance ``d`` between each segment ``[a_i, b_i]`` and the box ``|y| <= h_i`` (its
    frame).

    ``s`` is the parameter of the closest point ``x = a + s (b - a)`` of the
    segment, ``y`` the closest point of the box (module docstring); ``d = 0``
    when the segment meets the box. ``a``, ``b``, ``h`` are ``(P, 3)``.

    With the candidates ``S_0 = 0 <= S_1 <= ... <= S_7 = 1`` (the breakpoints,
    clipped to ``[0, 1]``) and ``f'`` linear between them, the zero of the
    non-decreasing ``f'`` is the length of ``{s : f'(s) <= 0}``: the sum over the
    intervals of their length times the fraction ``clamp(-f'_k / (f'_{k+1} - f'_k), 0, 1)``
    where ``f' <= 0`` (1 or 0 on an interval where ``f'`` is constant). Extra
    candidates are harmless (they only split an interval where ``f'`` is linear),
    so an axis with ``u_i = 0`` (no breakpoint) contributes arbitrary ones.
    Internally the pairs run along the last axis (long contiguous loops).
    """
    aT, hT = a.T, h.T
    uT = (b - a).T
    inv = 1.0 / (uT + (uT == 0.0))  # u_i = 0: arbitrary (finite) candidates; inf/nan ones are clipped below
    n = a.shape[0]
    S = np.empty((8, n))
    S[0] = 0.0
    S[7] = 1.0
    nhT = -hT
    np.multiply(hT - aT, inv, out=S[1:4])
    np.multiply(nhT - aT, inv, out=S[4:7])
    _fmax(_fmin(S, 1.0, out=S), 0.0, out=S)  # fmin / fmax map nan (0 * inf) into [0, 1] as well
    S.sort(axis=0)
    X = S * uT[:, None, :]  # (3, 8, P): x(S) - a
    X += aT[:, None, :]
    X -= _uclip(X, nhT[:, None, :], hT[:, None, :])  # phi(x(S))
    X *= uT[:, None, :]
    fp = X[0]
    fp += X[1]
    fp += X[2]  # f'(S) / 2, non-decreasing along each column
    f0 = fp[:-1]
    frac = np.negative(f0)
    frac /= _fmax(fp[1:] - f0, _TINY)
    _uclip(frac, 0.0, 1.0, out=frac)
    frac *= S[1:] - S[:-1]
    s = frac.sum(axis=0)
    x = (s * uT + aT).T
    v = x - _uclip(x, -h, h)
    return s, np.sqrt(_dot(v, v)), x, x - v


def segment_box_distance(a: Sequence[float], b: Sequence[float], h: Sequence[float]) -> tuple[float, float]:
    """``(s, d)`` of :func:`segment_box` for one segment ``[a, b]`` and one box ``h`` (3-sequences of floats).

    The same exact minimisation on plain floats: for a handful of pairs it costs
    less than the vectorised form's fixed overhead. ``f'`` is evaluated at the
    sorted breakpoints until it turns positive; the zero is interpolated on that
    interval.
    """
    a0, a1, a2 = a
    u0, u1, u2 = b[0] - a0, b[1] - a1, b[2] - a2
    h0, h1, h2 = h
    cands = [0.0, 1.0]
    for ai, ui, hi in ((a0, u0, h0), (a1, u1, h1), (a2, u2, h2)):
        if ui != 0.0:
            for e in (hi, -hi):
                t = (e - ai) / ui
                if 0.0 < t < 1.0:
                    cands.append(t)
    cands.sort()

    def fprime(t: float) -> float:  # f'(t) / 2 = sum_i u_i phi_i(a_i + t u_i)
        x0, x1, x2 = a0 + t * u0, a1 + t * u1, a2 + t * u2
        return (u0 * (x0 - h0 if x0 > h0 else x0 + h0 if x0 < -h0 else 0.0)
                + u1 * (x1 - h1 if x1 > h1 else x1 + h1 if x1 < -h1 else 0.0)
                + u2 * (x2 - h2 if x2 > h2 else x2 + h2 if x2 < -h2 else 0.0))

    s = 1.0
    t0, f0 = 0.0, fprime(0.0)
    if f0 > 0.0:
        s = 0.0
    else:
        for t1 in cands[1:]:
            f1 = fprime(t1)
            if f1 > 0.0:
                s = t0 - f0 * (t1 - t0) / (f1 - f0)
                s = 0.0 if s < 0.0 else 1.0 if s > 1.0 else s
                break
            t0, f0 = t1, f1
    x0, x1, x2 = a0 + s * u0, a1 + s * u1, a2 + s * u2
    v0 = x0 - h0 if x0 > h0 else x0 + h0 if x0 < -h0 else 0.0
    v1 = x1 - h1 if x1 > h1 else x1 + h1 if x1 < -h1 else 0.0
    v2 = x2 - h2 if x2 > h2 else x2 + h2 if x2 < -h2 else 0.0
    return s, math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
