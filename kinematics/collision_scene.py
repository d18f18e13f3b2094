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

* ``in_collision`` / ``first_collision`` start with the **sphere pre-check**
  (:mod:`.collision_spheres`, compiled): spheres fixed in the joint frames that
  contain every robot geometry, moved by the forward kinematics of the whole
  tree, against each other and against the obstacles' exact point distances
  give a lower bound of every checked pair's distance; a configuration whose
  bounds all exceed 10 um is certified free and never reaches coal (the same
  answer: a certified configuration is one coal finds free); one it cannot certify
  but with a point inside the robot deep in an obstacle is in collision without
  coal (:func:`.collision_spheres.certainly_colliding`). ``first_collision``
  certifies stacked rows (the IK's runs) in one compiled call (a sequence: its
  first configuration alone - the IK's answer, the likeliest to collide - then
  the rest in one call) and runs coal on the ones the pre-check cannot decide,
  in order. On the Panda with the table and wall
  it certifies 92 % of the collision-free random configurations; a certified
  ``in_collision`` costs ~1.5 us instead of ~4 us, an uncertified one ~1.3 us more
  than coal alone. Built per layout (robot spheres, pair table; the robot's spheres
  once per collision model) and per scene (obstacle poses, ~5 us) by the first
  ``first_collision`` or after a layout's first 32 ``in_collision`` calls (a
  process's first checks do not wait for Numba's import);
  robots whose tree has other joints than one-DoF revolute / prismatic ones keep
  coal alone (:meth:`CollisionScene.precheck` returns None);
* ``in_collision`` (coal) - ``pinocchio.computeCollisions`` through a broad phase
  (``pinocchio.BroadPhaseManager``): every geometry gets its world AABB, only
  checked pairs whose AABBs overlap reach GJK, and the call stops at the first
  collision. Four C++ calls bound once per thread (forward kinematics,
  placements, ``BroadPhaseManager.update``, ``collide`` with a reused
  callback; :func:`.collision_layout.collision_check`): the same answer as
  ``pinocchio.computeCollisions(model, data, manager, q, True)`` without its
  50-overload dispatch (32k instead of 43k instructions per Panda check);
  :meth:`CollisionScene.first_collision` loops over the configurations the pre-check leaves. The manager is coal's
  *naive* one (every AABB against every other,
  no tree) up to :data:`.collision_layout.NAIVE_MAX_GEOMETRIES` geometries and the dynamic AABB
  tree above: on the Panda with a table and a wall (19 geometries, 76 pairs)
  the naive manager takes 4.8 µs per check against 12.2 µs for the tree, whose
  refit costs more than the 171 AABB tests it saves; the tree wins from about
  120 geometries on. (Never the array form of the tree: in coal 3 / pin 4.1 it
  misses collisions once a third obstacle is added - 126 of 1000 Panda
  configurations in a test; the tests check the broad phase against
  pair-by-pair coal on scenes of 2 to 4 obstacles and on obstacles placed at
  the arm's surface.)
* ``colliding`` - every pair (``computeCollisions`` without early stop; no pre-check, nor in the queries
  below, which need pairs, distances or a security margin);
* ``near`` - the pairs closer than a threshold (the IK's rows): the same
  broad phase with AABBs inflated by the threshold collects the candidate
  pairs, GJK with that security margin decides on them only;
* ``distance_arrays`` - ``pinocchio.computeDistances``: per pair the signed
  distance ``d`` (m, negative = penetration depth), the witness points ``p1`` on
  the first and ``p2`` on the second geometry (world, m) and the unit normal
  ``n`` from the first towards the second (``p2 - p1 = d n``).

Each thread gets its own ``pinocchio.Data``, ``GeometryData`` and broad-phase
manager (``threading.local``), so a scene - like a ``Robot`` - may be shared
between threads. The geometry layout, the pair table and the per-thread
workspaces belong to a :class:`~.collision_layout.SceneLayout` shared by every
scene whose obstacles have the same shapes (poses aside); a scene holds its
obstacles and their placements, which a query puts into its thread's workspace
when another scene of the layout used it last. A new scene of a known layout
costs a few microseconds (~190 us for a scene built from nothing on the Panda).
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from .collision_layout import _UNBUILT, SceneLayout, _forward_kinematics, _update_placements, check_configurations

if TYPE_CHECKING:
    from .collision_model import CollisionModel

_compute_collisions = pin.computeCollisions
_compute_collision = pin.computeCollision


class CollisionScene:
    """Robot geometry + obstacles; see the module docstring. Built by :meth:`CollisionModel.scene`.

    ``layout`` (default: the model's layout for these obstacles' shapes) supplies the geometry
    objects, pairs, names and per-thread workspaces; the scene owns the obstacle placements.
    """

    def __init__(self, cmodel: "CollisionModel", obstacles: tuple, self_collision: bool = True,
                 layout: SceneLayout | None = None) -> None:
        if layout is None:
            layout = cmodel.layout(obstacles, self_collision)
        self.layout = layout
        self.model = layout.model
        self.obstacles = obstacles
        self.n_robot = layout.n_robot
        self.geometry_owner: list[str] = layout.geometry_owner  #: link name (robot) or obstacle name, per geometry
        self.pairs = layout.pairs
        self.pair_names: list[tuple[str, str]] = layout.pair_names
        #: Pinocchio joint of each pair's two geometries (0 = fixed in the world), shape (P, 2).
        self.pair_joints = layout.pair_joints
        self._local = layout._local  # the layout's per-thread state: its shell says whose obstacles it holds
        self._precheck: Any = _UNBUILT  # the sphere pre-check's arguments with these obstacle poses (first query)

    @cached_property
    def placements(self) -> list[pin.SE3]:
        """The ``pinocchio.SE3`` pose of each obstacle (the layout's own when the obstacle is the layout's);
        made when coal first needs them (a scene the sphere pre-check answers for never does)."""
        layout = self.layout
        return [placed if shape is first else shape.placement()
                for shape, first, placed in zip(self.obstacles, layout.obstacles, layout.placements)]

    def __len__(self) -> int:
        return len(self.pairs)

    @property
    def geometry(self) -> pin.GeometryModel:
        """The scene's ``GeometryModel``: robot geometry, then the obstacles at their poses (built on first use;
        the queries run on the thread's workspace)."""
        gm = self.__dict__.get("_geometry")
        if gm is None:
            gm = self._geometry = self.layout.placed(self.obstacles)
        return gm

    def workspace(self) -> tuple[pin.Data, pin.GeometryData, Any]:
        """This thread's ``(pinocchio.Data, GeometryData, broad-phase manager)``, holding this scene's obstacles
        (shared with the other scenes of the layout)."""
        return tuple(self._shell()[:3])

    def _shell(self) -> list:
        """This thread's shell of the layout with this scene's obstacles in place (:meth:`SceneLayout.shell`)."""
        ws = getattr(self._local, "shell", None)
        if ws is None or ws[4] is not self.obstacles:
            ws = self.layout.shell(self.obstacles, self.placements)
        return ws

    def precheck(self) -> tuple | None:
        """The arguments of the compiled sphere pre-check with this scene's obstacle poses
        (:meth:`.collision_spheres.ScenePrecheck.arguments`; built on first use), or None when the layout
        has none (:meth:`.collision_layout.SceneLayout.precheck`)."""
        pre = self._precheck
        if pre is _UNBUILT:
            layout_check = self.layout.precheck()
            pre = None if layout_check is None else layout_check.arguments(self.obstacles)
            self._precheck = pre
        return pre

    # ----------------------------------------------------------------- queries
    def in_collision(self, q: np.ndarray) -> bool:
        """True when any checked pair intersects at ``q`` (broad phase, stops at the first hit).

        ``q``: a float ``(nq,)`` array (unchecked). The sphere pre-check first (:meth:`precheck`; built
        after the layout's first :data:`~.collision_layout.PRECHECK_AFTER` calls, or by
        :meth:`first_collision`): a configuration it certifies is free without coal; otherwise
        :func:`~.collision_layout.check_configurations` on one configuration, its steps inlined.
        """
        pre = self._precheck
        if pre is _UNBUILT:
            pre = self.precheck() if self.layout.precheck_due() else None
        if pre is not None:
            try:
                if pre[0](pre[2], pre[3], q, pre[4]):
                    return False
                if pre[5](pre[2], pre[3], q, pre[4]):  # a point inside the robot deep in an obstacle
                    return True
            except TypeError:  # not a float vector: coal decides (and raises as before)
                pass
        ws = getattr(self._local, "shell", None)
        if ws is None or ws[4] is not self.obstacles:
            ws = self.layout.shell(self.obstacles, self.placements)
        check = ws[5]
        if check is None:
            return False
        model, data, gm, gd, update, collide, callback = check
        _forward_kinematics(model, data, q)
        _update_placements(model, data, gm, gd)
        update(False)
        return collide(callback)

    def first_collision(self, qs: Sequence[np.ndarray], uncertified: int | None = None) -> int:
        """Index of the first configuration of ``qs`` (float ``(nq,)`` arrays, checked in the given order)
        in collision, -1 when none is: the sphere pre-check (rows stacked in a float ``(N, nq)`` array in one
        compiled call; a sequence: the first configuration alone, the rest in one call), and
        :meth:`in_collision`'s coal check of each uncertified one, in order, stopping at the first hit
        (:func:`~.collision_layout.check_configurations`). ``uncertified``: for stacked rows, the index the
        caller's own pre-check call returned (the rows before it are certified; not certified again)."""
        pre = self._precheck
        if pre is _UNBUILT:
            pre = self.precheck()
        if pre is not None and type(qs) is np.ndarray and qs.ndim == 2 and qs.dtype == np.float64:
            # stacked rows (the IK's runs): one compiled call; coal only from the first uncertified row on
            k = pre[1](pre[2], pre[3], qs, 0, pre[4]) if uncertified is None else uncertified
            if k >= qs.shape[0]:
                return -1
            check = self._shell()[5]
            return -1 if check is None else check_configurations(check, qs, pre, uncertified=k)
        check = self._shell()[5]
        return -1 if check is None else check_configurations(check, qs, pre)

    def colliding(self, q: np.ndarray) -> list[int]:
        """Indices (into :attr:`pairs`) of every intersecting pair at ``q``."""
        data, gd, _bpm, gm = self._shell()[:4]
        if not len(self.pairs):
            return []
        _compute_collisions(self.model, data, gm, gd, q, False)
        return [k for k, res in enumerate(gd.collisionResults) if res.isCollision()]

    def distance_arrays(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(d, p1, p2, n)`` of every pair at ``q``: shapes ``(P,)``, ``(P, 3)``, ``(P, 3)``, ``(P, 3)``."""
        data, gd, _bpm, gm = self._shell()[:4]
        P = len(self.pairs)
        d = np.empty(P)
        p1, p2, n = np.empty((P, 3)), np.empty((P, 3)), np.empty((P, 3))
        if not P:
            return d, p1, p2, n
        pin.computeDistances(self.model, data, gm, gd, q)
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
        data, gd, _bpm, gm = self._shell()[:4]
        k = pin.computeDistances(self.model, data, gm, gd, q)
        return float(gd.distanceResults[k].min_distance), int(k)

    def _margin_data(self, threshold: float) -> pin.GeometryData:
        """This thread's GeometryData whose collision requests use ``security_margin = threshold``."""
        self._shell()
        return self.layout.margin_workspace(threshold)[0]

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
        shell = self._shell()
        geometry = shell[3]
        gd, bpm, collect = self.layout.margin_workspace(threshold)
        if data is None:
            data = shell[0]
            pin.forwardKinematics(self.model, data, q)
        pin.updateGeometryPlacements(self.model, data, geometry, gd)
        if bpm is None:
            return []
        bpm.update(False)
        _compute_collisions(bpm, collect)
        return [k for k in sorted(collect.pair_indexes) if _compute_collision(geometry, gd, k)]

    def near_distance(self, threshold: float, k: int) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
        """``(d, p1, p2, n)`` of pair ``k`` at the placements of the last :meth:`near` call with ``threshold`` on
        this thread (by any scene of the layout: call it right after this scene's :meth:`near`)."""
        gd = self._margin_data(threshold)
        res = pin.computeDistance(self._local.shell[3], gd, k)
        return res.min_distance, res.getNearestPoint1(), res.getNearestPoint2(), res.normal
