"""Plain 2-D map data for drawing: rectangles, circles and coverage grids.

``viz`` never imports the planners, so a map reaches it as plain data. Every
drawing function (:meth:`viz.Scene.add_map`, :func:`viz.plots.map_figure`)
runs its obstacles through :func:`as_shape`, which accepts

* a :class:`Rect` / :class:`Circle`;
* a dict ``{"rect": [x0, y0, x1, y1]}`` or ``{"min": [x0, y0], "max": [x1, y1]}``,
  ``{"circle": [cx, cy, r]}`` or ``{"center": [cx, cy], "radius": r}``
  (an optional ``"name"`` key is kept);
* any object with attributes ``xmin, ymin, xmax, ymax`` or ``center, radius``
  (``cx, cy, r`` also work), such as a planner's own obstacle type.

Coordinates are map units (the seed maps use a 480 x 480 grid); scenes scale
them to metres with their ``scale`` argument.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from kinserve.kinematics.errors import InputError, ShapeError
from kinserve.kinematics.validation import as_matrix, as_numbers, as_positive, as_real, as_text, describe


@dataclass(frozen=True)
class Rect:
    """Axis-aligned rectangle ``[xmin, xmax] x [ymin, ymax]`` (map units)."""

    xmin: float
    ymin: float
    xmax: float
    ymax: float
    name: str = ""

    def __post_init__(self):
        for field in ("xmin", "ymin", "xmax", "ymax"):
            object.__setattr__(self, field, as_real(getattr(self, field), f"Rect {field}"))
        as_text(self.name, "Rect name")
        if not (self.xmin < self.xmax and self.ymin < self.ymax):
            raise InputError(f"Rect needs xmin < xmax and ymin < ymax, got ({self.xmin}, "
                             f"{self.ymin})-({self.xmax}, {self.ymax})")

    @property
    def center(self) -> tuple[float, float]:
        """Centre ``(x, y)`` (map units)."""
        return (0.5 * (self.xmin + self.xmax), 0.5 * (self.ymin + self.ymax))

    @property
    def size(self) -> tuple[float, float]:
        """``(width, height)`` (map units)."""
        return (self.xmax - self.xmin, self.ymax - self.ymin)


@dataclass(frozen=True)
class Circle:
    """Disc of centre ``(cx, cy)`` and radius ``r`` (map units)."""

    cx: float
    cy: float
    r: float
    name: str = ""

    def __post_init__(self):
        object.__setattr__(self, "cx", as_real(self.cx, "Circle cx"))
        object.__setattr__(self, "cy", as_real(self.cy, "Circle cy"))
        object.__setattr__(self, "r", as_positive(self.r, "Circle radius"))
        as_text(self.name, "Circle name")

    @property
    def center(self) -> tuple[float, float]:
        """Centre ``(cx, cy)`` (map units)."""
        return (self.cx, self.cy)


@dataclass(frozen=True)
class Grid:
    """A boolean occupancy/coverage grid over the map.

    ``mask[i, j]`` is the cell ``x in [x0 + j*cell, x0 + (j+1)*cell)``,
    ``y in [y0 + i*cell, y0 + (i+1)*cell)``: rows go along y, columns along x.
    """

    mask: np.ndarray
    origin: tuple[float, float] = (0.0, 0.0)
    cell: float = 1.0

    def __post_init__(self):
        """``mask``: a 2-D array (read as bools); ``origin``: two finite numbers; ``cell``: a positive number
        (:class:`InputError` / :class:`ShapeError` otherwise, here rather than when the grid is drawn)."""
        object.__setattr__(self, "mask", _mask(self.mask))
        origin = as_matrix(self.origin, (2,), "Grid origin")
        object.__setattr__(self, "origin", (float(origin[0]), float(origin[1])))
        object.__setattr__(self, "cell", as_positive(self.cell, "Grid cell"))

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """``(xmin, xmax, ymin, ymax)`` of the whole grid (matplotlib ``imshow`` order)."""
        h, w = self.mask.shape
        x0, y0 = self.origin
        return (x0, x0 + w * self.cell, y0, y0 + h * self.cell)

    def fraction(self) -> float:
        """Fraction of true cells."""
        return float(self.mask.mean()) if self.mask.size else 0.0

    def rectangles(self) -> list[Rect]:
        """The true cells merged into row runs: one :class:`Rect` per maximal horizontal run."""
        out = []
        x0, y0 = self.origin
        c = self.cell
        for i, row in enumerate(self.mask):
            padded = np.concatenate(([False], row, [False])).astype(np.int8)
            d = np.diff(padded)
            starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
            for s, e in zip(starts, ends):
                out.append(Rect(x0 + s * c, y0 + i * c, x0 + e * c, y0 + (i + 1) * c))
        return out


def _mask(value: object) -> np.ndarray:
    """``value`` (a 2-D array or nested lists of bools or numbers) as a 2-D bool array, else
    :class:`ShapeError`."""
    mask = None
    if isinstance(value, (np.ndarray, list, tuple)):
        try:
            mask = np.asarray(value)
        except ValueError:  # ragged rows
            mask = None
    if mask is None or mask.ndim != 2 or mask.dtype.kind not in "biuf":
        raise ShapeError(f"a grid mask must be a 2-D boolean grid (rows along y), got {describe(value)}")
    return mask.astype(bool)


def as_shape(obj) -> Rect | Circle:
    """Normalise one obstacle description to a :class:`Rect` or :class:`Circle` (see module doc)."""
    if isinstance(obj, (Rect, Circle)):
        return obj
    try:
        if isinstance(obj, dict):
            name = str(obj.get("name", ""))
            if "rect" in obj:
                x0, y0, x1, y1 = (float(v) for v in obj["rect"])
                return Rect(min(x0, x1), min(y0, y1), max(x0, x1), max(y0, y1), name)
            if "min" in obj and "max" in obj:
                (x0, y0), (x1, y1) = obj["min"], obj["max"]
                return Rect(float(x0), float(y0), float(x1), float(y1), name)
            if "circle" in obj:
                cx, cy, r = (float(v) for v in obj["circle"])
                return Circle(cx, cy, r, name)
            if "center" in obj and "radius" in obj:
                cx, cy = obj["center"]
                return Circle(float(cx), float(cy), float(obj["radius"]), name)
        else:
            name = str(getattr(obj, "name", "") or "")
            if all(hasattr(obj, a) for a in ("xmin", "ymin", "xmax", "ymax")):
                return Rect(float(obj.xmin), float(obj.ymin), float(obj.xmax), float(obj.ymax), name)
            if hasattr(obj, "center") and hasattr(obj, "radius"):
                cx, cy = obj.center[:2]
                return Circle(float(cx), float(cy), float(obj.radius), name)
            if all(hasattr(obj, a) for a in ("cx", "cy", "r")):
                return Circle(float(obj.cx), float(obj.cy), float(obj.r), name)
    except (TypeError, ValueError, InputError):
        pass
    raise ShapeError(
        f"cannot read obstacle {obj!r}: expected a viz.Rect / viz.Circle, a dict with 'rect' / 'min'+'max' / "
        "'circle' / 'center'+'radius', or an object with xmin..ymax or center+radius attributes"
    )


def as_grid(obj) -> Grid:
    """Normalise a coverage grid: a :class:`Grid`, a bool array (origin 0, cell 1), or
    ``(mask, origin, cell)``."""
    if isinstance(obj, Grid):
        return obj
    if isinstance(obj, dict) and "mask" in obj:
        return Grid(obj["mask"], obj.get("origin", (0.0, 0.0)), obj.get("cell", 1.0))
    if isinstance(obj, tuple) and len(obj) == 3:
        return Grid(*obj)
    return Grid(obj)


def as_polyline(points, name: str = "path", dims=(2, 3)) -> np.ndarray:
    """An ``(N, d)`` float array of points (``d`` in ``dims``), ``N >= 1``."""
    arr = as_numbers(points, name)
    if arr.ndim != 2 or arr.shape[1] not in dims or arr.shape[0] < 1:
        raise ShapeError(f"{name} must be an (N, {' or '.join(map(str, dims))}) array of points, "
                         f"got shape {arr.shape}")
    return as_matrix(arr, (-1, arr.shape[1]), name)
