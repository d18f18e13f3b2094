"""Occupancy grids built from shapes, for planning a robot's centre.

The map is the rectangle ``bounds = (x_min, y_min, x_max, y_max)`` (world
units) sampled on a lattice of spacing ``resolution``: lattice point
``(i, j)`` (row ``i`` along y, column ``j`` along x) sits at
``(x_min + j res, y_min + i res)``; both map edges are lattice lines.

A lattice point is *free* when the robot centre may be there:

* its signed distance to every shape is ``>= inflation`` (the shapes are
  inflated by the robot's radius - half its footprint - so the centre can be
  planned as a point; touching at exactly ``inflation`` is allowed);
* its distance to the map border is ``>= border_clearance`` (default: the
  inflation; the border is a wall).

Anything outside the bounds is blocked.

Between lattice points, :meth:`OccupancyGrid.is_free` uses the raster rule:
a point is free iff every lattice point at the floor/ceiling of its
coordinates is free (1, 2 or 4 points). An 8-connected grid path that never
cuts a blocked corner (a diagonal step needs both orthogonal neighbours free)
is therefore free at every point along it, and a smoothed path is checked
with the same rule by dense sampling. :meth:`OccupancyGrid.clearance` gives
the exact (analytic) clearance for anything finer.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike
from scipy import ndimage

from kinserve.kinematics.errors import InputError, ShapeError
from kinserve.kinematics.validation import as_nonnegative, as_positive, as_vector, describe

from ._checks import as_point, as_points, check_samples, describe_length, polyline_samples
from .shapes import Circle, Polygon, Rectangle, Shape

_TOL = 1e-9
#: Most lattice points of a map (bounds / resolution): a bound on the memory of a grid.
MAX_LATTICE_POINTS = 50_000_000
#: Smallest accepted resolution (map units); with coordinates bounded by 1e6 it keeps lattice indices exact.
MIN_RESOLUTION = 1e-6
#: Largest lattice index accepted by :meth:`OccupancyGrid.index_to_world`.
MAX_INDEX = 10**8


def _bounds(bounds: object) -> tuple[float, float, float, float]:
    """``bounds`` ``(x_min, y_min, x_max, y_max)`` or ``(width, height)`` as four floats, checked."""
    try:
        n = len(bounds)  # type: ignore[arg-type]
    except TypeError:
        n = -1
    if n not in (2, 4) or isinstance(bounds, (str, bytes, dict)):
        raise ShapeError(f"bounds must be (x_min, y_min, x_max, y_max) or (width, height), got {bounds!r}")
    b = tuple(as_vector(bounds, n, "bounds").tolist())
    if n == 2:
        b = (0.0, 0.0, b[0], b[1])
    if not (b[0] < b[2] and b[1] < b[3]):
        raise InputError(f"bounds must be (x_min, y_min, x_max, y_max) with min < max, got {bounds!r}")
    return b


def _shapes(shapes: object) -> tuple:
    """``shapes`` as a tuple of Rectangle / Circle / Polygon (an iterator is read once)."""
    if shapes is None or isinstance(shapes, (str, bytes, dict)) or not isinstance(shapes, Iterable):
        raise InputError(f"shapes must be a sequence of Rectangle, Circle or Polygon, got {shapes!r:.60}")
    shapes = tuple(shapes)
    for k, s in enumerate(shapes):
        if not isinstance(s, (Rectangle, Circle, Polygon)):
            raise InputError(f"shapes[{k}] must be a Rectangle, Circle or Polygon, got {type(s).__name__}")
    return shapes


def _lattice_size(b: tuple[float, float, float, float], res: float) -> tuple[int, int]:
    """``(nx, ny)`` lattice points of the map; :class:`InputError` above :data:`MAX_LATTICE_POINTS`."""
    nx = int(round((b[2] - b[0]) / res)) + 1
    ny = int(round((b[3] - b[1]) / res)) + 1
    if nx * ny > MAX_LATTICE_POINTS:
        smallest = math.sqrt((b[2] - b[0]) * (b[3] - b[1]) / MAX_LATTICE_POINTS)
        raise InputError(f"resolution {res!r} gives a {nx} x {ny} lattice ({nx * ny:.3g} points) over the "
                         f"bounds {b}; at most {MAX_LATTICE_POINTS:,} points are allowed: resolution must be "
                         f"at least about {smallest:.3g} for these bounds")
    return nx, ny


@dataclass
class OccupancyGrid:
    """A boolean lattice ``free[i, j]`` plus the shapes it was made of (see module docstring).

    Build one with :meth:`from_shapes`. Direct construction is checked too:
    refused are bounds / resolution as :meth:`from_shapes` refuses them, and a
    ``free`` that is not a 2-D boolean array of the lattice's shape ``(ny, nx)``.
    """

    bounds: tuple[float, float, float, float]
    resolution: float
    free: np.ndarray
    shapes: tuple = ()
    inflation: float = 0.0
    border_clearance: float = 0.0
    _distance: np.ndarray | None = field(default=None, repr=False)

    def __post_init__(self):
        self.bounds = _bounds(self.bounds)
        self.resolution = as_positive(self.resolution, "resolution")
        if self.resolution < MIN_RESOLUTION:
            raise InputError(f"resolution must be at least {MIN_RESOLUTION:g}, got {self.resolution!r}")
        nx, ny = _lattice_size(self.bounds, self.resolution)
        F = self.free
        if not (isinstance(F, np.ndarray) and F.dtype == bool and F.shape == (ny, nx)):
            raise ShapeError(f"free must be a boolean array of shape ({ny}, {nx}) (the lattice of the bounds "
                             f"and resolution), got {type(self.free).__name__} "
                             f"{getattr(self.free, 'shape', '')} {getattr(self.free, 'dtype', '')}")
        self.inflation = as_nonnegative(self.inflation, "inflation")
        self.border_clearance = as_nonnegative(self.border_clearance, "border_clearance")
        self.shapes = _shapes(self.shapes)

    # ---------------------------------------------------------- construction
    @classmethod
    def from_shapes(
        cls,
        bounds: Sequence[float],
        shapes: Iterable[Shape] = (),
        *,
        resolution: float = 1.0,
        inflation: float = 0.0,
        border_clearance: float | None = None,
    ) -> "OccupancyGrid":
        """Rasterise ``shapes`` inflated by ``inflation`` on a lattice of spacing ``resolution``.

        ``bounds`` is ``(x_min, y_min, x_max, y_max)`` or ``(width, height)``
        (then the map starts at the origin). Only the lattice points within
        each shape's inflated bounding box are evaluated.

        Refused (:class:`InputError` and subclasses, naming the argument):
        bounds not 2 or 4 finite numbers with ``|x| <= 1e6`` and min < max;
        ``resolution`` not in ``[1e-6, 1e6]``, or so fine that the lattice
        would exceed :data:`MAX_LATTICE_POINTS` points; ``inflation`` /
        ``border_clearance`` negative, non-finite or above 1e6; ``shapes``
        not an iterable of Rectangle / Circle / Polygon.
        """
        b = _bounds(bounds)
        res = as_positive(resolution, "resolution")
        if res < MIN_RESOLUTION:
            raise InputError(f"resolution must be at least {MIN_RESOLUTION:g}, got {resolution!r}")
        r = as_nonnegative(inflation, "inflation")
        c = r if border_clearance is None else as_nonnegative(border_clearance, "border_clearance")
        shapes = _shapes(shapes)
        nx, ny = _lattice_size(b, res)
        xs = b[0] + res * np.arange(nx)
        ys = b[1] + res * np.arange(ny)
        free = np.ones((ny, nx), dtype=bool)
        if c > 0:
            free &= (np.minimum(xs - b[0], b[2] - xs)[None, :] >= c - _TOL)
            free &= (np.minimum(ys - b[1], b[3] - ys)[:, None] >= c - _TOL)
        for s in shapes:
            x0, y0, x1, y1 = s.bounds()
            j0 = max(0, int(math.floor((x0 - r - b[0]) / res)) - 1)
            j1 = min(nx, int(math.ceil((x1 + r - b[0]) / res)) + 2)
            i0 = max(0, int(math.floor((y0 - r - b[1]) / res)) - 1)
            i1 = min(ny, int(math.ceil((y1 + r - b[1]) / res)) + 2)
            if j0 >= j1 or i0 >= i1:
                continue
            sd = s.signed_distance(xs[None, j0:j1], ys[i0:i1, None])
            free[i0:i1, j0:j1] &= sd >= r - _TOL
        return cls(b, res, free, tuple(shapes), r, c)

    # ---------------------------------------------------------------- basics
    @property
    def shape(self) -> tuple[int, int]:
        """``(ny, nx)``: lattice rows (y) and columns (x)."""
        return self.free.shape

    @property
    def xs(self) -> np.ndarray:
        """x coordinates of the lattice columns (map units)."""
        return self.bounds[0] + self.resolution * np.arange(self.free.shape[1])

    @property
    def ys(self) -> np.ndarray:
        """y coordinates of the lattice rows (map units)."""
        return self.bounds[1] + self.resolution * np.arange(self.free.shape[0])

    @property
    def free_fraction(self) -> float:
        """Fraction of the lattice points that are free, in ``[0, 1]``."""
        return float(self.free.mean())

    def _points(self, points, name="points") -> np.ndarray:
        """``points`` (one ``(x, y)`` or ``(N, 2)``) as a finite ``(N, 2)`` array with ``|x| <= 1e6``
        (:class:`ShapeError` / :class:`NonFiniteError` naming ``name``)."""
        return as_points(points, name, min_rows=0, single=True)

    def contains(self, points: ArrayLike) -> np.ndarray:
        """True where a point lies within the map bounds (inclusive)."""
        P = self._points(points)
        b = self.bounds
        return ((P[:, 0] >= b[0] - _TOL) & (P[:, 0] <= b[2] + _TOL) & (P[:, 1] >= b[1] - _TOL)
                & (P[:, 1] <= b[3] + _TOL))

    def world_to_index(self, points: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Nearest lattice ``(row i, column j)`` of world points (not clipped: check :meth:`contains`).

        Points must be finite with ``|x| <= 1e6`` (else :class:`NonFiniteError`), so indices are exact."""
        P = self._points(points)
        j = np.rint((P[:, 0] - self.bounds[0]) / self.resolution).astype(np.int64)
        i = np.rint((P[:, 1] - self.bounds[1]) / self.resolution).astype(np.int64)
        return i, j

    def index_to_world(self, i: ArrayLike, j: ArrayLike) -> np.ndarray:
        """World ``(N, 2)`` coordinates of lattice points ``(i, j)`` (integer arrays of one shape, or
        broadcastable; refused: non-integers, NaN, ``|index| > 1e8``)."""
        i = _index_array(i, "i")
        j = _index_array(j, "j")
        try:
            i, j = np.broadcast_arrays(i, j)
        except ValueError:
            raise ShapeError(f"i and j must have the same length, got shapes {i.shape} and "
                             f"{j.shape}") from None
        return np.stack([self.bounds[0] + self.resolution * j,
                         self.bounds[1] + self.resolution * i], axis=-1).astype(float)

    def on_lattice(self, points: ArrayLike, tol: float = 1e-6) -> np.ndarray:
        """True where a point coincides with a lattice point (within ``tol`` resolutions, ``tol`` in
        ``[0, 0.5]``)."""
        tol = as_nonnegative(tol, "tol", maximum=0.5)
        P = self._points(points)
        i, j = self.world_to_index(P)
        return np.all(np.abs(self.index_to_world(i, j) - P) <= tol * self.resolution, axis=1)

    def is_free(self, points: ArrayLike) -> np.ndarray:
        """Raster rule: free iff inside the map and every floor/ceil lattice neighbour is free."""
        P = self._points(points)
        ny, nx = self.free.shape
        u = (P[:, 0] - self.bounds[0]) / self.resolution
        v = (P[:, 1] - self.bounds[1]) / self.resolution
        # snap values within rounding noise of a lattice line onto it
        ur, vr = np.rint(u), np.rint(v)
        u = np.where(np.abs(u - ur) < 1e-9, ur, u)
        v = np.where(np.abs(v - vr) < 1e-9, vr, v)
        inside = (u >= 0) & (u <= nx - 1) & (v >= 0) & (v <= ny - 1)
        j0 = np.clip(np.floor(u).astype(np.int64), 0, nx - 1)
        j1 = np.clip(np.ceil(u).astype(np.int64), 0, nx - 1)
        i0 = np.clip(np.floor(v).astype(np.int64), 0, ny - 1)
        i1 = np.clip(np.ceil(v).astype(np.int64), 0, ny - 1)
        F = self.free
        return inside & F[i0, j0] & F[i0, j1] & F[i1, j0] & F[i1, j1]

    def segment_is_free(self, a: ArrayLike, b: ArrayLike, step: float | None = None) -> bool:
        """True when points every ``step`` (default ``resolution / 4``) along ``a -> b`` are all free.

        Refused: ``a`` / ``b`` not finite ``(x, y)`` points with ``|x| <= 1e6``; ``step`` not in
        ``(0, 1e6]``, or so small that the segment would take more than 10**7 samples."""
        a = as_point(a, "a")
        b = as_point(b, "b")
        step = self._step(step)
        check_samples(np.linalg.norm(b - a) / step + 1.0, "step", step, describe_length(np.stack([a, b])))
        n = max(2, int(math.ceil(np.linalg.norm(b - a) / step)) + 1)
        s = np.linspace(0.0, 1.0, n)[:, None]
        return bool(np.all(self.is_free(a + s * (b - a))))

    def path_is_free(self, points: ArrayLike, step: float | None = None) -> bool:
        """Every segment of a polyline ``(N, 2)`` is free (dense sampling every ``step``, default
        ``resolution / 4``, raster rule).

        Refused: an empty or non-finite path, ``step`` not in ``(0, 1e6]``, or so small that the
        path would take more than 10**7 samples."""
        P = self._points(points, "path")
        if len(P) == 0:
            raise ShapeError("path must hold at least one (x, y) point, got shape (0, 2)")
        step = self._step(step)
        check_samples(polyline_samples(P, step), "step", step, describe_length(P))
        if len(P) == 1:
            return bool(self.is_free(P)[0])
        seg = np.diff(P, axis=0)
        lengths = np.linalg.norm(seg, axis=1)
        counts = np.maximum(1, np.ceil(lengths / step).astype(int))
        samples = [P[:1]]
        for p, d, c in zip(P[:-1], seg, counts):
            samples.append(p + (np.arange(1, c + 1) / c)[:, None] * d)
        return bool(np.all(self.is_free(np.concatenate(samples))))

    def _step(self, step: object) -> float:
        """A sampling step: ``resolution / 4`` when None, else a number in ``(0, 1e6]``."""
        return self.resolution / 4.0 if step is None else as_positive(step, "step")

    def clearance(self, points: ArrayLike) -> np.ndarray:
        """Exact margin: ``min(sd_shape - inflation, border distance - border_clearance)`` (>= 0 is free)."""
        P = self._points(points)
        b = self.bounds
        border = np.minimum.reduce([P[:, 0] - b[0], b[2] - P[:, 0], P[:, 1] - b[1], b[3] - P[:, 1]])
        out = border - self.border_clearance
        for s in self.shapes:
            out = np.minimum(out, s.signed_distance(P[:, 0], P[:, 1]) - self.inflation)
        return out

    def distance_field(self) -> np.ndarray:
        """Distance (world units) from each lattice point to the nearest blocked one (0 when blocked).

        Euclidean distance transform (``scipy.ndimage.distance_transform_edt``)
        of the lattice, with the outside of the map counted as blocked.
        """
        if self._distance is None:
            padded = np.pad(self.free, 1, constant_values=False)
            d = ndimage.distance_transform_edt(padded, sampling=self.resolution)
            self._distance = d[1:-1, 1:-1]
        return self._distance

    def first_blocked(self, points: ArrayLike) -> int | None:
        """Index of the first point that is not free, or None."""
        bad = np.flatnonzero(~self.is_free(points))
        return int(bad[0]) if bad.size else None


def check_grid(grid: object, name: str = "grid") -> None:
    """:class:`InputError` unless ``grid`` is an :class:`OccupancyGrid`."""
    if not isinstance(grid, OccupancyGrid):
        raise InputError(f"{name} must be an OccupancyGrid (OccupancyGrid.from_shapes(...)), "
                         f"got {describe(grid)}")


def _index_array(value: object, name: str) -> np.ndarray:
    """``value`` as a 1-D int64 array of lattice indices (integers with ``|k| <= MAX_INDEX``)."""
    if value is None or isinstance(value, (str, bytes, dict)):
        raise InputError(f"{name} must be integer lattice indices, got {value!r}")
    try:
        arr = np.atleast_1d(np.asarray(value, dtype=float))
    except (TypeError, ValueError):
        raise InputError(f"{name} must be integer lattice indices, got {value!r}") from None
    if arr.ndim != 1:
        raise ShapeError(f"{name} must be a 1-D array of lattice indices, got shape {arr.shape}")
    if not np.all(np.abs(arr) <= MAX_INDEX) or not np.all(arr == np.round(arr)):
        raise InputError(f"{name} must be integer lattice indices with |{name}| <= {MAX_INDEX:g}, got "
                         f"{arr[:5].tolist()}")
    return arr.astype(np.int64)
