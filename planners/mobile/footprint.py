"""A mobile base's rectangular footprint swept along a path: how deep it reaches into obstacles.

A planner that treats the robot as its centre pads the obstacles by a
clearance ``c``. For a ``length x width`` rectangle turning with the path,
the point of the footprint farthest from the centre is a corner, at the half
diagonal ``sqrt(length^2 + width^2) / 2``; padding by half the *width* lets the
corners of a turning (non axis-aligned) footprint cut into obstacles.

:func:`footprint_penetration` measures it with the obstacles' own geometry:
at every path sample ``(x, y, heading)`` the footprint's outline (its four
corners and points every ``spacing`` along its edges) is placed by the
rotation ``R(heading)`` about the centre, and the signed distance of every
outline point to every shape (:mod:`planners.mobile.shapes`; negative
inside) is evaluated. The penetration depth at a pose is ``max(0, -min sd)``:
how far the deepest outline point is inside an obstacle. Walls (the map
``bounds``) count as obstacles too: the depth past a wall is how far a point
lies outside the bounds. For convex obstacles a footprint whose outline
stays outside cannot hold an obstacle inside it unless the obstacle is
smaller than the footprint, so the outline suffices for the S7/S8 maps.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from kinserve.kinematics.errors import InputError
from kinserve.kinematics.validation import as_positive, as_vector

from ._checks import MAX_SAMPLES, as_headings, as_points, check_samples
from .shapes import Circle, Polygon, Rectangle

#: Most outline points of :func:`footprint_outline`.
MAX_OUTLINE_POINTS = 10**6
#: Most (pose, outline point) pairs :func:`footprint_penetration` evaluates per obstacle.
MAX_EVALUATIONS = 10**8
#: Most entries of one chunk of placed outline points.
_CHUNK_ENTRIES = 4_000_000


@dataclass(frozen=True)
class Penetration:
    """Deepest reach of a swept footprint into obstacles.

    ``depth``: the largest penetration over the whole path (0 when the
    footprint never enters an obstacle); ``index``, ``pose`` (x, y, heading)
    and ``shape``: where it happens and into which obstacle (None when
    ``depth == 0``); ``point``: the outline point that reaches deepest;
    ``per_shape``: ``{shape name: largest depth}`` for every obstacle (walls:
    ``"walls"``); ``poses_in_contact``: how many path samples penetrate at all.
    """

    depth: float
    index: int | None
    pose: tuple[float, float, float] | None
    shape: str | None
    point: tuple[float, float] | None
    per_shape: dict[str, float] = field(default_factory=dict)
    poses_in_contact: int = 0

    def summary(self) -> dict:
        """The fields as a JSON-ready dict (``depth`` as ``max_depth``, ``shape`` as ``obstacle``)."""
        return {"max_depth": self.depth, "index": self.index, "pose": self.pose, "obstacle": self.shape,
                "point": self.point, "per_obstacle": dict(self.per_shape),
                "poses_in_contact": self.poses_in_contact}


def footprint_outline(length: float, width: float, spacing: float) -> np.ndarray:
    """``(K, 2)`` points of a ``length x width`` rectangle's outline centred on the origin, x forward:
    the four corners first, then points at most ``spacing`` apart along the edges.

    Refused: ``length``, ``width``, ``spacing`` not in ``(0, 1e6]``; a ``spacing`` so small that the
    outline would exceed :data:`MAX_OUTLINE_POINTS` points."""
    length = as_positive(length, "length")
    width = as_positive(width, "width")
    spacing = as_positive(spacing, "spacing")
    check_samples(2.0 * (length + width) / spacing + 4.0, "spacing", spacing,
                  f"the outline of this {length:g} x {width:g} footprint", MAX_OUTLINE_POINTS)
    hl, hw = 0.5 * length, 0.5 * width
    corners = np.array([[hl, hw], [-hl, hw], [-hl, -hw], [hl, -hw]])
    pts = [corners]
    for a, b in zip(corners, np.roll(corners, -1, axis=0)):
        n = max(1, int(math.ceil(np.linalg.norm(b - a) / spacing)))
        t = (np.arange(1, n) / n)[:, None]
        pts.append(a + t * (b - a))
    return np.vstack(pts)


def _shape_name(s, k: int) -> str:
    return s.name or f"{type(s).__name__.lower()} {k}"


def _checked_arguments(path, heading, shapes, length, width, spacing, turn_step):
    """``(P, H, L, W)``: :func:`footprint_penetration`'s path, headings, length and width, checked
    (:class:`ShapeError` / :class:`InputError` naming the argument), with the other arguments."""
    P = as_points(path, "path")
    H = as_headings(heading, len(P))
    L = as_positive(length, "length")
    W = L if width is None else as_positive(width, "width")
    spacing = as_positive(spacing, "spacing")
    if shapes is None or isinstance(shapes, (str, bytes, dict)) or not isinstance(shapes, Sequence):
        raise InputError(f"shapes must be a list of Rectangle, Circle or Polygon, got {shapes!r:.60}")
    for k, s in enumerate(shapes):
        if not isinstance(s, (Rectangle, Circle, Polygon)):
            raise InputError(f"shapes[{k}] must be a Rectangle, Circle or Polygon, got {type(s).__name__}")
    turn_step = as_positive(turn_step, "turn_step", maximum=math.pi)
    n_outline = 2.0 * (L + W) / spacing + 4.0
    check_samples(n_outline, "spacing", spacing, f"the outline of this {L:g} x {W:g} footprint",
                  MAX_OUTLINE_POINTS)
    dh = np.abs(np.angle(np.exp(1j * np.diff(H))))
    n_turn = float(np.sum(np.ceil(dh[dh > turn_step] / turn_step)))
    check_samples(n_turn + 1.0, "turn_step", turn_step, "the turns in place of this path", MAX_SAMPLES)
    poses = len(P) + n_turn
    if poses * n_outline > MAX_EVALUATIONS:
        raise InputError(f"{poses:.0f} poses x {n_outline:.0f} outline points is more than "
                         f"{MAX_EVALUATIONS:.0e} evaluations per obstacle: use a larger spacing (got "
                         f"{spacing!r}) or turn_step (got {turn_step!r}), or fewer path samples")
    return P, H, L, W, spacing, turn_step


def _bounds(bounds: object) -> tuple[float, float, float, float] | None:
    """``bounds`` ``(x_min, y_min, x_max, y_max)`` with min < max (finite, ``|x| <= 1e6``) or None."""
    if bounds is None:
        return None
    b = tuple(as_vector(bounds, 4, "bounds").tolist())
    if not (b[0] < b[2] and b[1] < b[3]):
        raise InputError(f"bounds must be (x_min, y_min, x_max, y_max) with min < max, got {bounds!r}")
    return b


def footprint_penetration(path: Any, heading: Any, shapes: Sequence[Any], *, length: float,
                          width: float | None = None, bounds: tuple[float, float, float, float] | None = None,
                          spacing: float = 0.25, turn_step: float = math.radians(2.0)) -> Penetration:
    """How deep a ``length x width`` footprint (``width`` default ``length``: a square), centred on
    ``path[i]`` (``(N, 2)``) and turned by ``heading[i]`` (rad, ``(N,)``), reaches into ``shapes``
    (Rectangle / Circle / Polygon) and past the walls of ``bounds = (x_min, y_min, x_max, y_max)``.

    Where the heading jumps between samples by more than ``turn_step`` (a corner of the path, where
    a differential drive turns in place), the intermediate headings are swept too, at most
    ``turn_step`` apart (so a depth can be missed by at most ``R (1 - cos(turn_step / 2))``, ``R`` the
    half diagonal: 0.002 for a 20 x 20 footprint at 2 deg). ``index`` in the
    result is the path sample (of a turn: the sample where it happens). See the module docstring.

    Refused (:class:`InputError` and subclasses, naming the argument): ``path`` not finite
    ``(N >= 1, 2)`` points with ``|x| <= 1e6``; ``heading`` not ``N`` such angles; ``length``,
    ``width``, ``spacing`` not in ``(0, 1e6]``; ``turn_step`` not in ``(0, pi]``; ``shapes`` not a list
    of shapes; ``bounds`` not ``(x_min, y_min, x_max, y_max)`` with min < max; a ``spacing`` or
    ``turn_step`` so small that the sweep would exceed 10**8 evaluations per obstacle."""
    P, H, L, W, spacing, turn_step = _checked_arguments(path, heading, shapes, length, width, spacing,
                                                        turn_step)
    bounds = _bounds(bounds)
    outline = footprint_outline(L, W, spacing)
    reach = 0.5 * math.hypot(L, W)
    src, P, H = _with_turns_in_place(P, H, turn_step)
    c, s_ = np.cos(H), np.sin(H)

    def placed(idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World x, y ``(len(idx), K)`` of the outline at the poses ``idx``."""
        ox, oy = outline[:, 0][None, :], outline[:, 1][None, :]
        ci, si = c[idx][:, None], s_[idx][:, None]
        return P[idx, :1] + ci * ox - si * oy, P[idx, 1:] + si * ox + ci * oy

    depth_at = np.zeros(len(P))  # deepest penetration at each pose (path samples and turns in place)
    where: list = [None] * len(P)  # (shape name, point) of it
    per_shape: dict[str, float] = {}
    obstacles = [(_shape_name(s, k), s.signed_distance) for k, s in enumerate(shapes)]
    if bounds is not None:
        x0, y0, x1, y1 = (float(v) for v in bounds)
        obstacles.append(("walls", lambda x, y: np.minimum.reduce([x - x0, x1 - x, y - y0, y1 - y])))
    for name, sd in obstacles:
        near = np.flatnonzero(sd(P[:, 0], P[:, 1]) < reach + 1e-9)  # only these poses can reach the obstacle
        per_shape[name] = 0.0
        chunk = max(1, min(4096, _CHUNK_ENTRIES // len(outline)))
        for start in range(0, len(near), chunk):
            idx = near[start:start + chunk]
            X, Y = placed(idx)
            D = sd(X, Y)
            k = np.argmin(D, axis=1)
            deepest = -D[np.arange(len(idx)), k]
            if deepest.size:
                per_shape[name] = max(per_shape[name], float(max(deepest.max(), 0.0)))
            better = deepest > depth_at[idx]
            for j in np.flatnonzero(better):
                i = idx[j]
                depth_at[i] = deepest[j]
                where[i] = (name, (float(X[j, k[j]]), float(Y[j, k[j]])))
    if not np.any(depth_at > 0):
        return Penetration(0.0, None, None, None, None, per_shape, 0)
    i = int(np.argmax(depth_at))
    name, point = where[i]
    return Penetration(float(depth_at[i]), int(src[i]), (float(P[i, 0]), float(P[i, 1]), float(H[i])), name,
                       point, per_shape, int(np.unique(src[depth_at > 0]).size))


def _with_turns_in_place(P: np.ndarray, H: np.ndarray, turn_step: float):
    """``(source index, points, headings)``: the path samples, plus, where the heading jumps by more
    than ``turn_step`` from one sample to the next, the intermediate headings of turning in place
    at the later sample (the robot arrives with ``H[i-1]`` and leaves with ``H[i]``)."""
    dh = np.angle(np.exp(1j * np.diff(H)))  # shortest signed turn, (-pi, pi]
    idx, pts, hs = [np.arange(len(P))], [P], [H]
    for k in np.flatnonzero(np.abs(dh) > turn_step):
        n = int(math.ceil(abs(dh[k]) / turn_step))
        t = np.arange(1, n) / n
        idx.append(np.full(len(t), k + 1))
        pts.append(np.repeat(P[k + 1][None], len(t), axis=0))
        hs.append(H[k] + t * dh[k])
    return np.concatenate(idx), np.concatenate(pts), np.concatenate(hs)
