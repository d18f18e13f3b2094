"""``SceneLayout``: what the collision scenes of one robot with obstacles of the same *shapes* share.

Two obstacle sets whose shapes differ only by their poses (a 10 cm cube moved
from one place to another, a table and a wall given again) give scenes with the
same geometry objects, the same checked pairs, the same pair names and the same
per-pair narrow-phase functors; only the placements of the obstacle objects
differ. A layout holds all of that once, built with it:

* the Pinocchio ``GeometryModel`` (robot geometry, then one object per obstacle
  fixed to the universe, joint 0), the pair table and the names;
* the sphere pre-check of its pairs (:class:`~.scene_precheck.ScenePrecheck`,
  from the robot's spheres; None when the robot has none, the layout has no
  pairs or :data:`SPHERE_PRECHECK` is off);
* per thread, a :class:`Workspace`: a copy of that ``GeometryModel``, the
  thread's ``pinocchio.Data`` (the robot's: one per thread, shared by every layout,
  :meth:`RobotCollisionGeometry.thread_data`), the ``GeometryData`` (collision requests that answer as
  fresh ones, security margin 0: :func:`exact_requests`) and the broad-phase manager over them, plus one
  ``GeometryData`` / manager per security margin for the near-pair queries, and
  which obstacles the workspace's placements currently hold (the building
  thread's is made with the layout). A query of a scene first makes the
  workspace hold that scene's obstacles: the placements of the obstacles that
  differ are set, nothing else.

A scene of an existing layout therefore allocates nothing in Pinocchio or coal.
Sharing is sound because every query recomputes the world placements it reads
(``oMg``) from the workspace's ``GeometryModel``; the per-pair narrow-phase
functors refer to the layout's geometry objects, whose shapes equal every
scene's (same :attr:`~.shapes.Shape.signature`); and a thread runs one query at a time.

The **signature** of an obstacle (:attr:`~.shapes.Shape.signature`, made with the
shape) is its kind and sizes (``Sphere``: radius; ``Box``: edges; ``Capsule``,
``Cylinder``: radius and length); a ``Mesh`` is its own signature (by identity:
its file may change).
"""

from __future__ import annotations

import threading
import warnings
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, NamedTuple

import coal
import numpy as np
import pinocchio as pin

from .configuration_checks import PAIRWISE_MAX, CoalCheck, coal_test, collision_check, pair_test
from .hull_table import HullTable, hull_table
from .precheck_packing import RobotPacking

if TYPE_CHECKING:
    from .robot_spheres import RobotSpheres
    from .scene_precheck import ScenePrecheck
    from .shapes import Shape

#: Layouts built while this is True get the sphere pre-check (False: coal alone, e.g. to compare the two;
#: read when a layout is built).
SPHERE_PRECHECK = True

#: Largest number of geometries (robot + obstacles) checked by coal's naive broad phase; more use the AABB
#: tree.
NAIVE_MAX_GEOMETRIES = 96

_SE3 = pin.SE3
_DEFAULT_GUESS = coal.GJKInitialGuess.DefaultGuess

#: GJK tolerance (m) of the near-pair distances used by the IK rows (coal's default is 1e-6).
GJK_TOLERANCE = 1e-9
#: Margin workspaces a thread keeps per layout (:meth:`SceneLayout.margin_workspace`): one per threshold,
#: the oldest replaced beyond this many.
MARGIN_WORKSPACES = 8


@dataclass(frozen=True)
class RobotCollisionGeometry:
    """What a layout needs of the robot (built by :class:`~.collision_model.CollisionModel`).

    ``model``: the Pinocchio model; ``geometry``: the convex collision ``GeometryModel`` with the self pairs;
    ``links``: the link name of each geometry; ``geometry_joints``: the Pinocchio joint of each (0 = fixed
    base); ``model_pairs``: the self pairs in model order; ``spheres``: the robot's sphere model
    (:func:`~.robot_spheres.robot_spheres`; None when its tree has none); ``inner_radii``: the radius (m)
    of the ball about each of its inner points inside its geometry (:func:`~.inner_balls.robot_inner_radii`,
    made by the collision model; None without spheres); ``hulls``: the cores of its geometries in
    their joints' frames (:func:`~.hull_table.hull_table`, for the motion certificates' compiled distances;
    made with this object when not given; None without spheres); ``moving``: the geometries on a moving joint
    (each is paired with every obstacle), made with this object; ``packings``: the pre-check's arrays that do
    not depend on the obstacles (:class:`~.precheck_packing.RobotPacking`), with and without the self pairs
    (keys True, False), made with this object, shared by every layout (None without spheres). Each thread's
    ``pinocchio.Data`` for the layouts' workspaces is this object's too (:meth:`thread_data`).
    """

    model: pin.Model
    geometry: pin.GeometryModel
    links: tuple[str, ...]
    geometry_joints: tuple[int, ...]
    model_pairs: tuple[tuple[int, int], ...]
    spheres: RobotSpheres | None
    inner_radii: np.ndarray | None = None
    hulls: HullTable | None = None
    moving: tuple[int, ...] = field(default=(), init=False, compare=False)
    packings: dict[bool, RobotPacking] | None = field(default=None, init=False, compare=False)
    _threads: threading.local = field(default_factory=threading.local, init=False, compare=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "moving", tuple(i for i, j in enumerate(self.geometry_joints) if j != 0))
        if self.hulls is None and self.spheres is not None:
            object.__setattr__(self, "hulls", hull_table(self.geometry.geometryObjects))
        packings = None
        if self.spheres is not None:
            own = RobotPacking(self.spheres, self.model_pairs, self.moving, self.inner_radii)
            packings = {True: own, False: RobotPacking(self.spheres, (), self.moving, self.inner_radii)}
        object.__setattr__(self, "packings", packings)

    def thread_data(self) -> pin.Data:
        """This thread's ``pinocchio.Data`` for the workspaces of every layout of the robot (made on the
        thread's first workspace). Sharing it is sound: every query runs forward kinematics on it and places
        the geometries from it in the same call, and a thread runs one query at a time. One per layout cost
        too much on large robots: a ``Data`` holds nv x nv x nv derivative tensors (about 40 nv**3 bytes,
        44 MB for TIAGo dual's nv = 101, whose 32 cached layouts took 1.4 GB)."""
        data = getattr(self._threads, "data", None)
        if data is None:
            data = self._threads.data = self.model.createData()
        return data


@dataclass(eq=False)
class Workspace:
    """One thread's Pinocchio and coal state of a layout: ``data``, ``geometry_data`` (exact checks:
    security margin 0), the broad-phase ``manager`` (None without pairs), its own ``geometry`` (shares the
    coal shapes; obstacle ``k`` is at the pose of ``placed[k]``; ``held``: the obstacles tuple of the scene
    whose every obstacle is in place, None when only some are) and the bound ``check``
    (:func:`~.configuration_checks.collision_check`; None without pairs) with its tests ``hits(q)`` (every
    pair, :func:`~.configuration_checks.coal_test`) and ``pair_hits(q, pairs)`` (the pairs given,
    :func:`~.configuration_checks.pair_test`), None without pairs."""

    data: pin.Data
    geometry_data: pin.GeometryData
    manager: Any
    geometry: pin.GeometryModel
    held: tuple | None
    placed: list
    check: CoalCheck | None
    hits: Any = None
    pair_hits: Any = None


class MarginWorkspace(NamedTuple):
    """One thread's near-pair query state of a layout for one security margin (:meth:`SceneLayout.
    margin_workspace`): ``geometry_data`` (collision requests with that margin), the broad-phase ``manager``
    (None without pairs) and the pair ``collector`` (``pinocchio.CollisionCallBackCollect``)."""

    geometry_data: pin.GeometryData
    manager: Any
    collector: Any


def exact_requests(requests: Iterable[Any]) -> None:
    """Make these ``coal.CollisionRequest`` (a workspace's exact checks) answer as a fresh request does.

    * ``security_margin = 0``;
    * ``enable_contact = True`` (Pinocchio's ``GeometryData`` turns it off): coal 3's GJK without it reports
      some pairs of hulls free while they overlap by millimetres (13 of 700 000 MotionBenchMaker
      configurations, up to 7.4 mm deep, that a fresh request and ``coal.distance`` find in collision);
    * GJK starts every call from its default guess (:func:`default_gjk_start`): with the cached one a contact
      within a few times GJK's relative tolerance got either answer depending on which configurations were
      checked before (1.5e-5 m of penetration between two Panda hulls).
    """
    requests = list(requests)
    for req in requests:
        req.security_margin = 0.0
        req.enable_contact = True
    default_gjk_start(requests)


def default_gjk_start(requests: Iterable[Any]) -> None:
    """Make these coal requests (collision or distance) start GJK from its default guess every call, not
    from the cached one of the call before, which Pinocchio enables: an answer then depends on the
    configurations asked before (a distance asked twice differed by up to 1.7e-6 m; a contact's verdict
    could flip, :func:`exact_requests`). Both of coal's switches: ``gjk_initial_guess`` and the deprecated
    ``enable_cached_gjk_guess``, which coal 3 still honours on its own."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        for req in requests:
            req.gjk_initial_guess = _DEFAULT_GUESS
            req.enable_cached_gjk_guess = False


def broad_phase_manager_class(n_geometries: int) -> type:
    """The Pinocchio broad-phase manager class for a scene of ``n_geometries`` (see
    :mod:`.collision_scene`)."""
    if n_geometries <= NAIVE_MAX_GEOMETRIES:
        return pin.BroadPhaseManager_NaiveCollisionManager
    return pin.BroadPhaseManager_DynamicAABBTreeCollisionManager


def obstacle_name(k: int, shape: Shape) -> str:
    """Name of obstacle ``k`` in pair names: ``obstacle[k]:<kind>``."""
    return f"obstacle[{k}]:{shape.kind}"


def _scene_geometry(robot: RobotCollisionGeometry, obstacles: tuple, geometries: list, placements: list,
                    self_collision: bool):
    """``(GeometryModel, names, joints, pairs)`` of the robot's geometry plus ``obstacles`` (their coal
    ``geometries``) fixed to the world at ``placements``: the self pairs when ``self_collision``, and every
    moving robot geometry against every obstacle."""
    gm = robot.geometry.copy()
    if not self_collision:
        gm.removeAllCollisionPairs()
    names, joints = list(robot.links), list(robot.geometry_joints)
    pairs = list(robot.model_pairs) if self_collision else []
    for k, shape in enumerate(obstacles):
        name = obstacle_name(k, shape)
        idx = gm.addGeometryObject(pin.GeometryObject(name, 0, 0, placements[k], geometries[k]))
        names.append(name)
        joints.append(0)
        for i in robot.moving:
            gm.addCollisionPair(pin.CollisionPair(i, idx))
            pairs.append((i, idx))
    if len(pairs) != len(gm.collisionPairs):  # pragma: no cover - Pinocchio dropped or reordered a pair
        pairs = [(int(cp.first), int(cp.second)) for cp in gm.collisionPairs]
    return gm, names, joints, pairs


class SceneLayout:
    """Geometry, pairs, names, the sphere pre-check and per-thread workspaces shared by scenes of
    same-shaped obstacles.

    Built by :meth:`CollisionModel.layout` from ``robot`` and the first obstacle set of a signature
    (``obstacles``: validated shapes; kept alive: the layout's geometry objects are their coal geometries).
    """

    def __init__(self, robot: RobotCollisionGeometry, obstacles: tuple, self_collision: bool) -> None:
        self.model = robot.model
        #: The model's ``nq``, a Python int (a new scene reads it without a call into Pinocchio's bindings).
        self.nq: int = robot.model.nq
        self._robot = robot  # its thread_data() serves the workspaces
        self.obstacles = obstacles
        self.self_collision = bool(self_collision)
        #: The coal geometry (the one in :attr:`geometry`) and the ``pinocchio.SE3`` pose of each obstacle of
        #: the layout's first scene.
        self.obstacle_geometries = [shape.geometry() for shape in obstacles]
        self.placements = [shape.placement() for shape in obstacles]
        gm, names, joints, pairs = _scene_geometry(robot, obstacles, self.obstacle_geometries,
                                                   self.placements, self.self_collision)
        self.geometry = gm
        self.n_robot = len(robot.links)
        self.geometry_owner: list[str] = names  #: link name (robot) or obstacle name, per geometry
        self.pairs = np.array(pairs, dtype=int).reshape(-1, 2)
        self.pair_names: list[tuple[str, str]] = [(names[a], names[b]) for a, b in pairs]
        self.pair_joints = np.asarray(joints, dtype=int)[self.pairs].reshape(-1, 2)
        #: The obstacle (index into ``obstacles``) of each pair, -1 for a pair of robot geometries.
        self.pair_obstacle: list[int] = [b - self.n_robot if b >= self.n_robot else -1 for _, b in pairs]
        self.broad_phase = broad_phase_manager_class(gm.ngeoms)
        #: The layout's sphere pre-check (:class:`~.scene_precheck.ScenePrecheck`: the robot's spheres and the
        #: pair table), or None (see the module docstring); also :meth:`precheck`'s answer.
        self.sphere_precheck = self._build_precheck(robot)
        self._threads = threading.local()  # .workspace: Workspace; .margin: {threshold: margin workspace}
        self._threads.workspace = self._new_workspace()

    def _build_precheck(self, robot: RobotCollisionGeometry) -> ScenePrecheck | None:
        if not SPHERE_PRECHECK or robot.spheres is None or not len(self.pairs):
            return None
        from .scene_precheck import ScenePrecheck  # Numba's kernels: loaded with the collision model

        packing = robot.packings[self.self_collision]
        return ScenePrecheck(packing, self.pairs, self.n_robot, len(self.obstacles), robot.hulls)

    def precheck(self) -> ScenePrecheck | None:
        """The layout's sphere pre-check (:class:`~.scene_precheck.ScenePrecheck`: the robot's spheres and the
        pair table), or None (see the module docstring)."""
        return self.sphere_precheck

    def placements_of(self, obstacles: Sequence[Shape]) -> list[pin.SE3]:
        """The ``pinocchio.SE3`` pose of each of ``obstacles`` (the layout's own placement for an obstacle
        that is the layout's own object)."""
        return [self._placement(k, shape) for k, shape in enumerate(obstacles)]

    def placed(self, obstacles: Sequence[Shape], placements: Sequence[pin.SE3] | None = None
               ) -> pin.GeometryModel:
        """A copy of the layout's ``GeometryModel`` with the obstacle objects at ``placements`` (the poses of
        ``obstacles``; None: made from them; the layout's own model when they are its own obstacles)."""
        if obstacles is self.obstacles:
            return self.geometry
        gm = self.geometry.copy()  # shares the coal shapes; the placements are the copy's own
        objects = gm.geometryObjects
        for k, (shape, first) in enumerate(zip(obstacles, self.obstacles)):
            if shape is not first:  # the layout's own obstacles are in place already (shapes are immutable)
                objects[self.n_robot + k].placement = self._placement(k, shape) if placements is None \
                    else placements[k]
        return gm

    def thread_data(self) -> pin.Data:
        """This thread's ``pinocchio.Data`` for forward kinematics right before placing geometries, shared
        by every layout of the robot (:meth:`RobotCollisionGeometry.thread_data`)."""
        return self._robot.thread_data()

    def _new_workspace(self) -> Workspace:
        gm = self.geometry.copy()  # the thread's own placements; shares the coal shapes
        gd = pin.GeometryData(gm)
        exact_requests(gd.collisionRequests)
        default_gjk_start(gd.distanceRequests)
        data = self.thread_data()
        bpm = self.broad_phase(self.model, gm, gd) if len(self.pairs) else None
        check = None if bpm is None else collision_check(self.model, data, gm, gd, bpm)
        placed = list(self.obstacles)
        if check is None:
            return Workspace(data, gd, bpm, gm, self.obstacles, placed, None)
        return Workspace(data, gd, bpm, gm, self.obstacles, placed, check, coal_test(check), pair_test(check))

    def workspace(self, obstacles: tuple, placements: Sequence[pin.SE3] | None = None) -> Workspace:
        """This thread's :class:`Workspace` holding the placements of ``obstacles``; only the obstacles that
        differ from the ones it holds are placed (``placements``: their ``pinocchio.SE3`` poses; None: made
        from the shapes' poses, the layout's own placement for an obstacle that is the layout's own)."""
        ws = getattr(self._threads, "workspace", None)
        if ws is None:  # a thread's first query of this layout
            ws = self._threads.workspace = self._new_workspace()
        if ws.held is not obstacles:
            placed, objects, n = ws.placed, ws.geometry.geometryObjects, self.n_robot
            for k, shape in enumerate(obstacles):
                if placed[k] is not shape:  # shapes are immutable: the same object, the same pose
                    objects[n + k].placement = self._placement(k, shape) if placements is None \
                        else placements[k]
                    placed[k] = shape
            ws.held = obstacles
        return ws

    def pair_workspace(self, obstacles: tuple, pairs: list[int]) -> Workspace:
        """This thread's :class:`Workspace` with the obstacles of the scene pairs ``pairs`` (indices) in
        place - the others may hold another scene's poses - for a coal check of those pairs alone (every
        obstacle when there are more than :data:`~.configuration_checks.PAIRWISE_MAX`: that check runs the
        broad phase). A new scene's first undecided configuration places the one or two obstacles its
        pairs meet, not all."""
        ws = getattr(self._threads, "workspace", None)
        if ws is None or ws.held is obstacles or len(pairs) > PAIRWISE_MAX:
            return self.workspace(obstacles)
        placed, slot = ws.placed, self.pair_obstacle
        for p in pairs:
            k = slot[p]
            if k >= 0 and placed[k] is not obstacles[k]:
                ws.geometry.geometryObjects[self.n_robot + k].placement = self._placement(k, obstacles[k])
                placed[k] = obstacles[k]
                ws.held = None
        return ws

    def _placement(self, k: int, shape: Shape) -> pin.SE3:
        """The ``pinocchio.SE3`` pose of ``shape`` as obstacle ``k`` (the layout's own when it is its own)."""
        return self.placements[k] if shape is self.obstacles[k] else _SE3(shape.pose)

    def margin_workspace(self, threshold: float) -> MarginWorkspace:
        """This thread's :class:`MarginWorkspace` over its workspace's geometry whose collision requests use
        ``security_margin = threshold``, otherwise as :func:`exact_requests` makes them (the manager inflates
        every AABB by half of it; GJK distances to
        :data:`GJK_TOLERANCE`); made on a thread's first query with that threshold. A thread keeps those of
        its last :data:`MARGIN_WORKSPACES` thresholds (a new one replaces the oldest made), so callers that
        vary the threshold do not grow memory without bound.
        Call :meth:`workspace` first: the placements are the workspace's."""
        by_margin = getattr(self._threads, "margin", None)
        if by_margin is None:
            by_margin = self._threads.margin = {}
        entry = by_margin.get(threshold)
        if entry is None:
            if len(by_margin) >= MARGIN_WORKSPACES:  # the oldest goes: memory stays bounded
                del by_margin[next(iter(by_margin))]
            gm = self._threads.workspace.geometry
            gd = pin.GeometryData(gm)
            exact_requests(gd.collisionRequests)  # contacts on, no cached guess: see exact_requests
            for req in gd.collisionRequests:
                req.security_margin = threshold
            default_gjk_start(gd.distanceRequests)
            for req in gd.distanceRequests:  # GJK to 1e-9 m (default 1e-6): smooth enough for step rows
                req.gjk_tolerance = GJK_TOLERANCE
            bpm = self.broad_phase(self.model, gm, gd) if len(self.pairs) else None
            entry = by_margin[threshold] = MarginWorkspace(gd, bpm, pin.CollisionCallBackCollect(gm, gd))
        return entry


__all__ = ["GJK_TOLERANCE", "MARGIN_WORKSPACES", "NAIVE_MAX_GEOMETRIES", "SPHERE_PRECHECK", "MarginWorkspace",
           "RobotCollisionGeometry", "SceneLayout", "Workspace", "broad_phase_manager_class",
           "default_gjk_start", "exact_requests", "obstacle_name"]
