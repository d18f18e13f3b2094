"""``Scene``: a meshcat scene recorded as commands, so it needs no running server.

meshcat draws by receiving *commands* (``set_object``, ``set_transform``,
``set_property``, ``set_animation``, ``delete``) addressed to slash-separated
*paths* in a scene tree (``/meshcat/panda/visuals/panda_link3_0``). A
:class:`Scene` is a ``meshcat`` *window* that records those commands into a
tree (the last command of each kind per path wins, exactly as meshcat's own
server keeps its state), so that one scene can be

* exported to a self-contained static HTML file (:func:`viz.export_html`),
* sent to a live meshcat server (:class:`viz.LiveViewer`),
* inspected in tests (:meth:`Scene.transform`, :meth:`Scene.object`).

Robots are drawn by Pinocchio's own ``pinocchio.visualize.MeshcatVisualizer``
writing into the recording (meshes from the visual model: ``.dae``/``.stl``/
``.obj`` files, URDF primitives, or a stick-figure skeleton when the robot has
no visual geometry). Everything else is drawn from plain data.

Conventions: poses are 4x4 homogeneous arrays (metres, world frame);
cylinders and triad axes follow URDF (the cylinder axis is the local ``z``);
names are paths relative to ``/meshcat`` unless they start with ``/``.
"""

from __future__ import annotations

import numbers
import uuid
import warnings
from dataclasses import dataclass, field

import meshcat
import meshcat.commands
import meshcat.geometry as mg
import meshcat.path
import numpy as np
import pinocchio as pin
from pinocchio.visualize import MeshcatVisualizer

from kinserve.kinematics.errors import InputError
from kinserve.kinematics.validation import as_flag, as_pose, as_text, as_vector, describe

from . import colors
from .camera import CAMERA_FOV_DEG, box_corners, frame_points, view_commands  # noqa: F401 (CAMERA_FOV_DEG re-exported)
from .map2d import Circle, Rect, as_grid, as_polyline, as_shape
from .skeleton import skeleton_geometry

ROOT = "/meshcat"

#: three.js cylinders run along local y; this intrinsic rotation (Rx(+90 deg))
#: turns them to run along local z, as URDF cylinders do.
_Y_TO_Z = np.array([[1.0, 0, 0, 0], [0, 0, -1.0, 0], [0, 1.0, 0, 0], [0, 0, 0, 1.0]])

#: Background gradient (top, bottom) of every scene: meshcat's own sky blue to midnight blue,
#: written into the scene so that captions can be checked against it.
BACKGROUND = (0x87CEFA, 0x191970)


class _ZCylinder(mg.Cylinder):
    """A meshcat cylinder whose axis is the local z axis (URDF convention)."""

    def intrinsic_transform(self):
        return _Y_TO_Z


def _material(color, opacity: float = 1.0, kind=mg.MeshLambertMaterial):
    opacity = check_opacity(opacity)
    return kind(color=colors.to_int(color), opacity=opacity, transparent=opacity < 1.0)


def check_opacity(opacity: object, name: str = "opacity") -> float:
    """``opacity`` as a float if it is a number in ``(0, 1]`` (not a bool); else :class:`InputError` naming
    ``name``."""
    if type(opacity) is float and 0.0 < opacity <= 1.0:
        return opacity
    if isinstance(opacity, bool) or not isinstance(opacity, numbers.Real) or not 0.0 < opacity <= 1.0:
        raise InputError(f"{name} must be a number in (0, 1], got {describe(opacity)}")
    return float(opacity)


def _positive(value, name: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a positive number, got {value!r}") from None
    if not (np.isfinite(v) and v > 0.0):
        raise InputError(f"{name} must be a positive finite number, got {value!r}")
    return v


def _translation(p) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = p
    return T


@dataclass
class _Node:
    """One path of the recorded tree: its latest object, transform and properties."""

    children: dict = field(default_factory=dict)
    object: dict | None = None
    transform: dict | None = None
    properties: dict = field(default_factory=dict)


@dataclass
class SceneRobot:
    """A robot drawn in a :class:`Scene` (returned by :meth:`Scene.add_robot`).

    ``root`` is the robot's node (``/meshcat/<name>``), whose transform is the
    base pose; each visual geometry object ``g`` is the node
    ``nodes[g.name] = root + "/visuals/" + g.name`` with transform
    ``oMg(q) * diag(meshScale, 1)`` relative to the root, where
    ``oMg = oMi[parentJoint] * g.placement`` is Pinocchio's geometry placement.
    """

    name: str
    robot: object
    root: str
    visualizer: MeshcatVisualizer
    geometry: pin.GeometryModel
    nodes: dict[str, str]
    scene: "Scene"
    base: np.ndarray = field(default_factory=lambda: np.eye(4))
    q: np.ndarray | None = None
    missing: list[str] = field(default_factory=list)
    local_boxes: dict[str, np.ndarray] = field(default_factory=dict)

    def geometry_poses(self, q, world: bool = True) -> dict[str, np.ndarray]:
        """``{node path: 4x4}`` rigid pose of every drawn geometry at ``q`` (no mesh scale).

        ``world=True`` includes the base pose (``base @ oMg``); otherwise the
        poses are relative to the robot's root node (``oMg``).
        """
        world = as_flag(world, "world")
        q = self.robot.check_q(q)
        v = self.visualizer
        pin.forwardKinematics(v.model, v.data, q)
        pin.updateGeometryPlacements(v.model, v.data, self.geometry, v.visual_data)
        out = {}
        for i, g in enumerate(self.geometry.geometryObjects):
            path = self.nodes.get(g.name)
            if path is None:
                continue
            T = v.visual_data.oMg[i].homogeneous
            out[path] = self.base @ T if world else T.copy()
        return out

    def set_q(self, q) -> None:
        """Place the links at configuration ``q`` (records one ``set_transform`` per geometry)."""
        q = self.robot.check_q(q)
        self.visualizer.display(q)
        self.q = q.copy()
        self.scene._note_points(self.name, self.geometry_corners(q))

    def geometry_corners(self, q) -> np.ndarray:
        """``(8 G, 3)`` world corners of the drawn geometries' bounding boxes at ``q``.

        Each geometry's box is its local axis-aligned bounding box (coal's
        ``aabb_local``, in the geometry frame, mesh scale included), placed by
        ``base @ oMg(q)``: every drawn vertex lies inside one of these boxes.
        """
        poses = self.geometry_poses(q)
        pts = [(T[:3, :3] @ self.local_boxes[path].T).T + T[:3, 3]
               for path, T in poses.items() if path in self.local_boxes]
        return np.vstack(pts) if pts else np.array([T[:3, 3] for T in poses.values()]).reshape(-1, 3)

    def set_base(self, pose) -> None:
        """Pose (4x4, world) of the robot's base node."""
        self.base = as_pose(pose, "base")
        self.scene[self.root].set_transform(self.base)
        if self.q is not None:
            self.set_q(self.q)

    def tool_pose(self, q, frame: str | None = None) -> np.ndarray:
        """World pose of ``frame`` (default the robot's tip) at ``q``: ``base @ robot.fk(q, frame)``."""
        return self.base @ self.robot.fk(q, frame)


class Scene:
    """A recorded meshcat scene (see the module docstring).

    Parameters
    ----------
    title:
        Page title of exported HTML.
    grid, axes:
        Show meshcat's ground grid / world axes.
    """

    def __init__(self, title: str = "kinserve", *, grid: bool = True, axes: bool = False):
        self.title = as_text(title, "title")
        self._tree = _Node()
        self._animation: dict | None = None
        self._camera: tuple[np.ndarray, np.ndarray] | None = None
        self._extent: dict[str, list[np.ndarray]] = {}
        self.robots: dict[str, SceneRobot] = {}
        self.visualizer = meshcat.Visualizer(window=self)
        self.grid = as_flag(grid, "grid")
        self.axes = as_flag(axes, "axes")

    @classmethod
    def for_robot(cls, robot, q=None, *, tool_frame: bool = True, frame_length: float = 0.1,
                  collision: bool = False, obstacles=(), **kwargs) -> "Scene":
        """A scene showing one robot at ``q`` (default ``robot.neutral()``) and, with
        ``tool_frame``, a triad at its tool frame ``robot.tip`` (node ``"tool"``).
        Extra keyword arguments go to :meth:`add_robot`. (What ``kinserve view`` shows.)

        ``collision=True`` also draws the robot's collision shapes (convex hulls and
        primitives, node ``<name>_collision/<geometry>``) and the ``obstacles``
        (shapes, node ``obstacles/<k>``), bodies in collision in red
        (:mod:`viz.collision_drawing`).
        """
        tool_frame, collision = as_flag(tool_frame, "tool_frame"), as_flag(collision, "collision")
        scene = cls(getattr(robot, "name", "robot"))
        handle = scene.add_robot(robot, q, **kwargs)
        if tool_frame:
            scene.add_frame("tool", handle.tool_pose(handle.q), length=frame_length)
        if collision:
            from .collision_drawing import draw_collision_scene

            obstacles = list(obstacles)
            shapes = robot.collision_geometry(handle.q)
            for s in shapes:
                s["pose"] = handle.base @ s["pose"]
            draw_collision_scene(scene, handle.name, shapes, [o.to_dict() for o in obstacles],
                                 robot.collisions(handle.q, obstacles))
        return scene

    # ------------------------------------------------------------ recording
    @staticmethod
    def path(name: str) -> str:
        """Absolute meshcat path of ``name`` (relative names live under ``/meshcat``)."""
        if not isinstance(name, str) or not name.strip("/"):
            raise InputError(f"scene node name must be a non-empty string, got {name!r}")
        if name.startswith("/"):
            return "/" + "/".join(p for p in name.split("/") if p)
        return ROOT + "/" + "/".join(p for p in name.split("/") if p)

    def __getitem__(self, name: str) -> meshcat.Visualizer:
        """A ``meshcat.Visualizer`` at ``name`` whose commands are recorded in this scene."""
        parts = tuple(p for p in self.path(name).split("/") if p)
        return meshcat.Visualizer.view_into(self, meshcat.path.Path(parts))

    def send(self, command) -> None:
        """Record one meshcat command (anything with ``lower()``, or an already lowered dict)."""
        cmd = command if isinstance(command, dict) else command.lower()
        kind = cmd["type"]
        if kind == "set_animation":
            self._animation = cmd
            return
        parts = [p for p in cmd.get("path", "").split("/") if p]
        if kind == "delete":
            self._delete(parts)
            return
        node = self._tree
        for p in parts:
            node = node.children.setdefault(p, _Node())
        if kind == "set_object":
            node.object = cmd
        elif kind == "set_transform":
            node.transform = cmd
        elif kind == "set_property":
            node.properties[cmd["property"]] = cmd
        else:
            raise InputError(f"Scene cannot record meshcat command type {kind!r}")

    def _delete(self, parts: list[str]) -> None:
        if not parts:
            self._tree = _Node()
            self.robots.clear()
            self._extent.clear()
            self._animation = None
            return
        node = self._tree
        for p in parts[:-1]:
            node = node.children.get(p)
            if node is None:
                return
        node.children.pop(parts[-1], None)
        prefix = "/" + "/".join(parts)
        for name in [n for n, r in self.robots.items()
                     if r.root == prefix or r.root.startswith(prefix + "/")]:
            del self.robots[name]
        for key in [k for k in self._extent
                    if self.path(k) == prefix or self.path(k).startswith(prefix + "/")]:
            del self._extent[key]

    def delete(self, name: str) -> None:
        """Remove ``name`` and everything below it."""
        parts = tuple(p for p in self.path(name).split("/") if p)
        self.send(meshcat.commands.Delete(meshcat.path.Path(parts)))

    def _find(self, name: str) -> _Node | None:
        node = self._tree
        for p in (p for p in self.path(name).split("/") if p):
            node = node.children.get(p)
            if node is None:
                return None
        return node

    def _walk(self, node: _Node | None = None, prefix: str = ""):
        node = self._tree if node is None else node
        yield prefix or "/", node
        for name, child in node.children.items():
            yield from self._walk(child, prefix + "/" + name)

    # ------------------------------------------------------------ inspection
    def paths(self) -> list[str]:
        """Absolute paths of every node that has an object drawn at it."""
        return [p for p, n in self._walk() if n.object is not None]

    def __contains__(self, name: str) -> bool:
        node = self._find(name)
        return node is not None and (node.object is not None or bool(node.children))

    def object(self, name: str) -> dict | None:
        """The lowered ``set_object`` command drawn at ``name`` (None if nothing is drawn)."""
        node = self._find(name)
        return None if node is None else node.object

    def property_value(self, name: str, key: str):
        """The last value set for property ``key`` at ``name`` (None if never set)."""
        node = self._find(name)
        cmd = None if node is None else node.properties.get(key)
        return None if cmd is None else cmd["value"]

    def transform(self, name: str) -> np.ndarray:
        """The 4x4 transform of ``name`` relative to its parent node (identity if never set)."""
        node = self._find(name)
        if node is None:
            raise InputError(f"no scene node {self.path(name)!r}; nodes with objects: {self.paths()[:12]}")
        if node.transform is None:
            return np.eye(4)
        return np.asarray(node.transform["matrix"], dtype=float).reshape(4, 4).T

    def world_transform(self, name: str) -> np.ndarray:
        """The 4x4 transform of ``name`` in the world: the product of the transforms along its path."""
        parts = [p for p in self.path(name).split("/") if p]
        if self._find(name) is None:
            raise InputError(f"no scene node {self.path(name)!r}")
        T = np.eye(4)
        for i in range(1, len(parts) + 1):
            T = T @ self.transform("/" + "/".join(parts[:i]))
        return T

    @property
    def animation(self) -> dict | None:
        """The lowered ``set_animation`` command (None without animation)."""
        return self._animation

    # ------------------------------------------------------------ replay
    def commands(self) -> list[dict]:
        """Every command needed to rebuild the scene, in replay order.

        Depth-first over the tree (parents before children): object, then
        transform, then properties of each node; then the grid/axes switches,
        the background, the camera, and the animation last (its targets must exist).
        """
        out = []
        for _, node in self._walk():
            if node.object is not None:
                out.append(node.object)
            if node.transform is not None:
                out.append(node.transform)
            out.extend(node.properties.values())
        if self.grid:
            out.append(self.floor_grid_command())
        out.append({"type": "set_property", "path": "/Grid", "property": "visible", "value": self.grid})
        out.append({"type": "set_property", "path": "/Axes", "property": "visible", "value": self.axes})
        out.extend(self.background_commands())
        out.extend(self.camera_commands())
        if self._animation is not None:
            out.append(self._animation)
        return out

    def floor_grid(self) -> tuple[np.ndarray, float]:
        """``(segments (2K, 3), spacing)``: a square grid on z = 0 sized to the scene.

        The spacing is the "nice" number (1, 2 or 5 x 10^k m) nearest above
        1/16 of the scene's larger horizontal span; the grid covers the span
        plus a margin, centred on the scene, with lines on multiples of the
        spacing. (meshcat's own 20 m grid is replaced: its long lines are
        mostly off screen for a 1 m robot, and software renderers clip them badly.)
        """
        b = self.bounds()
        lo, hi = (np.array([-0.5, -0.5, 0.0]), np.array([0.5, 0.5, 0.0])) if b is None else b
        span = max(float(hi[0] - lo[0]), float(hi[1] - lo[1]), 0.5)
        raw = span / 16
        exp = 10.0 ** np.floor(np.log10(raw))
        step = next(m * exp for m in (1, 2, 5, 10) if m * exp >= raw - 1e-12)
        half = np.ceil(0.5 * span * 1.4 / step) * step
        cx, cy = (np.round(0.5 * (lo[:2] + hi[:2]) / step) * step).tolist()
        ticks = np.arange(-half, half + 0.5 * step, step)
        seg = []
        for t in ticks:
            seg += [[cx + t, cy - half, 0.0], [cx + t, cy + half, 0.0], [cx - half, cy + t, 0.0],
                    [cx + half, cy + t, 0.0]]
        return np.array(seg), float(step)

    def floor_grid_command(self) -> dict:
        """The ``set_object`` command drawing :meth:`floor_grid` at meshcat's ``/Grid`` node."""
        segments, _ = self.floor_grid()
        obj = mg.LineSegments(mg.PointsGeometry(segments.T.astype(np.float32)),
                              mg.LineBasicMaterial(color=0x9A9A9A))
        # deterministic ids (meshcat draws fresh random ones): the same scene replays identically
        key = uuid.uuid5(uuid.NAMESPACE_URL, "kinserve-grid:" + segments.astype(np.float32).tobytes().hex())
        obj.uuid, obj.geometry.uuid, obj.material.uuid = (str(uuid.uuid5(key, part))
                                                          for part in ("object", "geometry", "material"))
        return meshcat.commands.SetObject(obj, path=meshcat.path.Path(("Grid",))).lower()

    # ------------------------------------------------------------ camera
    def set_camera(self, eye, target=(0.0, 0.0, 0.0)) -> None:
        """Place the camera at ``eye`` looking at ``target`` (world, metres); the user can still orbit."""
        eye = as_vector(eye, 3, "eye")
        target = as_vector(target, 3, "target")
        if np.linalg.norm(eye - target) < 1e-6:
            raise InputError("camera eye and target must differ")
        self._camera = (eye.copy(), target.copy())

    def sweep_points(self, name: str, poses) -> None:
        """Frame a moving node: the points noted for the camera under ``name`` (given in that node's own
        frame, as drawn before it is moved) become their world positions under each 4x4 of ``poses``
        (``(K, 4, 4)``), so that :meth:`drawn_points` and the auto camera see the node's whole motion."""
        prefix = self.path(name)
        poses = np.asarray(poses, dtype=float).reshape(-1, 4, 4)
        for key in [k for k in self._extent
                    if self.path(k) == prefix or self.path(k).startswith(prefix + "/")]:
            local = np.array(self._extent[key], dtype=float).reshape(-1, 3)
            self._extent[key] = [p for W in poses for p in local @ W[:3, :3].T + W[:3, 3]]

    def _note_points(self, key: str, points) -> None:
        pts = [np.asarray(p, dtype=float)[:3] for p in points]
        if pts:
            self._extent[key] = pts

    def drawn_points(self) -> np.ndarray:
        """``(N, 3)`` world points (metres) enclosing what the scene draws: the corners of each
        robot geometry's bounding box (:meth:`SceneRobot.geometry_corners`), box and cylinder
        corners, sphere extremes, triad tips, path and point-cloud points, map corners."""
        pts = [p for ps in self._extent.values() for p in ps]
        return np.array(pts, dtype=float).reshape(-1, 3)

    def bounds(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Axis-aligned ``(min, max)`` corners of what the scene draws (world, metres), or None."""
        P = self.drawn_points()
        if len(P) == 0:
            return None
        return P.min(axis=0), P.max(axis=0)

    def camera(self) -> tuple[np.ndarray, np.ndarray]:
        """``(eye, target)``: the one set with :meth:`set_camera`, or one framing :meth:`bounds`.

        The automatic view (:func:`viz.camera.frame_points`) shows
        :meth:`drawn_points` centred in the window, spanning 90 % of a 4:3 window
        on the limiting axis (front-right view from above; a floor plan is seen
        steeply from the front).
        """
        if self._camera is not None:
            return self._camera
        pts = self.drawn_points()
        if len(pts) == 0:
            return np.array([1.5, 1.2, 1.0]), np.zeros(3)
        return frame_points(pts)

    def camera_commands(self) -> list[dict]:
        """meshcat commands placing the camera at :meth:`camera` (:func:`viz.camera.view_commands`).

        The drawing is shifted by ``-target`` (meshcat's orbit controls aim at
        the viewer's origin); scene transforms (:meth:`transform`) are not
        affected: the shift exists only in the replayed commands.
        """
        return view_commands(*self.camera())

    def background_commands(self) -> list[dict]:
        """meshcat commands setting the background gradient to :data:`BACKGROUND` (top, bottom RGB in [0,
        1])."""
        top, bottom = BACKGROUND
        return [{"type": "set_property", "path": "/Background", "property": "top_color",
                 "value": list(colors.to_rgb(top))},
                {"type": "set_property", "path": "/Background", "property": "bottom_color",
                 "value": list(colors.to_rgb(bottom))}]

    # ------------------------------------------------------------ robots
    def add_robot(
        self,
        robot,
        q=None,
        name: str | None = None,
        *,
        base=None,
        collisions: bool = False,
        color=None,
        skeleton_radius: float = 0.02,
    ) -> SceneRobot:
        """Draw a ``kinserve.kinematics.Robot`` at ``q`` (default ``robot.neutral()``).

        The links are drawn by Pinocchio's ``MeshcatVisualizer`` from
        ``robot.visual_model`` (meshes or primitives); a robot without visual
        geometry gets a stick-figure skeleton (:func:`viz.skeleton.skeleton_geometry`).
        ``base`` (4x4) poses the robot's root node in the world; ``collisions``
        also records the (hidden) collision geometry; ``color`` (RGBA or any
        colour) overrides the visual colours.

        ``name`` (a str; None for the robot's own name), ``q`` and ``base`` are checked before anything is
        drawn or registered: a bad ``name``, ``q`` (wrong shape, NaN, beyond the joint limits' checks of
        ``robot.check_q``) or ``base`` raises and leaves the scene unchanged, so a retry under the same name
        works.
        """
        q = robot.neutral() if q is None else robot.check_q(q)
        base = None if base is None else as_pose(base, "base")
        name = as_text(name, "name", optional=True) or getattr(robot, "name", "robot")
        root = self.path(name)
        if not root.startswith(ROOT + "/"):
            raise InputError(f"robot name must be relative to {ROOT} (no leading '/'), got {name!r}")
        if name in self.robots:
            raise InputError(f"a robot named {name!r} is already in the scene; pass another name=")
        visual = robot.visual_model
        if visual is None or visual.ngeoms == 0:
            visual = skeleton_geometry(robot.model, frames=[robot.tip], radius=skeleton_radius)
        collision = robot.collision_model if as_flag(collisions, "collisions") else None
        rgba = None
        if color is not None:
            rgba = list(colors.to_rgb(color)) + [float(color[3])
                                                 if isinstance(color, (list, tuple))
                                                 and len(color) == 4 else 1.0]
        vis = MeshcatVisualizer(robot.model, collision, visual)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            vis.initViewer(viewer=self.visualizer)
            vis.loadViewerModel(rootNodeName=root[len(ROOT) + 1:], visual_color=rgba)
        nodes, missing = {}, []
        for g in visual.geometryObjects:
            path = f"{root}/visuals/{g.name}"
            node = self._find(path)
            if node is not None and node.object is not None:
                nodes[g.name] = path
            else:
                missing.append(g.name)
        for w in caught:
            if "get_image" not in str(w.message):
                warnings.warn(f"drawing robot {name!r}: {w.message}", stacklevel=2)
        handle = SceneRobot(name=name, robot=robot, root=root, visualizer=vis, geometry=visual, nodes=nodes,
                            scene=self, missing=missing, local_boxes=_local_boxes(visual, nodes))
        self.robots[name] = handle
        if base is not None:
            handle.base = base
        self[root].set_transform(handle.base)
        handle.set_q(q)
        return handle

    # ------------------------------------------------------------ primitives
    def _draw(self, name: str, obj, pose=None) -> str:
        path = self.path(name)
        self[path].set_object(obj)
        if pose is not None:
            self[path].set_transform(pose)
        return path

    def add_frame(self, name: str, pose, length: float = 0.1, radius: float | None = None) -> str:
        """A triad at ``pose``: x, y, z axes as red, green, blue cylinders of ``length`` (m)."""
        T = as_pose(pose, "pose")
        length = _positive(length, "length")
        radius = _positive(radius if radius is not None else 0.04 * length, "radius")
        path = self.path(name)
        self[path].set_transform(T)
        # rotations taking the cylinder's z axis onto x (Ry(+90 deg)), y (Rx(-90 deg)) and z
        axes = {"x": (np.array([0.0, 1.0, 0.0]), np.pi / 2, 0xE41A1C),
                "y": (np.array([1.0, 0.0, 0.0]), -np.pi / 2, 0x4DAF4A),
                "z": (np.array([0.0, 0.0, 1.0]), 0.0, 0x377EB8)}
        for axis, (about, angle, color) in axes.items():
            A = np.eye(4)
            A[:3, :3] = pin.exp3(about * angle)
            A[:3, 3] = A[:3, 2] * (0.5 * length)
            self._draw(f"{path}/{axis}",
                       mg.Mesh(_ZCylinder(length, radius), _material(color, kind=mg.MeshPhongMaterial)), A)
        self._note_points(path, [T[:3, 3], T[:3, 3] + length * T[:3, 0], T[:3, 3] + length * T[:3, 1],
                                 T[:3, 3] + length * T[:3, 2]])
        return path

    def add_sphere(self, name: str, center, radius: float, color="red", opacity: float = 1.0) -> str:
        """A sphere of ``radius`` (m) at ``center`` (world)."""
        c = as_vector(center, 3, "center")
        r = _positive(radius, "radius")
        path = self._draw(name, mg.Mesh(mg.Sphere(r), _material(color, opacity, mg.MeshPhongMaterial)),
                          _translation(c))
        self._note_points(path, [c - r, c + r])
        return path

    def add_box(self, name: str, size, pose=None, color="grey", opacity: float = 1.0) -> str:
        """A box of edge lengths ``size = (sx, sy, sz)`` (m) centred at ``pose`` (4x4, or a 3-vector
        centre)."""
        s = as_vector(size, 3, "size")
        if np.any(s <= 0):
            raise InputError(f"box size must be positive, got {s.tolist()}")
        T = self._pose_or_point(pose)
        path = self._draw(name, mg.Mesh(mg.Box(s.tolist()), _material(color, opacity)), T)
        corners = [T @ np.r_[0.5 * s * (2 * np.array(idx) - 1), 1.0] for idx in np.ndindex(2, 2, 2)]
        self._note_points(path, corners)
        return path

    def add_cylinder(self, name: str, radius: float, length: float, pose=None, color="orange",
                     opacity: float = 1.0) -> str:
        """A cylinder of ``radius`` and ``length`` (m) along the local z axis, centred at ``pose``."""
        r, h = _positive(radius, "radius"), _positive(length, "length")
        T = self._pose_or_point(pose)
        path = self._draw(name, mg.Mesh(_ZCylinder(h, r), _material(color, opacity, mg.MeshPhongMaterial)), T)
        self._note_points(path, [T[:3, 3] + sz * 0.5 * h * T[:3, 2] + sx * r * T[:3, 0] + sy * r * T[:3, 1]
                                 for sz in (-1, 1) for sx in (-1, 1) for sy in (-1, 1)])
        return path

    @staticmethod
    def _pose_or_point(pose) -> np.ndarray:
        if pose is None:
            return np.eye(4)
        point = isinstance(pose, (list, tuple, np.ndarray)) and len(pose) == 3
        if point and all(np.ndim(v) == 0 for v in pose):  # a point: the pose with that translation
            return _translation(as_vector(pose, 3, "pose"))
        return as_pose(pose, "pose")  # 4x4, SE3, (xyz, quat) or 7-vector

    def add_path(self, name: str, points, color="blue", linewidth: float = 2.0,
                 markers: float | None = None) -> str:
        """A polyline through ``points`` (``(N, 3)`` metres, or ``(N, 2)`` on z = 0).

        ``markers`` (a radius in m) also draws a small sphere at every point.
        """
        P = as_polyline(points, "points")
        if P.shape[1] == 2:
            P = np.c_[P, np.zeros(len(P))]
        path = self.path(name)
        line = mg.Line(mg.PointsGeometry(P.T.astype(np.float32)),
                       mg.LineBasicMaterial(color=colors.to_int(color), linewidth=float(linewidth)))
        self._draw(path, line)
        if markers:
            r = _positive(markers, "markers")
            for i, p in enumerate(P):
                self._draw(f"{path}/m{i}", mg.Mesh(mg.Sphere(r), _material(color, kind=mg.MeshPhongMaterial)),
                           _translation(p))
        self._note_points(path, list(P))
        return path

    def add_points(self, name: str, points, color="black", size: float = 0.01) -> str:
        """A point cloud (``(N, 3)`` metres), each point ``size`` m wide."""
        P = as_polyline(points, "points", dims=(3,))
        rgb = np.tile(np.array(colors.to_rgb(color), dtype=np.float32)[:, None], (1, len(P)))
        path = self._draw(name, mg.Points(mg.PointsGeometry(P.T.astype(np.float32), color=rgb),
                                          mg.PointsMaterial(size=_positive(size, "size"))))
        self._note_points(path, list(P))
        return path

    # ------------------------------------------------------------ 2-D maps
    def add_map(
        self,
        name: str,
        obstacles=(),
        bounds=None,
        *,
        paths=None,
        waypoints=None,
        coverage=None,
        inflate: float = 0.0,
        scale: float = 0.01,
        z: float = 0.0,
        obstacle_height: float = 5.0,
    ) -> str:
        """A 2-D map drawn flat in 3-D: floor, obstacles, paths, waypoints, coverage.

        Everything below the map's node is in *map units* (``x, y`` of the
        planners' data); the node's transform scales them by ``scale`` metres
        per unit and lifts them to height ``z``. So a base moving on the map is
        animated in map units (:meth:`viz.Animation.planar`).

        ``obstacles``: shapes accepted by :func:`viz.map2d.as_shape`, drawn as
        prisms ``obstacle_height`` units tall; ``inflate`` > 0 also draws the
        inflated (padded) outline translucently. ``bounds = (xmin, ymin, xmax,
        ymax)`` is the floor. ``paths``: ``{name: (N, 2) points}`` or a list of
        them, drawn as polylines; ``waypoints``: ``{name: (x, y)}`` or a list,
        drawn as discs; ``coverage``: a grid (:func:`viz.map2d.as_grid`) whose
        true cells are drawn as translucent green tiles.
        """
        scale = _positive(scale, "scale")
        h = _positive(obstacle_height, "obstacle_height")
        root = self.path(name)
        shapes = [as_shape(o) for o in obstacles]
        if bounds is None:
            if not shapes:
                raise InputError("add_map needs bounds=(xmin, ymin, xmax, ymax) or at least one obstacle")
            xs = [v for s in shapes
                  for v in ((s.xmin, s.xmax) if isinstance(s, Rect) else (s.cx - s.r, s.cx + s.r))]
            ys = [v for s in shapes
                  for v in ((s.ymin, s.ymax) if isinstance(s, Rect) else (s.cy - s.r, s.cy + s.r))]
            bounds = (min(xs), min(ys), max(xs), max(ys))
        x0, y0, x1, y1 = (float(v) for v in bounds)
        if not (x1 > x0 and y1 > y0):
            raise InputError("map bounds must be (xmin, ymin, xmax, ymax) with xmax > xmin, ymax > ymin; "
                             f"got {bounds}")
        T = np.diag([scale, scale, scale, 1.0])
        T[2, 3] = float(z)
        self[root].set_transform(T)
        thick = 0.01 * max(x1 - x0, y1 - y0)
        self._draw(f"{root}/floor", mg.Mesh(mg.Box([x1 - x0, y1 - y0, thick]), _material(0xEDEDE6)),
                   _translation([0.5 * (x0 + x1), 0.5 * (y0 + y1), -0.5 * thick]))
        for i, s in enumerate(shapes):
            label = s.name or f"{i}"
            self._draw_shape(f"{root}/obstacles/{label}", s, h, 0x8C564B, 1.0)
            if inflate > 0:
                grown = (Rect(s.xmin - inflate, s.ymin - inflate, s.xmax + inflate, s.ymax + inflate)
                         if isinstance(s, Rect)
                         else Circle(s.cx, s.cy, s.r + inflate))
                self._draw_shape(f"{root}/inflated/{label}", grown, 0.5 * h, 0xD62728, 0.25)
        lift = 0.02 * h
        if coverage is not None:
            grid = as_grid(coverage)
            rects = grid.rectangles()
            if rects:
                V, F = [], []
                for k, r in enumerate(rects):
                    V += [[r.xmin, r.ymin, lift], [r.xmax, r.ymin, lift], [r.xmax, r.ymax, lift],
                          [r.xmin, r.ymax, lift]]
                    F += [[4 * k, 4 * k + 1, 4 * k + 2], [4 * k, 4 * k + 2, 4 * k + 3]]
                self._draw(f"{root}/coverage", mg.Mesh(mg.TriangularMeshGeometry(np.array(V), np.array(F)),
                                                      _material("green", 0.35, mg.MeshBasicMaterial)))
        for i, (label, pts) in enumerate(_named(paths, "path")):
            P = as_polyline(pts, f"paths[{label!r}]", dims=(2,))
            P3 = np.c_[P, np.full(len(P), 2 * lift)]
            material = mg.LineBasicMaterial(color=colors.to_int(colors.cycle(i)), linewidth=2.0)
            self._draw(f"{root}/paths/{label}", mg.Line(mg.PointsGeometry(P3.T.astype(np.float32)), material))
        radius = 0.012 * max(x1 - x0, y1 - y0)
        for i, (label, p) in enumerate(_named(waypoints, "waypoint")):
            xy = as_vector(p, 2, f"waypoints[{label!r}]")
            A = _translation([xy[0], xy[1], 0.5 * lift])
            self._draw(f"{root}/waypoints/{label}",
                       mg.Mesh(_ZCylinder(lift, radius), _material("orange", kind=mg.MeshPhongMaterial)), A)
        self._note_points(root, [np.array([scale * x, scale * y, float(z) + scale * hz]) for x in (x0, x1)
                                 for y in (y0, y1) for hz in (0.0, h)])
        return root

    def add_mobile_base(self, name: str, size=(20.0, 20.0, 8.0), color="sky", pose=None) -> str:
        """A mobile base: a box body ``size = (length, width, height)`` with a dark nose on its
        front (+x) face, so the heading shows. The node ``name`` is the base frame (body
        centre on the floor, x forward); its children are drawn relative to it. Under a map
        node the units are map units, and :meth:`viz.Animation.planar` moves it.
        """
        L, W, H = (float(v) for v in as_vector(size, 3, "size"))
        if min(L, W, H) <= 0:
            raise InputError(f"mobile base size must be positive, got {size}")
        path = self.path(name)
        T = self._pose_or_point(pose)
        self[path].set_transform(T)
        self._draw(f"{path}/body", mg.Mesh(mg.Box([L, W, H]), _material(color)),
                   _translation([0.0, 0.0, 0.5 * H]))
        self._draw(f"{path}/nose", mg.Mesh(mg.Box([0.2 * L, 0.4 * W, 0.5 * H]), _material("darkgrey")),
                   _translation([0.5 * L, 0.0, 0.75 * H]))
        return path

    def _draw_shape(self, path: str, s, height: float, color, opacity: float) -> None:
        if isinstance(s, Rect):
            (cx, cy), (sx, sy) = s.center, s.size
            self._draw(path, mg.Mesh(mg.Box([sx, sy, height]), _material(color, opacity)),
                       _translation([cx, cy, 0.5 * height]))
        else:
            self._draw(path, mg.Mesh(_ZCylinder(height, s.r), _material(color, opacity)),
                       _translation([s.cx, s.cy, 0.5 * height]))


def _local_boxes(geometry: pin.GeometryModel, nodes: dict[str, str]) -> dict[str, np.ndarray]:
    """``{node path: (8, 3) corners}`` of each drawn geometry's local bounding box (geometry frame,
    metres)."""
    out = {}
    for g in geometry.geometryObjects:
        path = nodes.get(g.name)
        if path is None:
            continue
        try:
            g.geometry.computeLocalAABB()
            box = g.geometry.aabb_local
            lo, hi = np.asarray(box.min_, dtype=float), np.asarray(box.max_, dtype=float)
        except (AttributeError, RuntimeError):  # a geometry without a local box: its origin stands for it
            lo = hi = np.zeros(3)
        if np.isfinite(lo).all() and np.isfinite(hi).all() and np.all(hi >= lo):
            out[path] = box_corners(lo, hi)
    return out


def _named(items, stem: str) -> list[tuple[str, object]]:
    """``[(label, item)]`` from a dict, a list, or None (labels ``stem0, stem1, ...`` for lists)."""
    if items is None:
        return []
    if isinstance(items, dict):
        return [(str(k).replace("/", "_"), v) for k, v in items.items()]
    if isinstance(items, np.ndarray) and items.ndim == 2 and stem == "path":
        return [(f"{stem}0", items)]
    return [(f"{stem}{i}", v) for i, v in enumerate(items)]
