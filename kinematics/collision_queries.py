"""Collision queries of a ``Robot``: self-collision and obstacles, through its convex collision model.

``Robot`` inherits :class:`CollisionQueries`. The collision model
(:class:`~.collision_model.CollisionModel`) is built on first use from the
``GeometryModel`` the loader handed over (or from the stored URDF text) and the
SRDF the loader found (or MoveIt-style computed pairs), then shared by every
copy of the robot.

Pair names: a robot geometry is named by its **link**; obstacle ``k`` of the
``obstacles`` argument by ``"obstacle[k]:<kind>"`` (e.g. ``"obstacle[0]:box"``); a
carried object (:meth:`CollisionQueries.attach`) by ``"attached:<name>"``.
Obstacles are :mod:`~.shapes` (``Sphere``, ``Box``, ``Capsule``, ``Cylinder``,
``Mesh``; ``kinserve.ik`` re-exports them) or their ``to_dict()`` forms. Their
``frames`` option is an IK setting; these queries always use the whole geometry.

Units: metres; distances are signed (negative = penetration depth).
"""

from __future__ import annotations

import threading
from collections.abc import Iterable
from dataclasses import dataclass
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np

from .attached import AttachedObject, attached_object
from .errors import InputError, ModelError
from .extensions import Extensions
from .types import VectorLike
from .validation import as_flag, describe

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


#: :attr:`CollisionQueries.attached` of a robot that carries nothing (read-only, shared).
_NOTHING_ATTACHED: MappingProxyType = MappingProxyType({})


def _frame_link(model: Any, frame_id: int, links: list[str]) -> str | None:
    """The collision link ``frame_id`` belongs to: the frame itself or its nearest ancestor frame (through
    ``parentFrame``) that carries collision geometry; None when none on its joint does."""
    names = set(links)
    joint = model.frames[frame_id].parentJoint
    fid = frame_id
    while True:
        frame = model.frames[fid]
        if frame.name in names:
            return frame.name
        if frame.parentJoint != joint or frame.parentFrame == fid:
            return None
        fid = frame.parentFrame


class CollisionQueries:
    """Mixin of :class:`~.robot.Robot`: ``in_collision``, ``collisions``, ``distances``, ``min_distance``."""

    # provided by Robot
    _attached: tuple = ()  # the carried objects (AttachedObject), in attach order
    _attached_holder: list | None = None  # [this robot's CollisionModel with them] (None: nothing carried)
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
        """The robot's :class:`~.collision_model.CollisionModel`: the bare one (built on first use, shared by
        copies and by every ``robots.load`` of one cached model), or with carried objects this robot's own
        (:meth:`attach`; made by ``attach``, again on first use after unpickling or after the bare model was
        replaced, e.g. by a new SRDF).

        :class:`~.errors.ModelError` when the URDF has no ``<collision>`` elements.
        """
        own = self._attached_holder
        if own is None:  # the bare model: read here once built (one call less on every query)
            return self._collision_holder[0] or self.bare_collision
        cm = own[0]
        if cm is not None and cm.bare is self._collision_holder[0]:
            return cm
        return self._attached_model()

    def _attached_model(self) -> "CollisionModel":
        """Build this robot's model with its carried objects from the current bare model (once: under the
        build lock, which is not held while the bare model is built - that takes the lock itself)."""
        bare = self.bare_collision
        with _BUILD_LOCK:
            own = self._attached_holder
            cm = own[0]
            if cm is None or cm.bare is not bare:
                cm = bare.with_attached(self._attached)
                if own[0] is None:  # after unpickling: shared with the copies made since
                    own[0] = cm
                else:  # the bare model changed under this robot only: its own holder
                    self._attached_holder = [cm]
        return cm

    @property
    def bare_collision(self) -> "CollisionModel":
        """The :class:`~.collision_model.CollisionModel` of the robot's own links, without carried objects."""
        holder = self._collision_holder
        cm = holder[0]
        if cm is None:
            with _BUILD_LOCK:
                cm = holder[0]
                if cm is None:
                    cm = holder[0] = self._build_collision_model()
        return cm

    def forget_collision_scenes(self) -> None:
        """:meth:`~.collision_model.CollisionModel.forget_scenes` on the collision models this robot has built
        (the bare one, shared with its copies, and its own with carried objects); builds none."""
        own = self._attached_holder
        for cm in (self._collision_holder[0], None if own is None else own[0]):
            if cm is not None:
                cm.forget_scenes()

    # ---------------------------------------------------------- carried objects
    @property
    def attached(self) -> "MappingProxyType[str, AttachedObject]":
        """The carried objects, ``{name: AttachedObject}`` (read-only; see :meth:`attach`)."""
        if not self._attached:
            return _NOTHING_ATTACHED
        return MappingProxyType({obj.name: obj for obj in self._attached})

    def attach(self, name: str, shape: Any, frame: str, pose_in_frame: Any = None,
               touch_links: Iterable[str] | None = None) -> Any:
        """Carry ``shape`` with ``frame`` (a gripped part, a tool): returns the robot (for chaining).

        ``shape``: a sphere, box, capsule or cylinder of :mod:`.shapes` (or its ``to_dict()``); its own
        ``pose`` / centre is read in the object's frame, whose pose in ``frame`` is ``pose_in_frame`` (4x4 or
        ``pinocchio.SE3``, m; default identity). So the geometry's world pose at ``q`` is
        ``fk(q, frame) @ pose_in_frame @ shape.pose`` (:meth:`attached_poses`). ``touch_links``: the
        collision links it may touch, never checked against it (default: the link ``frame`` belongs to; name
        a gripper's fingers when they sit on other joints). Links on the same rigid body (Pinocchio joint) as
        ``frame`` are never checked against it either: they cannot move relative to it.

        Where it counts: :meth:`in_collision`, :meth:`collisions`, :meth:`distances`, :meth:`min_distance`
        (pair name ``"attached:<name>"``, against the obstacles always, against the other links with
        ``self_collision``), ``planners.plan_motion`` and ``ik.solve`` - through the collision model: with
        ``self_collision=True`` or ``collision_margin``, and also with ``obstacles=`` / ``spheres=`` alone
        (while something is carried, those are checked against the collision model, carried objects
        included, instead of the link capsules of ``ik.ObstacleAvoidance``; ``link_radius`` then plays no
        part). Constraints a caller builds and binds himself (``ik.ObstacleAvoidance``, ``tasks=`` /
        ``constraints=`` compositions) use the link capsules and do not see carried objects.

        Changes this ``Robot`` object only (and copies made from it afterwards; ``robot.copy()`` and
        pickling carry the objects): another ``robots.load`` result, an earlier copy or a pooled service
        robot keep their own geometry, and ``kinserve.clear_caches`` detaches nothing. Attaching is not
        meant to race with queries on the same object: to carry something in one request or thread, use
        ``robot.copy().attach(...)``. The robot's IK state (seed tables, bound collision constraints) is
        dropped, since its collision model changed; the next solve (or ``ik.warm``) builds it again.

        :class:`~.errors.InputError` (naming the argument) for a name already carried, an unknown frame or
        one fixed to the world (add the shape as an obstacle instead), an unknown touch link, a mesh or a
        malformed pose (NaN, not 4x4, rotation not orthonormal). :class:`~.errors.ModelError` when the
        robot has no collision geometry.
        """
        if isinstance(name, str) and any(obj.name == name for obj in self._attached):
            raise InputError(f"attach: {name!r} is already attached; detach it first "
                             f"(attached: {sorted(self.attached)})")
        fid = self.frame_id(frame)
        if self.model.frames[fid].parentJoint == 0:
            raise InputError(f"attach({name!r}): frame {frame!r} is fixed to the world, so the object would "
                             "never move; expected a frame on a moving link (or pass it as an obstacle)")
        cm = self.bare_collision
        obj = attached_object(name, shape, frame, pose_in_frame, touch_links, cm.links,
                              _frame_link(self.model, fid, cm.links))
        self._set_attached((*self._attached, obj))
        return self

    def detach(self, name: str) -> "AttachedObject":
        """Stop carrying ``name``; returns its :class:`~.attached.AttachedObject`. :class:`InputError` when
        ``name`` is not a str or nothing of that name is attached."""
        if not isinstance(name, str):
            raise InputError(f"detach: name must be a str (the name given to attach), got {describe(name)}")
        for obj in self._attached:
            if obj.name == name:
                self._set_attached(tuple(o for o in self._attached if o is not obj))
                return obj
        raise InputError(f"detach: nothing named {name!r} is attached (attached: {sorted(self.attached)})")

    def attached_poses(self, q: VectorLike) -> dict[str, np.ndarray]:
        """``{name: (4, 4) world pose}`` of each carried object's geometry at ``q``: ``fk(q, frame) @
        placement``."""
        q = self.check_q(q)
        return {obj.name: self.fk(q, obj.frame) @ obj.placement for obj in self._attached}

    def _set_attached(self, objects: tuple) -> None:
        cm = self.bare_collision.with_attached(objects) if objects else None
        self._attached = objects
        self._attached_holder = None if cm is None else [cm]
        self.extensions = Extensions()  # the IK state was bound to the other collision model

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
        """The :class:`~.collision_scene.CollisionScene` of this robot with ``obstacles``: the collision
        model's last scene when they are its very objects, else a new one that replaces it
        (:meth:`~.collision_model.CollisionModel.scene`). ``self_collision``: True or False
        (:class:`~.errors.InputError` otherwise)."""
        return self.collision.scene_of(obstacles, as_flag(self_collision, "self_collision"))

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
        the scene's look-up and that pass. ``q`` is checked by the scene's call
        (:meth:`CollisionScene.in_collision`: the same errors as :func:`~.validation.as_vector`, and no
        second check of a float vector the compiled pre-check reads and bounds itself). ``self_collision``:
        True or False (:class:`~.errors.InputError` for anything else, e.g. ``"yes"`` or None; here and in
        :meth:`collisions`, :meth:`distances`, :meth:`min_distance`).
        """
        if not (self_collision is True or self_collision is False):
            self_collision = as_flag(self_collision, "self_collision")
        return self.collision.scene_of(obstacles, self_collision).in_collision(q)

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
