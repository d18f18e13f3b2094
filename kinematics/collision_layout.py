"""``SceneLayout``: what the collision scenes of one robot with obstacles of the same *shapes* share.

Two obstacle sets whose shapes differ only by their poses (a 10 cm cube moved
from one place to another, a table and a wall given again) give scenes with the
same geometry objects, the same checked pairs, the same pair names and the same
per-pair narrow-phase functors; only the placements of the obstacle objects
differ. A layout holds all of that once:

* the Pinocchio ``GeometryModel`` (robot geometry, then one object per obstacle
  fixed to the universe, joint 0), the pair table and the names;
* per thread, a **shell** (:meth:`SceneLayout.shell`): a copy of that
  ``GeometryModel``, the ``pinocchio.Data``, the ``GeometryData`` (collision
  requests with ``security_margin = 0``) and the broad-phase manager over them,
  plus one ``GeometryData`` / manager per security margin for the near-pair
  queries, and which obstacles the shell's placements currently hold.
  A query of a scene first makes the shell hold that scene's obstacles: the
  placements of the obstacles that differ are set (~2 us each), nothing else.

A scene of an existing layout therefore allocates nothing in Pinocchio or coal
(building a ``GeometryData`` costs ~30 us on the Panda's scenes, a ``Data``
~14 us, a broad-phase manager ~5 us, and freeing them again when the scene
cache drops the scene about as much). Sharing is sound because every query
recomputes the world placements it reads (``oMg``) from the shell's
``GeometryModel``; the per-pair narrow-phase functors refer to the layout's
geometry objects, whose shapes equal every scene's (same
:func:`shape_signature`); and a thread runs one query at a time.

The **signature** of an obstacle is its kind and sizes (``Sphere``: radius;
``Box``: edges; ``Capsule``, ``Cylinder``: radius and length); a ``Mesh`` (or any
other shape) is its own signature (by identity: its file may change).
"""

from __future__ import annotations

from collections.abc import Iterable
import threading
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

if TYPE_CHECKING:
    from .collision_model import CollisionModel
    from .shapes import Shape

#: Layouts built while this is True get the sphere pre-check of :mod:`.collision_spheres` (False: coal alone, e.g.
#: to compare the two; read when a layout builds its pre-check).
SPHERE_PRECHECK = True
#: ``in_collision`` calls a layout answers with coal alone before it builds its pre-check (``first_collision``
#: builds it at once): the first checks of a process - e.g. the start checks of its first IK solve, inside that
#: solve's time budget - do not wait for Numba's import and the robot's spheres (~0.1-1 s, once per process).
PRECHECK_AFTER = 32

#: Largest number of geometries (robot + obstacles) checked by coal's naive broad phase; more use the AABB tree.
NAIVE_MAX_GEOMETRIES = 96

#: Whether Pinocchio's fresh ``GeometryData`` requests have ``security_margin == 0`` (learnt on the first one).
_FRESH_MARGINS_ZERO: list[bool] = []


def broad_phase_manager_class(n_geometries: int) -> type:
    """The Pinocchio broad-phase manager class for a scene of ``n_geometries`` (see :mod:`.collision_scene`)."""
    if n_geometries <= NAIVE_MAX_GEOMETRIES:
        return pin.BroadPhaseManager_NaiveCollisionManager
    return pin.BroadPhaseManager_DynamicAABBTreeCollisionManager


def _zero_security_margins(gd: pin.GeometryData) -> None:
    """Set every collision request of a fresh ``gd`` to ``security_margin = 0`` (the exact check).

    Pinocchio builds them with coal's default, 0: the first ``GeometryData`` is checked request by
    request, later ones are left as built when that held.
    """
    if _FRESH_MARGINS_ZERO and _FRESH_MARGINS_ZERO[0]:
        return
    zero = all(req.security_margin == 0.0 for req in gd.collisionRequests)
    for req in gd.collisionRequests:
        req.security_margin = 0.0
    if not _FRESH_MARGINS_ZERO:
        _FRESH_MARGINS_ZERO.append(zero)


_UNBUILT = object()  #: marks a pre-check not built yet (None means: none possible)

#: GJK tolerance (m) of the near-pair distances used by the IK rows (coal's default is 1e-6).
GJK_TOLERANCE = 1e-9


def shape_signature(shape: "Shape") -> tuple:
    """What makes two obstacles interchangeable up to their pose (see the module docstring)."""
    kind = shape.kind
    if kind == "box":
        return ("box", shape.size)
    if kind == "sphere":
        return ("sphere", shape.radius)
    if kind == "capsule":
        return ("capsule", shape.radius, shape.length)
    if kind == "cylinder":
        return ("cylinder", shape.radius, shape.length)
    return (kind, id(shape))  # meshes and unknown kinds: this very object (the layout keeps it alive)


def obstacle_name(k: int, shape: "Shape") -> str:
    """Name of obstacle ``k`` in pair names: ``obstacle[k]:<kind>``."""
    return f"obstacle[{k}]:{shape.kind}"


def collision_check(model: pin.Model, data: pin.Data, gm: pin.GeometryModel, gd: pin.GeometryData,
                    bpm: Any) -> tuple:
    """The pieces of one broad-phase collision check, bound once: ``(model, data, gm, gd, bpm.update,
    bpm.collide, callback)``; see :func:`check_configurations`.

    Same answer as ``pinocchio.computeCollisions(model, data, bpm, q, True)`` (which runs these four steps
    in C++), for a quarter fewer instructions: that call resolves among Pinocchio's 50 overloads of
    ``computeCollisions`` on every call (boost.python compares the type names of the arguments of each
    candidate, ~13k instructions of the ~45k of one Panda check); the member calls here have 1 to 3
    overloads each. The callback (``CollisionCallBackDefault``, stop at the first collision) is reset
    by the manager at the start of every ``collide``.
    """
    return (model, data, gm, gd, bpm.update, bpm.collide, pin.CollisionCallBackDefault(gm, gd, True))


_forward_kinematics = pin.forwardKinematics
_update_placements = pin.updateGeometryPlacements


def check_configurations(check: tuple, qs: Iterable[np.ndarray], precheck: tuple | None = None,
                         uncertified: int | None = None) -> int:
    """Index of the first configuration of ``qs`` (an iterable of ``(nq,)`` float arrays, taken in order)
    in collision, or -1: per configuration forward kinematics, geometry placements, world AABBs, then
    broad and narrow phase, stopping at the first colliding pair (``check`` from :func:`collision_check`).

    With ``precheck`` (:meth:`.collision_spheres.ScenePrecheck.arguments` of the scene), the sphere
    pre-check runs first and coal only on the configurations it cannot certify free, in order: a stacked
    ``(K, nq)`` float array in one compiled call; otherwise the first configuration alone (the IK checks
    its answer first, the likeliest to collide: when it does, no array is built), then the rest in one
    compiled call
    (:func:`.collision_spheres.first_uncertified`, resumed after an uncertified configuration coal finds
    free). An uncertified configuration goes to :func:`.collision_spheres.certainly_colliding` first (a point
    inside the robot deep in an obstacle: in collision, no coal). The same answer as coal alone, since a
    certified configuration is one coal finds free and a certain one is one coal finds in collision.
    ``uncertified``: for stacked rows, the first row the pre-check cannot certify when the caller has found it
    already (the rows before it are certified).
    """
    model, data, gm, gd, update, collide, callback = check
    fk, place = _forward_kinematics, _update_placements

    def coal_hits(q) -> bool:  # coal: forward kinematics, placements, broad phase, narrow phase
        fk(model, data, q)
        place(model, data, gm, gd)
        update(False)
        return collide(callback)

    if precheck is None:
        return next((k for k, q in enumerate(qs) if coal_hits(q)), -1)
    one, first, floats, ints, tol, certain = precheck

    def hits(q) -> bool:  # an inner point deep in an obstacle answers without coal
        try:
            if certain(floats, ints, q, tol):
                return True
        except TypeError:  # not a float vector: coal decides (and raises as before)
            pass
        return coal_hits(q)

    if type(qs) is np.ndarray and qs.ndim == 2 and qs.dtype == np.float64:  # rows already stacked: one call
        k = first(floats, ints, qs, 0, tol) if uncertified is None else uncertified
        return _first_hit_after_precheck(hits, first, floats, ints, tol, qs, qs, k)
    qs = qs if isinstance(qs, (list, tuple, np.ndarray)) else list(qs)
    N = len(qs)
    if not N:
        return -1
    try:
        clear = one(floats, ints, qs[0], tol)
    except TypeError:  # not a float vector: coal decides (and raises as before)
        clear = False
    if not clear and hits(qs[0]):
        return 0
    if N == 1:
        return -1
    try:
        Q = np.asarray(qs, dtype=float)
    except (TypeError, ValueError):  # not configurations of one size: coal decides (and raises)
        Q = None
    if Q is not None and Q.ndim == 2:
        return _first_hit_after_precheck(hits, first, floats, ints, tol, Q, qs, first(floats, ints, Q, 1, tol))
    return next((k for k in range(1, N) if hits(qs[k])), -1)


def _first_hit_after_precheck(hits, first, floats, ints, tol, Q: np.ndarray, qs, k: int) -> int:
    """The first row of ``Q`` from ``k`` (the first row the compiled pre-check ``first`` cannot certify, ``N``
    when none) on that coal finds in collision, coal running only on the rows ``first`` cannot certify
    (``qs[k]`` is the configuration handed to coal)."""
    N = Q.shape[0]
    while k < N:
        if hits(qs[k]):
            return k
        k = first(floats, ints, Q, k + 1, tol)
    return -1


class SceneLayout:
    """Geometry, pairs, names and per-thread workspaces shared by scenes of same-shaped obstacles.

    Built by :meth:`CollisionModel.layout` from the first obstacle set of a signature (kept alive:
    the layout's geometry objects are its shapes).
    """

    def __init__(self, cmodel: "CollisionModel", obstacles: tuple, self_collision: bool) -> None:
        self.model = cmodel.model
        self.obstacles = obstacles
        #: The coal geometry and the ``pinocchio.SE3`` pose of each obstacle of the layout's first scene.
        self.obstacle_geometries = [shape.geometry() for shape in obstacles]
        self.placements = [shape.placement() for shape in obstacles]
        gm = cmodel.geometry.copy()
        if not self_collision:
            gm.removeAllCollisionPairs()
        n_robot = gm.ngeoms
        names = list(cmodel.links)
        joints = list(cmodel.geometry_joints)
        moving = [i for i, j in enumerate(joints) if j != 0]
        pairs = list(cmodel.model_pairs) if self_collision else []
        for k, shape in enumerate(obstacles):
            name = obstacle_name(k, shape)
            idx = gm.addGeometryObject(pin.GeometryObject(name, 0, 0, self.placements[k], self.obstacle_geometries[k]))
            names.append(name)
            joints.append(0)
            for i in moving:
                gm.addCollisionPair(pin.CollisionPair(i, idx))
                pairs.append((i, idx))
        if len(pairs) != len(gm.collisionPairs):  # pragma: no cover - Pinocchio dropped or reordered a pair
            pairs = [(int(cp.first), int(cp.second)) for cp in gm.collisionPairs]
        self.geometry = gm
        self.n_robot = n_robot
        self.geometry_owner: list[str] = names
        self.pairs = np.array(pairs, dtype=int).reshape(-1, 2)
        self.pair_names: list[tuple[str, str]] = [(names[a], names[b]) for a, b in pairs]
        self.pair_joints = np.asarray(joints, dtype=int)[self.pairs].reshape(-1, 2)
        self.broad_phase = broad_phase_manager_class(gm.ngeoms)
        self._local = threading.local()
        self._cmodel = cmodel
        self._precheck: Any = _UNBUILT
        self.coal_checks = 0  #: ``in_collision`` calls answered by coal alone before the pre-check was built

    def precheck_due(self) -> bool:
        """Whether an ``in_collision`` call should build the pre-check now (:data:`PRECHECK_AFTER`); counts it."""
        if self._precheck is not _UNBUILT:
            return True
        self.coal_checks += 1
        return self.coal_checks > PRECHECK_AFTER

    def precheck(self) -> Any:
        """The layout's sphere pre-check (:class:`.collision_spheres.ScenePrecheck`: the robot's spheres and
        the pair table; built on first use), or None when the robot's tree or geometry has no sphere
        packing (:func:`.collision_spheres.robot_spheres`), the layout has no pairs, Numba is missing or
        :data:`SPHERE_PRECHECK` is off."""
        pre = self._precheck
        if pre is _UNBUILT:
            pre = None
            if SPHERE_PRECHECK and len(self.pairs):
                try:
                    from . import collision_spheres
                except ImportError:  # pragma: no cover - Numba is a dependency; without it coal alone decides
                    collision_spheres = None
                robot = None if collision_spheres is None else collision_spheres.robot_spheres_of(self._cmodel)
                if robot is not None:
                    pre = collision_spheres.ScenePrecheck(robot, self.pairs, self.n_robot, self.obstacle_geometries,
                                                          self.obstacles)
            self._precheck = pre
        return pre

    def placed(self, obstacles: tuple) -> pin.GeometryModel:
        """A copy of the layout's ``GeometryModel`` with the obstacle objects at the poses of ``obstacles``."""
        if obstacles is self.obstacles:
            return self.geometry
        gm = self.geometry.copy()  # shares the coal shapes; the placements are the copy's own
        objects = gm.geometryObjects
        for k, (shape, first) in enumerate(zip(obstacles, self.obstacles), start=self.n_robot):
            if shape is not first:  # the layout's own obstacle objects are in place already (shapes are immutable)
                objects[k].placement = shape.placement()
        return gm

    def shell(self, obstacles: tuple, placements: list) -> list:
        """This thread's shell ``[Data, GeometryData, broad-phase manager or None, GeometryModel, obstacles,
        check]`` with the obstacle placements of ``obstacles`` (``placements``: their ``pinocchio.SE3`` poses);
        ``check`` is :func:`collision_check` over the shell (None without pairs)."""
        ws = getattr(self._local, "shell", None)
        if ws is None:
            gm = self.geometry.copy()  # the thread's own placements; shares the coal shapes
            gd = pin.GeometryData(gm)
            _zero_security_margins(gd)
            data = self.model.createData()
            bpm = self.broad_phase(self.model, gm, gd) if len(self.pairs) else None
            check = None if bpm is None else collision_check(self.model, data, gm, gd, bpm)
            ws = self._local.shell = [data, gd, bpm, gm, self.obstacles, check]
        held = ws[4]
        if held is not obstacles:
            objects = ws[3].geometryObjects
            for k, (now, shape) in enumerate(zip(held, obstacles)):
                if now is not shape:  # shapes are immutable: the same object, the same pose
                    objects[self.n_robot + k].placement = placements[k]
            ws[4] = obstacles
        return ws

    def margin_workspace(self, threshold: float) -> tuple[pin.GeometryData, Any, Any]:
        """This thread's ``(GeometryData, broad-phase manager, pair collector)`` over the shell's geometry whose
        collision requests use ``security_margin = threshold`` (the manager inflates every AABB by half of it;
        GJK distances to :data:`GJK_TOLERANCE`). Call :meth:`shell` first: the placements are the shell's."""
        by_margin = getattr(self._local, "margin", None)
        if by_margin is None:
            by_margin = self._local.margin = {}
        entry = by_margin.get(threshold)
        if entry is None:
            gm = self._local.shell[3]
            gd = pin.GeometryData(gm)
            for req in gd.collisionRequests:
                req.security_margin = threshold
            for req in gd.distanceRequests:  # GJK to 1e-9 m (default 1e-6): smooth enough for step rows
                req.gjk_tolerance = GJK_TOLERANCE
            bpm = self.broad_phase(self.model, gm, gd) if len(self.pairs) else None
            entry = by_margin[threshold] = (gd, bpm, pin.CollisionCallBackCollect(gm, gd))
        return entry
