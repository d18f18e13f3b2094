"""Matplotlib figures of plain data, saved as PNG.

Every ``*_figure`` function takes arrays and returns a
``matplotlib.figure.Figure`` built without ``pyplot`` (no global state, no
display: the Agg canvas renders it), and :func:`save_png` writes one to disk.
So a scenario does ``viz.save_png(viz.joints_figure(t, Q, names), out / "joints.png")``.

Figures:

* :func:`series_figure` - any named series against a common x (iteration or time);
* :func:`joints_figure` - joint variables against x (S3, S5, S9), with limits;
* :func:`errors_figure` - task errors against x, log scale by default;
* :func:`joints_and_errors_figure` - both stacked (the S9 layout);
* :func:`manipulability_figure` - manipulability along a trajectory, with a threshold;
* :func:`xy_figure` - planar curves (reference vs. followed path, S5);
* :func:`map_figure` - a 2-D map with obstacles, paths, waypoints and coverage (S7, S8);
* :func:`planar_arm_figure` - configurations of a planar arm, e.g. the S1 solution family.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Circle as CirclePatch
from matplotlib.patches import Rectangle

from kinserve.kinematics.errors import InputError, NonFiniteError, ShapeError
from kinserve.kinematics.validation import (
    MAX_ABS,
    as_count,
    as_flag,
    as_matrix,
    as_nonnegative,
    as_numbers,
    as_path,
    as_positive,
    as_text,
    describe,
)

from . import colors
from .map2d import Rect, as_grid, as_polyline, as_shape

#: Smallest value drawn on a log axis (exact zeros would vanish).
LOG_FLOOR = 1e-16
#: The range of :func:`save_png`'s ``dpi`` (dots per inch).
MIN_DPI, MAX_DPI = 10, 1200


def _check_labels(**labels: object) -> None:
    """Each keyword argument (an axis label, a title, the units) must be a str: :class:`InputError` naming
    it (matplotlib would draw ``3``, ``nan`` or ``True`` as the text)."""
    for name, value in labels.items():
        as_text(value, name)


def _figure(rows: int = 1, size=(7.0, 4.2)):
    fig = Figure(figsize=size, layout="constrained")
    FigureCanvasAgg(fig)
    axes = [fig.add_subplot(rows, 1, i + 1) for i in range(rows)]
    return fig, axes


def save_png(fig: Figure, path: str | os.PathLike, dpi: int = 120) -> Path:
    """Write ``fig`` as a PNG at ``path`` (a ``str`` or ``os.PathLike`` ending in ``.png``; parent folders
    created) at ``dpi`` dots per inch, an integer from :data:`MIN_DPI` to :data:`MAX_DPI`; returns the
    path. :class:`InputError` for anything else."""
    if not isinstance(fig, Figure):
        raise InputError(f"save_png needs a matplotlib Figure, got {type(fig).__name__}")
    path = as_path(path, "save_png: path")
    dpi = as_count(dpi, "dpi", minimum=MIN_DPI, maximum=MAX_DPI)
    if path.suffix.lower() != ".png":
        raise InputError(f"save_png writes PNG files; the path must end in .png, got {str(path)!r}")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi, format="png")
    return path


def _xvalues(x, n: int, name: str = "x") -> np.ndarray:
    if x is None:
        return np.arange(n, dtype=float)
    xs = as_numbers(x, name)
    if xs.shape != (n,):
        raise ShapeError(f"{name} must have shape ({n},) to match the data, got {xs.shape}")
    return xs


def _samples(values: object, name: str) -> np.ndarray:
    """``values`` as a float array of numbers with magnitude at most ``MAX_ABS``, where NaN marks a missing
    sample (drawn as a gap: e.g. a method that stopped earlier than the others); :class:`ShapeError` /
    :class:`NonFiniteError` naming ``name`` for anything else (text, infinities, huge numbers)."""
    try:
        return as_numbers(values, name)
    except NonFiniteError:
        arr = np.asarray(values, dtype=float)  # numbers (as_numbers read them), some NaN or out of bounds
        if np.all(np.isnan(arr) | (np.abs(arr) <= MAX_ABS)):
            return arr
        raise


def _series(series, name: str) -> list[tuple[str, np.ndarray]]:
    """``[(label, 1-D array)]`` from a dict of arrays or a single ``(N,)``/``(N, k)`` array."""
    if isinstance(series, dict):
        out = []
        for label, v in series.items():
            arr = _samples(v, f"{name}[{label!r}]")
            if arr.ndim != 1:
                raise ShapeError(f"{name}[{label!r}] must be 1-D, got shape {arr.shape}")
            out.append((str(label), arr))
        return out
    arr = _samples(series, name)
    if arr.ndim == 1:
        return [(name, arr)]
    if arr.ndim == 2:
        return [(f"{name}[{j}]", arr[:, j]) for j in range(arr.shape[1])]
    raise ShapeError(f"{name} must be a dict of 1-D arrays or an (N,) / (N, k) array, got shape {arr.shape}")


def _plot_series(ax, x, series, *, logy: bool, name: str):
    logy = as_flag(logy, "logy")
    items = _series(series, name)
    if not items:
        raise InputError(f"{name}: nothing to plot")
    n = len(items[0][1])
    xs = _xvalues(x, n)
    for i, (label, v) in enumerate(items):
        if len(v) != n:
            raise ShapeError(f"{name}[{label!r}] has {len(v)} samples, expected {n} like the others")
        y = np.maximum(np.abs(v), LOG_FLOOR) if logy else v
        ax.plot(xs, y, label=label, color=colors.to_rgb(colors.cycle(i)), linewidth=1.6)
    if logy:
        ax.set_yscale("log")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)


def series_figure(x, series, *, xlabel: str = "iteration", ylabel: str = "", title: str = "",
                  logy: bool = False) -> Figure:
    """Named series (``{label: (N,)}`` or an ``(N, k)`` array) against ``x`` (``(N,)``; default 0..N-1).
    Labels and title are str."""
    _check_labels(xlabel=xlabel, ylabel=ylabel, title=title)
    fig, (ax,) = _figure()
    _plot_series(ax, x, series, logy=logy, name=ylabel or "y")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    return fig


def _joints(ax, x, Q, names, limits):
    Q = as_matrix(Q, (-1, -1), "Q")
    n, k = Q.shape
    names = _names(names, k)
    xs = _xvalues(x, n)
    for j in range(k):
        ax.plot(xs, Q[:, j], label=names[j], color=colors.to_rgb(colors.cycle(j)), linewidth=1.6)
    if limits is not None:
        if not (isinstance(limits, (tuple, list, np.ndarray)) and len(limits) == 2):
            raise ShapeError(f"limits must be (lower, upper), each of shape ({k},), got {describe(limits)}")
        lower, upper = as_matrix(limits[0], (k,), "limits lower"), as_matrix(limits[1], (k,), "limits upper")
        for j in range(k):
            c = colors.to_rgb(colors.cycle(j))
            ax.axhline(lower[j], color=c, linestyle=":", linewidth=0.9)
            ax.axhline(upper[j], color=c, linestyle=":", linewidth=0.9)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8, ncol=2 if k > 4 else 1)


def _names(names: object, k: int) -> list[str]:
    """The ``k`` joint names of a legend: ``names`` (a sequence of ``k`` strings) or ``q1..qk`` for None."""
    if names is None:
        return [f"q{j + 1}" for j in range(k)]
    if isinstance(names, (str, bytes)) or not isinstance(names, (list, tuple, np.ndarray)) \
            or not all(isinstance(v, str) for v in names):
        raise InputError(f"names must be a sequence of {k} joint names (str), got {describe(names)}")
    if len(names) != k:
        raise ShapeError(f"names has {len(names)} entries for {k} joints")
    return list(names)


def joints_figure(x, Q, names=None, *, limits=None, xlabel: str = "iteration",
                  ylabel: str = "joint value (rad or m)", title: str = "Joint variables") -> Figure:
    """One line per joint of ``Q`` (``(N, nq)``) against ``x``; ``limits=(lower, upper)`` adds dotted
    lines. Labels and title are str."""
    _check_labels(xlabel=xlabel, ylabel=ylabel, title=title)
    fig, (ax,) = _figure()
    _joints(ax, x, Q, names, limits)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    return fig


def errors_figure(x, errors, *, xlabel: str = "iteration", ylabel: str = "error (m or rad)",
                  title: str = "Task errors", logy: bool = True, tolerance: float | None = None) -> Figure:
    """Task errors (``{label: (N,)}``) against ``x``; ``|e|`` on a log axis by default; ``tolerance`` as a
    dashed line (a positive number). Labels and title are str."""
    _check_labels(xlabel=xlabel, ylabel=ylabel, title=title)
    tolerance = None if tolerance is None else as_positive(tolerance, "tolerance")
    fig, (ax,) = _figure()
    _plot_series(ax, x, errors, logy=logy, name="error")
    if tolerance is not None:
        ax.axhline(tolerance, color="black", linestyle="--", linewidth=1.0, label="tolerance")
        ax.legend(loc="best", fontsize=8)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    return fig


def joints_and_errors_figure(x, Q, errors, names=None, *, limits=None, xlabel: str = "iteration",
                             title: str = "", logy: bool = True) -> Figure:
    """Two stacked panels sharing ``x``: joint variables (top) and task errors (bottom). ``xlabel`` and
    ``title`` are str."""
    _check_labels(xlabel=xlabel, title=title)
    fig, (top, bottom) = _figure(rows=2, size=(7.0, 6.4))
    _joints(top, x, Q, names, limits)
    top.set_ylabel("joint value (rad or m)")
    top.set_title(title or "Joint variables and task errors")
    _plot_series(bottom, x, errors, logy=logy, name="error")
    bottom.set_ylabel("error (m or rad)")
    bottom.set_xlabel(xlabel)
    return fig


def manipulability_figure(x, manipulability, *, threshold: float | None = None, xlabel: str = "time (s)",
                          title: str = "Manipulability along the trajectory") -> Figure:
    """Yoshikawa manipulability ``w = sqrt(det(J J^T))`` (``(N,)`` or ``{label: (N,)}``) against ``x``.

    ``threshold`` (a number >= 0) draws the singularity warning level and shades the samples below it.
    ``xlabel`` and ``title`` are str.
    """
    _check_labels(xlabel=xlabel, title=title)
    threshold = None if threshold is None else as_nonnegative(threshold, "threshold")
    fig, (ax,) = _figure()
    series = manipulability if isinstance(manipulability, dict) else {"w": manipulability}
    _plot_series(ax, x, series, logy=False, name="w")
    if threshold is not None:
        ax.axhline(threshold, color="red", linestyle="--", linewidth=1.0, label="threshold")
        w = _series(series, "w")[0][1]
        xs = _xvalues(x, len(w))
        ax.fill_between(xs, 0, 1, where=w < threshold, color="red", alpha=0.12,
                        transform=ax.get_xaxis_transform(), label="below threshold")
        ax.legend(loc="best", fontsize=8)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("manipulability")
    ax.set_title(title)
    return fig


def xy_figure(curves, *, points=None, title: str = "", xlabel: str = "x (m)",
              ylabel: str = "y (m)") -> Figure:
    """Planar curves ``{label: (N, 2)}`` on equal axes; ``points``: ``{label: (x, y)}`` markers. Labels and
    title are str."""
    _check_labels(xlabel=xlabel, ylabel=ylabel, title=title)
    if not isinstance(curves, dict) or not curves:
        raise InputError("curves must be a non-empty dict {label: (N, 2) points}")
    fig, (ax,) = _figure(size=(6.0, 6.0))
    for i, (label, pts) in enumerate(curves.items()):
        P = as_polyline(pts, f"curves[{label!r}]", dims=(2,))
        ax.plot(P[:, 0], P[:, 1], label=str(label), color=colors.to_rgb(colors.cycle(i)), linewidth=1.6)
    for label, (px, py) in _points(points, "points"):
        ax.plot([px], [py], marker="o", linestyle="none", color="black")
        ax.annotate(str(label), (px, py), textcoords="offset points", xytext=(4, 4), fontsize=8)
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    return fig


def _points(points: object, name: str) -> list[tuple[object, tuple[float, float]]]:
    """``[(label, (x, y))]`` of labelled markers: ``points`` None, ``{label: (x, y)}`` or a sequence of
    ``(x, y)`` (labelled by index); :class:`InputError` / :class:`ShapeError` naming ``name`` otherwise."""
    if points is None:
        return []
    if isinstance(points, dict):
        items = list(points.items())
    elif isinstance(points, (list, tuple, np.ndarray)):
        items = list(enumerate(points))
    else:
        raise InputError(f"{name} must be a dict {{label: (x, y)}} or a sequence of (x, y), got "
                         f"{describe(points)}")
    out = []
    for label, p in items:
        xy = as_matrix(p, (-1,), f"{name}[{label!r}]")
        if len(xy) < 2:
            raise ShapeError(f"{name}[{label!r}] must be a point (x, y), got shape {xy.shape}")
        out.append((label, (float(xy[0]), float(xy[1]))))
    return out


def _paths(paths: object) -> list[tuple[object, np.ndarray]]:
    """``[(label, (N, 2) points)]`` of :func:`map_figure`'s ``paths``: None, ``{label: (N, 2)}``, one
    ``(N, 2)`` array, or a sequence of them."""
    if paths is None:
        return []
    if isinstance(paths, dict):
        items = list(paths.items())
    elif isinstance(paths, np.ndarray) and paths.ndim == 2:
        items = [("path", paths)]
    elif isinstance(paths, (list, tuple, np.ndarray)):
        items = list(enumerate(paths))
    else:
        raise InputError(f"paths must be a dict {{label: (N, 2) points}}, an (N, 2) array or a sequence of "
                         f"them, got {describe(paths)}")
    return [(label, as_polyline(pts, f"paths[{label!r}]", dims=(2,))) for label, pts in items]


def _bounds(bounds: object) -> tuple[float, float, float, float] | None:
    """``(xmin, ymin, xmax, ymax)`` of :func:`map_figure` (finite, ``min < max``), or None."""
    if bounds is None:
        return None
    x0, y0, x1, y1 = (float(v) for v in as_matrix(bounds, (4,), "bounds (xmin, ymin, xmax, ymax)"))
    if not (x0 < x1 and y0 < y1):
        raise InputError(f"bounds must be (xmin, ymin, xmax, ymax) with xmin < xmax and ymin < ymax, got "
                         f"{(x0, y0, x1, y1)}")
    return x0, y0, x1, y1


def map_figure(obstacles=(), bounds=None, *, paths=None, waypoints=None, coverage=None, inflate: float = 0.0,
               title: str = "", units: str = "map units") -> Figure:
    """A 2-D map: obstacles (filled), their ``inflate`` margin (hatched outline), the
    coverage grid (green cells), paths (``{label: (N, 2)}``, one line each) and
    waypoints (``{label: (x, y)}``, labelled dots). ``bounds = (xmin, ymin, xmax, ymax)``.

    Accepted: ``obstacles`` None or a list / tuple of shapes (:func:`viz.map2d.as_shape`); ``bounds`` None
    or four finite numbers with ``xmin < xmax``, ``ymin < ymax``; ``paths`` None, a dict, one ``(N, 2)``
    array or a sequence of them; ``waypoints`` None, a dict or a sequence of points; ``coverage`` None or a
    grid (:func:`viz.map2d.as_grid`); ``inflate`` a number in ``[0, 1e6]``; ``title`` and ``units`` str.
    Anything else raises a kinserve error naming the argument, before anything is drawn.
    """
    _check_labels(title=title, units=units)
    if obstacles is None:
        obstacles = ()
    if not isinstance(obstacles, (list, tuple)):
        raise InputError(f"obstacles must be a list of shapes (viz.Rect, viz.Circle, dicts), got "
                         f"{describe(obstacles)}")
    shapes = [as_shape(o) for o in obstacles]
    inflate = as_nonnegative(inflate, "inflate")
    path_items, marks, limits = _paths(paths), _points(waypoints, "waypoints"), _bounds(bounds)
    grid = None if coverage is None else as_grid(coverage)
    fig, (ax,) = _figure(size=(6.4, 6.4))
    if grid is not None:
        ax.imshow(np.where(grid.mask, 1.0, np.nan), origin="lower", extent=grid.extent, cmap="Greens",
                  vmin=0.0, vmax=1.6, alpha=0.55, interpolation="nearest", zorder=0)
    for s in shapes:
        if isinstance(s, Rect):
            ax.add_patch(Rectangle((s.xmin, s.ymin), *s.size, facecolor="#8c564b",
                                   edgecolor="black", zorder=2))
        else:
            ax.add_patch(CirclePatch(s.center, s.r, facecolor="#8c564b", edgecolor="black", zorder=2))
        if inflate > 0:
            if isinstance(s, Rect):
                grown = Rectangle((s.xmin - inflate, s.ymin - inflate), s.size[0] + 2 * inflate,
                                  s.size[1] + 2 * inflate, fill=False, edgecolor="#d62728", linestyle="--",
                                  linewidth=0.9, zorder=2)
            else:
                grown = CirclePatch(s.center, s.r + inflate, fill=False, edgecolor="#d62728", linestyle="--",
                                    linewidth=0.9, zorder=2)
            ax.add_patch(grown)
        if s.name:
            ax.annotate(s.name, s.center, ha="center", va="center", fontsize=7, color="white", zorder=3)
    for i, (label, P) in enumerate(path_items):
        ax.plot(P[:, 0], P[:, 1], color=colors.to_rgb(colors.cycle(i)), linewidth=1.5, zorder=4,
                label=str(label) if isinstance(paths, dict) else None)
    for label, (px, py) in marks:
        ax.plot([px], [py], marker="o", markersize=6, color="black", linestyle="none", zorder=5)
        ax.annotate(str(label), (px, py), textcoords="offset points", xytext=(5, 5), fontsize=8, zorder=5)
    if limits is not None:
        x0, y0, x1, y1 = limits
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
    else:
        ax.autoscale()
    ax.set_aspect("equal")
    ax.grid(True, alpha=0.25)
    ax.set_xlabel(f"x ({units})")
    ax.set_ylabel(f"y ({units})")
    ax.set_title(title)
    if isinstance(paths, dict) and paths:
        ax.legend(loc="upper right", fontsize=8)
    return fig


def planar_chain(link_lengths, q, base=(0.0, 0.0)) -> np.ndarray:
    """Joint and tip positions ``(n+1, 2)`` of a planar serial arm with revolute joints about z.

    ``p_0 = base``, ``p_i = p_{i-1} + l_i (cos(q_1+...+q_i), sin(q_1+...+q_i))``.
    """
    lengths = as_matrix(link_lengths, (-1,), "link_lengths")
    q = as_matrix(q, lengths.shape, "q (one angle per link)")
    p0 = as_matrix(base, (2,), "base")
    phi = np.cumsum(q)
    steps = lengths[:, None] * np.c_[np.cos(phi), np.sin(phi)]
    return np.vstack([p0, p0 + np.cumsum(steps, axis=0)])


def planar_arm_figure(link_lengths, branches, *, target=None, base=(0.0, 0.0),
                      title: str = "Planar arm configurations", max_per_branch: int = 24,
                      count_in_label: bool = True) -> Figure:
    """Configurations of a planar arm (e.g. the S1 4R solution family), one colour per branch.

    ``branches``: ``{label: (M, n) joint angles}`` (rad; e.g. ``{"elbow up": Q1,
    "elbow down": Q2}``); each configuration is drawn as its chain of links
    (:func:`planar_chain`), at most ``max_per_branch`` evenly chosen per branch.
    ``target = (x, y, theta)`` marks the task pose with an arrow along ``theta``.
    Legend entries read ``label (M)``, ``M`` the branch's number of configurations;
    ``count_in_label=False`` keeps the labels as given (they state their own counts).
    """
    _check_labels(title=title)
    if not isinstance(branches, dict) or not branches:
        raise InputError("branches must be a non-empty dict {label: (M, n) joint angles}")
    lengths = as_matrix(link_lengths, (-1,), "link_lengths")
    max_per_branch = as_count(max_per_branch, "max_per_branch", minimum=1, maximum=10**4)
    count_in_label = as_flag(count_in_label, "count_in_label")
    base = tuple(as_matrix(base, (2,), "base"))
    target = None if target is None else as_matrix(target, (3,), "target")
    fig, (ax,) = _figure(size=(6.4, 6.4))
    for i, (label, Q) in enumerate(branches.items()):
        if (isinstance(Q, np.ndarray) and Q.size == 0) or (isinstance(Q, (list, tuple)) and len(Q) == 0):
            continue  # a branch with no configuration (e.g. no solution on that branch)
        Q = as_matrix(Q, (-1, len(lengths)), f"branches[{label!r}]")
        idx = np.unique(np.linspace(0, len(Q) - 1, min(len(Q), max_per_branch)).round().astype(int))
        c = colors.to_rgb(colors.cycle(i))
        for j, k in enumerate(idx):
            P = planar_chain(lengths, Q[k], base)
            ax.plot(P[:, 0], P[:, 1], "-o", color=c, markersize=2.5, linewidth=1.1, alpha=0.75,
                    label=(f"{label} ({len(Q)})" if count_in_label else str(label)) if j == 0 else None)
    if target is not None:
        x, y, th = (float(v) for v in target)
        reach = 0.15 * float(lengths.sum())
        ax.annotate("", xy=(x + reach * np.cos(th), y + reach * np.sin(th)), xytext=(x, y),
                    arrowprops=dict(arrowstyle="->", color="black", linewidth=1.5))
        ax.plot([x], [y], marker="*", markersize=12, color="black", linestyle="none", label="target")
    ax.plot([base[0]], [base[1]], marker="s", markersize=8, color="black", linestyle="none")
    reach = float(lengths.sum())
    ax.add_patch(CirclePatch(base, reach, fill=False, linestyle=":", edgecolor="grey"))
    ax.set_xlim(base[0] - 1.05 * reach, base[0] + 1.05 * reach)
    ax.set_ylim(base[1] - 1.05 * reach, base[1] + 1.05 * reach)
    ax.set_aspect("equal")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="lower left", fontsize=8)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title)
    return fig


__all__ = [
    "save_png", "series_figure", "joints_figure", "errors_figure", "joints_and_errors_figure",
    "manipulability_figure", "xy_figure", "map_figure", "planar_chain", "planar_arm_figure",
]
