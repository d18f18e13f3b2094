"""Collision queries of a ``Robot``: self-collision and obstacles, through its convex collision model.

``Robot`` inherits :class:`CollisionQueries`. The collision model
(:class:`~.collision_model.CollisionModel`) is built on first use from the
``GeometryModel`` the loader handed over (or from the stored URDF text) and the
SRDF the loader found (or MoveIt-style computed pairs), then shared by every
copy of the robot.

Pair names: a robot geometry is named by its **link**; obstacle ``k`` of the
``obstacles`` argument by ``"obstacle[k]:<kind>"`` (e.g. ``"obstacle[0]:box"``).
Obstacles are :mod:`~.shapes` (``Sphere``, ``Box``, ``Capsule``, ``Cylinder``,
``Mesh``; ``kinserve.ik`` re-exports them) or their ``to_dict()`` forms. Their
``frames`` option is an IK setting; these queries always use the whole geometry.

Units: metres; distances are signed (negative = penetration depth).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .errors import InputError, ModelError
from .shapes import Shape, as_shape
from .types import VectorLike
from .validation import as_vector

if TYPE_CHECKING:  # annotations only (collision_model imports pinocchio/coal)
    from .collision_model import CollisionModel
    from .collision_scene import CollisionScene

_BUILD_LOCK = threading.Lock()


@dataclass(frozen=True)
class PairDistance:
    """Signed distance ``distance`` (m) between two bodies with witness points (world, m).

    ``point_a`` lies on the first body, ``point_b`` on the second, and
    ``normal`` is the unit vector from the first towards the second:
    ``point_b - point_a = distance * normal`` (for a penetration, ``distance < 0``
    and the points are the deepest points of each body inside the other).
    """

    distance: float
    point_a: np.ndarray
    point_b: np.ndarray
    normal: np.ndarray

    def to_dict(self) -> dict:
        """The distance (m), the witness points and the normal (world) as plain lists."""
        return {"distance": self.distance, "point_a": self.point_a.tolist(), "point_b": self.point_b.tolist(),
                "normal": self.normal.tolist()}


def as_obstacles(obstacles: Any, name: str = "obstacles") -> tuple[Shape, ...]:
    """A tuple of shapes from a shape, a sequence of shapes / shape dicts, or None."""
    if obstacles is None:
        return ()
    if isinstance(obstacles, (Shape, dict)):
        return (as_shape(obstacles, f"{name}[0]"),)
    if isinstance(obstacles, (str, bytes)):
        raise InputError(f"{name} must be a sequence of shapes (Sphere, Box, Capsule, Cylinder, Mesh), "
                         "got a string")
    try:
        items = tuple(obstacles)
    except TypeError:
        raise InputError(f"{name} must be a sequence of shapes, got {type(obstacles).__name__}") from None
    for o in items:
        if not isinstance(o, Shape):
            break
    else:
        return items
    return tuple(as_shape(o, f"{name}[{k}]") for k, o in enumerate(items))


class CollisionQueries:
    """Mixin of :class:`~.robot.Robot`: ``in_collision``, ``collisions``, ``distances``, ``min_distance``."""

    # provided by Robot
    model: Any
    nq: int
    name: str
    collision_model: Any
    source: str | None
    package_dirs: tuple
    resolve_meshes: Any
    srdf: str | None
    lower: np.ndarray
    upper: np.ndarray

    @property
    def collision(self) -> "CollisionModel":
        """The robot's :class:`~.collision_model.CollisionModel` (built on first use, shared by copies).

        :class:`~.errors.ModelError` when the URDF has no ``<collision>`` elements.
        """
        holder = self._collision_holder
        cm = holder[0]
        if cm is None:
            with _BUILD_LOCK:
                cm = holder[0]
                if cm is None:
                    cm = holder[0] = self._build_collision_model()
        return cm

    def _build_collision_model(self):
        from .collision_model import CollisionModel

        kw = dict(srdf=self.srdf, srdf_label=f"SRDF of robot {self.name!r}", name=self.name,
                  model_text=self.source)
        if self.collision_model is not None:
            return CollisionModel(self.model, self.collision_model, self.lower, self.upper, **kw)
        if self.source is None:
            raise ModelError(f"robot {self.name!r} has no collision geometry and no URDF text to build it "
                             "from")
        # the loader's meshes
        urdf = self.source if self.resolve_meshes is None else self.resolve_meshes(self.source)
        return CollisionModel.from_urdf(self.model, urdf, self.package_dirs, self.lower, self.upper, **kw)

    def collision_scene(self, obstacles: Any = (), self_collision: bool = True) -> "CollisionScene":
        """The :class:`~.collision_scene.CollisionScene` of this robot with ``obstacles`` (cached by
        identity)."""
        cm = self.collision
        self_collision = self_collision is True or bool(self_collision)
        return cm.cached_scene(obstacles, self_collision) or cm.scene(as_obstacles(obstacles), self_collision)

    def collision_geometry(self, q: VectorLike) -> list[dict]:
        """Plain data of the robot's collision shapes at ``q``: :meth:`CollisionModel.shape_data` with
        ``"pose"`` = the shape's 4x4 world pose (``oMi[joint] @ placement``). For viewers."""
        import pinocchio as pin

        q = self.check_q(q)
        data = self.model.createData()
        pin.forwardKinematics(self.model, data, q)
        out = []
        for s in self.collision.shape_data():
            d = dict(s)
            d["pose"] = data.oMi[s["joint"]].homogeneous @ s["placement"]
            out.append(d)
        return out

    def in_collision(self, q: VectorLike, obstacles: Any = (), *, self_collision: bool = True) -> bool:
        """True when the robot at ``q`` intersects itself (checked pairs) or an obstacle.

        One broad-phase pass in C++ (see :meth:`CollisionScene.in_collision`); the
        scene of the same obstacle objects is reused, so a repeated call costs
        the validation of ``q``, a dictionary lookup and that pass.
        """
        q = as_vector(q, self.nq)
        return self.collision_scene(obstacles, self_collision).in_collision(q)

    def collisions(self, q: VectorLike, obstacles: Any = (), *,
                   self_collision: bool = True) -> list[tuple[str, str]]:
        """The intersecting pairs at ``q``, named (link / obstacle names), each once, in model order."""
        q = self.check_q(q)
        scene = self.collision_scene(obstacles, self_collision)
        return list(dict.fromkeys(scene.pair_names[k] for k in scene.colliding(q)))

    def distances(self, q: VectorLike, obstacles: Any = (), *,
                  self_collision: bool = True) -> dict[tuple[str, str], PairDistance]:
        """``{(name_a, name_b): PairDistance}`` for every checked pair at ``q`` (the closest geometries per
        pair)."""
        q = self.check_q(q)
        scene = self.collision_scene(obstacles, self_collision)
        d, p1, p2, n = scene.distance_arrays(q)
        out: dict[tuple[str, str], PairDistance] = {}
        for k, key in enumerate(scene.pair_names):
            old = out.get(key)
            if old is None or d[k] < old.distance:
                out[key] = PairDistance(float(d[k]), p1[k], p2[k], n[k])
        return out

    def min_distance(self, q: VectorLike, obstacles: Any = (), *, self_collision: bool = True) -> float:
        """The smallest signed distance (m) over the checked pairs at ``q`` (``inf`` when there is no
        pair)."""
        q = self.check_q(q)
        return self.collision_scene(obstacles, self_collision).min_distance(q)[0]
