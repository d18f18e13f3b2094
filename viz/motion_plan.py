"""A motion plan as an animated scene: the robot moving, the obstacles, the tool's path, carried objects.

:func:`motion_plan_scene` draws plain data: the plan's time-stamped joint
positions (``plan.trajectory.times`` / ``.positions``: a ``MotionPlan``, a
``CartesianPlan``, a ``JointTrajectory`` or a ``(times, positions)`` pair),
the obstacle shapes, and what the robot carries (``robot.attached``). It
never plans or solves: the plan is only read.

Sampling (:func:`sample_motion`): frame ``k`` of the animation is shown at
``k / fps`` seconds and holds the configuration at time ``t_k = t_0 + k / fps``
(clamped to the last time ``t_N``), linearly interpolated between the
trajectory's points (``JointTrajectory.position_at`` does the same), for
``k = 0 .. ceil((t_N - t_0) fps)``. A plan with a path but no trajectory is
timed at a constant joint-space speed ``path_speed`` (rad/s, Euclidean norm
of the joint step).

Nodes (below ``/meshcat``):

* ``<robot name>/visuals/<geometry>``: the links, keyed with ``oMg(q_k)``
  (:meth:`viz.Animation.robot`);
* ``obstacles/<i>``: the obstacles (:func:`viz.collision_drawing.draw_shape`;
  a mesh as its convex hull, the hull collision queries use);
* ``tool_path``: the polyline through ``fk(q_k, frame)[:3, 3]`` (metres, world);
* ``attached/<name>``: each carried object, keyed with its world pose
  ``fk(q_k, obj.frame) @ obj.placement`` (``robot.attached_poses(q_k)``); its
  shape is drawn in that frame at ``attached/<name>/shape``.

The robot's base is the world frame (the poses above are world poses).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from kinserve.kinematics.errors import InputError
from kinserve.kinematics.robot import Robot, as_robot
from kinserve.kinematics.shapes import Shape, as_obstacles
from kinserve.kinematics.validation import as_matrix, as_positive, as_text

from . import colors
from .animation import MAX_FPS, MAX_FRAMES, Animation
from .collision_drawing import draw_shape
from .scene import Scene, check_opacity

#: Samples of the motion (at most) whose carried-object poses enter the scene's extent (camera framing).
_EXTENT_SAMPLES = 40


def _plan_arrays(plan: Any, path_speed: float) -> tuple[np.ndarray, np.ndarray]:
    """``(times (N,), positions (N, nq))`` of a plan-like object (see :func:`sample_motion`)."""
    trajectory = getattr(plan, "trajectory", None)
    if trajectory is not None:
        return np.asarray(trajectory.times, dtype=float), np.asarray(trajectory.positions, dtype=float)
    if hasattr(plan, "times") and hasattr(plan, "positions"):  # a JointTrajectory itself
        return np.asarray(plan.times, dtype=float), np.asarray(plan.positions, dtype=float)
    if hasattr(plan, "path"):
        path = as_matrix(plan.path, (-1, -1), "plan.path")
        if len(path) == 0:
            raise InputError("plan has no path to draw (plan.message: "
                             f"{getattr(plan, 'message', '')!r})")
        step = np.linalg.norm(np.diff(path, axis=0), axis=1)
        keep = np.r_[True, step > 0.0]
        return np.cumsum(np.r_[0.0, step[step > 0.0]]) / path_speed, path[keep]
    if isinstance(plan, (tuple, list)) and len(plan) == 2:
        return np.asarray(plan[0], dtype=float), np.asarray(plan[1], dtype=float)
    raise InputError("plan must be a MotionPlan / CartesianPlan (with .trajectory or .path), a "
                     f"JointTrajectory, or a (times, positions) pair; got {type(plan).__name__}")


def sample_motion(plan: Any, fps: float = 30.0, *, path_speed: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    """``(t (K,), Q (K, nq))``: the plan's configurations at the animation's frames (module docstring).

    ``plan``: anything with ``.trajectory`` (``times (N,)`` s, ``positions (N, nq)`` rad or m), a
    trajectory itself, anything with a ``.path (N, nq)`` (timed at ``path_speed`` rad/s), or a
    ``(times, positions)`` pair. ``t_k = min(t_0 + k / fps, t_N)``; ``Q[k]`` interpolates the positions
    linearly at ``t_k``. :class:`InputError` / :class:`ShapeError` for times that are not strictly
    increasing, positions whose row count differs from the times', an ``fps`` outside (0, 240]
    (:data:`MAX_FPS`), a ``path_speed`` outside (0, 1e6], or a motion needing more than
    :data:`MAX_FRAMES` (10**5) frames at this ``fps``.
    """
    fps = as_positive(fps, "fps (frames per second)", maximum=MAX_FPS)
    path_speed = as_positive(path_speed, "path_speed (rad/s)")
    times, positions = _plan_arrays(plan, path_speed)
    times = as_matrix(times, (-1,), "times")
    positions = as_matrix(positions, (len(times), -1), "positions")
    if len(times) == 0 or np.any(np.diff(times) <= 0):
        raise InputError(f"times must be non-empty and strictly increasing (s), got {len(times)} times")
    duration = float(times[-1] - times[0])
    frames = math.ceil(duration * fps - 1e-9) + 1 if math.isfinite(duration * fps) else math.inf
    if frames > MAX_FRAMES:
        raise InputError(f"the motion lasts {duration:g} s: at fps={fps:g} it needs {frames:g} frames, "
                         f"more than the {MAX_FRAMES:,} allowed; lower fps to at most "
                         f"{(MAX_FRAMES - 1) / duration:.3g}")
    n = int(frames)
    t = np.minimum(times[0] + np.arange(n) / fps, times[-1])
    Q = np.column_stack([np.interp(t, times, positions[:, j]) for j in range(positions.shape[1])])
    return t, Q


def _obstacle_dict(shape: Shape) -> dict:
    """The drawing dict of an obstacle (:func:`draw_shape`): its ``to_dict()``; a mesh as its convex hull."""
    if shape.kind != "mesh":
        return shape.to_dict()
    import trimesh

    hull = trimesh.Trimesh(vertices=np.asarray(shape.hull_vertices)).convex_hull  # outward faces
    return {"kind": "convex", "vertices": np.asarray(hull.vertices), "faces": np.asarray(hull.faces),
            "pose": np.asarray(shape.pose)}


def _local_dict(shape: Shape) -> dict:
    """The drawing dict of a carried shape in its own frame (the frame ``placement`` puts in the world)."""
    eye = np.eye(4)
    if shape.kind == "sphere":
        return {"kind": "sphere", "center": [0.0, 0.0, 0.0], "radius": shape.radius}
    if shape.kind == "box":
        return {"kind": "box", "size": list(shape.size), "pose": eye}
    if shape.kind in ("cylinder", "capsule"):
        return {"kind": shape.kind, "radius": shape.radius, "length": shape.length, "pose": eye}
    raise InputError(f"cannot draw a carried {shape.kind!r} (expected sphere, box, capsule or cylinder)")


def _draw_carried(scene: Scene, node: str, shape: Shape, poses: np.ndarray, color: Any) -> None:
    """Draw ``shape`` at ``node/shape`` in the frame of ``node``, whose transform is ``poses[0]`` (world).

    The points the drawing noted for the camera (in the node's frame) are replaced by their world
    positions at up to :data:`_EXTENT_SAMPLES` poses of the motion.
    """
    draw_shape(scene, f"{node}/shape", _local_dict(shape), color, opacity=1.0)
    scene[node].set_transform(poses[0])
    picks = np.unique(np.linspace(0, len(poses) - 1, min(len(poses), _EXTENT_SAMPLES)).round().astype(int))
    scene.sweep_points(f"{node}/shape", poses[picks])


def _check_color(color: Any, name: str) -> None:
    """:func:`viz.colors.to_int`'s :class:`InputError` for a colour it cannot read, prefixed with ``name``."""
    try:
        colors.to_int(color)
    except InputError as exc:
        raise InputError(f"{name}: {exc}") from None


def motion_plan_scene(robot: Robot, plan: Any, obstacles: Any = (), frame: str | None = None, *,
                      fps: float = 30.0, title: str | None = None, name: str | None = None,
                      path_speed: float = 0.5, obstacle_color: Any = "purple", obstacle_opacity: float = 0.6,
                      path_color: Any = "yellow", attached_color: Any = "orange") -> Scene:
    """A :class:`Scene` animating ``robot`` (a ``kinserve.kinematics.Robot``) along ``plan``.

    ``plan``: see :func:`sample_motion` (resampled at ``fps`` frames per second). ``obstacles``: kinserve
    shapes (or their ``to_dict()`` form, or one shape), drawn in ``obstacle_color``. ``frame``: the tool
    frame whose path is drawn (default ``robot.tip``). Every object the robot carries (``robot.attached``)
    is drawn in ``attached_color`` and moves with its frame. ``name``: the robot's node (default its name).
    Node names and the poses keyed: the module docstring. The scene opens on the whole motion; export it
    with :func:`viz.export_html` (the page plays the animation) or show it with :class:`viz.LiveViewer`.

    Checked before anything is drawn: ``robot`` a Robot, ``obstacles`` (None for none), ``title`` and
    ``name`` None or a str, the three colours (:mod:`viz.colors` forms, even one not used), and
    ``obstacle_opacity`` a number in (0, 1]; a kinserve error names the argument.
    """
    robot = as_robot(robot)
    shapes = as_obstacles(obstacles)
    obstacle_opacity = check_opacity(obstacle_opacity, "obstacle_opacity")
    title, name = as_text(title, "title", optional=True), as_text(name, "name", optional=True)
    for color, argument in ((obstacle_color, "obstacle_color"), (path_color, "path_color"),
                            (attached_color, "attached_color")):
        _check_color(color, argument)
    t, Q = sample_motion(plan, fps, path_speed=path_speed)
    Q = as_matrix(Q, (-1, robot.nq), "plan positions")
    scene = Scene(title or f"{getattr(robot, 'name', 'robot')} motion plan ({t[-1] - t[0]:.2f} s)")
    handle = scene.add_robot(robot, Q[0], name=name)
    for i, shape in enumerate(shapes):
        draw_shape(scene, f"obstacles/{i}", _obstacle_dict(shape), obstacle_color, opacity=obstacle_opacity)
    scene.add_path("tool_path", np.array([robot.fk(q, frame)[:3, 3] for q in Q]), color=path_color)
    anim = Animation(scene, fps=fps)
    anim.robot(handle.name, Q)
    carried = [robot.attached_poses(q) for q in Q]
    for obj_name, obj in robot.attached.items():
        node = "attached/" + obj_name.replace("/", "_")
        poses = np.array([c[obj_name] for c in carried])
        _draw_carried(scene, node, obj.shape, poses, attached_color)
        anim.poses(node, poses)
    anim.apply()
    return scene


__all__ = ["motion_plan_scene", "sample_motion"]
