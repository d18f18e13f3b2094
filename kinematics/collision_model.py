"""``CollisionModel``: a robot's collision geometry as convex shapes, and the link pairs to check.

Built from the Pinocchio ``GeometryModel`` of the URDF's ``<collision>`` elements
(the loader builds it; :meth:`CollisionModel.from_urdf` builds it from URDF text).

**Meshes become convex hulls** (:mod:`.mesh_hulls`: coal's qhull, scipy's when coal
cannot make one - :attr:`CollisionModel.hull_fallbacks` names those meshes): GJK on a
hull costs a fraction of a triangle-soup BVH query (Panda: 22 µs against 40 µs
for ``pinocchio.computeCollisions`` over its 44 SRDF pairs, and far less for
distances), and coal returns *signed* distances (penetration depth) only for
convex shapes. The error of the choice: a hull contains the mesh, so collision
answers are conservative - a pair is never reported clear when the meshes touch;
the distance is exact for a convex mesh and a lower bound for a concave one, by at
most the depth of the concavity. :attr:`CollisionModel.hull_volume_ratio` gives
``volume(hull) / volume(mesh)`` per mesh (the Panda's meshes are convex:
ratios 1.0000 to 1.0003). Primitive shapes (box, sphere, cylinder, capsule) stay
as they are.

**Pairs**: see :mod:`.collision_pairs` (SRDF when given, else computed MoveIt-style
and cached per model text by :mod:`.collision_cache`).

**Progress**: a build that computes hulls and pairs for more than a second shows a
bar on stderr when stderr is a terminal (:mod:`.build_progress`); it is silent
otherwise.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Iterable, Sequence
from itertools import repeat
from operator import attrgetter, is_
from typing import TYPE_CHECKING, Any

import coal
import numpy as np
import pinocchio as pin

from . import collision_cache
from .build_progress import build_progress
from .collision_layout import RobotCollisionGeometry, SceneLayout
from .collision_pairs import (
    ALGORITHM_VERSION,
    SAMPLES,
    SEED,
    LinkPair,
    candidate_geometry_pairs,
    compute_disabled_pairs,
    geometry_links,
    srdf_disabled_pairs,
)
from .collision_scene import CollisionScene
from .errors import ModelError
from .mesh_hulls import HullFallback, coal_message, convex_hulls
from .shapes import Shape, as_obstacles
from .validation import as_flag

if TYPE_CHECKING:
    from .sphere_cover import GeometrySpheres

#: Scene layouts (obstacle shapes, poses aside) kept per model, least recently used dropped first.
LAYOUT_CACHE_SIZE = 32


class _NoScene:
    """What :attr:`CollisionModel._last_scene` holds before a model's first scene: no call matches its
    ``self_collision`` (None), so every call builds a scene."""

    __slots__ = ()
    obstacles: tuple = ()
    self_collision = None


_NO_SCENE = _NoScene()
#: A shape's :attr:`~.shapes.Shape.signature_key` (read by ``map``: no Python frame per scene).
_SIGNATURE_KEY = attrgetter("signature_key")


def _same_objects(last: CollisionScene | _NoScene, obstacles: Sequence, self_collision: bool) -> bool:
    """Whether a call with ``obstacles`` and ``self_collision`` asks for the scene ``last``: the same choice
    of self pairs and, item by item, the very objects ``last`` was built from (it keeps them alive, so no
    other object can be identical to one of them)."""
    held = last.obstacles
    return self_collision is last.self_collision and len(obstacles) == len(held) \
        and all(map(is_, obstacles, held))


def bounding_sphere(geometry: coal.CollisionGeometry, placement: pin.SE3) -> tuple[np.ndarray, float]:
    """Centre and radius (m) of a sphere containing ``geometry`` placed at ``placement``: coal's local AABB
    sphere (``aabb_center``, ``aabb_radius``; computed on first use) moved by the placement."""
    if geometry.aabb_radius < 0.0:
        geometry.computeLocalAABB()
    return placement.act(np.asarray(geometry.aabb_center, dtype=float)), float(geometry.aabb_radius)


def _shape_dict(g: pin.GeometryObject, link: str) -> dict:
    """:meth:`CollisionModel.shape_data`'s entry of geometry object ``g`` carried by ``link``."""
    geo = g.geometry
    out = {"name": g.name, "link": link, "joint": int(g.parentJoint),
           "placement": g.placement.homogeneous.copy()}
    if isinstance(geo, coal.Box):
        out.update(kind="box", size=(2.0 * np.asarray(geo.halfSide)).tolist())
    elif isinstance(geo, coal.Sphere):
        out.update(kind="sphere", radius=float(geo.radius))
    elif isinstance(geo, (coal.Cylinder, coal.Capsule)):
        out.update(kind="cylinder" if isinstance(geo, coal.Cylinder) else "capsule", radius=float(geo.radius),
                   length=2.0 * float(geo.halfLength))
    elif isinstance(geo, coal.Convex):
        triangles = (geo.polygons(i) for i in range(geo.num_polygons))
        faces = [[int(t[0]), int(t[1]), int(t[2])] for t in triangles]
        out.update(kind="convex", vertices=np.array(geo.points(), dtype=float).reshape(-1, 3),
                   faces=np.array(faces, dtype=int).reshape(-1, 3))
    else:
        out.update(kind="other", type=type(geo).__name__)
    return out


class CollisionModel:
    """The robot's convex collision geometry with its self-collision pairs.

    Parameters
    ----------
    model:
        The robot's Pinocchio model.
    geometry:
        Its collision ``GeometryModel`` (copied; meshes are replaced by hulls in the copy).
    lower, upper:
        Joint limits, for the sampled pair computation.
    srdf:
        SRDF text whose ``<disable_collisions>`` give the disabled pairs; None to
        compute them (MoveIt-style, cached on disk per ``model_text``).
    model_text:
        The URDF text, the cache key of computed pairs (None: no cache).
    name:
        Robot name, for messages (and the progress bar).
    samples, seed:
        Number of random configurations of the computed pairs and their seed.

    Raises :class:`ModelError` when the geometry is empty (the URDF has no
    ``<collision>`` elements), a mesh has no convex hull (the message names the
    geometry, its link, its mesh file and the cause) or the SRDF names unknown links.
    """

    def __init__(self, model: pin.Model, geometry: pin.GeometryModel, lower: np.ndarray, upper: np.ndarray, *,
                 srdf: str | None = None, srdf_label: str = "SRDF", model_text: str | None = None,
                 name: str = "robot", samples: int = SAMPLES, seed: int = SEED) -> None:
        if geometry is None or geometry.ngeoms == 0:
            raise ModelError(
                f"robot {name!r} has no collision geometry: its URDF has no <collision> elements, so "
                "collisions cannot be checked; add <collision> shapes (cylinders, boxes, meshes) to its links"
            )
        self.name = name
        self.model = model
        gm = geometry.copy()
        gm.removeAllCollisionPairs()
        self.links: list[str] = geometry_links(model, gm)
        cached = self._cached_pairs(model_text, samples, seed) if srdf is None else None
        sampled = int(samples) if srdf is None and cached is None else 0
        with build_progress(gm.ngeoms + sampled, f"collision model of {name!r}") as bar:
            hulls = convex_hulls(gm, self.links, on_mesh=lambda: bar.update(1))
            #: ``{geometry name: volume(hull) / volume(mesh)}`` of every mesh (:mod:`.mesh_hulls`).
            self.hull_volume_ratio: dict[str, float] = hulls.volume_ratio
            #: The meshes whose hull scipy's qhull made because coal's failed, with coal's reason.
            self.hull_fallbacks: tuple[HullFallback, ...] = hulls.fallbacks
            self.geometry_names: list[str] = [g.name for g in gm.geometryObjects]
            if srdf is not None:
                frame_names = [f.name for f in model.frames]
                self.disabled = srdf_disabled_pairs(srdf, frame_names, srdf_label)
                self.pair_source = "srdf"
            elif cached is not None:
                self.disabled, self.pair_source = cached, "cache"
            else:
                self.disabled = self._computed_pairs(gm, lower, upper, model_text, samples, seed, bar.update)
                self.pair_source = "computed"
        self.attached: tuple = ()  #: the carried objects (:mod:`.attached`) of a model made by with_attached
        #: The model without carried objects that :meth:`with_attached` made this one from (None: this one).
        self.bare: CollisionModel | None = None
        self._assemble(gm, candidate_geometry_pairs(model, gm, self.disabled))

    @classmethod
    def from_urdf(cls, model: pin.Model, urdf: str, package_dirs: Sequence[str], lower: np.ndarray,
                  upper: np.ndarray,
                  **kw: Any) -> "CollisionModel":
        """Build the collision ``GeometryModel`` from URDF text, then the model (see the class)."""
        try:
            gm = pin.buildGeomFromUrdfString(model, urdf, pin.GeometryType.COLLISION,
                                             package_dirs=list(package_dirs))
        except (ValueError, RuntimeError, OSError) as exc:
            name = kw.get("name", "robot")
            raise ModelError(f"robot {name!r}: cannot build the collision geometry: {coal_message(exc)}") \
                from None
        return cls(model, gm, lower, upper, model_text=kw.pop("model_text", urdf), **kw)

    def _assemble(self, gm: pin.GeometryModel, self_pairs: list[tuple[int, int]],
                  bare: CollisionModel | None = None) -> None:
        """Set the self pairs of ``gm`` (hulls, no pairs yet) and make everything derived from the geometry:
        the sphere model, the layouts' robot geometry, the viewer data, the base spheres, empty caches.
        ``bare``: the model without carried objects whose geometries are the first ones of ``gm``
        (:meth:`with_attached`): their sphere covers, inner radii and viewer data are its own, reused; only
        the carried objects' are computed."""
        model = self.model
        self.self_pairs: list[tuple[int, int]] = self_pairs
        for i, j in self.self_pairs:
            gm.addCollisionPair(pin.CollisionPair(i, j))
        self.geometry = gm
        #: Pinocchio joint of each robot geometry (0 = fixed base) and the model's self pairs, in model order.
        self.geometry_joints: list[int] = [int(g.parentJoint) for g in gm.geometryObjects]
        self.model_pairs: list[tuple[int, int]] = [(int(cp.first), int(cp.second))
                                                   for cp in gm.collisionPairs]
        #: The sphere cover of each geometry (:func:`~.sphere_cover.geometry_spheres`, in its own frame), or
        #: None when the tree has no sphere model.
        self.sphere_covers: list[GeometrySpheres] | None = _sphere_covers(
            model, gm, (bare.sphere_covers or ()) if bare is not None else ())
        #: The robot's sphere model (:func:`~.robot_spheres.robot_spheres`; None when its tree has other
        #: joints than one-DoF revolute / prismatic ones), built with the model, as is the compiled pre-check.
        self.spheres = _sphere_model(model, gm, self.sphere_covers)
        from .inner_balls import robot_inner_radii  # (scipy's qhull: imported with the first model)

        known = bare.robot_geometry.inner_radii if bare is not None else None
        radii = None if self.spheres is None else robot_inner_radii(gm, self.spheres.inner,
                                                                    self.spheres.inner_ranges, known)
        #: What every scene layout of this model reads (:class:`~.collision_layout.RobotCollisionGeometry`).
        self.robot_geometry = RobotCollisionGeometry(model, gm, tuple(self.links),
                                                     tuple(self.geometry_joints), tuple(self.model_pairs),
                                                     self.spheres, radii)
        known_data = bare._shape_data if bare is not None else []
        self._shape_data = [*known_data, *(_shape_dict(gm.geometryObjects[k], self.links[k])
                                           for k in range(len(known_data), len(self.links)))]
        self._base_spheres = _base_spheres(gm, self.geometry_joints)
        #: (self_collision, the shapes' signature keys joined) -> SceneLayout
        self._layouts: OrderedDict = OrderedDict()
        #: The last scene built (its ``obstacles`` and ``self_collision`` are what a call is compared with);
        #: one, so a new scene frees the one before it.
        self._last_scene: CollisionScene | _NoScene = _NO_SCENE
        self._lock = threading.Lock()

    def forget_scenes(self) -> None:
        """Forget the scene layouts and the last scene (:func:`kinserve.clear_caches`): the next scene of any
        shapes builds its layout again. Scenes a caller holds stay valid (each keeps its layout); the robot's
        geometry, spheres and pre-check packings are the model itself and stay."""
        with self._lock:
            self._layouts.clear()
            self._last_scene = _NO_SCENE

    def with_attached(self, objects: Sequence[Any]) -> "CollisionModel":
        """A new model: this one's geometry plus the carried ``objects`` (:class:`~.attached.AttachedObject`).

        Object ``k`` becomes geometry ``G + k`` (``G``: this model's geometries), named and linked
        ``"attached:<name>"``, fixed to the parent joint ``j`` of its frame ``f`` at ``jMf @ placement`` (the
        frame's placement on its joint times the object's ``pose_in_frame @ shape pose``), so its world pose
        is ``oMj(q) @ jMf @ placement = fk(q, frame) @ placement``. Its self pairs: with every geometry on
        another joint whose link is not one of its touch links (geometries on its own joint cannot move
        relative to it; an earlier object on another joint is paired too); obstacle pairs as for every
        geometry on a moving joint. The sphere model and the pre-check are built over the whole geometry,
        so they cover the objects too. This model is not changed; its hulls, pair source and disabled
        pairs are shared; :attr:`bare` is this model.
        """
        if self.attached:
            raise ModelError("with_attached: start from the model without carried objects")
        out = object.__new__(CollisionModel)
        for key in ("name", "model", "hull_volume_ratio", "hull_fallbacks", "disabled", "pair_source"):
            setattr(out, key, getattr(self, key))
        gm = self.geometry.copy()
        gm.removeAllCollisionPairs()
        links = list(self.links)
        for obj in objects:
            fid = self.model.getFrameId(obj.frame)
            frame = self.model.frames[fid]
            placement = frame.placement * pin.SE3(np.array(obj.placement, dtype=float))
            gm.addGeometryObject(pin.GeometryObject(obj.link_name, int(frame.parentJoint), fid, placement,
                                                    obj.shape.geometry()))
            links.append(obj.link_name)
        out.links = links
        out.geometry_names = [g.name for g in gm.geometryObjects]
        out.attached = tuple(objects)
        out.bare = self
        out._assemble(gm, list(self.self_pairs) + _attached_pairs(gm, links, out.attached, len(self.links)),
                      self)
        return out

    @staticmethod
    def _cache_key(model_text: str | None, samples: int, seed: int) -> str | None:
        return collision_cache.cache_key(model_text, samples, seed, ALGORITHM_VERSION) if model_text else None

    def _cached_pairs(self, model_text, samples, seed) -> dict[LinkPair, str] | None:
        key = self._cache_key(model_text, samples, seed)
        return collision_cache.load_pairs(key) if key is not None else None

    def _computed_pairs(self, gm, lower, upper, model_text, samples, seed, progress) -> dict[LinkPair, str]:
        pairs = compute_disabled_pairs(self.model, gm, np.asarray(lower), np.asarray(upper), samples, seed,
                                       progress)
        key = self._cache_key(model_text, samples, seed)
        if key is not None:
            collision_cache.store_pairs(key, pairs)
        return pairs

    def shape_data(self) -> list[dict]:
        """Plain data of every robot geometry in its joint frame (for viewers; made with the model).

        ``{"name", "link", "joint", "placement" (4x4 in the joint frame), "kind"}`` plus,
        by kind: ``box`` ``size`` (full edges, m); ``sphere`` ``radius``; ``cylinder`` /
        ``capsule`` ``radius``, ``length`` (local z); ``convex`` ``vertices`` ``(V, 3)``
        and ``faces`` ``(F, 3)`` (triangles of the hull).
        """
        return self._shape_data

    def base_spheres(self) -> list[tuple[int, np.ndarray, float]]:
        """``[(geometry index, centre (3,), radius), ...]``: a sphere (world, m) containing each geometry
        to the world (joint 0), from coal's local AABB sphere at the geometry's placement (made with the
        model)."""
        return self._base_spheres

    def __repr__(self) -> str:
        return (f"CollisionModel({self.name!r}, {len(self.links)} geometries, "
                f"{len(self.self_pairs)} self pairs, "
                f"pairs from {self.pair_source})")

    # ----------------------------------------------------------------- scenes
    def cached_scene(self, obstacles: Any, self_collision: bool = True) -> CollisionScene | None:
        """The last scene built (:meth:`scene`) when ``obstacles`` (a list or tuple, unvalidated) are its very
        objects, in order, and ``self_collision`` (a bool) its choice, else None.

        A hit is safe without validating ``obstacles``: the last scene holds the (validated, immutable) shapes
        it was built from, so objects identical to those are those very shapes. Dict forms never hit. The
        same tuple as the last scene's answers without comparing its items.
        """
        last = self._last_scene
        if obstacles is last.obstacles and self_collision is last.self_collision:
            return last
        if (type(obstacles) is tuple or type(obstacles) is list) and _same_objects(last, obstacles,
                                                                                    self_collision):
            return last
        return None

    def scene_of(self, obstacles: Any, self_collision: bool = True) -> CollisionScene:
        """The scene of ``obstacles`` as a caller gives them (a shape, a sequence of shapes or shape dicts, or
        None; :func:`~.shapes.as_obstacles`): :meth:`cached_scene`'s answer, else a new scene
        (:meth:`scene`)."""
        last = self._last_scene
        if obstacles is last.obstacles and self_collision is last.self_collision:
            return last
        if type(obstacles) is tuple or type(obstacles) is list:
            held = last.obstacles  # _same_objects, without its frame: every new scene passes here
            if self_collision is last.self_collision and len(obstacles) == len(held) \
                    and all(map(is_, obstacles, held)):
                return last
            del held
            if all(map(isinstance, obstacles, repeat(Shape))):  # shapes already
                del last  # (below too) no local keeps the old scene alive while the new one is built
                return self._new_scene(obstacles if type(obstacles) is tuple else tuple(obstacles),
                                       self_collision)
        del last
        return self._new_scene(as_obstacles(obstacles), self_collision)

    def scene(self, obstacles: Iterable = (), self_collision: bool = True) -> CollisionScene:
        """The :class:`~.collision_scene.CollisionScene` of this robot with ``obstacles`` (shapes). The model
        remembers the last scene it built: passing its very objects again costs a comparison of identities;
        other objects - equal to those or not - get a new scene on the layout of their signatures
        (:meth:`layout`), and the one before is freed (a caller that switches between scenes holds each one).
        The obstacle rows are the shapes' own (:attr:`~.shapes.Shape.obstacle_bytes`), so a new scene costs a
        few microseconds and allocates nothing in Pinocchio or coal.
        """
        obs = obstacles if type(obstacles) is tuple else tuple(obstacles)
        self_collision = as_flag(self_collision, "self_collision")
        last = self._last_scene
        if _same_objects(last, obs, self_collision):
            return last
        del last  # no local keeps the old scene alive while the new one is built (:meth:`_new_scene`)
        return self._new_scene(obs, self_collision)

    def _new_scene(self, obstacles: tuple, self_collision: bool) -> CollisionScene:
        """A new scene of ``obstacles`` (validated shapes), kept as the last one. The one before is freed
        first when the model holds the last reference to it (the callers keep no local one), so the memory
        peak holds one scene's arrays, not two."""
        self._last_scene = _NO_SCENE
        scene = self._last_scene = CollisionScene(self.layout(obstacles, self_collision), obstacles)
        return scene

    def layout(self, obstacles: tuple, self_collision: bool = True) -> SceneLayout:
        """The :class:`~.collision_layout.SceneLayout` of obstacles shaped like ``obstacles`` (validated
        shapes), cached by their signatures (:attr:`~.shapes.Shape.signature`): scenes whose
        obstacles differ only by pose share it, so a moved obstacle does not rebuild a scene from nothing. The
        key joins the shapes' :attr:`~.shapes.Shape.signature_key` (each a complete ``repr``, so the join is
        unambiguous)."""
        key = (self_collision, b"".join(map(_SIGNATURE_KEY, obstacles)))
        layout = self._layouts.get(key)
        if layout is None:
            layout = SceneLayout(self.robot_geometry, obstacles, self_collision)
            with self._lock:
                _remember(self._layouts, key, layout)
        return layout


def _sphere_covers(model: pin.Model, geometry: pin.GeometryModel,
                   known: Sequence[GeometrySpheres]) -> list[GeometrySpheres] | None:
    """The sphere cover of each geometry of ``geometry`` (``known``'s for the first ones), or None when the
    model's tree has no sphere model (:func:`~.robot_spheres.robot_spheres` would answer None). Imported
    here, as in :func:`_sphere_model`: the covers' kernels are compiled code."""
    from .serial_chain import kinematic_tree
    from .sphere_cover import geometry_spheres

    if kinematic_tree(model) is None:
        return None
    objects = geometry.geometryObjects
    return [*known, *(geometry_spheres(objects[k].geometry) for k in range(len(known), len(objects)))]


def _sphere_model(model: pin.Model, geometry: pin.GeometryModel,
                  covers: list[GeometrySpheres] | None) -> Any:
    """:func:`~.robot_spheres.robot_spheres` of the hull geometry with its ``covers`` (None: no sphere
    model); the scenes' pre-check and its compiled kernels (Numba) are loaded now too, so no scene of the
    model loads them (imported here, not with this module: ``import kinserve`` does not pay for them)."""
    from . import scene_precheck  # noqa: F401 - its kernels compile (or load from Numba's cache) on import
    from .robot_spheres import robot_spheres

    if covers is None:
        return None
    return robot_spheres(model, geometry, covers)


def _attached_pairs(gm: pin.GeometryModel, links: list[str], objects: tuple,
                    first: int) -> list[tuple[int, int]]:
    """The pairs of the carried objects (geometries ``first, first + 1, ...`` of ``gm``): each against every
    earlier geometry on another joint whose link is not one of its touch links (:mod:`.attached`)."""
    objs = gm.geometryObjects
    pairs = []
    for k, obj in enumerate(objects):
        a = first + k
        touch = set(obj.touch_links)
        for i in range(a):
            if objs[i].parentJoint != objs[a].parentJoint and links[i] not in touch:
                pairs.append((i, a))
    return pairs


def _base_spheres(geometry: pin.GeometryModel, joints: list[int]) -> list[tuple[int, np.ndarray, float]]:
    """:meth:`CollisionModel.base_spheres` of ``geometry`` (``joints``: the joint of each geometry)."""
    out = []
    for i, joint in enumerate(joints):
        if joint == 0:
            obj = geometry.geometryObjects[i]
            centre, radius = bounding_sphere(obj.geometry, obj.placement)
            out.append((i, centre, radius))
    return out


def _remember(cache: OrderedDict, key: tuple, value: Any) -> None:
    """Put ``key`` (absent) last in ``cache`` and drop the oldest entries beyond :data:`LAYOUT_CACHE_SIZE`."""
    cache[key] = value
    while len(cache) > LAYOUT_CACHE_SIZE:
        cache.popitem(last=False)
