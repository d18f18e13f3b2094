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
  (:mod:`.precheck_kernels`, compiled): spheres fixed in the joint frames that
  contain every robot geometry, moved by the forward kinematics of the whole
  tree, against each other and against the obstacles' exact point distances
  give a lower bound of every checked pair's distance; a configuration whose
  bounds all exceed 10 um is certified free and never reaches coal (the same
  answer: a certified configuration is one coal finds free); one it cannot
  certify but with a ball inside the robot deep in an obstacle or in another
  link's is in collision without coal (:func:`~.precheck_kernels.certainly_colliding`);
  the pairs the spheres leave (at most three) are measured next on the hulls
  (:func:`~.hull_verdict.hull_verdict`, compiled GJK: apart by more than 10 um
  is free, cores overlapping deeper than 10 um a collision); coal checks the
  others on the pairs neither certifies only
  (:func:`~.configuration_checks.pair_test`).
  ``first_collision`` certifies stacked rows (the IK's runs) in one compiled
  call (a sequence: its first configuration alone - the IK's answer, the
  likeliest to collide - then the rest in one call) and runs coal on the ones
  the pre-check cannot decide, in order. The pre-check's arguments for this
  scene's obstacle poses (:meth:`CollisionScene.precheck`) are made with the
  scene, from its layout's pre-check; robots whose tree has other joints than
  one-DoF revolute / prismatic ones keep coal alone (``precheck()`` is None);
* ``in_collision`` (coal) - a broad phase (``pinocchio.BroadPhaseManager``):
  every geometry gets its world AABB, only checked pairs whose AABBs overlap
  reach GJK, and the call stops at the first collision
  (:mod:`.configuration_checks`). The manager is coal's *naive* one (every AABB
  against every other, no tree) up to
  :data:`~.collision_layout.NAIVE_MAX_GEOMETRIES` geometries and the dynamic
  AABB tree above (its refit costs more than the AABB tests it saves on arm-sized
  scenes; docs/benchmarks.md). Never the array form of the tree: in coal 3 / pin
  4.1 it misses collisions once a third obstacle is added; the tests check the
  broad phase against pair-by-pair coal on scenes of 2 to 4 obstacles and on
  obstacles placed at the arm's surface;
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
manager (:class:`~.collision_layout.Workspace`), so a scene - like a ``Robot`` -
may be shared between threads. The geometry layout, the pair table, the
pre-check of the pairs and the per-thread workspaces belong to a
:class:`~.collision_layout.SceneLayout` shared by every scene whose obstacles
have the same shapes (poses aside); a scene holds its obstacles and its
pre-check floats (its shapes' own obstacle rows, joined), made with
the scene; a query that reaches coal puts the obstacles' placements into its
thread's workspace when another scene of the layout used it last (``in_collision``:
only the obstacles of the pairs coal checks). The scene's
own ``GeometryModel`` (:attr:`CollisionScene.geometry`, for the planners' and
viewers' Pinocchio calls) is made on its first read: no query reads it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import pinocchio as pin

from .collision_layout import SceneLayout, Workspace
from .configuration_checks import check_configurations, undecided_pairs
from .errors import InputError, ShapeError
from .precheck_verdicts import COLLIDING, FREE, UNDECIDED
from .validation import MAX_ABS, as_count, as_nonnegative, as_rows, as_vector

if TYPE_CHECKING:
    from .scene_precheck import PrecheckArguments

_compute_collisions = pin.computeCollisions
_compute_collision = pin.computeCollision
_NDARRAY, _FLOAT64 = np.ndarray, np.dtype(np.float64)


class DistanceArrays(NamedTuple):
    """Every pair's signed distance ``distance`` ``(P,)`` (m), witness points ``point_a`` / ``point_b``
    ``(P, 3)`` (world, m) and unit normal ``normal`` ``(P, 3)``: ``point_b - point_a = distance * normal``."""

    distance: np.ndarray
    point_a: np.ndarray
    point_b: np.ndarray
    normal: np.ndarray


class PairWitness(NamedTuple):
    """One pair's signed distance ``distance`` (m), witness points ``point_a`` / ``point_b`` (world, m) and
    unit normal ``normal``."""

    distance: float
    point_a: np.ndarray
    point_b: np.ndarray
    normal: np.ndarray


class ClosestPair(NamedTuple):
    """The smallest signed distance ``distance`` (m) of a scene and the index ``pair`` of its pair."""

    distance: float
    pair: int


class CollisionScene:
    """Robot geometry + obstacles; see the module docstring. Built by :meth:`CollisionModel.scene` (or
    directly on a layout: ``CollisionScene(layout, obstacles)`` with validated shapes of the layout's
    signatures, at any poses).

    ``layout`` supplies the geometry objects, pairs, names, the pre-check and per-thread workspaces; the scene
    owns the obstacle placements.
    """

    __slots__ = ("layout", "obstacles", "self_collision", "_nq", "_geometry", "_layout_check", "_classify",
                 "_uncertified", "_floats", "_ints", "_tolerance", "_hull_verdict", "_hull_arguments",
                 "__weakref__")

    def __init__(self, layout: SceneLayout, obstacles: tuple) -> None:
        self.layout = layout
        self.obstacles = obstacles
        #: Whether the robot's self pairs are checked (the layout's choice, a bool).
        self.self_collision: bool = layout.self_collision
        self._nq: int = layout.nq
        self._geometry: pin.GeometryModel | None = None  # made on its first read (:attr:`geometry`)
        # the pre-check's packed floats: all a new scene computes (read by in_collision without a look-up)
        check = self._layout_check = layout.sphere_precheck
        if check is None:
            self._classify = self._uncertified = self._floats = self._ints = None
            self._hull_verdict = self._hull_arguments = None
            self._tolerance = 0.0
        else:
            self._floats = check.scene_floats(obstacles)
            self._ints, self._tolerance = check.ints, check.tolerance
            self._classify, self._uncertified = check.classify_entry, check.uncertified_pairs
            self._hull_verdict, self._hull_arguments = check.hull_verdict_entry, check.hull_arguments

    # the layout's, read through the scene
    @property
    def model(self) -> pin.Model:
        """The robot's Pinocchio model."""
        return self.layout.model

    @property
    def n_robot(self) -> int:
        """The number of robot geometries (the obstacles follow them)."""
        return self.layout.n_robot

    @property
    def geometry_owner(self) -> list[str]:
        """The link name (robot) or obstacle name of each geometry."""
        return self.layout.geometry_owner

    @property
    def pairs(self) -> np.ndarray:
        """The checked pairs: geometry indices, int ``(P, 2)``, in scene order."""
        return self.layout.pairs

    @property
    def pair_names(self) -> list[tuple[str, str]]:
        """Each pair's two owners (:attr:`geometry_owner`)."""
        return self.layout.pair_names

    @property
    def pair_joints(self) -> np.ndarray:
        """Pinocchio joint of each pair's two geometries (0 = fixed in the world), shape (P, 2)."""
        return self.layout.pair_joints

    def __len__(self) -> int:
        return len(self.layout.pairs)

    @property
    def placements(self) -> list[pin.SE3]:
        """The ``pinocchio.SE3`` pose of each obstacle (the layout's own when the obstacle is the layout's),
        made on each read."""
        return self.layout.placements_of(self.obstacles)

    @property
    def geometry(self) -> pin.GeometryModel:
        """The scene's ``GeometryModel``: robot geometry, then the obstacles at their poses, for the planners'
        and viewers' own Pinocchio calls. Made on its first read and kept (the queries never read it: they run
        on the thread's workspace, so building a scene does not copy a ``GeometryModel``)."""
        gm = self._geometry
        if gm is None:
            gm = self._geometry = self.layout.placed(self.obstacles)
        return gm

    def workspace(self) -> Workspace:
        """This thread's :class:`~.collision_layout.Workspace` of the layout, holding this scene's
        obstacles."""
        return self.layout.workspace(self.obstacles)

    def precheck(self) -> PrecheckArguments | None:
        """The arguments of the compiled sphere pre-check with this scene's obstacle poses
        (:class:`~.scene_precheck.PrecheckArguments`: a new record on each call, for set-up code - every
        record holds the scene's own packed floats), or None when the layout has none
        (:meth:`.collision_layout.SceneLayout.precheck`)."""
        check = self._layout_check
        return None if check is None else check.arguments(self._floats)

    # ----------------------------------------------------------------- queries
    def in_collision(self, q: np.ndarray) -> bool:
        """True when any checked pair intersects at ``q`` (broad phase, stops at the first hit).

        ``q``: ``nq`` finite numbers (:class:`~.errors.ShapeError` / :class:`~.errors.NonFiniteError`
        otherwise, as :func:`~.validation.as_vector` words them). The sphere pre-check first
        (:meth:`precheck`, one compiled call, through the kernel's entry point, bound when the layout's
        pre-check was built: no dispatch per call; any other ``q`` is checked and converted first): a
        configuration it certifies is free without coal, one with an inner ball deep in an obstacle or in
        another link's is in collision without coal; otherwise coal checks the pairs the spheres do not
        certify - carried by the verdict when there are at most three
        (:func:`~.precheck_kernels.classify_configuration`), and then only those the hulls' distances leave
        open (:func:`~.hull_verdict.hull_verdict`, a second compiled call: free when each pair is apart, in
        collision when one pair's cores overlap deeper than the tolerance), else listed by a second compiled
        call (``pinocchio.computeCollision`` each, or the broad phase over all pairs when more than
        :data:`~.configuration_checks.PAIRWISE_MAX` are left: the workspace's
        :func:`~.configuration_checks.pair_test`), with only their obstacles placed in coal
        (:meth:`~.collision_layout.SceneLayout.pair_workspace`). The pre-check checks ``q`` itself (one entry
        per joint, ``q·q < MAX_ABS**2``) and leaves any other ``q`` undecided: every configuration that
        reaches coal without a pair-carrying verdict is checked first (:func:`~.validation.as_vector`).
        """
        classify = self._classify
        # the kernels' entry points read a float64 vector only; without them coal needs a checked q
        if classify is None or type(q) is not _NDARRAY or q.dtype is not _FLOAT64 or q.ndim != 1:
            q = as_vector(q, self._nq)
        if classify is None:
            ws = self.layout.workspace(self.obstacles)
            return False if ws.check is None else ws.hits(q)
        verdict = classify(self._floats, self._ints, q, self._tolerance)
        if verdict == FREE:
            return False
        if verdict == COLLIDING:
            return True
        if verdict > UNDECIDED and self._hull_verdict is not None:
            verdict = self._hull_verdict(self._floats, self._ints, *self._hull_arguments, q, verdict,
                                         self._tolerance)
            if verdict == FREE or verdict == COLLIDING:
                return verdict == COLLIDING
        elif verdict == UNDECIDED:  # the pre-check judged nothing: q may be malformed
            q = as_vector(q, self._nq)
        pairs = undecided_pairs(verdict, self._uncertified, self._floats, self._ints, q, self._tolerance)
        ws = self.layout.pair_workspace(self.obstacles, pairs)  # the obstacles of these pairs placed
        return False if ws.check is None else ws.pair_hits(q, pairs)

    def first_collision(self, qs: Sequence[np.ndarray], uncertified: int | None = None) -> int:
        """Index of the first configuration of ``qs`` (float ``(nq,)`` arrays, checked in the given order) in
        collision, -1 when none is (:class:`~.errors.ShapeError` / :class:`~.errors.NonFiniteError` for rows
        that are not ``nq`` finite numbers each: :func:`~.validation.as_rows`); the sphere pre-check (rows
        stacked in a float ``(N, nq)`` array in one compiled call; a sequence: the first configuration alone,
        the rest in one call), and :meth:`in_collision`'s coal check of each uncertified one, in order,
        stopping at the first hit (:func:`~.configuration_checks.check_configurations`). ``uncertified``: for
        stacked rows, the index the caller's own pre-check call returned (the rows before it are certified;
        not certified again)."""
        if type(qs) is np.ndarray:
            qs = as_rows(qs, self._nq)
        else:
            try:
                qs = [as_vector(q, self._nq, f"qs[{k}]") for k, q in enumerate(qs)]
            except TypeError:  # (not iterable)
                raise ShapeError(f"qs must be a sequence of configurations or a float (N, {self._nq}) array, "
                                 f"got {type(qs).__name__}") from None
        pre = self.precheck()
        if pre is not None and type(qs) is np.ndarray and qs.ndim == 2 and qs.dtype == np.float64:
            # stacked rows (the IK's runs): one compiled call; coal only from the first uncertified row on
            k = pre.first_uncertified(pre.floats, pre.ints, qs, 0, pre.tolerance) if uncertified is None \
                else uncertified
            if k >= qs.shape[0]:
                return -1
            check = self.workspace().check
            return -1 if check is None else check_configurations(check, qs, pre, uncertified=k)
        check = self.workspace().check
        return -1 if check is None else check_configurations(check, qs, pre)

    def colliding(self, q: np.ndarray) -> list[int]:
        """Indices (into :attr:`pairs`) of every intersecting pair at ``q`` (``nq`` finite numbers)."""
        q = as_vector(q, self._nq)
        ws = self.workspace()
        if not len(self.pairs):
            return []
        gd = ws.geometry_data
        _compute_collisions(self.model, ws.data, ws.geometry, gd, q, False)
        return [k for k, res in enumerate(gd.collisionResults) if res.isCollision()]

    def distance_arrays(self, q: np.ndarray) -> DistanceArrays:
        """The :class:`DistanceArrays` of every pair at ``q``: shapes ``(P,)``, ``(P, 3)``, ``(P, 3)``,
        ``(P, 3)``. ``q``: ``nq`` finite numbers."""
        q = as_vector(q, self._nq)
        ws = self.workspace()
        P = len(self.pairs)
        d = np.empty(P)
        p1, p2, n = np.empty((P, 3)), np.empty((P, 3)), np.empty((P, 3))
        if not P:
            return DistanceArrays(d, p1, p2, n)
        pin.computeDistances(self.model, ws.data, ws.geometry, ws.geometry_data, q)
        for k, res in enumerate(ws.geometry_data.distanceResults):
            d[k] = res.min_distance
            p1[k] = res.getNearestPoint1()
            p2[k] = res.getNearestPoint2()
            n[k] = res.normal
        return DistanceArrays(d, p1, p2, n)

    def min_distance(self, q: np.ndarray) -> ClosestPair:
        """The :class:`ClosestPair` at ``q``: the smallest signed distance (m) and its pair index
        (``(inf, -1)`` without pairs). One ``pinocchio.computeDistances`` (it returns the index of the closest
        pair). ``q``: ``nq`` finite numbers."""
        q = as_vector(q, self._nq)
        if not len(self.pairs):
            return ClosestPair(float("inf"), -1)
        ws = self.workspace()
        k = pin.computeDistances(self.model, ws.data, ws.geometry, ws.geometry_data, q)
        return ClosestPair(float(ws.geometry_data.distanceResults[k].min_distance), int(k))

    def near(self, threshold: float, q: np.ndarray | None = None, data: pin.Data | None = None) -> list[int]:
        """Indices of the pairs closer than ``threshold`` (m), at ``q`` or at the placements of ``data``.

        Give ``q`` (forward kinematics runs on this thread's workspace) or a
        ``pinocchio.Data`` whose joint placements ``oMi`` are current. The
        placements stay in place for :meth:`near_distance`.

        Broad phase first: the candidates are the checked pairs whose world
        AABBs, each inflated by ``threshold / 2``, overlap (``CollisionCallBackCollect``;
        two shapes closer than ``threshold`` always qualify, since an AABB gap is
        never larger than the shapes' distance); GJK with the security margin then
        runs on the candidates only: the same pairs as GJK on every pair.

        ``threshold``: a number in ``[0, 1e6]`` m (:class:`~.errors.InputError` /
        :class:`~.errors.NonFiniteError` for NaN, a negative, huge or non-numeric one); ``q``: ``nq`` finite
        numbers.
        """
        if type(threshold) is not float or not 0.0 <= threshold <= MAX_ABS:
            threshold = as_nonnegative(threshold, "threshold")
        ws = self.workspace()
        geometry = ws.geometry
        gd, bpm, collect = self.layout.margin_workspace(threshold)
        if data is None:
            q = as_vector(q, self._nq)
            data = ws.data
            pin.forwardKinematics(self.model, data, q)
        pin.updateGeometryPlacements(self.model, data, geometry, gd)
        if bpm is None:
            return []
        bpm.update(False)
        _compute_collisions(bpm, collect)
        return [k for k in sorted(collect.pair_indexes) if _compute_collision(geometry, gd, k)]

    def near_distance(self, threshold: float, k: int) -> PairWitness:
        """The :class:`PairWitness` of pair ``k`` at the placements of the last :meth:`near` call with
        ``threshold`` on this thread (by any scene of the layout: call it right after this scene's
        :meth:`near`). ``threshold`` as for :meth:`near`; ``k``: an integer pair index from 0 to ``len(self) -
        1`` (:class:`~.errors.InputError` otherwise)."""
        if type(threshold) is not float or not 0.0 <= threshold <= MAX_ABS:
            threshold = as_nonnegative(threshold, "threshold")
        n_pairs = len(self.layout.pairs)
        if type(k) is not int or not 0 <= k < n_pairs:
            if not n_pairs:
                raise InputError(f"k: this scene has no checked pairs, so there is no pair {k!r}")
            k = as_count(k, "k (a pair index)", minimum=0, maximum=n_pairs - 1)
        ws = self.workspace()
        gd = self.layout.margin_workspace(threshold).geometry_data
        res = pin.computeDistance(ws.geometry, gd, k)
        return PairWitness(res.min_distance, res.getNearestPoint1(), res.getNearestPoint2(), res.normal)


__all__ = ["ClosestPair", "CollisionScene", "DistanceArrays", "PairWitness"]
