"""Argument checks shared by the public entry points of :mod:`planners.mobile`.

Thin wrappers over :mod:`kinserve.kinematics.validation`: planar points and
point lists, map objects, simple polygons, and the sample-count bound that
keeps a step size from allocating or looping without limit.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import numpy as np

from kinserve.kinematics.errors import InputError, ShapeError
from kinserve.kinematics.validation import (
    as_count,
    as_numbers,
    as_positive,
    as_rows,
    as_vector,
    check_bounded,
    describe,
)

#: Most samples a step size may produce along a path (or a time step along a trajectory).
MAX_SAMPLES = 10**7


def as_point(value: object, name: str) -> np.ndarray:
    """``value`` as a finite, bounded ``(x, y)`` point (:class:`ShapeError` / :class:`NonFiniteError`)."""
    return as_vector(value, 2, name)


def as_points(value: object, name: str, min_rows: int = 1, single: bool = False) -> np.ndarray:
    """``value`` as a finite, bounded ``(N, 2)`` float array with ``N >= min_rows``.

    With ``single`` one ``(x, y)`` point is accepted too (as a ``(1, 2)`` array).
    """
    if single:
        arr = np.asarray(value) if isinstance(value, (list, tuple, np.ndarray)) else None
        if arr is not None and arr.shape == (2,):
            return as_point(value, name)[None]
    P = as_rows(value, 2, name)
    if len(P) < min_rows:
        raise ShapeError(f"{name} must hold at least {min_rows} (x, y) point(s) "
                         f"(shape (N >= {min_rows}, 2)), got shape {P.shape}")
    return P


def as_headings(value: object, n: int) -> np.ndarray:
    """``value`` as the ``n`` headings (rad) of a path of ``n`` points: :class:`ShapeError` when it is not
    ``n`` numbers (the message says "like the path"), :class:`NonFiniteError` naming the entries that are
    not finite or exceed 1e6 in magnitude."""
    try:
        heading = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ShapeError(f"heading must be {n} angles (rad), got {value!r:.60}") from None
    if heading.shape != (n,):
        raise ShapeError(f"heading must have shape ({n},) like the path, got {heading.shape}")
    check_bounded(heading, "heading")
    return heading


#: Relative tolerance of the orientation predicate of :func:`as_polygon` (an angle in radians; see there).
POLYGON_TOL = 1e-12
#: Most (edge, edge) pairs :func:`as_polygon` tests at once (bounds its memory to a few tens of MB).
_PAIR_CHUNK = 1 << 18
_SIMPLE = "expected a simple polygon: edges meet only at shared corners"


def as_polygon(value: object, what: str, max_vertices: int) -> np.ndarray:
    """``value`` as the ``(k, 2)`` vertices of a simple polygon with ``3 <= k <= max_vertices``.

    ``what`` names the polygon in messages (e.g. ``"polygon 'ramp'"``; the argument is
    ``"<what> vertices"``). Either orientation is accepted, and so is a last vertex equal to the
    first (a closed ring: it is kept, and the checks below run on the ring without it). Edge ``i``
    joins vertex ``i`` to vertex ``i + 1`` (the last edge joins the last vertex to the first).

    Refused: not a numeric ``(k, 2)`` array, or ``k`` out of range (:class:`ShapeError`); non-finite
    or huge (``|x| > 1e6``) numbers (:class:`NonFiniteError`); and with :class:`InputError` naming the
    argument: a vertex equal to the one before it; all vertices on one line, or an area of at most
    ``1e-12 * extent**2`` (zero area); two edges that cross or touch anywhere but at the corner shared
    by consecutive edges - non-adjacent edges that intersect (including collinear overlaps and a vertex
    lying on a non-adjacent edge), or consecutive edges that fold back onto each other (the message
    gives both edges' indices and end points).

    Numerical care: the orientation of three points ``a, b, c`` is the sign of the float
    ``(a - c) x (b - c)``, counted as zero (collinear) when its magnitude is at most
    :data:`POLYGON_TOL` ``* |a - c| |b - c|``, i.e. when the angle at ``c`` is within about ``1e-12`` rad
    of 0 or pi. That band is far wider than the rounding error of the float expression (Shewchuk's
    bound, at most ``3.4e-16`` times the same scale), so every non-zero sign is the exact one, and a zero sign
    is always treated as "possibly touching": a polygon that is not simple in exact arithmetic is
    always refused, and a simple one is refused only when it is within that tolerance of touching
    itself (collinear edges whose projections overlap within ``1e-12`` of an edge's length, or a
    vertex practically on a non-adjacent edge). Edge pairs whose bounding boxes do not meet are never
    tested. The test is vectorised over all ``O(k^2)`` pairs, in chunks of :data:`_PAIR_CHUNK`, so
    ``max_vertices`` bounds both its time and memory.
    """
    V = np.array(as_rows(value, 2, f"{what} vertices"), dtype=float)
    if not 3 <= V.shape[0] <= max_vertices:
        raise ShapeError(f"{what} needs vertices of shape (k, 2) with 3 <= k <= {max_vertices}, "
                         f"got {V.shape}")
    name = f"{what} vertices"
    same = np.flatnonzero(np.all(V[1:] == V[:-1], axis=1))
    if len(same):
        k = int(same[0]) + 1
        raise InputError(f"{name}: vertex {k} {tuple(V[k].tolist())} repeats vertex {k - 1}; {_SIMPLE} "
                         "(no repeated consecutive vertices; only a last vertex equal to the first, "
                         "closing the ring, is accepted)")
    ring = V[:-1] if np.all(V[-1] == V[0]) else V
    extent = float(np.ptp(V, axis=0).max())
    zero_area = (f"{what} has zero area (collinear vertices {tuple(map(tuple, V[:4].tolist()))}...): "
                 "it needs at least three vertices not on one line")
    if _collinear(ring):
        raise InputError(zero_area)
    pair = _touching_edges(ring)
    if pair is not None:
        i, j = pair
        n = len(ring)

        def edge(e: int) -> str:
            return f"{e} {tuple(ring[e].tolist())}-{tuple(ring[(e + 1) % n].tolist())}"
        raise InputError(f"{name}: edges {edge(i)} and {edge(j)} cross or touch (edge i joins vertex i to "
                         f"vertex i + 1); {_SIMPLE}")
    if not shoelace_area(V) > 1e-12 * extent * extent:  # a sliver, simple but too thin to have an area
        raise InputError(zero_area)
    return V


def shoelace_area(V: np.ndarray) -> float:
    """Area of the polygon with vertices ``V`` ``(k, 2)`` by the shoelace formula (absolute value)."""
    return float(0.5 * abs(np.dot(V[:, 0], np.roll(V[:, 1], -1)) - np.dot(V[:, 1], np.roll(V[:, 0], -1))))


def _orientation(ax: np.ndarray, ay: np.ndarray, bx: np.ndarray, by: np.ndarray, cx: np.ndarray,
                 cy: np.ndarray) -> np.ndarray:
    """Sign (-1, 0 or 1, int8) of ``(a - c) x (b - c)`` for points given by their x and y arrays
    (broadcast together); 0 within the relative band of :data:`POLYGON_TOL` (see :func:`as_polygon`)."""
    ux, uy, vx, vy = ax - cx, ay - cy, bx - cx, by - cy
    det = ux * vy - uy * vx
    band = np.sqrt((ux * ux + uy * uy) * (vx * vx + vy * vy))
    band *= POLYGON_TOL
    return (det > band).view(np.int8) - (det < -band).view(np.int8)


def _collinear(ring: np.ndarray) -> bool:
    """True when every vertex is on the line through vertex 0 and the vertex farthest from it."""
    x, y = ring[:, 0], ring[:, 1]
    far = int(np.argmax(np.hypot(x - x[0], y - y[0])))
    return not np.any(_orientation(x[0], y[0], x[far], y[far], x, y))


def _segments_touch(p1: tuple[np.ndarray, np.ndarray], p2: tuple[np.ndarray, np.ndarray],
                    p3: tuple[np.ndarray, np.ndarray], p4: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """Whether segments ``p1 p2`` and ``p3 p4`` (each point an ``(x, y)`` pair of arrays) intersect,
    touching included.

    The exact rule with :func:`_orientation`'s signs (a zero sign may stand for either sign, so the
    rule errs towards "touch"): the segments meet when neither lies strictly on one side of the
    other's line; when all four signs are zero (collinear) they meet when their projections on
    ``p3 p4`` overlap, within ``POLYGON_TOL`` of its length.
    """
    d1, d2 = _orientation(*p3, *p4, *p1), _orientation(*p3, *p4, *p2)
    meet = d1 * d2 <= 0  # p1 p2 not strictly on one side of the line p3 p4: only these pairs go on
    k = np.flatnonzero(meet)
    p1, p2, p3, p4 = ((x[k], y[k]) for x, y in (p1, p2, p3, p4))
    d3, d4 = _orientation(*p1, *p2, *p3), _orientation(*p1, *p2, *p4)
    collinear = (d1[k] == 0) & (d2[k] == 0) & (d3 == 0) & (d4 == 0)
    meet[k] = (d3 * d4 <= 0) & ~collinear
    if collinear.any():
        c = k[collinear]
        p1, p2, p3, p4 = ((x[collinear], y[collinear]) for x, y in (p1, p2, p3, p4))
        ex, ey = p4[0] - p3[0], p4[1] - p3[1]
        length2 = ex * ex + ey * ey
        s1 = (p1[0] - p3[0]) * ex + (p1[1] - p3[1]) * ey
        s2 = (p2[0] - p3[0]) * ex + (p2[1] - p3[1]) * ey
        meet[c] = ((np.maximum(s1, s2) >= -POLYGON_TOL * length2)
                   & (np.minimum(s1, s2) <= (1 + POLYGON_TOL) * length2))
    return meet


def _touching_edges(ring: np.ndarray) -> tuple[int, int] | None:
    """The first pair ``(i, j)``, ``i < j``, of edges of the closed ring that cross or touch other than
    at the corner shared by consecutive edges, or None (see :func:`as_polygon`).

    Consecutive edges first: they fold onto each other when their corner has an angle of zero.
    Then every non-adjacent pair whose bounding boxes meet, a chunk of rows ``i`` at a time.
    """
    n = len(ring)
    x, y = np.ascontiguousarray(ring[:, 0]), np.ascontiguousarray(ring[:, 1])
    x1, y1 = np.roll(x, -1), np.roll(y, -1)
    x0, y0 = np.roll(x, 1), np.roll(y, 1)
    fold = (_orientation(x0, y0, x1, y1, x, y) == 0) & ((x0 - x) * (x1 - x) + (y0 - y) * (y1 - y) > 0)
    if fold.any():
        k = int(np.argmax(fold))
        return ((k - 1) % n, k) if k > 0 else (0, n - 1)
    lox, hix = np.minimum(x, x1), np.maximum(x, x1)
    loy, hiy = np.minimum(y, y1), np.maximum(y, y1)
    rows = max(1, _PAIR_CHUNK // n)
    for start in range(0, n - 2, rows):
        r, c = slice(start, min(n - 2, start + rows)), slice(start + 2, n)  # pairs (i, j) with j >= i + 2
        cand = ((lox[c] <= hix[r, None]) & (lox[r, None] <= hix[c])
                & (loy[c] <= hiy[r, None]) & (loy[r, None] <= hiy[c]))
        cand &= np.arange(cand.shape[1]) >= np.arange(cand.shape[0])[:, None]
        if start == 0:
            cand[0, -1] = False  # edges 0 and n - 1 are consecutive
        ii, jj = np.nonzero(cand)
        ii += start
        jj += start + 2
        touch = _segments_touch((x[ii], y[ii]), (x1[ii], y1[ii]), (x[jj], y[jj]), (x1[jj], y1[jj]))
        hit = np.flatnonzero(touch)
        if len(hit):
            return int(ii[hit[0]]), int(jj[hit[0]])
    return None


def check_samples(count: float, name: str, value: float, what: str, maximum: int = MAX_SAMPLES) -> None:
    """:class:`InputError` when a step ``value`` (argument ``name``) would give ``count > maximum``
    samples over ``what`` (e.g. "this 12.5 m path"); the message gives the smallest accepted step."""
    if not count <= maximum:  # also refuses NaN
        smallest = value * count / maximum
        raise InputError(f"{name} must be at least {smallest:.3g} ({maximum:,} samples at most over {what}), "
                         f"got {value!r}")


def as_indices(values: Iterable[object] | None, name: str, size: int) -> list[int]:
    """``values`` as a list of indices in ``[0, size)`` (each an integer; :class:`InputError` naming it)."""
    if values is None or isinstance(values, (str, bytes, dict)) or not isinstance(values, Iterable):
        raise InputError(f"{name} must be a sequence of indices, got {describe(values)}")
    out = []
    for k, v in enumerate(values):
        if size == 0:
            raise InputError(f"{name}[{k}] = {v!r}: there are no points to index")
        out.append(as_count(v, f"{name}[{k}]", minimum=0, maximum=size - 1))
    return out


def polyline_samples(P: np.ndarray, step: float) -> float:
    """How many samples a step ``step`` gives along the polyline ``P`` (one per segment at least)."""
    if len(P) < 2:
        return 1.0
    lengths = np.linalg.norm(np.diff(P, axis=0), axis=1)
    return float(np.sum(np.maximum(1.0, np.ceil(lengths / step)))) + 1.0


def describe_length(P: np.ndarray) -> str:
    """The phrase ``this <length> long path`` for messages."""
    L = float(np.sum(np.linalg.norm(np.diff(P, axis=0), axis=1))) if len(P) > 1 else 0.0
    return f"this {L:.6g} long path"


#: Most output times of a drive simulation (``t_eval``).
MAX_EVAL_TIMES = 10**6
#: Most wheel-speed evaluations of one drive simulation (a bound on its run time).
MAX_RHS_EVALUATIONS = 200_000


def simulation_arguments(wheel_speeds: object, n_wheels: int, pose0: object, t_span: object,
                         t_eval: object, rtol: object, atol: object
                         ) -> tuple[Callable[[float], np.ndarray], np.ndarray, tuple[float, float],
                                    np.ndarray | None, float, float]:
    """Checked arguments of a base's ``simulate``: ``(f, pose0, t_span, t_eval, rtol, atol)``.

    ``f(t)`` returns the wheel speeds as a finite vector of ``n_wheels`` numbers
    (a callable's output is checked at every call). Refused: wheel speeds,
    ``pose0`` (3 numbers), ``t_span`` (2 distinct times) not finite with
    ``|x| <= 1e6``; ``t_eval`` not None or 1 to 10**6 times as :func:`as_times`
    accepts them; ``rtol`` not in ``(0, 1]``; ``atol`` not in ``(0, 1e6]``.
    ``f`` raises :class:`InputError` once called more than
    :data:`MAX_RHS_EVALUATIONS` times (a span too long for the motion and
    tolerance: the integration would not end in reasonable time).
    """
    calls = [0]
    limit = MAX_RHS_EVALUATIONS
    if callable(wheel_speeds):
        user = wheel_speeds

        def speeds(t: float) -> np.ndarray:
            return as_vector(user(t), n_wheels, f"wheel_speeds({t:g})")
    else:
        w = as_vector(wheel_speeds, n_wheels, "wheel_speeds")

        def speeds(t: float) -> np.ndarray:
            return w

    def f(t: float) -> np.ndarray:
        calls[0] += 1
        if calls[0] > limit:
            raise InputError(f"the simulation over t_span {list(span.tolist())} needs more than {limit:,} "
                             f"evaluations (reached t = {t:.6g}): shorten t_span, slow the wheels or raise "
                             "rtol / atol")
        return speeds(t)
    p0 = as_vector(pose0, 3, "pose0")
    span = as_vector(t_span, 2, "t_span")
    if span[0] == span[1]:
        raise InputError(f"t_span must be (t0, t1) with t0 != t1, got {span.tolist()}")
    t_eval = None if t_eval is None else as_times(t_eval, span)
    rtol = as_positive(rtol, "rtol", maximum=1.0)
    atol = as_positive(atol, "atol")
    return f, p0, (float(span[0]), float(span[1])), t_eval, rtol, atol


def as_times(t_eval: object, span: np.ndarray) -> np.ndarray:
    """``t_eval`` as the output times of a simulation over ``span = (t0, t1)``: a 1-D array of 1 to
    :data:`MAX_EVAL_TIMES` finite numbers (not bools; :class:`ShapeError` / :class:`NonFiniteError`) inside
    ``span``, strictly increasing when ``t0 < t1`` and strictly decreasing when ``t0 > t1`` (the direction
    of the integration, as ``scipy.integrate.solve_ivp`` needs; :class:`InputError`)."""
    te = as_numbers(t_eval, "t_eval")
    if te.ndim != 1 or not 1 <= len(te) <= MAX_EVAL_TIMES:
        raise ShapeError(f"t_eval must be a 1-D array of 1 to {MAX_EVAL_TIMES:,} times, got shape {te.shape}")
    lo, hi = min(span), max(span)
    if np.any((te < lo) | (te > hi)):
        raise InputError(f"t_eval must lie within t_span {span.tolist()}")
    step = np.diff(te) if span[1] > span[0] else -np.diff(te)
    if np.any(step <= 0):
        k = int(np.argmax(step <= 0))
        order = "increasing" if span[1] > span[0] else "decreasing (t_span runs backwards)"
        raise InputError(f"t_eval must be strictly {order}; t_eval[{k}] = {te[k]:g} and t_eval[{k + 1}] = "
                         f"{te[k + 1]:g}")
    return te
