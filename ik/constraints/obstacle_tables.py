"""The pair tables of obstacles bound to a robot: one immutable object (:func:`build_obstacle_tables`).

A **pair** is (obstacle, link segment): every default segment for an obstacle without ``frames``,
the frame points of its ``frames`` otherwise. Pairs are grouped by how their distance is computed -
spheres, capsules, boxes (closed forms) and the coal shapes (cylinders, meshes) - in that order, obstacle
by obstacle: the order of the clearance vector. Per kind the table holds, per pair, the pair's segment
(``seg``, a row of the skeleton's ``links``), the rows of ``LinkSkeleton.points`` holding its two ends
(``ia``, ``ib``) and its obstacle's constants in world axes (m):

* spheres: centre ``o``, radius ``r``, ``r + offset`` and its square; ``1 / |b - a|^2`` when no segment
  slides; for the rows ``n^T [I, -[o]x] J``: ``W = [I, -[o]x]`` (3 x 6) and the support mask of the
  segment's joint (``(pairs, nv)``);
* capsules: core ``[a, b]``, radius ``r``, ``r + offset``;
* boxes: rotation ``R``, centre ``t``, half extents ``h`` per pair and per box;
* coal shapes: coal geometry and placement, centre, rotation, bounding radius and local extent (the lower
  bounds), and per rigid segment its capsule core and its placement in its joint's frame.

``offset`` is ``link_radius + margin``. Every array is read-only (``arr.flags.writeable`` is False) and
the records are immutable (named tuples and a frozen dataclass): constraints bound to the same obstacles
share one :class:`ObstacleTables` by reference. An obstacle that contains the robot's base raises
:class:`~kinserve.kinematics.errors.InputError` here (:mod:`.obstacle_base`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from types import ModuleType
from typing import Any, NamedTuple

import coal
import numpy as np
import pinocchio as pin

from kinserve.ik.constraints.link_capsules import LinkSkeleton
from kinserve.ik.constraints.obstacle_base import check_base
from kinserve.ik.constraints.obstacle_geometry import (
    axis_placement,
    bounding_radius,
    coal_transform,
    local_extent,
    segment_core,
)
from kinserve.ik.constraints.robot_skeleton import PairIndex, RobotSkeleton, pair_index
from kinserve.kinematics.shapes import Box, Capsule, Shape, Sphere


def _frozen(*arrays: np.ndarray) -> None:
    for a in arrays:
        if a is not None:
            a.setflags(write=False)


class SpherePairs(NamedTuple):
    """Sphere pairs (module docstring): ``seg``, ``row`` (the pair's sphere, an index of ``members``),
    ``ia``, ``ib``, ``iab = [ia, ib]``, centres ``(n, 3)``, radii, radii + offset and their squares
    ``(n,)``, ``support`` ``(n, nv)``. ``inv_len2`` is None when a pair's segment slides; ``blocks``:
    ``(spheres, segments)`` when the pairs are whole blocks of the default segments, sphere by sphere (else
    None). ``W`` per pair, or with ``blocks`` ``W_blocks``, the ``W`` of each sphere stacked
    ``(3 spheres, 6)``: for the NumPy rows of a robot whose tree the compiled kernels do not model (None
    otherwise)."""

    members: tuple[int, ...]
    seg: np.ndarray
    row: np.ndarray
    ia: np.ndarray
    ib: np.ndarray
    iab: np.ndarray
    center: np.ndarray
    radius: np.ndarray
    r_off: np.ndarray
    r_off2: np.ndarray
    inv_len2: np.ndarray | None
    blocks: tuple[int, int] | None
    W: np.ndarray | None
    support: np.ndarray
    W_blocks: np.ndarray | None


class CapsulePairs(NamedTuple):
    """Capsule pairs (module docstring): cores ``[a, b]`` ``(n, 3)``, radii and radii + offset ``(n,)``."""

    members: tuple[int, ...]
    seg: np.ndarray
    row: np.ndarray
    ia: np.ndarray
    ib: np.ndarray
    a: np.ndarray
    b: np.ndarray
    radius: np.ndarray
    r_off: np.ndarray


class BoxPairs(NamedTuple):
    """Box pairs (module docstring). Per box: ``box_R`` ``(boxes, 3, 3)``, ``box_t`` ``(boxes, 1, 3)``;
    per pair: its box ``row``, ``R``, ``t``, ``h`` and the shape; ``iab_boxes``: the rows of a per-box
    stack of the points (``row * points + ia``, then ``+ ib``) holding the pairs' ends."""

    members: tuple[int, ...]
    seg: np.ndarray
    row: np.ndarray
    ia: np.ndarray
    ib: np.ndarray
    iab_boxes: np.ndarray
    box_R: np.ndarray
    box_t: np.ndarray
    R: np.ndarray
    t: np.ndarray
    h: np.ndarray
    shapes: tuple[Box, ...]


class RigidCore(NamedTuple):
    """The capsule core of a rigid segment: its joint, its placement in the joint's frame, its coal
    geometry."""

    joint: int
    placement: pin.SE3
    geometry: coal.Capsule


class CoalPairs(NamedTuple):
    """Pairs with a cylinder or a mesh (module docstring): per pair the shape, its coal placement, centre,
    rotation, bounding radius, local extent ``lo``, ``hi`` and the core of a rigid segment (else None)."""

    members: tuple[int, ...]
    seg: np.ndarray
    row: np.ndarray
    ia: np.ndarray
    ib: np.ndarray
    shapes: tuple[Shape, ...]
    transforms: tuple[coal.Transform3s, ...]
    #: per pair, its shape's coal geometry (made once per obstacle with the tables: the tables own them)
    geometries: tuple[coal.CollisionGeometry, ...]
    center: np.ndarray
    R: np.ndarray
    bound: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    cores: tuple[RigidCore | None, ...]


@dataclass(frozen=True, eq=False, slots=True, repr=False)
class ObstacleTables:
    """The pair tables of ``obstacles`` bound to a robot skeleton with ``link_radius`` and ``margin`` (m;
    module docstring); ``m`` pairs; ``sphere_only``: every pair a sphere on a rigid segment (the compiled
    sphere path of :mod:`.sphere_rows`). Per kind, ``members`` are the indices in ``obstacles`` of its
    obstacles."""

    obstacles: tuple[Shape, ...]
    link_radius: float
    margin: float
    skeleton: RobotSkeleton
    offset: float
    spheres: SpherePairs
    capsules: CapsulePairs
    boxes: BoxPairs
    coal_shapes: CoalPairs
    m: int
    sphere_only: bool
    #: :mod:`.clearance_kernel` (the skeleton's: loaded with it, never inside a solve)
    kernel: ModuleType

    @property
    def links(self) -> LinkSkeleton:
        """The skeleton's moving segments (``skeleton.links``)."""
        return self.skeleton.links

    def pair_names(self) -> list[tuple[int, str]]:
        """``(obstacle index, segment name)`` of every pair, in the order of the clearance vector."""
        names = self.skeleton.links.names
        kinds = (self.spheres, self.capsules, self.boxes, self.coal_shapes)
        return [(kind.members[r], names[i]) for kind in kinds
                for r, i in zip(kind.row.tolist(), kind.seg.tolist())]

    def fits(self, obstacles: Sequence[Shape], link_radius: float, margin: float) -> bool:
        """True when these tables are of ``obstacles`` (equal shapes, in order), link radius and margin."""
        return (tuple(obstacles) == self.obstacles and link_radius == self.link_radius
                and margin == self.margin)

    def __repr__(self) -> str:
        return (f"ObstacleTables({len(self.obstacles)} obstacles, {self.m} pairs, "
                f"link_radius={self.link_radius:g}, margin={self.margin:g})")


_I0, _F0, _F03, _F033, _F013 = (np.zeros(0, dtype=int), np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3, 3)),
                                np.zeros((0, 1, 3)))
_frozen(_I0, _F0, _F03, _F033, _F013)
# the records of a kind without pairs (constants: zero-size read-only arrays)
_NO_SPHERES = SpherePairs((), _I0, _I0, _I0, _I0, _I0, _F03, _F0, _F0, _F0, None, None, None, _F03, None)
_NO_CAPSULES = CapsulePairs((), _I0, _I0, _I0, _I0, _F03, _F03, _F0, _F0)
_NO_BOXES = BoxPairs((), _I0, _I0, _I0, _I0, _I0, _F033, _F013, _F033, _F03, _F03, ())
_NO_COAL_PAIRS = CoalPairs((), _I0, _I0, _I0, _I0, (), (), (), _F03, _F033, _F0, _F03, _F03, ())


class _Group(NamedTuple):
    """The obstacles of one kind: ``(obstacle index, shape, segment ids)`` each, and whether every one of them
    is kept clear of the default segments."""

    members: Sequence
    default: bool


#: The group of a kind without obstacles.
_NO_GROUP = _Group((), True)


def obstacle_frames(obstacles: Sequence[Shape]) -> tuple[str, ...]:
    """The frames the obstacles with ``frames`` are kept clear of, each once, in order of appearance."""
    named = [ob.frames for ob in obstacles if ob.frames is not None]
    return tuple(dict.fromkeys(f for frames in named for f in frames)) if named else ()


def build_obstacle_tables(skeleton: RobotSkeleton, obstacles: Sequence[Shape], link_radius: float,
                          margin: float) -> ObstacleTables:
    """The :class:`ObstacleTables` of ``obstacles`` (shapes) on ``skeleton`` with link radius and required
    margin (m); raises :class:`InputError` for an obstacle containing the base. ``skeleton.frames`` must hold
    the frames of every obstacle with ``frames``."""
    groups = _groups(skeleton, obstacles, link_radius)
    offset = link_radius + margin
    spheres = _sphere_pairs(skeleton, groups[0], offset) if groups[0].members else _NO_SPHERES
    capsules = _capsule_pairs(skeleton, groups[1], offset) if groups[1].members else _NO_CAPSULES
    boxes = _box_pairs(skeleton, groups[2]) if groups[2].members else _NO_BOXES
    coal_shapes = _coal_pairs(skeleton, groups[3]) if groups[3].members else _NO_COAL_PAIRS
    m = spheres.seg.size + capsules.seg.size + boxes.seg.size + coal_shapes.seg.size
    sphere_only = spheres.inv_len2 is not None and m == spheres.seg.size
    return ObstacleTables(tuple(obstacles), link_radius, margin, skeleton, offset, spheres, capsules, boxes,
                          coal_shapes, m, sphere_only, skeleton.kernel)


def _groups(skeleton: RobotSkeleton, obstacles: Sequence[Shape], link_radius: float) -> list[_Group]:
    """The four kinds' groups (spheres, capsules, boxes, coal shapes; :data:`_NO_GROUP` for a kind without
    obstacles); checks each obstacle against the base."""
    members: tuple = ([], [], [], [])
    default = [True, True, True, True]
    for k, ob in enumerate(obstacles):
        g = _KIND.get(type(ob))
        if g is None:  # (a subclass)
            g = next((_KIND[kind] for kind in _KIND if isinstance(ob, kind)), 3)
        if ob.frames is None:
            check_base(k, ob, skeleton.base, skeleton.base_ball, link_radius)
            members[g].append((k, ob, None))
        else:
            members[g].append((k, ob, [skeleton.frame_segment(f) for f in ob.frames]))
            default[g] = False
    return [_Group(m, d) if m else _NO_GROUP for m, d in zip(members, default)]


#: The group of each shape type (by exact type; other shapes are the coal shapes).
_KIND = {Sphere: 0, Capsule: 1, Box: 2}


def _pair_index(skeleton: RobotSkeleton, group: _Group) -> PairIndex:
    """The :class:`PairIndex` of ``group`` (not empty): built with the skeleton for a few obstacles kept
    clear of the default segments."""
    if group.default:
        return skeleton.default_pairs(len(group.members))
    n = skeleton.n_default
    ids = [list(range(n)) if ids is None else ids for _, _, ids in group.members]
    seg = np.array([i for one in ids for i in one], dtype=int)
    row = np.array([r for r, one in enumerate(ids) for _ in one], dtype=int)
    return pair_index(skeleton.links, seg, row)


def _per_obstacle(group: _Group, field: Any) -> np.ndarray:
    """``field(obstacle)`` of each obstacle of ``group`` as a float array (one row per obstacle)."""
    return np.array([field(ob) for _, ob, _ in group.members], dtype=float)


def _sphere_pairs(skeleton: RobotSkeleton, group: _Group, offset: float) -> SpherePairs:
    links = skeleton.links
    x = _pair_index(skeleton, group)
    members = group.members
    centers = np.array([ob.center for _, ob, _ in members], dtype=float)
    radius = np.array([ob.radius for _, ob, _ in members], dtype=float)[x.row]
    rigid = links.all_rigid or bool(links.rigid[x.seg].all())
    blocks = (len(members), skeleton.n_default) if group.default else None
    Wk = _moment_matrices(centers) if links.tree is None else None  # (the NumPy rows: no compiled tree)
    r_off = radius + offset if offset else radius  # (read-only arrays: one can serve twice)
    out = SpherePairs(tuple([k for k, _, _ in members]), x.seg, x.row, x.ia, x.ib, x.iab,
                      centers.take(x.row, 0), radius, r_off, r_off * r_off, x.inv_len2 if rigid else None,
                      blocks, None if Wk is None or blocks is not None else Wk[x.row], x.support,
                      None if Wk is None or blocks is None else Wk.reshape(-1, 6))
    _frozen(out.center, radius, r_off, out.r_off2, out.W, out.W_blocks)
    return out


def _moment_matrices(centers: np.ndarray) -> np.ndarray:
    """``W = [I, -[o]x]`` ``(spheres, 3, 6)`` per sphere centre ``o``: ``n^T W = [n, o x n]``."""
    W = np.zeros((len(centers), 3, 6))
    W[:, 0, 0] = W[:, 1, 1] = W[:, 2, 2] = 1.0
    ox, oy, oz = centers.T
    W[:, 0, 4], W[:, 0, 5], W[:, 1, 3], W[:, 1, 5], W[:, 2, 3], W[:, 2, 4] = oz, -oy, -oz, ox, oy, -ox
    return W


def _capsule_pairs(skeleton: RobotSkeleton, group: _Group, offset: float) -> CapsulePairs:
    x = _pair_index(skeleton, group)
    radius = _per_obstacle(group, lambda ob: ob.radius)[x.row]
    out = CapsulePairs(tuple(k for k, _, _ in group.members), x.seg, x.row, x.ia, x.ib,
                       _per_obstacle(group, lambda ob: ob.a)[x.row],
                       _per_obstacle(group, lambda ob: ob.b)[x.row], radius, radius + offset)
    _frozen(out.a, out.b, radius, out.r_off)
    return out


def _box_pairs(skeleton: RobotSkeleton, group: _Group) -> BoxPairs:
    x = _pair_index(skeleton, group)
    row = x.row
    poses = _per_obstacle(group, lambda ob: ob.pose)
    box_R, box_t = poses[:, :3, :3], poses[:, None, :3, 3]  # per box (t: (boxes, 1, 3))
    h = (0.5 * _per_obstacle(group, lambda ob: ob.size)).take(row, 0)
    boxes = [ob for _, ob, _ in group.members]
    out = BoxPairs(tuple([k for k, _, _ in group.members]), x.seg, row, x.ia, x.ib, x.iab_stacked, box_R,
                   box_t, box_R.take(row, 0), poses[:, :3, 3].take(row, 0), h,
                   tuple([boxes[r] for r in row.tolist()]))
    _frozen(box_R, box_t, out.R, out.t, h)
    return out


def _coal_pairs(skeleton: RobotSkeleton, group: _Group) -> CoalPairs:
    x = _pair_index(skeleton, group)
    rows = x.row.tolist()
    placements = [coal_transform(ob.pose) for _, ob, _ in group.members]  # per obstacle once
    geometries = [ob.geometry() for _, ob, _ in group.members]
    poses = _per_obstacle(group, lambda ob: ob.pose).reshape(-1, 4, 4)
    extents = [local_extent(ob) for _, ob, _ in group.members]
    out = CoalPairs(
        tuple(k for k, _, _ in group.members), x.seg, x.row, x.ia, x.ib,
        tuple(group.members[r][1] for r in rows), tuple(placements[r] for r in rows),
        tuple(geometries[r] for r in rows), poses[x.row, :3, 3],
        poses[x.row, :3, :3], _per_obstacle(group, bounding_radius)[x.row],
        np.array([e[0] for e in extents], dtype=float).reshape(-1, 3)[x.row],
        np.array([e[1] for e in extents], dtype=float).reshape(-1, 3)[x.row],
        tuple(_rigid_core(skeleton.links, i) for i in x.seg.tolist()))
    _frozen(out.center, out.R, out.bound, out.lo, out.hi)
    return out


def _rigid_core(links: LinkSkeleton, i: int) -> RigidCore | None:
    """The core of segment ``i`` when both its ends sit on one moving body, else None."""
    if not links.rigid[i] or links.ja[i] == 0:
        return None
    la, lb = links.la[i], links.lb[i]
    length = float(np.linalg.norm(lb - la))
    return RigidCore(int(links.ja[i]), axis_placement(la, lb - la, length), segment_core(length))
