"""``CollisionScene``: a robot's convex geometry plus obstacles fixed in the world, and the queries on it.

One Pinocchio ``GeometryModel`` holds the robot's geometries followed by one
object per obstacle, attached to the universe (joint 0) at the obstacle's pose.
Checked pairs: the robot's self pairs (:mod:`.collision_pairs`) when
``self_collision``, and every moving robot geometry against every obstacle.
Geometries of the fixed base (on joint 0) are not paired with obstacles: no
configuration can change that answer, and a base that touches its mounting
surface (the Panda's base mesh reaches 0.03 mm below its mounting plane) would
otherwise put every configuration in collision.

Queries are single Pinocchio calls over all pairs:

* ``in_collision`` - ``pinocchio.computeCollisions`` through a broad phase
  (``pinocchio.BroadPhaseManager``): every geometry gets its world AABB, only
  checked pairs whose AABBs overlap reach GJK, and the call stops at the first
  collision. All of it - forward kinematics, placements, AABBs, GJK - is one
  C++ call. The manager is coal's *naive* one (every AABB against every other,
  no tree) up to :data:`NAIVE_MAX_GEOMETRIES` geometries and the dynamic AABB
  tree above: on the Panda with a table and a wall (19 geometries, 76 pairs)
  the naive manager takes 4.8 µs per check against 12.2 µs for the tree, whose
  refit costs more than the 171 AABB tests it saves; the tree wins from about
  120 geometries on. (Never the array form of the tree: in coal 3 / pin 4.1 it
  misses collisions once a third obstacle is added - 126 of 1000 Panda
  configurations in a test; the tests check the broad phase against
  pair-by-pair coal on scenes of 2 to 4 obstacles and on obstacles placed at
  the arm's surface.)
* ``colliding`` - every pair (``computeCollisions`` without early stop);
* ``near`` - the pairs closer than a threshold (the IK's rows): the same
  broad phase with AABBs inflated by the threshold collects the candidate
  pairs, GJK with that security margin decides on them only;
* ``distance_arrays`` - ``pinocchio.computeDistances``: per pair the signed
  distance ``d`` (m, negative = penetration depth), the witness points ``p1`` on
  the first and ``p2`` on the second geometry (world, m) and the unit normal
  ``n`` from the first towards the second (``p2 - p1 = d n``).

Each thread gets its own ``pinocchio.Data``, ``GeometryData`` and broad-phase
manager (``threading.local``), so a scene - like a ``Robot`` - may be shared
between threads.
"""

from __future__ import annotations

import threading
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

#: GJK tolerance (m) of the near-pair distances used by the IK rows (coal's default is 1e-6).
GJK_TOLERANCE = 1e-9

if TYPE_CHECKING:
    from .collision_model import CollisionModel
    from .shapes import Shape

_compute_collisions = pin.computeCollisions
_compute_collision = pin.computeCollision

#: Largest number of geometries (robot + obstacles) checked by coal's naive broad phase; more use the AABB tree.
NAIVE_MAX_GEOMETRIES = 96


def broad_phase_manager_class(n_geometries: int) -> type:
    """The Pinocchio broad-phase manager class for a scene of ``n_geometries`` (see the module docstring)."""
    if n_geometries <= NAIVE_MAX_GEOMETRIES:
        return pin.BroadPhaseManager_NaiveCollisionManager
    return pin.BroadPhaseManager_DynamicAABBTreeCollisionManager


#: Whether Pinocchio's fresh ``GeometryData`` requests have ``security_margin == 0`` (learnt on the first one).
_FRESH_MARGINS_ZERO: list[bool] = []


def _zero_security_margins(gd: pin.GeometryData) -> None:
    """Set every collision request of a fresh ``gd`` to ``security_margin = 0`` (the exact check).

    Pinocchio builds them with coal's default, 0: the first ``GeometryData`` is checked request by
    request, later ones are left as built when that held (the loop over the requests costs ~20 µs
    on the Panda's scenes, a sixth of building a workspace).
    """
    if _FRESH_MARGINS_ZERO and _FRESH_MARGINS_ZERO[0]:
        return
    zero = all(req.security_margin == 0.0 for req in gd.collisionRequests)
    for req in gd.collisionRequests:
        req.security_margin = 0.0
    if not _FRESH_MARGINS_ZERO:
        _FRESH_MARGINS_ZERO.append(zero)


def obstacle_name(k: int, shape: "Shape") -> str:
    """Name of obstacle ``k`` in pair names: ``obstacle[k]:<kind>``."""
    return f"obstacle[{k}]:{shape.kind}"


class CollisionScene:
    """Robot geometry + obstacles; see the module docstring. Built by :meth:`CollisionModel.scene`."""

    def __init__(self, cmodel: "CollisionModel", obstacles: tuple, self_collision: bool = True) -> None:
        self.model = cmodel.model
        self.obstacles = obstacles
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
            idx = gm.addGeometryObject(pin.GeometryObject(name, 0, 0, shape.placement(), shape.geometry()))
            names.append(name)
            joints.append(0)
            for i in moving:
                gm.addCollisionPair(pin.CollisionPair(i, idx))
                pairs.append((i, idx))
        if len(pairs) != len(gm.collisionPairs):  # pragma: no cover - Pinocchio dropped or reordered a pair
            pairs = [(int(cp.first), int(cp.second)) for cp in gm.collisionPairs]
        self.geometry = gm
        self.n_robot = n_robot
        self.geometry_owner: list[str] = names  #: link name (robot) or obstacle name, per geometry
        self.pairs = np.array(pairs, dtype=int).reshape(-1, 2)
        self.pair_names: list[tuple[str, str]] = [(names[a], names[b]) for a, b in pairs]
        #: Pinocchio joint of each pair's two geometries (0 = fixed in the world), shape (P, 2).
        self.pair_joints = np.asarray(joints, dtype=int)[self.pairs].reshape(-1, 2)
        self._broad_phase = broad_phase_manager_class(gm.ngeoms)
        self._local = threading.local()

    def __len__(self) -> int:
        return len(self.pairs)

    def workspace(self) -> tuple[pin.Data, pin.GeometryData, Any]:
        """This thread's ``(pinocchio.Data, GeometryData, broad-phase manager)``."""
        ws = getattr(self._local, "ws", None)
        if ws is None:
            data = self.model.createData()
            gd = pin.GeometryData(self.geometry)
            _zero_security_margins(gd)
            bpm = self._broad_phase(self.model, self.geometry, gd) if len(self.pairs) else None
            ws = self._local.ws = (data, gd, bpm)
        return ws

    # ----------------------------------------------------------------- queries
    def in_collision(self, q: np.ndarray) -> bool:
        """True when any checked pair intersects at ``q`` (broad phase, stops at the first hit)."""
        ws = getattr(self._local, "ws", None) or self.workspace()
        bpm = ws[2]
        return False if bpm is None else _compute_collisions(self.model, ws[0], bpm, q, True)

    def colliding(self, q: np.ndarray) -> list[int]:
        """Indices (into :attr:`pairs`) of every intersecting pair at ``q``."""
        data, gd, _bpm = self.workspace()
        if not len(self.pairs):
            return []
        _compute_collisions(self.model, data, self.geometry, gd, q, False)
        return [k for k, res in enumerate(gd.collisionResults) if res.isCollision()]

    def distance_arrays(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(d, p1, p2, n)`` of every pair at ``q``: shapes ``(P,)``, ``(P, 3)``, ``(P, 3)``, ``(P, 3)``."""
        data, gd, _bpm = self.workspace()
        P = len(self.pairs)
        d = np.empty(P)
        p1, p2, n = np.empty((P, 3)), np.empty((P, 3)), np.empty((P, 3))
        if not P:
            return d, p1, p2, n
        pin.computeDistances(self.model, data, self.geometry, gd, q)
        for k, res in enumerate(gd.distanceResults):
            d[k] = res.min_distance
            p1[k] = res.getNearestPoint1()
            p2[k] = res.getNearestPoint2()
            n[k] = res.normal
        return d, p1, p2, n

    def min_distance(self, q: np.ndarray) -> tuple[float, int]:
        """``(d, k)``: the smallest signed distance (m) at ``q`` and its pair index (``(inf, -1)`` without pairs).

        One ``pinocchio.computeDistances`` (it returns the index of the closest pair); no per-pair reading.
        """
        if not len(self.pairs):
            return float("inf"), -1
        data, gd, _bpm = self.workspace()
        k = pin.computeDistances(self.model, data, self.geometry, gd, q)
        return float(gd.distanceResults[k].min_distance), int(k)

    def _margin_workspace(self, threshold: float) -> tuple[pin.GeometryData, Any, Any]:
        """This thread's ``(GeometryData, broad-phase manager, pair collector)`` whose collision requests use
        ``security_margin = threshold`` (the manager inflates every AABB by half of it)."""
        ws = getattr(self._local, "margin", None)
        if ws is None:
            ws = self._local.margin = {}
        entry = ws.get(threshold)
        if entry is None:
            gd = pin.GeometryData(self.geometry)
            for req in gd.collisionRequests:
                req.security_margin = threshold
            for req in gd.distanceRequests:  # GJK to 1e-9 m (default 1e-6): smooth enough for step rows
                req.gjk_tolerance = GJK_TOLERANCE
            bpm = self._broad_phase(self.model, self.geometry, gd) if len(self.pairs) else None
            entry = ws[threshold] = (gd, bpm, pin.CollisionCallBackCollect(self.geometry, gd))
        return entry

    def _margin_data(self, threshold: float) -> pin.GeometryData:
        """This thread's GeometryData whose collision requests use ``security_margin = threshold``."""
        return self._margin_workspace(threshold)[0]

    def near(self, threshold: float, q: np.ndarray | None = None, data: pin.Data | None = None) -> list[int]:
        """Indices of the pairs closer than ``threshold`` (m), at ``q`` or at the placements of ``data``.

        Give ``q`` (forward kinematics runs on this thread's workspace) or a
        ``pinocchio.Data`` whose joint placements ``oMi`` are current. The
        placements stay in place for :meth:`near_distance`.

        Broad phase first: the candidates are the checked pairs whose world
        AABBs, each inflated by ``threshold / 2``, overlap (``CollisionCallBackCollect``;
        two shapes closer than ``threshold`` always qualify, since an AABB gap is
        never larger than the shapes' distance); GJK with the security margin then
        runs on the candidates only. Same pairs as GJK on every pair, a third of
        the time on the Panda with three boxes and a 5 cm threshold (20 against
        60 µs).
        """
        gd, bpm, collect = self._margin_workspace(threshold)
        if data is None:
            data = self.workspace()[0]
            pin.forwardKinematics(self.model, data, q)
        pin.updateGeometryPlacements(self.model, data, self.geometry, gd)
        if bpm is None:
            return []
        bpm.update(False)
        _compute_collisions(bpm, collect)
        geometry = self.geometry
        return [k for k in sorted(collect.pair_indexes) if _compute_collision(geometry, gd, k)]

    def near_distance(self, threshold: float, k: int) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
        """``(d, p1, p2, n)`` of pair ``k`` at the placements of the last :meth:`near` call with ``threshold``."""
        res = pin.computeDistance(self.geometry, self._margin_data(threshold), k)
        return res.min_distance, res.getNearestPoint1(), res.getNearestPoint2(), res.normal
