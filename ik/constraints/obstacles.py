"""``ObstacleAvoidance``: any solid shape kept clear of the robot's links, hard on every iterate.

The robot body is its skeleton of segments (:mod:`.robot_skeleton`), each the core of a capsule of
radius ``link_radius`` (:mod:`.link_capsules`; ``link_radius=0`` = bare segments). An obstacle with
``frames`` set is kept clear of those frame origins only. For every (obstacle, segment) pair the
**clearance** is

    c = d(segment core, obstacle) - link_radius - margin        (m)

with ``d`` the Euclidean distance (negative when they overlap), computed by :mod:`.obstacle_distance`
(closed forms for spheres, capsules and boxes; coal for cylinders and meshes, exact below
:data:`MARGIN_EXACT` in the true check and a lower bound above, which is all the step back-off needs).

With ``x`` the witness point on the segment ``[a, b]`` (parameter ``s``) and ``n`` the unit normal
pointing from the obstacle to ``x``, the clearance gradient is ``g = n^T ((1 - s) J_a + s J_b)``
(:meth:`LinkSkeleton.gradient_rows`) and the constraint row is the velocity damper

    g^T dq >= -xi c                    (xi = ``gain``, default 0.5)

so a step consumes at most the fraction ``xi`` of the clearance, and a negative clearance (a start in
collision) must grow. Rows are returned for the pairs with ``c < influence`` only (the others cannot
bind a step of reasonable size; the true check after the step covers every pair). ``margin(q)`` is the
smallest clearance over all pairs. With spheres only, both come from the compiled path of
:mod:`.sphere_rows`; :meth:`ObstacleAvoidance.violations` checks many configurations at once
(:mod:`.obstacle_violations`).

Binding builds the :class:`~.obstacle_tables.ObstacleTables` (immutable, shared by reference by every
constraint adopting them: :meth:`ObstacleAvoidance.bound_copy`, :meth:`ObstacleAvoidance.adopt`) on the
robot's :class:`~.robot_skeleton.RobotSkeleton` (built, or handed over by its owner). An obstacle that
contains a part of the robot fixed to the world (its base segments) makes the problem infeasible:
:class:`InputError` at ``bind``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np

from kinserve.ik import numpy_fast
from kinserve.ik.constraints.base import DAMPER_GAIN, Constraint
from kinserve.ik.constraints.obstacle_arguments import (
    as_obstacle,
    damper_gain,
    frame_names,
    non_negative,
    obstacle_list,
)
from kinserve.ik.constraints.obstacle_distance import pair_clearances
from kinserve.ik.constraints.obstacle_tables import ObstacleTables, build_obstacle_tables, obstacle_frames
from kinserve.ik.constraints.obstacle_violations import obstacle_violations
from kinserve.ik.constraints.robot_skeleton import RobotSkeleton
from kinserve.ik.constraints.sphere_rows import sphere_geometry, sphere_rows, upper_bounds
from kinserve.kinematics.errors import InputError

if TYPE_CHECKING:  # annotations only
    import pinocchio as pin

    from kinserve.ik.constraints.link_capsules import LinkSkeleton
    from kinserve.kinematics.robot import Robot

__all__ = ["ObstacleAvoidance", "as_obstacle", "INFLUENCE", "MARGIN_EXACT", "COAL_INFLUENCE"]

#: Pairs whose clearance is below this (m) contribute rows to the QP.
INFLUENCE = 0.3
#: The true check computes coal distances exactly only for pairs whose lower bound is below this (m).
MARGIN_EXACT = 0.05
#: Box and coal pairs give rows when their lower bound is below this (m).
COAL_INFLUENCE = 0.15

_einsum = numpy_fast.einsum
_min = np.minimum.reduce


class ObstacleAvoidance(Constraint):
    """Keep ``obstacles`` (any :mod:`kinserve.kinematics.shapes` shape) clear of the robot (module docstring).

    Parameters
    ----------
    obstacles:
        Shapes (or dicts / ``(center, radius)`` pairs, see :func:`as_obstacle`).
    link_radius:
        Radius (m, >= 0) of the capsules around the link segments (0 = bare segments).
    margin:
        Extra clearance (m, >= 0) required between links and obstacles.
    gain:
        Velocity-damper gain ``xi`` in ``(0, 1]``.
    tool_frames:
        Frames whose tool segment (parent joint -> frame origin) is part of the
        body (default: the robot's tip).
    influence:
        Pairs with clearance below this (m) give QP rows.
    """

    def __init__(self, obstacles: Any, link_radius: float = 0.0, margin: float = 0.0,
                 gain: float = DAMPER_GAIN, tool_frames: Sequence[str] | str | None = None,
                 influence: float = INFLUENCE) -> None:
        super().__init__(name="obstacles")
        self.obstacles = obstacle_list(obstacles)
        self.link_radius = non_negative(link_radius, "link_radius")
        self.margin_required = non_negative(margin, "margin")
        self.gain = damper_gain(gain)
        self.tool_frames = frame_names(tool_frames)
        self.influence = non_negative(influence, "influence")
        #: the bound pair tables (None until bound), shared with every constraint adopting them
        self.tables: ObstacleTables | None = None
        self._kernel: ModuleType | None = None  # :mod:`.clearance_kernel`, loaded when bound
        self._last: tuple | None = None  # (data, q, geometry) of the last margin() without box or coal pairs

    # ---------------------------------------------------------------------------------------- binding
    def skeleton_frames(self, robot: Robot) -> tuple[tuple[str, ...], tuple[str, ...]]:
        """``(tool_frames, frames)`` of the :class:`RobotSkeleton` this constraint needs on ``robot``."""
        return self.tool_frames or (robot.tip,), obstacle_frames(self.obstacles)

    def bind(self, robot: Robot, skeleton: RobotSkeleton | None = None) -> ObstacleAvoidance:
        """Validate against ``robot`` and bind the pair tables (nothing to do when bound to it already).

        The tables bound before on the same skeleton with the same obstacle objects, link radius and margin
        are shared (:attr:`RobotSkeleton.bound_tables`); others are built.

        ``skeleton``: a :class:`RobotSkeleton` of ``robot`` for :meth:`skeleton_frames` (default: the one its
        IK state owns, :meth:`kinserve.ik.state.IKState.robot_skeleton`, built on first use). Raises
        :class:`InputError` for an obstacle containing the robot's base or a skeleton of another robot or
        other frames, :class:`FrameError` for an unknown frame.
        """
        tools, frames = self.skeleton_frames(robot)
        if self.tables is not None and self.tables.skeleton.matches(robot, tools, frames):
            return self
        if skeleton is None:
            from kinserve.ik.state import ik_state  # the robot's IK state owns its skeletons

            skeleton = ik_state(robot).robot_skeleton(tools, frames)
        elif not skeleton.matches(robot, tools, frames):
            raise InputError(f"skeleton must be {robot.name}'s for tool frames {tools} and frames {frames}, "
                             f"got {skeleton!r}")
        tables = skeleton.bound_tables.find(self.obstacles, self.link_radius, self.margin_required)
        if tables is None:  # (an obstacle containing the base raises here, every time: errors are not kept)
            tables = build_obstacle_tables(skeleton, self.obstacles, self.link_radius, self.margin_required)
            skeleton.bound_tables.add(tables)
        return self._take(tables)

    def adopt(self, robot: Robot, tables: ObstacleTables) -> ObstacleAvoidance:
        """Bind to ``robot`` with already built ``tables`` (shared by reference, not copied); they must be of
        this constraint's obstacles (the same objects), link radius, margin and skeleton frames on ``robot``,
        else :class:`InputError`."""
        if not (tables.fits(self.obstacles, self.link_radius, self.margin_required)
                and tables.skeleton.matches(robot, *self.skeleton_frames(robot))):
            raise InputError("tables must be built on robot for this constraint's obstacles, link_radius, "
                             f"margin and tool_frames, got tables of {len(tables.obstacles)} obstacles on "
                             f"{tables.skeleton!r}")
        return self._take(tables)

    def _take(self, tables: ObstacleTables) -> ObstacleAvoidance:
        """Hold ``tables`` (checked to be this constraint's) and their compiled kernels."""
        self.tables, self._kernel, self._last = tables, tables.kernel, None
        return self

    def bound_copy(self, robot: Robot, gain: float | None = None,
                   influence: float | None = None) -> ObstacleAvoidance:
        """A constraint on the same obstacles bound to ``robot`` with these tables (shared by reference; its
        own memo, e.g. one per thread), with another ``gain`` or ``influence`` if given."""
        twin = ObstacleAvoidance(self.obstacles, self.link_radius, self.margin_required,
                                 self.gain if gain is None else gain, self.tool_frames,
                                 self.influence if influence is None else influence)
        if self.tables is None:
            return twin.bind(robot)
        return twin.adopt(robot, self.tables)

    @property
    def skeleton(self) -> LinkSkeleton:
        """The bound skeleton's moving segments (:class:`LinkSkeleton`)."""
        return self.tables.links

    @property
    def m(self) -> int:
        """Number of (obstacle, segment) pairs."""
        return self.tables.m

    @property
    def pair_names(self) -> list[tuple[int, str]]:
        """``(obstacle index, segment name)`` of every pair, in the order of the clearance vector."""
        return self.tables.pair_names()

    # ------------------------------------------------------------------------------------- checks
    def clearances(self, data: pin.Data, exact_below: float = MARGIN_EXACT) -> np.ndarray:
        """Clearance ``c`` (m) of every pair after forward kinematics in ``data``; coal pairs whose lower
        bound is at least ``exact_below`` (m) keep that bound (``math.inf``: every pair exact)."""
        return pair_clearances(self.tables, data, False, exact_below)

    def first_violation(self, robot: Robot, Q: np.ndarray) -> int | None:
        """Index of the first configuration of ``Q`` (``(K, nq)``) with a negative clearance, or None."""
        hits = np.flatnonzero(self.violations(robot, Q, first_only=True))
        return int(hits[0]) if hits.size else None

    def violations(self, robot: Robot, Q: np.ndarray | Sequence[np.ndarray],
                   first_only: bool = False) -> np.ndarray:
        """``(K,)`` booleans: True where configuration ``k`` of ``Q`` (``(K, nq)``, or a list of ``(nq,)``
        arrays) has a negative clearance (:func:`.obstacle_violations.obstacle_violations`).

        ``first_only``: only the first True entry must be right (coal pairs of later configurations are
        skipped).
        """
        return obstacle_violations(self.tables, self._kernel, robot, Q, first_only)

    # ------------------------------------------------------------------------------------- protocol
    def margin(self, robot: Robot, data: pin.Data, q: np.ndarray) -> float:
        """Smallest clearance (m), exact (box and coal pairs: only the smallest is computed exactly).

        Without box and coal pairs the witness geometry is kept: :meth:`rows` at the same ``q`` (same array
        object, same ``data``) reuses it. With spheres only (on rigid segments) that is the lean
        :func:`.sphere_rows.sphere_geometry` (``c = d - (r + offset)``, equal to ``(d - r) - offset`` to
        ~1e-17 m).
        """
        t = self.tables
        if t.sphere_only:
            w = sphere_geometry(t, self._kernel, data, q, self.influence)
            self._last = (data, q, w)
            return float(_min(w.c))
        if not t.coal_shapes.seg.size and not t.boxes.seg.size:
            w = pair_clearances(t, data, True)
            self._last = (data, q, w)
            return float(w.c.min()) if w.c.size else math.inf
        c = pair_clearances(t, data, False, MARGIN_EXACT, min_only=True)
        return float(c.min()) if c.size else math.inf

    def rows(self, robot: Robot, data: pin.Data, q: np.ndarray,
             dt: float | None = None) -> tuple[np.ndarray | None, np.ndarray, np.ndarray]:
        """The damper rows ``g^T dq >= -gain c`` of the pairs with ``c < influence`` (module docstring)."""
        t = self.tables
        last = self._last
        kept = last[2] if last is not None and last[0] is data and last[1] is q else None
        if t.sphere_only:
            if kept is None:
                kept = sphere_geometry(t, self._kernel, data, q, self.influence)
            return sphere_rows(t, self._kernel, data, kept, self.gain)
        c, seg, s, N, A, B = kept if kept is not None else pair_clearances(
            t, data, True, min(self.influence, COAL_INFLUENCE))
        # rows of the pairs within reach; a witness exactly at the obstacle's core has no direction (skipped)
        near = (c < self.influence) & (_einsum("ij,ij->i", N, N) > 0.5)
        if not near.all():
            if not near.any():
                return np.zeros((0, robot.model.nv)), np.zeros(0), np.zeros(0)
            c, seg, s, N, A, B = c[near], seg[near], s[near], N[near], A[near], B[near]
        G = t.links.gradient_rows(data, seg, s, A, B, N)
        return G, -self.gain * c, upper_bounds(c.shape[0])

    def rows_all(self, robot: Robot, data: pin.Data) -> tuple[np.ndarray, np.ndarray]:
        """``(c, G)`` for every pair (tests, diagnostics); needs ``computeJointJacobians``."""
        w = pair_clearances(self.tables, data, True, math.inf)
        return w.c, self.tables.links.gradient_rows(data, w.seg, w.s, w.A, w.B, w.N)

    def describe(self, robot: Robot, data: pin.Data, q: np.ndarray) -> str:
        """The pairs entered at ``q`` (after forward kinematics) in words, "" if none."""
        c = pair_clearances(self.tables, data, False, math.inf)
        parts = []
        names = self.tables.pair_names()
        for p in np.flatnonzero(c < 0.0):
            k, seg = names[p]
            parts.append(f"obstacles[{k}] ({self.obstacles[k].kind}) is entered by {seg} by {-c[p]:.4g} m")
        return "; ".join(parts)

    def __repr__(self) -> str:
        return (f"ObstacleAvoidance({len(self.obstacles)} obstacles, link_radius={self.link_radius:g}, "
                f"margin={self.margin_required:g})")
