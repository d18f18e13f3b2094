"""Drawing the mall maps of S7/S8: planner shapes as viz data, and a browser scene with the base driving.

Map units throughout (the 480 x 480 mall); the 3-D scene scales them by
``SCALE`` metres per unit (the floor is 4.8 m wide in the viewer).
"""

from __future__ import annotations

import math

import numpy as np

from kinserve import viz
from kinserve.planners.mobile import Circle, Rectangle

#: Metres per map unit in the 3-D scene.
SCALE = 0.01


def viz_obstacles(shapes, *, wrap: bool = False) -> list[dict]:
    """Planner :class:`Rectangle` / :class:`Circle` shapes as the plain dicts :mod:`viz` draws.

    ``wrap`` breaks names of three words or more after the first word (to fit small shapes in a PNG)."""
    out = []
    for s in shapes:
        name = s.name.replace(" (padded)", "")
        if wrap and name.count(" ") >= 2:  # "hot-dog stand 1" -> "hot-dog\nstand 1"
            name = "\n".join(name.split(" ", 1))
        if isinstance(s, Rectangle):
            out.append({"rect": [s.x_min, s.y_min, s.x_max, s.y_max], "name": name})
        elif isinstance(s, Circle):
            out.append({"circle": [s.cx, s.cy, s.radius], "name": name})
        else:
            raise TypeError(f"cannot draw obstacle {s!r}")
    return out


def draw_keep_out(ax, grid, *, label: str, step: float = 0.5, color="#d62728") -> None:
    """Outline, on matplotlib axes ``ax``, where the robot centre may not go: the zero level of
    ``grid.clearance`` (inflated obstacles with their rounded corners, and the wall margin)."""
    x0, y0, x1, y1 = grid.bounds
    xs = np.arange(x0, x1 + 0.5 * step, step)
    ys = np.arange(y0, y1 + 0.5 * step, step)
    X, Y = np.meshgrid(xs, ys)
    C = grid.clearance(np.c_[X.ravel(), Y.ravel()]).reshape(X.shape)
    ax.contour(X, Y, C, levels=[0.0], colors=[color], linestyles="--", linewidths=0.9, zorder=3)
    ax.plot([], [], color=color, linestyle="--", linewidth=0.9, label=label)


def resample_motion(t, x, y, heading, fps: float, speedup: float = 1.0) -> np.ndarray:
    """Rows ``(x, y, heading)`` at ``fps`` frames per second of playback (``speedup`` x real time)."""
    t = np.asarray(t, dtype=float)
    duration = float(t[-1] - t[0])
    n = max(2, int(math.floor(duration / speedup * fps)) + 1)
    tf = t[0] + np.minimum(np.arange(n) * speedup / fps, duration)
    h = np.unwrap(np.asarray(heading, dtype=float))
    return np.c_[np.interp(tf, t, x), np.interp(tf, t, y), np.interp(tf, t, h)]


def map_scene(title: str, obstacles, bounds, *, zones=(), motion=None, fps: float = 30.0,
              robot_width: float = 20.0, **map_kwargs) -> viz.Scene:
    """A :class:`viz.Scene` of the 2-D map (``viz.Scene.add_map`` arguments in ``map_kwargs``) with a
    square base ``robot_width`` wide - blue body, yellow nose at the front, the dark vacuum bar at the
    back - keyed along ``motion`` (rows ``(x, y, heading)``, one per frame at ``fps``).

    ``zones``: rectangles drawn flat and translucent (no-go zones are floor areas, not walls)."""
    scene = viz.Scene(title, grid=False)
    scene.add_map("map", viz_obstacles(obstacles), bounds, scale=SCALE, obstacle_height=15.0, **map_kwargs)
    for k, z in enumerate(zones):
        scene.add_box(f"map/zones/zone{k}", [z.x_max - z.x_min, z.y_max - z.y_min, 1.0],
                      [0.5 * (z.x_min + z.x_max), 0.5 * (z.y_min + z.y_max), 0.5], color="grey", opacity=0.55)
    w = float(robot_width)
    scene.add_box("map/robot/body", [w, w, 0.4 * w], [0.0, 0.0, 0.2 * w], color="blue")
    scene.add_box("map/robot/nose", [0.15 * w, 0.3 * w, 0.1 * w], [0.42 * w, 0.0, 0.45 * w], color="yellow")
    scene.add_box("map/robot/vacuum", [0.15 * w, 0.9 * w, 0.1 * w], [-0.55 * w, 0.0, 0.05 * w],
                  color="darkgrey")
    if motion is not None:
        anim = viz.Animation(scene, fps=fps)
        anim.planar("map/robot", motion)
        anim.apply()
    else:
        scene["map/robot"].set_transform(np.eye(4))
    x0, y0, x1, y1 = (float(v) for v in bounds)
    cx, cy, size = 0.5 * (x0 + x1) * SCALE, 0.5 * (y0 + y1) * SCALE, max(x1 - x0, y1 - y0) * SCALE
    # shapes under the scaled map node would make the automatic framing too wide: look at the map from the
    # front, above
    scene.set_camera([cx, cy - 0.6 * size, 0.75 * size], [cx, cy + 0.03 * size, 0.0])
    return scene
