"""Reachability map figure: share of sampled poses reached, projected on the xy and xz planes."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from kinserve.kinematics.errors import ShapeError


def reachability_figure(edges, counts, hits, *, title: str = "Reachability") -> Figure:
    """Two heat maps: reached/sampled summed over z (xy view) and over y (xz view).

    ``edges`` are the three cell-edge arrays (m); ``counts`` and ``hits`` the
    per-cell sample and reached counts, shape ``(nx, ny, nz)``.
    """
    counts = np.asarray(counts, dtype=float)
    hits = np.asarray(hits, dtype=float)
    if counts.ndim != 3 or hits.shape != counts.shape or len(edges) != 3:
        raise ShapeError("counts and hits must be (nx, ny, nz) arrays of one shape with 3 edge arrays, "
                         f"got {counts.shape}, {hits.shape}")
    fig = Figure(figsize=(10.0, 4.4))
    views = [("x (m)", "y (m)", 2, edges[0], edges[1]), ("x (m)", "z (m)", 1, edges[0], edges[2])]
    for k, (xl, yl, axis, ex, ey) in enumerate(views):
        ax = fig.add_subplot(1, 2, k + 1)
        c, h = counts.sum(axis=axis), hits.sum(axis=axis)
        with np.errstate(invalid="ignore", divide="ignore"):
            frac = np.where(c > 0, h / np.maximum(c, 1), np.nan)
        mesh = ax.pcolormesh(ex, ey, frac.T, vmin=0.0, vmax=1.0, cmap="viridis", shading="flat")
        ax.set_xlabel(xl)
        ax.set_ylabel(yl)
        ax.set_aspect("equal")
        ax.set_title(f"{title}: {yl[0]} vs {xl[0]}")
        fig.colorbar(mesh, ax=ax, label="reached / sampled")
    fig.tight_layout()
    return fig
