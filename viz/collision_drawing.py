"""Drawing collision geometry and obstacles from plain data (used by
``Scene.for_robot(..., collision=True)``).

Inputs are plain data: the shape dicts of
:meth:`kinserve.kinematics.Robot.collision_geometry` (``kind``, world ``pose``,
dimensions, hull ``vertices``/``faces``) and obstacle dicts
(:meth:`kinserve.kinematics.shapes.Shape.to_dict`). Colliding bodies - named by
link or ``obstacle[k]:kind`` in the ``colliding`` pairs - are drawn in
:data:`COLLIDING_COLOR`; the others in :data:`CLEAR_COLOR` (robot shapes,
translucent over the visual meshes) and :data:`OBSTACLE_COLOR`.

Nodes: ``<robot>/collision/<geometry name>`` and ``obstacles/<k>``.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import meshcat.geometry as mg
import numpy as np

from kinserve.kinematics.errors import InputError

COLLIDING_COLOR = "red"
CLEAR_COLOR = "green"
OBSTACLE_COLOR = "grey"
#: Opacity of the collision shapes (the visual meshes show through).
OPACITY = 0.45


def involved(colliding: Iterable[Sequence[str]]) -> set[str]:
    """Names (links, obstacles) that appear in any colliding pair."""
    return {name for pair in colliding for name in pair}


def draw_shape(scene, path: str, shape: dict, color, opacity: float = OPACITY) -> str:
    """Draw one shape dict at its ``pose`` (world); returns the node path."""
    kind = shape.get("kind")
    T = np.asarray(shape.get("pose", np.eye(4)), dtype=float)
    if kind == "box":
        return scene.add_box(path, shape["size"], T, color=color, opacity=opacity)
    if kind == "sphere":
        center = shape.get("center", T[:3, 3])
        return scene.add_sphere(path, center, shape["radius"], color=color, opacity=opacity)
    if kind == "cylinder":
        return scene.add_cylinder(path, shape["radius"], shape["length"], T, color=color, opacity=opacity)
    if kind == "capsule":
        if "a" in shape:  # obstacle form: segment end points
            a, b = np.asarray(shape["a"], float), np.asarray(shape["b"], float)
            from kinserve.kinematics.shapes import Capsule

            T, length = Capsule(a, b, shape["radius"]).pose, float(np.linalg.norm(b - a))
        else:
            length = shape["length"]
        out = scene.add_cylinder(path + "/core", shape["radius"], max(length, 1e-6), T, color=color,
                                 opacity=opacity)
        for end, sign in (("a", -1.0), ("b", 1.0)):
            scene.add_sphere(f"{path}/{end}", T[:3, 3] + sign * 0.5 * length * T[:3, 2], shape["radius"],
                             color=color, opacity=opacity)
        return out
    if kind == "convex":
        verts = np.asarray(shape["vertices"], dtype=float)
        faces = np.asarray(shape["faces"], dtype=int)
        material = mg.MeshLambertMaterial(color=_color_int(color), opacity=opacity, transparent=opacity < 1.0)
        p = scene.path(path)
        scene[p].set_object(mg.Mesh(mg.TriangularMeshGeometry(verts, faces), material))
        scene[p].set_transform(T)
        scene._note_points(p, [T[:3, :3] @ v + T[:3, 3] for v in verts])
        return p
    raise InputError(f"cannot draw a shape of kind {kind!r} (expected box, sphere, cylinder, "
                     "capsule or convex)")


def _color_int(color) -> int:
    from . import colors

    return colors.to_int(color)


def draw_collision_scene(scene, robot_name: str, shapes: Sequence[dict], obstacles: Sequence[dict] = (),
                         colliding: Iterable[Sequence[str]] = ()) -> list[str]:
    """Draw a robot's collision shapes and the obstacles, the colliding ones highlighted; returns the node
    paths."""
    hit = involved(colliding)
    paths = []
    for s in shapes:
        color = COLLIDING_COLOR if s.get("link") in hit else CLEAR_COLOR
        paths.append(draw_shape(scene, f"{robot_name}_collision/{s['name']}", s, color))
    for k, ob in enumerate(obstacles):
        name = f"obstacle[{k}]:{ob.get('kind')}"
        color = COLLIDING_COLOR if name in hit else OBSTACLE_COLOR
        paths.append(draw_shape(scene, f"obstacles/{k}", ob, color, opacity=0.8))
    return paths
