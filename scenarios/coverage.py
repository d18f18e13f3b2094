"""S8: the cleaning robot covers the mall floor - boustrophedon lanes, detours, smooth U-turns (SCENARIOS.md
S8).

Map (:func:`planners.mobile.mall.s8_map`), in map units (u): 480 x 480,
stores 1-4 on the left (x 0-120), stores 5-8 on the right (x 360-480), the
central hallway between. The obstacles are given already padded by half the
20 u footprint: hot-dog stands (210,90)-(270,150) and (150,150)-(210,210),
fountain centre (240,240) radius 50, escalators (125,365)-(195,435) and
(286,365)-(355,435), and the no-go zones (110,-10)-(370,50) and
(110,430)-(370,490); the robot centre also keeps 10 u from the walls.

Planner (:func:`planners.mobile.boustrophedon_coverage`): horizontal lanes
every 20 u (the robot width) from the start (10, 10); lanes cut by obstacles
split the floor into boustrophedon cells, each swept by a zig-zag whose
U-turns are cubic Bezier half-turns of radius ~10 u; the cells are chained
greedily, with detours along smoothed A* paths.

Coverage: a 1 u pixel counts as covered when its centre lies in the
robot's 20 x 20 footprint (rotated with the heading) at some point of the
path; the free area is every pixel the footprint could reach at all.
``coverage_fraction`` = covered / free.

Corners: padding by half the width (10) lets a turning 20 x 20 footprint's
corners reach up to ``10 sqrt(2) - 10 = 4.14`` u into the obstacles
(:func:`planners.mobile.footprint_penetration` sweeps the rotated square,
turns in place included, against the physical shapes, the no-go floor areas
and the walls); ``padding="diagonal"`` pads by half the diagonal instead and
the reach is 0, at the cost of some coverage.

``result.json``: ``coverage_fraction``, ``max_corner_penetration`` (u) with
``penetration`` (where, which obstacle, per obstacle), ``padding``,
``path`` ([x, y] points; the planner's dense samples with the interior points
of straight runs dropped - the same polyline), ``length``, and the cell /
lane / U-turn / detour counts. Artefacts: ``coverage.png``, ``cells.png``, ``scene.html``. The drawings
show the physical obstacles (those of S7, which padded by 10 u are exactly the
shapes above) with the keep-out outline of the padded ones.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.colors import ListedColormap

from kinserve import viz
from kinserve.planners.mobile import boustrophedon_coverage, footprint_penetration, mall

from .map_drawing import draw_keep_out, map_scene, resample_motion, viz_obstacles


def drop_collinear(points, tol: float = 1e-9) -> np.ndarray:
    """The polyline without its interior points that lie on a straight run (same shape, fewer points).

    Point ``i`` is dropped when ``p_{i-1} -> p_i -> p_{i+1}`` keeps its direction:
    ``|cross(d_in, d_out)| <= tol |d_in| |d_out|`` and ``dot(d_in, d_out) > 0``.
    """
    P = np.asarray(points, dtype=float)
    if len(P) < 3:
        return P.copy()
    d_in, d_out = P[1:-1] - P[:-2], P[2:] - P[1:-1]
    cross = d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0]
    dot = np.sum(d_in * d_out, axis=1)
    scale = np.linalg.norm(d_in, axis=1) * np.linalg.norm(d_out, axis=1)
    straight = (np.abs(cross) <= tol * scale) & (dot > 0)
    keep = np.concatenate([[True], ~straight, [True]])
    return P[keep]


def run(out: Path, *, resolution: float = 1.0, speed: float = 50.0, playback_speedup: float = 4.0,
        fps: float = 30.0, padding: str = "width", scene: bool = True) -> dict:
    """Run S8 into ``out``; returns the key numbers (see the module docstring).

    ``speed`` (u/s) is the cleaning speed used for the animation and the
    reported ``duration`` (constant speed along the path); ``playback_speedup``
    plays the scene faster than real time. ``padding``: ``"width"`` (the
    document's padded shapes, 10 = half the width) or ``"diagonal"`` (the
    physical shapes padded by half the diagonal, 10 sqrt(2), start at (15, 15)).
    """
    out = Path(out)
    grid = mall.s8_map(resolution, padding=padding)
    start = mall.s8_start(padding, resolution)
    res = boustrophedon_coverage(grid, start, lane_spacing=mall.S8_LANE_SPACING, robot_width=mall.ROBOT_WIDTH)
    path = drop_collinear(res.path)
    summary = res.summary()
    # the turning footprint against the physical obstacles, the no-go floor areas and the walls
    reach = footprint_penetration(res.path, res.heading, mall.S8_OBSTACLES + mall.S8_NO_GO_RAW,
                                  length=mall.ROBOT_WIDTH, bounds=mall.BOUNDS)

    covered = res.covered & res.coverable
    missed = res.coverable & ~res.covered
    pix = grid.resolution

    # coverage map
    fig = viz.map_figure(viz_obstacles(mall.S7_OBSTACLES, wrap=True), mall.BOUNDS,
                         paths={f"coverage path ({res.length:.0f} u)": path},
                         waypoints={f"start ({start[0]:g}, {start[1]:g})": start},
                         coverage=viz.Grid(covered, (grid.bounds[0], grid.bounds[1]), pix),
                         title=f"S8 floor coverage ({padding} padding, {mall.s8_padding(padding):.3g} u): "
                               f"{100 * res.covered_fraction:.1f} % of the free area swept\n"
                               f"turning footprint reaches {reach.depth:.2f} u into obstacles/walls at most")
    ax = fig.axes[0]
    ax.lines[0].set_linewidth(0.7)
    ax.imshow(np.where(missed, 1.0, np.nan), origin="lower",
              extent=(grid.bounds[0], grid.bounds[2], grid.bounds[1],
              grid.bounds[3]), cmap=ListedColormap(["#e41a1c"]), vmin=0, vmax=1, alpha=0.9,
              interpolation="nearest", zorder=1)
    for z in viz_obstacles(mall.S8_NO_GO):
        x0, y0, x1, y1 = z["rect"]
        ax.fill([x0, x1, x1, x0], [y0, y0, y1, y1], facecolor="none", edgecolor="#7f7f7f", hatch="///",
                linewidth=0.8, zorder=2)
    ax.fill([], [], facecolor="none", edgecolor="#7f7f7f", hatch="///", label="no-go zone (padded)")
    draw_keep_out(ax, grid, label="keep-out for the centre (padded shapes, walls)")
    ax.fill([], [], color="#74c476", alpha=0.7, label=f"covered ({res.covered_area:.0f} u²)")
    ax.fill([], [], color="#e41a1c", alpha=0.9, label=f"missed ({missed.sum() * pix * pix:.0f} u²)")
    for x in (120.0, 360.0):
        ax.axvline(x, color="black", linestyle=":", linewidth=0.7, zorder=1)
    for x, text in ((60, "stores 1–4"), (240, "hallway"), (420, "stores 5–8")):
        ax.text(x, 471, text, ha="center", va="center", fontsize=8, style="italic", zorder=6,
                bbox=dict(facecolor="white", edgecolor="none", alpha=0.8, pad=1.0))
    fig.set_size_inches(6.4, 7.3)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.09), ncol=2, fontsize=8, frameon=False)
    viz.save_png(fig, out / "coverage.png")

    # boustrophedon cells and their visiting order
    fig = viz.map_figure(viz_obstacles(mall.S7_OBSTACLES, wrap=True), mall.BOUNDS,
                         title=f"Boustrophedon cells ({len(res.cells)}) and their visiting order")
    ax = fig.axes[0]
    for rank, cid in enumerate(res.visit_order):
        cell = res.cells[cid]
        color = viz.colors.to_rgb(viz.colors.cycle(rank))
        for iv in cell:
            ax.plot([iv.x0, iv.x1], [iv.y, iv.y], color=color, linewidth=2.2, solid_capstyle="butt")
        mid = cell[len(cell) // 2]
        ax.text(0.5 * (mid.x0 + mid.x1), mid.y, str(rank + 1), ha="center", va="center", fontsize=9,
                weight="bold",
                bbox=dict(facecolor="white", edgecolor=color, boxstyle="circle,pad=0.25"), zorder=6)
    for z in viz_obstacles(mall.S8_NO_GO):
        x0, y0, x1, y1 = z["rect"]
        ax.fill([x0, x1, x1, x0], [y0, y0, y1, y1], facecolor="none", edgecolor="#7f7f7f", hatch="///",
                linewidth=0.8)
    draw_keep_out(ax, grid, label="keep-out for the centre")
    ax.plot([], [], color="grey", linewidth=2.2, label="lanes of a cell (20 u apart)")
    fig.set_size_inches(6.4, 6.9)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.09), ncol=2, fontsize=8, frameon=False)
    viz.save_png(fig, out / "cells.png")

    duration = res.length / float(speed)
    if scene:
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(res.path, axis=0), axis=1))])
        motion = resample_motion(s / float(speed), res.path[:, 0], res.path[:, 1], res.heading, fps,
                                 speedup=playback_speedup)
        sc = map_scene("kinserve S8 floor coverage: boustrophedon path and swept area", mall.S7_OBSTACLES,
                       mall.BOUNDS, zones=mall.S8_NO_GO, inflate=mall.s8_padding(padding), motion=motion,
                       fps=fps, robot_width=mall.ROBOT_WIDTH, paths={"coverage": path},
                       waypoints={"start": start},
                       coverage=viz.Grid(covered, (grid.bounds[0], grid.bounds[1]), pix))
        viz.export_html(sc, out / "scene.html")

    return {
        "coverage_fraction": res.covered_fraction,
        "max_corner_penetration": reach.depth,
        "padding": padding,
        "padding_distance": mall.s8_padding(padding),
        "length": res.length,
        "covered_area": res.covered_area,
        "free_area": res.free_area,
        "missed_area": float(missed.sum() * pix * pix),
        "cells": summary["cells"],
        "lanes": summary["lanes"],
        "u_turns": summary["u_turns"],
        "detours": summary["detours"],
        "path_is_free": res.path_is_free,
        "penetration": reach.summary(),
        "path": path,
        "visit_order": res.visit_order,
        "start": start,
        "lane_spacing": mall.S8_LANE_SPACING,
        "robot_width": mall.ROBOT_WIDTH,
        "speed": float(speed),
        "duration": duration,
        "obstacles": viz_obstacles(mall.S8_PADDED_OBSTACLES),
        "physical_obstacles": viz_obstacles(mall.S8_OBSTACLES + mall.S8_NO_GO_RAW),
        "no_go_zones": viz_obstacles(mall.S8_NO_GO),
        "bounds": mall.BOUNDS,
    }
