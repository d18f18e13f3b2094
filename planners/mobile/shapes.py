"""Obstacle shapes in world units, each with a vectorised signed distance.

``signed_distance(x, y)`` is negative inside the shape, zero on its boundary
and the Euclidean distance to the shape outside. A shape inflated by ``r``
(the robot's radius) is the set ``{p : signed_distance(p) < r}`` (an open
set: a robot centre exactly ``r`` away from an obstacle only touches it).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from kinserve.kinematics.errors import InputError
from kinserve.kinematics.validation import as_positive, as_real

from ._checks import as_polygon, shoelace_area

#: Most vertices of a :class:`Polygon` (its signed distance costs points x vertices, its simplicity test
#: vertices^2).
MAX_VERTICES = 10_000


def _finite(shape: object, fields: tuple[str, ...], what: str) -> None:
    """Check (and store as floats) the numeric ``fields`` of the frozen dataclass ``shape``: each a finite
    real with ``|x| <= 1e6`` (:func:`as_real`; :class:`InputError` / :class:`NonFiniteError` naming it)."""
    for f in fields:
        object.__setattr__(shape, f, as_real(getattr(shape, f), f"{what} {f}"))


def _check_name(name: object, what: str) -> None:
    if not isinstance(name, str):
        raise InputError(f"{what}: name must be a string, got {type(name).__name__}")


@dataclass(frozen=True)
class Rectangle:
    """Axis-aligned rectangle ``[x_min, x_max] x [y_min, y_max]``.

    Refuses non-numeric, non-finite or huge (``|x| > 1e6``) coordinates and an empty rectangle.
    """

    x_min: float
    y_min: float
    x_max: float
    y_max: float
    name: str = ""

    def __post_init__(self):
        _check_name(self.name, "rectangle")
        _finite(self, ("x_min", "y_min", "x_max", "y_max"), f"rectangle {self.name!r}")
        if not (self.x_min < self.x_max and self.y_min < self.y_max):
            raise InputError(
                f"rectangle {self.name!r} needs x_min < x_max and y_min < y_max, got ({self.x_min}, "
                f"{self.y_min})-({self.x_max}, {self.y_max})"
            )

    def signed_distance(self, x: ArrayLike, y: ArrayLike) -> np.ndarray:
        """Signed distance (negative inside) of the points ``(x, y)`` to the rectangle."""
        dx = np.maximum(self.x_min - np.asarray(x, dtype=float), np.asarray(x, dtype=float) - self.x_max)
        dy = np.maximum(self.y_min - np.asarray(y, dtype=float), np.asarray(y, dtype=float) - self.y_max)
        outside = np.hypot(np.maximum(dx, 0.0), np.maximum(dy, 0.0))
        return outside + np.minimum(np.maximum(dx, dy), 0.0)

    def bounds(self) -> tuple[float, float, float, float]:
        """``(x_min, y_min, x_max, y_max)``."""
        return (self.x_min, self.y_min, self.x_max, self.y_max)

    @property
    def area(self) -> float:
        """Area ``(x_max - x_min) (y_max - y_min)`` (map units squared)."""
        return (self.x_max - self.x_min) * (self.y_max - self.y_min)


@dataclass(frozen=True)
class Circle:
    """Disc of ``radius`` around ``(cx, cy)``.

    Refuses non-numeric, non-finite or huge (``|x| > 1e6``) numbers and a radius ``<= 0``.
    """

    cx: float
    cy: float
    radius: float
    name: str = ""

    def __post_init__(self):
        _check_name(self.name, "circle")
        _finite(self, ("cx", "cy"), f"circle {self.name!r}")
        object.__setattr__(self, "radius", as_positive(self.radius, f"circle {self.name!r} radius"))

    def signed_distance(self, x: ArrayLike, y: ArrayLike) -> np.ndarray:
        """Signed distance (negative inside) of the points ``(x, y)`` to the circle."""
        return np.hypot(np.asarray(x, dtype=float) - self.cx,
                        np.asarray(y, dtype=float) - self.cy) - self.radius

    def bounds(self) -> tuple[float, float, float, float]:
        """``(x_min, y_min, x_max, y_max)`` of the enclosing square."""
        r = self.radius
        return (self.cx - r, self.cy - r, self.cx + r, self.cy + r)

    @property
    def area(self) -> float:
        """Area ``pi r^2`` (map units squared)."""
        return float(np.pi * self.radius**2)


@dataclass(frozen=True)
class Polygon:
    """Simple polygon with vertices ``(k, 2)`` (either orientation, ``3 <= k <= 10000``).

    Its edges may meet only at the corners shared by consecutive edges; a last vertex equal to the
    first (a closed ring) is accepted and kept. Refuses other shapes, non-numeric, non-finite or huge
    (``|x| > 1e6``) vertices, a vertex repeating the one before it, a zero area (collinear vertices) and
    a self-crossing or self-touching outline (a bow-tie, a vertex on a non-adjacent edge, overlapping
    collinear edges; the message names the two edges), all with kinserve's errors naming
    ``vertices``. The test and its tolerance (angles within 1e-12 rad of 0 or pi count as collinear)
    are those of :func:`planners.mobile._checks.as_polygon`.
    """

    vertices: tuple
    name: str = ""
    _v: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        _check_name(self.name, "polygon")
        V = as_polygon(self.vertices, f"polygon {self.name!r}", MAX_VERTICES)
        object.__setattr__(self, "vertices", tuple(map(tuple, V.tolist())))
        object.__setattr__(self, "_v", V)

    def signed_distance(self, x: ArrayLike, y: ArrayLike) -> np.ndarray:
        """Distance from the points ``(x, y)`` (broadcast together) to the boundary, negative inside."""
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        shape = np.broadcast(x, y).shape
        px, py = np.broadcast_to(x, shape).ravel(), np.broadcast_to(y, shape).ravel()
        A = self._v
        B = np.roll(A, -1, axis=0)
        ex, ey = (B - A)[:, 0], (B - A)[:, 1]
        wx = px[:, None] - A[None, :, 0]
        wy = py[:, None] - A[None, :, 1]
        den = ex * ex + ey * ey  # 0 for a repeated vertex: then t = 0 (the distance to that vertex)
        t = np.clip((wx * ex + wy * ey) / np.where(den > 0.0, den, 1.0), 0.0, 1.0)
        d = np.hypot(wx - t * ex, wy - t * ey).min(axis=1)
        # even-odd rule: count edges crossed by a ray towards +x
        ay, by = A[None, :, 1], B[None, :, 1]
        crosses = (ay > py[:, None]) != (by > py[:, None])
        with np.errstate(divide="ignore", invalid="ignore"):
            xint = A[None, :, 0] + (py[:, None] - ay) * (B[None, :, 0] - A[None, :, 0]) / (by - ay)
        inside = (np.sum(crosses & (px[:, None] < xint), axis=1) % 2) == 1
        return np.where(inside, -d, d).reshape(shape)

    def bounds(self) -> tuple[float, float, float, float]:
        """``(x_min, y_min, x_max, y_max)`` of the vertices."""
        V = self._v
        return (V[:, 0].min(), V[:, 1].min(), V[:, 0].max(), V[:, 1].max())

    @property
    def area(self) -> float:
        """Area by the shoelace formula (map units squared)."""
        return shoelace_area(self._v)


Shape = Rectangle | Circle | Polygon
