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
  (coal's dynamic AABB tree, ``BroadPhaseManager``): only pairs whose world
  AABBs overlap reach GJK; stops at the first collision. (Not the array form of
  the tree: in coal 3 / pin 4.1 it misses collisions once a third obstacle is
  added - 126 of 1000 Panda configurations in a test; the tests check the
  broad phase against pair-by-pair coal on scenes of 2 to 4 obstacles);
* ``colliding`` - every pair (``computeCollisions`` without early stop);
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
_BroadPhase = pin.BroadPhaseManager_DynamicAABBTreeCollisionManager


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
        moving = [i for i, g in enumerate(gm.geometryObjects) if g.parentJoint != 0]
        for k, shape in enumerate(obstacles):
            name = obstacle_name(k, shape)
            idx = gm.addGeometryObject(pin.GeometryObject(name, 0, 0, shape.placement(), shape.geometry()))
            names.append(name)
            for i in moving:
                gm.addCollisionPair(pin.CollisionPair(i, idx))
        self.geometry = gm
        self.n_robot = n_robot
        self.geometry_owner: list[str] = names  #: link name (robot) or obstacle name, per geometry
        pairs = [(cp.first, cp.second) for cp in gm.collisionPairs]
        self.pairs = np.array(pairs, dtype=int).reshape(-1, 2)
        self.pair_names: list[tuple[str, str]] = [(names[a], names[b]) for a, b in pairs]
        objs = gm.geometryObjects
        #: Pinocchio joint of each pair's two geometries (0 = fixed in the world), shape (P, 2).
        self.pair_joints = np.array([(objs[a].parentJoint, objs[b].parentJoint) for a, b in pairs], dtype=int).reshape(-1, 2)
        self._local = threading.local()

    def __len__(self) -> int:
        return len(self.pairs)

    def workspace(self) -> tuple[pin.Data, pin.GeometryData, Any]:
        """This thread's ``(pinocchio.Data, GeometryData, broad-phase manager)``."""
        ws = getattr(self._local, "ws", None)
        if ws is None:
            data = self.model.createData()
            gd = pin.GeometryData(self.geometry)
            for req in gd.collisionRequests:
                req.security_margin = 0.0
            bpm = _BroadPhase(self.model, self.geometry, gd) if len(self.pairs) else None
            ws = self._local.ws = (data, gd, bpm)
        return ws

    # ----------------------------------------------------------------- queries
    def in_collision(self, q: np.ndarray) -> bool:
        """True when any checked pair intersects at ``q`` (broad phase, stops at the first hit)."""
        data, _gd, bpm = self.workspace()
        if bpm is None:
            return False
        return _compute_collisions(self.model, data, bpm, q, True)

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

    def _margin_data(self, threshold: float):
        """This thread's GeometryData whose collision requests use ``security_margin = threshold``."""
        ws = getattr(self._local, "margin", None)
        if ws is None:
            ws = self._local.margin = {}
        gd = ws.get(threshold)
        if gd is None:
            gd = ws[threshold] = pin.GeometryData(self.geometry)
            for req in gd.collisionRequests:
                req.security_margin = threshold
            for req in gd.distanceRequests:  # GJK to 1e-9 m (default 1e-6): smooth enough for step rows
                req.gjk_tolerance = GJK_TOLERANCE
        return gd

    def near(self, threshold: float, q: np.ndarray | None = None, data: pin.Data | None = None) -> list[int]:
        """Indices of the pairs closer than ``threshold`` (m), at ``q`` or at the placements of ``data``.

        Give ``q`` (forward kinematics runs on this thread's workspace) or a
        ``pinocchio.Data`` whose joint placements ``oMi`` are current. The
        placements stay in place for :meth:`near_distance`.
        """
        gd = self._margin_data(threshold)
        if data is None:
            data = self.workspace()[0]
            pin.forwardKinematics(self.model, data, q)
        pin.updateGeometryPlacements(self.model, data, self.geometry, gd)
        if not len(self.pairs):
            return []
        if not _compute_collisions(self.geometry, gd, True):  # the common case: nothing near, no result to read
            return []
        _compute_collisions(self.geometry, gd, False)
        return [k for k, res in enumerate(gd.collisionResults) if res.isCollision()]

    def near_distance(self, threshold: float, k: int) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
        """``(d, p1, p2, n)`` of pair ``k`` at the placements of the last :meth:`near` call with ``threshold``."""
        res = pin.computeDistance(self.geometry, self._margin_data(threshold), k)
        return res.min_distance, res.getNearestPoint1(), res.getNearestPoint2(), res.normal
