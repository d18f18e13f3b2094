"""Layout checks of matplotlib figures as they were saved (titles inside, legends clear of the data).

``capture_figures()`` wraps ``viz.save_png`` so that a scenario run keeps the
Figure objects it wrote (``{png file name: Figure}``); the checks read the
drawn figure's window extents from the Agg renderer.
"""

from __future__ import annotations

import contextlib
from pathlib import Path

import numpy as np
import pytest
from matplotlib.lines import Line2D
from matplotlib.transforms import Bbox


@contextlib.contextmanager
def capture_figures():
    """Within the block, every ``viz.save_png(fig, path)`` also records ``{Path(path).name: fig}``."""
    from kinserve import viz

    saved: dict = {}
    real = viz.save_png

    def keep(fig, path, *args, **kwargs):
        saved[Path(path).name] = fig
        return real(fig, path, *args, **kwargs)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(viz, "save_png", keep)
        yield saved


def _renderer(fig):
    fig.canvas.draw()
    return fig.canvas.get_renderer()


def titles_inside(fig) -> None:
    """Every axes title and the figure's suptitle lie wholly inside the figure."""
    r = _renderer(fig)
    box = fig.bbox
    texts = [t for ax in fig.axes for t in (ax.title, ax._left_title, ax._right_title) if t.get_text()]
    if fig._suptitle is not None and fig._suptitle.get_text():
        texts.append(fig._suptitle)
    assert texts, "the figure has no title"
    for t in texts:
        e = t.get_window_extent(r)
        inside = (e.x0 >= box.x0 - 0.5 and e.x1 <= box.x1 + 0.5
                  and e.y0 >= box.y0 - 0.5 and e.y1 <= box.y1 + 0.5)
        assert inside, f"title {t.get_text()!r} extends outside the figure: {e} vs {box}"


def data_lines(ax) -> list[Line2D]:
    """The lines of ``ax`` drawn in data coordinates (curves and markers; not axhline/axvline references)."""
    return [ln for ln in ax.lines if ln.get_transform() == ax.transData and len(ln.get_xydata()) > 0]


def _points_in(bbox: Bbox, xy: np.ndarray) -> np.ndarray:
    return (xy[:, 0] > bbox.x0) & (xy[:, 0] < bbox.x1) & (xy[:, 1] > bbox.y0) & (xy[:, 1] < bbox.y1)


def legends_clear_of_data(fig) -> None:
    """No legend (axes' or figure's) covers any point of any data line: each segment is sampled
    every pixel or so in display coordinates and none of the samples is inside a legend's box."""
    r = _renderer(fig)
    legends = [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None] + list(fig.legends)
    assert legends, "the figure has no legend"
    for leg in legends:
        box = leg.get_window_extent(r)
        for ax in fig.axes:
            for ln in data_lines(ax):
                xy = ax.transData.transform(np.asarray(ln.get_xydata(), dtype=float))
                xy = xy[np.isfinite(xy).all(axis=1)]
                if len(xy) > 1:
                    step = np.linalg.norm(np.diff(xy, axis=0), axis=1)
                    k = np.clip(np.ceil(step).astype(int), 1, 2000)
                    xy = np.vstack([a + np.outer(np.linspace(0, 1, n, endpoint=False), b - a)
                                    for a, b, n in zip(xy[:-1], xy[1:], k)] + [xy[-1:]])
                # only what is visible: the samples inside the axes
                xy = xy[_points_in(ax.bbox, xy)]
                inside = _points_in(box, xy)
                assert not inside.any(), (f"legend {[t.get_text() for t in leg.get_texts()][:3]} covers "
                                          f"{inside.sum()} points of line {ln.get_label()!r}")


def axis_labels(ax) -> None:
    assert ax.get_xlabel().strip(), f"axes {ax.get_title()!r} has no x label"
    assert ax.get_ylabel().strip(), f"axes {ax.get_title()!r} has no y label"
