"""Boustrophedon (zig-zag) floor coverage with detours and smooth U-turns (SCENARIOS.md S8).

Input: an occupancy grid for the robot *centre* (obstacles already padded by
half the footprint), a start point and the lane spacing (the robot width).

1. *Lanes*: horizontal lines ``y = y_start + k * spacing`` (every ``k`` whose
   line has free points); each lane splits into free *intervals* where
   obstacles cut it.
2. *Cells* (boustrophedon decomposition): an interval continues the cell of
   the interval below it when each is the other's only overlapping neighbour
   and the robot can U-turn between them; otherwise it opens a new cell.
   A cell is covered by a zig-zag over its lanes.
3. *U-turns*: between consecutive lanes of a cell the robot leaves the lane
   ``r = spacing / 2`` before the turn point and follows a cubic Bezier arc
   (control points ``4 r / 3`` ahead, the classic circle approximation) whose
   apex reaches the turn point - a smooth half-circle-like turn of radius
   ``~r``. The turn point is the nearer of the two lanes' ends (tried first:
   each lane's own end); every turn is checked against the map and moved
   inwards, or replaced by a grid path, if it would touch an obstacle.
4. *Order of cells*: greedy from the start - the next cell is the unvisited
   one whose nearest corner (bottom/top lane, left/right end) is cheapest to
   reach by A* among the few nearest by straight-line distance; *detours*
   between cells follow the A* path, smoothed (:mod:`planners.mobile.smoothing`).

Coverage is measured on pixels of side ``resolution``: a pixel is *covered*
when its centre lies inside the robot's square footprint (side
``robot_width``, rotated with the heading = path tangent) at some sample of
the path (samples every ``resolution / 2``); the *free area* is the set of
pixels that the footprint could cover at all, i.e. whose centre is within
``robot_width / 2`` (Chebyshev) of some free centre position of the grid.
``covered_fraction`` = covered free pixels / free pixels.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from kinserve.kinematics.errors import InputError
from kinserve.kinematics.validation import as_count, as_positive, as_real

from ._checks import MAX_SAMPLES, as_headings, as_point, as_points, check_samples
from .astar import astar
from .maps import OccupancyGrid, check_grid
from .smoothing import smooth_path

#: Most pixel offsets of the footprint stencil of :func:`swept_coverage` (``(2 R + 1)^2``).
MAX_FOOTPRINT_PIXELS = 10**6
#: Most entries of one chunk of :func:`swept_coverage` (poses x footprint pixels).
_CHUNK_ENTRIES = 2_000_000


def _robot_width(grid: OccupancyGrid, robot_width: object, name: str = "robot_width") -> float:
    """``robot_width`` in ``(0, 1e6]`` whose footprint stencil has at most :data:`MAX_FOOTPRINT_PIXELS`."""
    width = as_positive(robot_width, name)
    R = int(math.ceil(0.5 * width * math.sqrt(2.0) / grid.resolution)) + 1
    if (2 * R + 1) ** 2 > MAX_FOOTPRINT_PIXELS:
        largest = ((math.isqrt(MAX_FOOTPRINT_PIXELS) - 1) // 2 - 1) * grid.resolution * math.sqrt(2.0)
        raise InputError(f"{name} must be at most {largest:.6g} ({MAX_FOOTPRINT_PIXELS:,} footprint pixels "
                         f"of side {grid.resolution:g} at most), got {robot_width!r}")
    return width


def _lane_spacing(grid: OccupancyGrid, spacing: object, name: str = "lane_spacing") -> float:
    """``spacing`` in ``(0, 1e6]`` and a whole multiple of the grid's resolution (lanes on the lattice)."""
    sp = as_positive(spacing, name)
    k = sp / grid.resolution
    if k < 1.0 - 1e-6 or abs(k - round(k)) > 1e-6 * max(1.0, k):
        raise InputError(f"{name} must be a whole multiple (>= 1) of the grid resolution {grid.resolution:g} "
                         f"(lanes lie on the lattice), got {spacing!r}")
    return sp


@dataclass(frozen=True)
class Interval:
    """A free stretch ``[x0, x1]`` of lane ``lane`` at height ``y``."""

    lane: int
    y: float
    x0: float
    x1: float


@dataclass
class CoverageResult:
    """A coverage path (dense points, heading = tangent) and how much floor it sweeps."""

    path: np.ndarray
    heading: np.ndarray
    length: float
    covered_fraction: float
    covered_area: float
    free_area: float
    cells: list[list[Interval]]
    visit_order: list[int]
    n_lanes: int
    n_uturns: int
    n_detours: int
    path_is_free: bool
    covered: np.ndarray = field(repr=False)
    coverable: np.ndarray = field(repr=False)

    def summary(self) -> dict:
        """The scalar figures as a JSON-ready dict (no arrays)."""
        return {
            "length": self.length,
            "covered_fraction": self.covered_fraction,
            "covered_area": self.covered_area,
            "free_area": self.free_area,
            "cells": len(self.cells),
            "lanes": self.n_lanes,
            "u_turns": self.n_uturns,
            "detours": self.n_detours,
            "path_is_free": self.path_is_free,
        }


# --------------------------------------------------------------- geometry
def _bezier(p0, p1, p2, p3, n: int) -> np.ndarray:
    t = np.linspace(0.0, 1.0, n)[:, None]
    return (1 - t) ** 3 * p0 + 3 * (1 - t) ** 2 * t * p1 + 3 * (1 - t) * t**2 * p2 + t**3 * p3


def _segment(a, b, step: float) -> np.ndarray:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    n = max(2, int(math.ceil(np.linalg.norm(b - a) / step)) + 1)
    return a + np.linspace(0.0, 1.0, n)[:, None] * (b - a)


def lane_intervals(grid: OccupancyGrid, y_start: float, spacing: float) -> list[list[Interval]]:
    """Free intervals of every lane ``y_start + k spacing`` inside the map, bottom to top.

    Refused: ``grid`` not an :class:`OccupancyGrid`; ``y_start`` not a finite
    number with ``|x| <= 1e6``; ``spacing`` not a positive whole multiple of the
    resolution (at most 1e6); lanes off the lattice.
    """
    check_grid(grid)
    y_start = as_real(y_start, "y_start")
    spacing = _lane_spacing(grid, spacing, "spacing")
    res = grid.resolution
    y_min, y_max = grid.bounds[1], grid.bounds[3]
    k_lo = -int(math.floor((y_start - y_min) / spacing + 1e-9))
    k_hi = int(math.floor((y_max - y_start) / spacing + 1e-9))
    lanes = []
    xs = grid.xs
    for k in range(k_lo, k_hi + 1):
        y = y_start + k * spacing
        i = int(round((y - y_min) / res))
        if abs(grid.bounds[1] + i * res - y) > 1e-6 * res:
            raise InputError(f"lane y={y:g} is not on the grid's lattice; "
                             "choose spacing and start on multiples of the resolution")
        row = grid.free[i]
        if not row.any():
            continue
        d = np.diff(np.concatenate([[0], row.astype(np.int8), [0]]))
        starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1) - 1
        lanes.append([Interval(len(lanes), y, float(xs[a]), float(xs[b])) for a, b in zip(starts, ends)])
    return lanes


# ------------------------------------------------------------ the planner
class _Builder:
    def __init__(self, grid: OccupancyGrid, spacing: float, step: float):
        self.grid = grid
        self.r = spacing / 2.0
        self.step = step
        self.pieces: list[np.ndarray] = []
        self.n_uturns = 0
        self.n_detours = 0

    @property
    def here(self) -> np.ndarray:
        return self.pieces[-1][-1]

    def add(self, pts: np.ndarray):
        pts = np.asarray(pts, dtype=float)
        if self.pieces and np.linalg.norm(pts[0] - self.here) < 1e-9:
            pts = pts[1:]
        if len(pts):
            self.pieces.append(pts)

    def free(self, pts) -> bool:
        return bool(np.all(self.grid.is_free(pts)))

    def go_to(self, target):
        """Straight if free, else along a smoothed A* path (a detour)."""
        target = np.asarray(target, dtype=float)
        if np.linalg.norm(target - self.here) < 1e-9:
            return
        seg = _segment(self.here, target, self.step)
        if self.free(seg):
            self.add(seg)
            return
        gp = astar(self.grid, self.here, target)
        sp = smooth_path(self.grid, gp.points)
        self.add(sp.points)
        self.n_detours += 1

    def uturn(self, a: Interval, b: Interval, direction: int):
        """Turn from lane ``a`` (travelling ``direction`` = +1 right / -1 left) onto lane ``b``."""
        r, c = self.r, 4.0 * self.r / 3.0
        ya, yb = a.y, b.y
        end_a = a.x1 if direction > 0 else a.x0
        end_b = b.x1 if direction > 0 else b.x0
        candidates = [(end_a, end_b)]
        near = min(end_a, end_b) if direction > 0 else max(end_a, end_b)
        candidates += [(near - direction * k * r, near - direction * k * r) for k in range(0, 4)]
        for ta, tb in candidates:
            pa = np.array([ta - direction * r, ya])
            pb = np.array([tb - direction * r, yb])
            lane_part = _segment(self.here, pa, self.step)
            if (pa[0] - self.here[0]) * direction < -1e-9:
                continue  # would have to drive backwards along the lane
            arc = _bezier(pa, pa + [direction * c, 0.0], pb + [direction * c, 0.0], pb,
                          max(8, int(math.ceil(2.5 * r / self.step))))
            if self.free(lane_part) and self.free(arc):
                self.add(lane_part)
                self.add(arc)
                self.n_uturns += 1
                return
        # no clean turn: finish the lane and take a grid path to the next lane's end
        self.go_to(np.array([end_a, ya]))
        self.go_to(np.array([end_b, yb]))


def _overlap(a: Interval, b: Interval) -> bool:
    return a.x0 <= b.x1 and b.x0 <= a.x1


def decompose(lanes: list[list[Interval]]) -> list[list[Interval]]:
    """Boustrophedon cells: chains of intervals in consecutive lanes with one-to-one overlap.

    ``lanes`` is what :func:`lane_intervals` returns: a list of non-empty lists of
    :class:`Interval` (anything else is refused with :class:`InputError`).
    """
    if not isinstance(lanes, (list, tuple)):
        raise InputError(f"lanes must be a list of lanes (lists of Interval), got {type(lanes).__name__}")
    for k, lane in enumerate(lanes):
        if (not isinstance(lane, (list, tuple)) or not lane
                or not all(isinstance(iv, Interval) for iv in lane)):
            raise InputError(f"lanes[{k}] must be a non-empty list of Interval (from lane_intervals)")
    cells: list[list[Interval]] = []
    cell_of: dict[Interval, int] = {}
    for k, lane in enumerate(lanes):
        below = lanes[k - 1] if k > 0 and abs(lanes[k - 1][0].lane - lane[0].lane) == 1 else []
        for iv in lane:
            downs = [d for d in below if _overlap(d, iv)]
            if len(downs) == 1:
                ups = [u for u in lane if _overlap(downs[0], u)]
                if len(ups) == 1:
                    cid = cell_of[downs[0]]
                    cells[cid].append(iv)
                    cell_of[iv] = cid
                    continue
            cell_of[iv] = len(cells)
            cells.append([iv])
    return cells


def _zigzag(b: _Builder, cell: list[Interval], from_top: bool, from_right: bool):
    lanes = cell[::-1] if from_top else cell
    direction = -1 if from_right else 1
    first = lanes[0]
    b.go_to(np.array([first.x1 if from_right else first.x0, first.y]))
    for cur, nxt in zip(lanes[:-1], lanes[1:]):
        b.uturn(cur, nxt, direction)
        direction = -direction
    last = lanes[-1]
    b.go_to(np.array([last.x1 if direction > 0 else last.x0, last.y]))


def _corners(cell: list[Interval]):
    """(from_top, from_right, entry point) for the four ways into a cell."""
    bot, top = cell[0], cell[-1]
    return [
        (False, False, np.array([bot.x0, bot.y])),
        (False, True, np.array([bot.x1, bot.y])),
        (True, False, np.array([top.x0, top.y])),
        (True, True, np.array([top.x1, top.y])),
    ]


def swept_coverage(grid: OccupancyGrid, path: np.ndarray, heading: np.ndarray,
                   robot_width: float) -> np.ndarray:
    """Pixels (side ``resolution``, shape ``(ny - 1, nx - 1)``) whose centre the rotating square footprint
    covers.

    Refused: ``grid`` not an :class:`OccupancyGrid`; ``path`` not finite ``(N >= 1, 2)`` points;
    ``heading`` not ``N`` finite angles; ``robot_width`` not in ``(0, 1e6]`` or wider than
    :data:`MAX_FOOTPRINT_PIXELS` pixels allow; a path so long that sampling it every
    ``resolution / 2`` would exceed 10**7 samples.
    """
    check_grid(grid)
    path = as_points(path, "path")
    heading = as_headings(heading, len(path))
    robot_width = _robot_width(grid, robot_width)
    res = grid.resolution
    length = float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))
    if length / (0.5 * res) + 1.0 > MAX_SAMPLES:
        raise InputError(f"path of length {length:.6g} is too long to sample every resolution / 2 = "
                         f"{0.5 * res:g} ({MAX_SAMPLES:,} samples at most)")
    ny, nx = grid.free.shape
    cov = np.zeros((ny - 1, nx - 1), dtype=bool)
    half = robot_width / 2.0
    R = int(math.ceil(half * math.sqrt(2.0) / res)) + 1
    oy, ox = np.mgrid[-R : R + 1, -R : R + 1]
    ox, oy = ox.ravel(), oy.ravel()
    x0, y0 = grid.bounds[0], grid.bounds[1]
    # resample every resolution / 2 along the path
    seg = np.linalg.norm(np.diff(path, axis=0), axis=1)
    s_path = np.concatenate([[0.0], np.cumsum(seg)])
    n = max(2, int(math.ceil(s_path[-1] / (0.5 * res))) + 1)
    ss = np.linspace(0.0, s_path[-1], n)
    idx = np.clip(np.searchsorted(s_path, ss, side="right") - 1, 0, len(path) - 1)
    path = np.stack([np.interp(ss, s_path, path[:, 0]), np.interp(ss, s_path, path[:, 1])], axis=1)
    heading = heading[idx]
    # axis-aligned footprints (heading a multiple of pi/2) are plain rectangles of pixels
    quarter = np.mod(heading, 0.5 * math.pi)
    aligned = (quarter < 1e-9) | (0.5 * math.pi - quarter < 1e-9)
    for p in path[aligned]:
        j0 = max(0, int(math.ceil((p[0] - half - x0) / res - 0.5 - 1e-9)))
        j1 = min(nx - 2, int(math.floor((p[0] + half - x0) / res - 0.5 + 1e-9)))
        i0 = max(0, int(math.ceil((p[1] - half - y0) / res - 0.5 - 1e-9)))
        i1 = min(ny - 2, int(math.floor((p[1] + half - y0) / res - 0.5 + 1e-9)))
        if j0 <= j1 and i0 <= i1:
            cov[i0 : i1 + 1, j0 : j1 + 1] = True
    path, heading = path[~aligned], heading[~aligned]
    chunk = max(1, min(256, _CHUNK_ENTRIES // len(ox)))
    for s in range(0, len(path), chunk):
        P = path[s : s + chunk]
        H = heading[s : s + chunk]
        pj = np.floor((P[:, 0] - x0) / res - 0.5).astype(np.int64)
        pi = np.floor((P[:, 1] - y0) / res - 0.5).astype(np.int64)
        cols = pj[:, None] + ox[None, :]
        rows = pi[:, None] + oy[None, :]
        cx = x0 + (cols + 0.5) * res - P[:, :1]
        cy = y0 + (rows + 0.5) * res - P[:, 1:2]
        c, sn = np.cos(H)[:, None], np.sin(H)[:, None]
        u = c * cx + sn * cy
        v = -sn * cx + c * cy
        inside = (np.abs(u) <= half + 1e-9) & (np.abs(v) <= half + 1e-9)
        inside &= (rows >= 0) & (rows < ny - 1) & (cols >= 0) & (cols < nx - 1)
        cov[rows[inside], cols[inside]] = True
    return cov


def coverable_pixels(grid: OccupancyGrid, robot_width: float) -> np.ndarray:
    """Pixels whose centre lies within ``robot_width / 2`` (Chebyshev) of a free centre lattice point.

    Refused: ``grid`` not an :class:`OccupancyGrid`; ``robot_width`` not in ``(0, 1e6]``."""
    check_grid(grid)
    robot_width = as_positive(robot_width, "robot_width")
    res = grid.resolution
    F = grid.free.astype(np.int64)
    ny, nx = F.shape
    S = np.zeros((ny + 1, nx + 1), dtype=np.int64)
    S[1:, 1:] = F.cumsum(0).cumsum(1)
    half = robot_width / 2.0
    # pixel p (centre p + 0.5) reaches lattice q iff |q - p - 0.5| <= half/res
    lo = int(math.ceil(0.5 - half / res - 1e-9))
    hi = int(math.floor(0.5 + half / res + 1e-9))
    pi = np.arange(ny - 1)[:, None]
    pj = np.arange(nx - 1)[None, :]
    i0, i1 = np.clip(pi + lo, 0, ny), np.clip(pi + hi + 1, 0, ny)
    j0, j1 = np.clip(pj + lo, 0, nx), np.clip(pj + hi + 1, 0, nx)
    count = S[i1, j1] - S[i0, j1] - S[i1, j0] + S[i0, j0]
    return count > 0


def boustrophedon_coverage(
    grid: OccupancyGrid,
    start: ArrayLike,
    *,
    lane_spacing: float,
    robot_width: float | None = None,
    step: float | None = None,
    candidates: int = 4,
) -> CoverageResult:
    """Zig-zag coverage path from ``start`` over the free space of ``grid`` (see the module docstring).

    ``lane_spacing`` is the distance between lanes (the robot width for full
    coverage without overlap); ``robot_width`` (default ``lane_spacing``) is
    the footprint used to measure coverage; ``step`` (default
    ``resolution / 2``) the spacing of the output path samples; ``candidates``
    how many nearest cell corners are compared by A* when choosing the next cell.

    Refused (:class:`InputError` and subclasses): ``grid`` not an
    :class:`OccupancyGrid`; ``start`` not a free finite ``(x, y)`` point of the
    map; ``lane_spacing`` not a whole multiple (>= 1) of the resolution, at most
    1e6; ``robot_width`` not in ``(0, 1e6]`` or with a footprint of more than
    :data:`MAX_FOOTPRINT_PIXELS` pixels; ``step`` not in ``(0, 1e6]``, or so
    small that the lanes alone would take more than 10**7 samples;
    ``candidates`` not an integer in ``[1, 1000]``.
    """
    check_grid(grid)
    p0 = as_point(start, "start")
    lane_spacing = _lane_spacing(grid, lane_spacing)
    width = _robot_width(grid, lane_spacing if robot_width is None else robot_width)
    step = grid.resolution / 2.0 if step is None else as_positive(step, "step")
    candidates = as_count(candidates, "candidates", minimum=1, maximum=1000)
    b = grid.bounds
    n_lanes = math.floor((b[3] - b[1]) / lane_spacing) + 1
    check_samples(n_lanes * ((b[2] - b[0]) / step + 1.0), "step", step,
                  f"the {n_lanes} lanes of this {b[2] - b[0]:g} wide map")
    if not bool(grid.is_free(p0)[0]):
        raise InputError(f"start {tuple(p0.tolist())} must be a free (x, y) point of the map")
    lanes = lane_intervals(grid, float(p0[1]), float(lane_spacing))
    cells = decompose(lanes)
    b = _Builder(grid, float(lane_spacing), step)
    b.pieces.append(p0[None].copy())
    todo = set(range(len(cells)))
    order = []
    while todo:
        here = b.here
        options = []
        for cid in todo:
            for from_top, from_right, entry in _corners(cells[cid]):
                options.append((float(np.linalg.norm(entry - here)), cid, from_top, from_right, entry))
        options.sort(key=lambda o: o[0])
        best = None
        for d, cid, ft, fr, entry in options[:candidates]:
            cost = 0.0 if d < 1e-9 else astar(grid, here, entry).cost
            if best is None or cost < best[0]:
                best = (cost, cid, ft, fr)
        _, cid, ft, fr = best
        _zigzag(b, cells[cid], ft, fr)
        order.append(cid)
        todo.remove(cid)
    path = np.concatenate(b.pieces)
    d = np.diff(path, axis=0)
    keep = np.concatenate([[True], np.linalg.norm(d, axis=1) > 1e-12])
    path = path[keep]
    d = np.diff(path, axis=0)
    heading = np.arctan2(d[:, 1], d[:, 0])
    heading = np.concatenate([heading, heading[-1:]]) if len(heading) else np.zeros(1)
    length = float(np.linalg.norm(d, axis=1).sum())
    covered = swept_coverage(grid, path, heading, width)
    coverable = coverable_pixels(grid, width)
    pix = grid.resolution**2
    free_area = float(coverable.sum() * pix)
    covered_area = float((covered & coverable).sum() * pix)
    return CoverageResult(
        path, heading, length, covered_area / free_area if free_area else 0.0, covered_area, free_area, cells,
        order, len(lanes), b.n_uturns, b.n_detours, grid.path_is_free(path, step), covered, coverable,
    )
