"""The sphere pre-check of one scene layout, and the arguments of its compiled kernels for one scene.

A :class:`~.collision_layout.SceneLayout` (obstacles of given shapes, any poses)
builds one :class:`ScenePrecheck` on the robot's packing
(:class:`~.precheck_packing.RobotPacking`: the robot's spheres and the pair table -
robot geometry, other geometry or obstacle, pair kind, index of the pair in the
scene; obstacle pairs first, a configuration in collision usually hits an
obstacle: found sooner; the verdict does not depend on the order), which every
layout and scene of the robot shares. Each scene of the layout then gets its
packed floats (:meth:`ScenePrecheck.scene_floats`): its obstacles' rows
(:attr:`~.shapes.Shape.obstacle_bytes`, made with each shape), one join - all a new
scene computes (the robot's floats are in the packing's integer array). Its
:class:`PrecheckArguments` (:meth:`ScenePrecheck.arguments`), the record the planners
and the IK read at set-up, are made from those floats when asked.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from operator import attrgetter
from typing import Any, NamedTuple

import numpy as np

from .hull_table import HullTable
from .hull_verdict import hull_verdict
from .kernel_cache import entry_point
from .precheck_kernels import (
    OBSTACLE_PAIR,
    SELF_PAIR,
    TOLERANCE,
    certainly_colliding,
    certify_configuration,
    certify_configurations,
    classify_configuration,
    first_uncertified,
    uncertified_pairs,
)
from .precheck_packing import RobotPacking, table_view

#: A shape's :attr:`~.shapes.Shape.obstacle_bytes` (read by ``map``: no Python frame per scene).
_OBSTACLE_BYTES = attrgetter("obstacle_bytes")


class PrecheckArguments(NamedTuple):
    """What a scene's pre-check calls: the kernels of :mod:`.precheck_kernels` and their arguments.

    ``certify(floats, ints, q, tolerance)`` (:func:`~.precheck_kernels.certify_configuration`),
    ``first_uncertified(floats, ints, rows, start, tolerance)``,
    ``certainly_colliding(floats, ints, q, tolerance)``; ``floats``, ``ints``: the scene's packed arrays
    (:mod:`.precheck_packing`); ``tolerance`` (m): :data:`~.precheck_kernels.TOLERANCE`.
    ``sphere_reach`` ``(S, J)`` and ``pair_reach`` ``(P, J)`` (:meth:`ScenePrecheck.motion_reach`): the
    layout's rate tables of the motion certificates (:mod:`.motion_kernels`).
    ``classify(floats, ints, q, tolerance)`` (:func:`~.precheck_kernels.classify_configuration`: free, in
    collision or undecided - carrying up to three pairs for coal - in one call) and
    ``uncertified_pairs(floats, ints, q, tolerance)`` (the scene indices of the pairs the spheres do not
    certify at ``q``: coal need check only those).
    ``hulls``: the robot's :class:`~.hull_table.HullTable` (None: the compiled distances are not available)
    and ``table_rows`` ``(P,)``: the row of the pair table of each scene pair (:mod:`.precheck_packing`), for
    :func:`~.motion_kernels.advance_on_distances`.
    ``hull_verdict(floats, ints, *hull_arguments, q, verdict, tolerance)``
    (:func:`~.hull_verdict.hull_verdict`: the hulls' distances on the pairs an undecided ``classify``
    verdict carries; None without ``hulls``) and ``hull_arguments`` ``(points, hull_geoms, radius,
    table_rows)``: the layout's :attr:`ScenePrecheck.hull_arguments` (None without ``hulls``).
    """

    certify: Callable[..., bool]
    first_uncertified: Callable[..., int]
    floats: np.ndarray
    ints: np.ndarray
    tolerance: float
    certainly_colliding: Callable[..., bool]
    sphere_reach: np.ndarray
    pair_reach: np.ndarray
    classify: Callable[..., int]
    uncertified_pairs: Callable[..., np.ndarray]
    hulls: HullTable | None
    table_rows: np.ndarray
    hull_verdict: Callable[..., int] | None
    hull_arguments: tuple | None


class ScenePrecheck:
    """The pre-check of one layout of ``n_obstacles`` obstacles: the robot's packing ``packing`` (shared by
    every layout of the robot and self-collision choice: :class:`~.precheck_packing.RobotPacking`) and the
    pair table ``pairs`` ``(P, 4)`` the layout's scenes read (a view of the packing's); :meth:`arguments`
    adds a scene's obstacle rows. ``scene_pairs`` ``(P, 2)``: the layout's pairs (geometry indices, robot
    geometries first then the obstacles from ``n_robot`` on), checked against the table; ``hulls``: the
    cores of the robot's geometries (:mod:`.hull_table`; None: no compiled distances).
    """

    def __init__(self, packing: RobotPacking, scene_pairs: np.ndarray, n_robot: int, n_obstacles: int,
                 hulls: HullTable | None = None) -> None:
        self.robot = packing.robot
        self.hulls = hulls
        #: The kernels a scene's check calls (:mod:`.precheck_kernels`) and their tolerance (m), read by
        #: :class:`~.collision_scene.CollisionScene` without importing the kernels itself.
        self.classify, self.uncertified_pairs, self.tolerance = \
            classify_configuration, uncertified_pairs, TOLERANCE
        #: The packed integers (the robot's floats in them), the packing's own array.
        self.ints = packing.ints_for(n_obstacles)
        self.pairs = table_view(self.ints, n_obstacles)
        _check_table(self.pairs, scene_pairs, n_robot)
        #: The row of :attr:`pairs` of each scene pair (never written once made; writable, as :attr:`ints`).
        self.table_rows = np.empty(len(self.pairs), dtype=np.int64)
        self.table_rows[self.pairs[:, 3]] = np.arange(len(self.pairs))
        #: :meth:`motion_reach`'s pair rates of the self pairs, per row of ``pairs``.
        self.pair_reach = self.motion_reach()
        #: The hulls' verdict on an undecided configuration's carried pairs
        #: (:func:`~.hull_verdict.hull_verdict`) and what it reads after the packed arrays, ``(points, geoms,
        #: radius, table_rows)``: None, None without ``hulls``.
        self.hull_verdict = None if hulls is None else hull_verdict
        self.hull_arguments = None if hulls is None else (hulls.points, hulls.geoms, hulls.radius,
                                                          self.table_rows)
        #: :attr:`classify` and :attr:`hull_verdict` (None without ``hulls``) without Numba's dispatch
        #: (:func:`~.kernel_cache.entry_point`), for a caller that passes the signatures' types only: this
        #: pre-check's own arrays and a configuration it has checked to be a float64 vector
        #: (:meth:`~.collision_scene.CollisionScene.in_collision`).
        self.classify_entry = entry_point(classify_configuration)
        self.hull_verdict_entry = None if hulls is None else entry_point(hull_verdict)

    def motion_reach(self) -> np.ndarray:
        """``(P, J)``: per row of the pair table, a bound (m per unit of each joint's coordinate) of how fast
        the gap of two spheres of a self pair can change (:func:`~.motion_kernels.motion_hard_pairs`): the sum
        of the two geometries' :attr:`~.robot_spheres.RobotSpheres.geometry_reach` on the joints that
        carry one of them and not the other (a joint carrying both moves them rigidly together); 0 on the
        rows of obstacle pairs (their rates are the spheres' own)."""
        robot = self.robot
        reach = robot.geometry_reach
        out = np.zeros((len(self.pairs), len(robot.joints)))
        own = self.pairs[:, 2] == SELF_PAIR
        a, b = self.pairs[own, 0], self.pairs[own, 1]
        apart = robot.carrying[a] != robot.carrying[b]
        out[own] = np.where(apart, reach[a] + reach[b], 0.0)
        return np.ascontiguousarray(out)

    def scene_floats(self, obstacles: Sequence[Any]) -> np.ndarray:
        """The packed floats of a scene with ``obstacles`` (one per obstacle geometry: shapes of the layout's
        signatures, each with its :attr:`~.shapes.Shape.obstacle_bytes`): the obstacles' rows, a new float64
        array over one new ``bytearray`` (one join; writable, as the compiled kernels' dispatch reads a
        writable array faster than a read-only one)."""
        return np.frombuffer(bytearray().join(map(_OBSTACLE_BYTES, obstacles)))

    def arguments(self, floats: np.ndarray) -> PrecheckArguments:
        """The :class:`PrecheckArguments` of the scene whose packed floats are ``floats``
        (:meth:`scene_floats`): a new record on each call, holding ``floats`` itself."""
        return PrecheckArguments(certify_configuration, first_uncertified, floats, self.ints, self.tolerance,
                                 certainly_colliding, self.robot.sphere_reach,
                                 self.pair_reach, self.classify, self.uncertified_pairs, self.hulls,
                                 self.table_rows, self.hull_verdict, self.hull_arguments)


def _check_table(table: np.ndarray, scene_pairs: np.ndarray, n_robot: int) -> None:
    """Raise RuntimeError unless the pair table ``table`` ``(P, 4)`` lists exactly the scene's pairs
    ``scene_pairs`` ``(P, 2)``, each at its scene index (robot geometry first, obstacles as indices from
    ``n_robot``)."""
    scene_pairs = np.asarray(scene_pairs, dtype=np.int64).reshape(-1, 2)
    other = np.where(table[:, 2] == OBSTACLE_PAIR, table[:, 1] + n_robot, table[:, 1])
    if len(table) != len(scene_pairs) or not np.array_equal(np.sort(table[:, 3]), np.arange(len(table))) \
            or not np.array_equal(scene_pairs[table[:, 3]], np.column_stack([table[:, 0], other])):
        raise RuntimeError("the pre-check's pair table does not list the scene's pairs")  # pragma: no cover


def certify(arguments: PrecheckArguments, qs: Any) -> np.ndarray:
    """:func:`~.precheck_kernels.certify_configurations` with a scene's ``arguments`` on configurations ``qs``
    (a sequence of ``(nq,)`` float arrays or an ``(N, nq)`` array): per configuration, True when certified
    free."""
    Q = np.asarray(qs, dtype=float)
    Q = Q.reshape(len(Q), -1)
    return certify_configurations(arguments.floats, arguments.ints, Q, arguments.tolerance)


__all__ = ["PrecheckArguments", "ScenePrecheck", "certify"]
