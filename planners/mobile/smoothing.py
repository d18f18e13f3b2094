"""Smoothing a grid path without entering the inflated obstacles.

An optimal grid path hugs the obstacles (its vertices touch the inflated
boundaries), so a curve fitted straight through it would cut into them at
every bend. The smoother therefore first makes room, then fits, then checks:

1. *Shortcutting* (string pulling): from each kept vertex, jump to the
   farthest following path point whose straight segment is free by the map's
   raster rule - the taut polyline of the grid path.
2. *Relaxation*: the polyline, resampled every ``resolution``, is relaxed by
   a few hundred explicit steps of
   ``p_i += w_s (p_{i-1} - 2 p_i + p_{i+1}) + w_o (m - d(p_i))^+ grad d / |grad d|``
   (discrete curve shortening plus a push away from obstacles closer than the
   margin ``m``; ``d`` is the bilinearly interpolated distance transform of the
   map). A step that would leave the free space is refused for that point.
   End points and ``keep`` points stay fixed.
3. *Spline*: a C2 cubic spline (scipy ``CubicSpline``, chord-length
   parameter) through every ``k``-th relaxed point, so heading and curvature
   are continuous.
4. *Verification*: the spline is sampled every ``resolution / 4`` and every
   sample is checked against the map. If a sample is blocked the spline is
   refitted through denser points (``k`` halved); if even ``k = 1`` fails,
   the result falls back to the taut polyline, which is free by construction;
   its corners are then stop points (the robot halts and turns in place).

The returned :class:`SmoothPath` holds dense samples with arc length,
heading and signed curvature, ready for time scaling
(:mod:`planners.mobile.path_timing`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy import ndimage
from scipy.interpolate import CubicSpline

from kinserve.kinematics.errors import InputError
from kinserve.kinematics.validation import as_count, as_nonnegative, as_numbers, as_positive

from ._checks import as_indices, as_points, check_samples, describe_length, polyline_samples
from .maps import OccupancyGrid, check_grid

#: Most relaxation iterations of :func:`smooth_path`.
MAX_ITERATIONS = 10_000


@dataclass(frozen=True)
class SmoothPath:
    """Dense samples of a planar path: ``points (N, 2)``, arc length ``s``, ``heading``, ``curvature``.

    ``kind`` is ``"spline"`` (C2, curvature finite) or ``"polyline"`` (straight
    pieces; ``stops`` lists the arc lengths of its corners, where the heading
    jumps). ``stops`` always contains 0 and the total length. ``verified`` is
    True when every sample passed the map check.
    """

    points: np.ndarray
    s: np.ndarray
    heading: np.ndarray
    curvature: np.ndarray
    vertices: np.ndarray
    kind: str
    stops: np.ndarray
    verified: bool
    refinements: int = 0

    @property
    def length(self) -> float:
        """Arc length of the path (map units): the last sample's ``s``."""
        return float(self.s[-1])

    def at(self, s: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(x, y, heading, curvature)`` at arc lengths ``s`` (linear interpolation of the samples;
        clipped to ``[0, length]``). ``s`` is a number or an array of numbers, each finite with
        ``|s| <= 1e6``; refused: bools, text, anything non-numeric (:class:`ShapeError`), NaN, infinities
        and larger magnitudes (:class:`NonFiniteError`)."""
        s = np.clip(as_numbers(s, "s"), 0.0, self.length)
        x = np.interp(s, self.s, self.points[:, 0])
        y = np.interp(s, self.s, self.points[:, 1])
        h = np.interp(s, self.s, np.unwrap(self.heading))
        k = np.interp(s, self.s, self.curvature)
        return x, y, h, k


def _visible(grid: OccupancyGrid, a, b, margin: float, step: float) -> bool:
    n = max(2, int(math.ceil(np.linalg.norm(b - a) / step)) + 1)
    pts = a + np.linspace(0.0, 1.0, n)[:, None] * (b - a)
    if not np.all(grid.is_free(pts)):
        return False
    if margin > 0:
        i, j = grid.world_to_index(pts)
        if np.any(grid.distance_field()[i, j] < margin):
            return False
    return True


def shortcut(grid: OccupancyGrid, points: ArrayLike, *, margin: float = 0.0,
             keep: Iterable[int] = ()) -> np.ndarray:
    """Indices of the vertices kept by greedy string pulling (first and last always kept).

    ``keep``: indices that must stay vertices (e.g. waypoints in the middle of a path).
    Consecutive path points are always connected (the input path is assumed free).

    Refused: ``grid`` not an :class:`OccupancyGrid`; ``points`` not finite
    ``(N >= 1, 2)`` points inside the map; ``margin`` negative or above 1e6;
    ``keep`` entries that are not indices of ``points``.
    """
    check_grid(grid)
    P = as_points(points, "points")
    _inside(grid, P, "points")
    margin = as_nonnegative(margin, "margin")
    n = len(P)
    keep = as_indices(keep, "keep", n)
    if n <= 2:
        return np.arange(n)
    must = sorted(set(keep) | {0, n - 1})
    step = grid.resolution / 4.0
    out = [0]
    i = 0
    while i < n - 1:
        nxt_must = next(k for k in must if k > i)
        j = i + 1
        while j + 1 <= nxt_must and _visible(grid, P[i], P[j + 1], margin, step):
            j += 1
        out.append(j)
        i = j
    return np.array(out)


def _inside(grid: OccupancyGrid, P: np.ndarray, name: str) -> None:
    """:class:`InputError` naming the first point of ``P`` outside the map."""
    out = np.flatnonzero(~grid.contains(P))
    if out.size:
        k = int(out[0])
        raise InputError(f"{name}[{k}] = {P[k].tolist()} lies outside the map bounds {grid.bounds}")


def _dedupe(P: np.ndarray) -> np.ndarray:
    keep = np.ones(len(P), dtype=bool)
    keep[1:] = np.linalg.norm(np.diff(P, axis=0), axis=1) > 1e-12
    return P[keep]


def _spline_samples(V: np.ndarray, step: float):
    u = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(V, axis=0), axis=1))])
    if len(V) == 2:
        bc = "natural"
    else:
        bc = "not-a-knot" if len(V) > 3 else "natural"
    cs = CubicSpline(u, V, axis=0, bc_type=bc)
    n = max(2, int(math.ceil(u[-1] / step)) + 1)
    for _ in range(4):  # samples at most `step` apart along the curve (|r'(u)| may exceed 1)
        uu = np.unique(np.concatenate([np.linspace(0.0, u[-1], n), u]))  # every knot sampled exactly
        pts = cs(uu)
        longest = float(np.linalg.norm(np.diff(pts, axis=0), axis=1).max())
        if longest <= step:
            break
        n = int(math.ceil(n * longest / step * 1.05)) + 1
    return u, uu, pts, cs(uu, 1), cs(uu, 2)


def _geometry(pts, d1, d2):
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    heading = np.arctan2(d1[:, 1], d1[:, 0])
    speed = np.linalg.norm(d1, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        kappa = np.where(speed > 1e-12, (d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]) / speed**3, 0.0)
    return s, heading, kappa


def polyline_path(points: ArrayLike, step: float = 0.25) -> SmoothPath:
    """A polyline as a :class:`SmoothPath` (zero curvature on each piece, stops at the corners),
    sampled at most ``step`` apart.

    Refused: ``points`` not finite ``(N >= 1, 2)`` points with ``|x| <= 1e6``;
    ``step`` not in ``(0, 1e6]`` or so small that the path would take more than
    10**7 samples.
    """
    P = as_points(points, "points")
    step = as_positive(step, "step")
    check_samples(polyline_samples(P, step), "step", step, describe_length(P))
    V = _dedupe(P)
    if len(V) < 2:
        p = V[:1]
        return SmoothPath(p, np.zeros(1), np.zeros(1), np.zeros(1), V, "polyline", np.zeros(1), True)
    pieces, s_list, h_list = [], [], []
    s0 = 0.0
    stops = [0.0]
    for a, b in zip(V[:-1], V[1:]):
        L = float(np.linalg.norm(b - a))
        n = max(2, int(math.ceil(L / step)) + 1)
        t = np.linspace(0.0, 1.0, n)[:, None]
        seg = a + t * (b - a)
        h = math.atan2(b[1] - a[1], b[0] - a[0])
        start = 0 if not pieces else 1  # corners appear once, with the incoming heading
        pieces.append(seg[start:])
        s_list.append(s0 + L * t[start:, 0])
        h_list.append(np.full(n - start, h))
        s0 += L
        stops.append(s0)
    pts = np.concatenate(pieces)
    return SmoothPath(pts, np.concatenate(s_list), np.concatenate(h_list), np.zeros(len(pts)), V, "polyline",
                      np.array(stops), True)


def _resample(V: np.ndarray, step: float, fixed_vertices) -> tuple[np.ndarray, np.ndarray]:
    """Points every ``<= step`` along a polyline; returns (points, mask of fixed points)."""
    pts, fixed = [V[:1]], [True]
    for k, (a, b) in enumerate(zip(V[:-1], V[1:])):
        n = max(1, int(math.ceil(np.linalg.norm(b - a) / step)))
        t = (np.arange(1, n + 1) / n)[:, None]
        pts.append(a + t * (b - a))
        f = [False] * n
        f[-1] = (k + 1) in fixed_vertices
        fixed.extend(f)
    return np.concatenate(pts), np.array(fixed)


def relax(grid: OccupancyGrid, P: np.ndarray, fixed: np.ndarray, margin: float, iterations: int = 300,
          w_smooth: float = 0.3, w_obstacle: float = 0.5) -> np.ndarray:
    """Curve-shortening + obstacle-repulsion relaxation of a dense free polyline (see module docstring)."""
    D = grid.distance_field()
    res = grid.resolution
    gy, gx = np.gradient(D, res)
    x0, y0 = grid.bounds[0], grid.bounds[1]
    P = P.copy()
    movable = ~fixed
    movable[0] = movable[-1] = False
    if not movable.any():
        return P
    for _ in range(iterations):
        lap = np.zeros_like(P)
        lap[1:-1] = P[:-2] + P[2:] - 2.0 * P[1:-1]
        coords = np.stack([(P[:, 1] - y0) / res, (P[:, 0] - x0) / res])
        d = ndimage.map_coordinates(D, coords, order=1, mode="nearest")
        g = np.stack([ndimage.map_coordinates(gx, coords, order=1, mode="nearest"),
                      ndimage.map_coordinates(gy, coords, order=1, mode="nearest")], axis=1)
        gn = np.linalg.norm(g, axis=1)
        push = np.where((d < margin) & (gn > 1e-9),
                        (margin - d) / np.where(gn > 1e-9, gn, 1.0), 0.0)[:, None] * g
        step = w_smooth * lap + w_obstacle * push
        step[~movable] = 0.0
        new = P + step
        ok = grid.is_free(new)
        new[~ok] = P[~ok]
        moved = float(np.abs(new - P).max())
        P = new
        if moved < 1e-3 * res:
            break
    return P


def smooth_path(
    grid: OccupancyGrid,
    points: ArrayLike,
    *,
    margin: float | None = None,
    iterations: int = 300,
    knot_spacing: float | None = None,
    keep: Iterable[int] = (),
) -> SmoothPath:
    """Shortcut, relax and spline a free path ``(N, 2)``, verified against ``grid``.

    ``margin`` (world units, default ``3 * resolution``) is the clearance the
    relaxation aims for where there is room; ``knot_spacing`` (default
    ``4 * resolution``) the spacing of the spline's knots; ``keep`` lists
    path indices that must stay on the path (e.g. waypoints). See the module
    docstring for the steps and the fallback.

    Refused (:class:`InputError` and subclasses): ``grid`` not an
    :class:`OccupancyGrid`; ``points`` not finite ``(N >= 1, 2)`` points, or
    a path that leaves the map or is not free; ``margin`` negative or above
    1e6; ``iterations`` not an integer in ``[0, 10000]``; ``knot_spacing``
    not in ``(0, 1e6]``; ``keep`` entries that are not indices of ``points``.
    """
    check_grid(grid)
    P = as_points(points, "points")
    m = 3.0 * grid.resolution if margin is None else as_nonnegative(margin, "margin")
    iterations = as_count(iterations, "iterations", minimum=0, maximum=MAX_ITERATIONS)
    spacing = 4.0 * grid.resolution if knot_spacing is None else as_positive(knot_spacing, "knot_spacing")
    keep = as_indices(keep, "keep", len(P))
    res = grid.resolution
    step = res / 4.0
    outside = np.flatnonzero(~grid.contains(P))
    if outside.size:
        k = int(outside[0])
        raise InputError(f"the path to smooth is not free (point {k} {P[k].tolist()} lies outside the map "
                         f"bounds {grid.bounds})")
    if not grid.path_is_free(P, step):
        bad = grid.first_blocked(P)
        where = f"point {bad} {P[bad].tolist()}" if bad is not None else "a segment between its points"
        raise InputError(f"the path to smooth is not free ({where} is blocked)")
    keep = sorted(set(keep))
    if len(P) >= 2:
        mask = np.ones(len(P), dtype=bool)
        mask[1:] = np.linalg.norm(np.diff(P, axis=0), axis=1) > 1e-12
        mask[keep] = True
        new_index = np.cumsum(mask) - 1
        keep = sorted(set(int(new_index[k]) for k in keep))
        P = P[mask]
    if len(P) < 3:
        return polyline_path(P, step)
    vidx = list(shortcut(grid, P, keep=keep))
    taut = P[vidx]
    if len(vidx) == 2:
        return polyline_path(taut, step)
    fixed_vertices = {k for k, v in enumerate(vidx) if v in set(keep)}
    dense, fixed = _resample(taut, res, fixed_vertices)
    relaxed = relax(grid, dense, fixed, m, iterations)
    k = max(1, int(round(spacing / res)))
    tries = 0
    while True:
        sel = np.zeros(len(relaxed), dtype=bool)
        sel[::k] = True
        sel[fixed] = True
        sel[0] = sel[-1] = True
        V = _dedupe(relaxed[sel])
        if len(V) >= 2:
            u, uu, pts, d1, d2 = _spline_samples(V, step)
            if np.all(grid.is_free(pts)):
                s, heading, kappa = _geometry(pts, d1, d2)
                return SmoothPath(pts, s, heading, kappa, V, "spline", np.array([0.0, s[-1]]), True, tries)
        if k == 1:
            break
        k = max(1, k // 2)
        tries += 1
    return polyline_path(taut, step)
