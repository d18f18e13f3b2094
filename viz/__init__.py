"""viz: meshcat scenes (robots, frames, spheres, paths, maps, animation, static HTML) and matplotlib plots.

``viz`` draws plain data (poses, arrays, paths, maps) and ``kinserve.kinematics.Robot``
objects; it never calls a solver.

3-D scenes::

    scene = viz.Scene("pick and place")
    arm = scene.add_robot(robot, q0)                 # meshes via Pinocchio's MeshcatVisualizer
    scene.add_frame("target", T_goal, length=0.1)    # triad
    scene.add_sphere("obstacle", [0.4, -0.7, 0.5], 0.2, color="red", opacity=0.4)
    scene.add_cylinder("part", radius=0.02, length=0.05, pose=T_part)
    scene.add_path("tool_path", points)              # (N, 3) polyline
    anim = viz.Animation(scene, fps=30)
    anim.robot(arm.name, Q)                          # joint trajectory (N, nq)
    anim.attach("part", arm.name, grasp=40, release=120)
    anim.apply()
    viz.export_html(scene, "scene.html")             # self-contained, opens offline
    viz.serve(scene)                                 # live meshcat server until Ctrl-C

``motion_plan_scene(robot, plan, obstacles)`` is a motion plan (``planners.plan_motion``'s, or any
``(times, positions)``) animated: the robot, the obstacles, the tool's path, what the robot carries.
``Scene.for_robot(robot, q)`` is a robot plus its tool triad (``kinserve view``).
``viz.screenshot(html, png)`` and ``viz.page_status(html)`` open an exported
page in headless Chromium (software WebGL) for pictures and load checks.

2-D maps (mobile scenarios) draw flat in 3-D with :meth:`Scene.add_map` (map
units scaled to metres; :meth:`Scene.add_mobile_base` and
:meth:`Animation.planar` for a moving base) and as PNG with :func:`map_figure`;
plots are ``*_figure`` functions returning matplotlib figures, written by
:func:`save_png`::

    viz.save_png(viz.joints_and_errors_figure(it, Q, {"|e_p|": ep, "|e_phi|": eo}), out / "s9.png")
    viz.save_png(viz.map_figure(obstacles, (0, 0, 480, 480), paths=segments, waypoints=wps, inflate=10),
                 out / "map.png")
    viz.save_png(viz.planar_arm_figure([1, .8, .6, .4], {"elbow up": Qu, "elbow down": Qd},
                                       target=(x, y, th)), out / "family.png")
"""

from . import camera, colors, map2d
from .animation import Animation
from .export import export_html, read_html_commands, static_html
from .live import LiveViewer, serve
from .map2d import Circle, Grid, Rect
from .motion_plan import motion_plan_scene, sample_motion
from .plots import (
    errors_figure,
    joints_and_errors_figure,
    joints_figure,
    manipulability_figure,
    map_figure,
    planar_arm_figure,
    planar_chain,
    save_png,
    series_figure,
    xy_figure,
)
from .scene import Scene, SceneRobot
from .screenshot import BrowserUnavailable, find_browser, page_status, screenshot
from .skeleton import skeleton_geometry

__all__ = [
    "Scene", "SceneRobot", "Animation", "export_html", "static_html", "read_html_commands",
    "LiveViewer", "serve", "motion_plan_scene", "sample_motion", "Rect", "Circle", "Grid",
    "skeleton_geometry",
    "save_png", "series_figure", "joints_figure", "errors_figure", "joints_and_errors_figure",
    "manipulability_figure", "xy_figure", "map_figure", "planar_arm_figure", "planar_chain",
    "screenshot", "page_status", "find_browser", "BrowserUnavailable", "colors", "map2d", "camera",
]
