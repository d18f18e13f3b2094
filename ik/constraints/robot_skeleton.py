"""The robot body obstacle avoidance keeps clear, for one set of tool frames and frame points.

A :class:`RobotSkeleton` is built once per robot and ``(tool frames, frames)`` by
:func:`build_robot_skeleton` and never changes:

* ``links``: a :class:`~kinserve.ik.constraints.link_capsules.LinkSkeleton` of the segments that move -
  first the default ones (links, sliders, one tool segment per tool frame, :mod:`.link_segments`), then
  one zero-length segment at the origin of each of ``frames`` (the frames an obstacle with ``frames=``
  is kept clear of);
* ``base``: the default segments fixed to the world (both ends on joint 0), with a ball enclosing them:
  an obstacle that reaches them makes every problem infeasible (:mod:`.obstacle_base`).

Building one costs far more than binding obstacles to it (a Pinocchio pass over the model and the
packed tree of the compiled kernels), so the robot's IK state keeps it
(:meth:`kinserve.ik.state.IKState.robot_skeleton`) and hands it to every constraint bound with the same
tool frames and frames. The pair tables bound on a skeleton are immutable and depend only on the
obstacles, the link radius and the margin: the skeleton keeps the last few (:class:`BoundTables`), so a
scene solved again binds by one look-up.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from operator import is_
from types import ModuleType
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from kinserve.ik.constraints.link_capsules import LinkSkeleton, skeleton_segments

if TYPE_CHECKING:  # annotations only
    import pinocchio as pin

    from kinserve.kinematics.robot import Robot

#: Pair tables a skeleton keeps (least recently used dropped first).
TABLES_PER_SKELETON = 16
#: The pair index of 1 .. this many obstacles of one kind kept clear of the default segments is built with the
#: skeleton (more are indexed when bound).
PRECOMPUTED_BLOCKS = 8


class BaseSegment(NamedTuple):
    """A segment fixed to the world: its name and its two end points (m, world, plain floats)."""

    name: str
    a: tuple[float, float, float]
    b: tuple[float, float, float]


class Ball(NamedTuple):
    """A ball: centre (m, world) and radius (m)."""

    center: tuple[float, float, float]
    radius: float


class PairIndex(NamedTuple):
    """(obstacle, segment) pairs of one kind of obstacle: per pair its segment ``seg`` (a row of ``links``),
    its obstacle's row in the kind ``row``, the rows of ``LinkSkeleton.points`` holding its ends ``ia``,
    ``ib`` and both in one index ``iab = [ia, ib]``; ``iab_stacked``: the same rows of a per-obstacle stack
    of the points (``row * points + ia``, then ``+ ib``); ``support``: the support mask of the segment's
    joint ``(pairs, nv)``; ``inv_len2``: ``1 / |b - a|^2`` of the segment (meaningful when its ends sit on
    one body). Read-only."""

    seg: np.ndarray
    row: np.ndarray
    ia: np.ndarray
    ib: np.ndarray
    iab: np.ndarray
    iab_stacked: np.ndarray
    support: np.ndarray
    inv_len2: np.ndarray


def pair_index(links: LinkSkeleton, seg: np.ndarray, row: np.ndarray) -> PairIndex:
    """The :class:`PairIndex` of the pairs ``(row, seg)`` (integer arrays, one entry per pair)."""
    ia, ib = links.end_index(seg)
    n_pts = links.n_points
    index = PairIndex(seg, row, ia, ib, np.concatenate((ia, ib)),
                      np.concatenate((row * n_pts + ia, row * n_pts + ib)), links.support[links.ja[seg]],
                      links.inv_len2[seg])
    for a in index:
        a.setflags(write=False)
    return index


def default_pair_index(links: LinkSkeleton, n_default: int, count: int) -> PairIndex:
    """The :class:`PairIndex` of ``count`` obstacles each kept clear of the default segments
    ``0 .. n_default - 1`` (obstacle by obstacle)."""
    return pair_index(links, np.array(list(range(n_default)) * count, dtype=int),
                      np.repeat(np.arange(count), n_default))


class BoundTables:
    """The pair tables bound last on one skeleton (at most ``size``, least recently used dropped first),
    found by their obstacles - the same shape objects, in order - link radius and margin
    (``tables.obstacles``, ``.link_radius``, ``.margin``). Safe to share between threads: the tables are
    immutable.

    Identity, not value: hashing new shapes by value costs more than binding them; equal shapes that are other
    objects are bound afresh (and get equal tables). ``first_ids`` counts the entries by the identity of
    their first obstacle (held alive by the entry, so the identity is its own): a new obstacle set misses at
    one look-up.
    """

    def __init__(self, size: int = TABLES_PER_SKELETON) -> None:
        self.size = size
        self.lock = threading.Lock()
        self.entries: list[Any] = []
        self.first_ids: dict[int, int] = {}

    def find(self, obstacles: Sequence[Any], link_radius: float, margin: float) -> Any | None:
        """The tables of exactly these obstacle objects, link radius and margin, or None."""
        n = len(obstacles)
        first = obstacles[0] if n else None
        if id(first) not in self.first_ids:
            return None
        with self.lock:
            entries = self.entries
            for i in range(len(entries) - 1, -1, -1):
                obs = entries[i].obstacles
                if len(obs) == n and (not n or obs[0] is first) \
                        and all(map(is_, obs, obstacles)) \
                        and entries[i].link_radius == link_radius and entries[i].margin == margin:
                    tables = entries[i]
                    if i != len(entries) - 1:
                        entries.append(entries.pop(i))
                    return tables
        return None

    def add(self, tables: Any) -> None:
        """Keep ``tables`` (dropping the least recently used beyond ``size``)."""
        with self.lock:
            self.entries.append(tables)
            self._count(tables, 1)
            while len(self.entries) > self.size:
                self._count(self.entries.pop(0), -1)

    def _count(self, tables: Any, change: int) -> None:
        key = id(tables.obstacles[0] if tables.obstacles else None)
        count = self.first_ids.get(key, 0) + change
        if count:
            self.first_ids[key] = count
        else:
            del self.first_ids[key]


class RobotSkeleton:
    """The moving segments and the fixed base of a robot for one ``(tool_frames, frames)`` (module docstring).

    Attributes are set once by :func:`build_robot_skeleton` and only read afterwards; ``bound_tables`` keeps
    the pair tables bound on it; ``kernel``: :mod:`.clearance_kernel` (Numba and the compiled code, loaded
    with the skeleton: never inside a solve's time budget).
    """

    __slots__ = ("model", "tool_frames", "frames", "links", "n_default", "base", "base_ball", "bound_tables",
                 "_default_pairs", "kernel")

    def __init__(self, model: pin.Model, tool_frames: tuple[str, ...], frames: tuple[str, ...],
                 links: LinkSkeleton, n_default: int, base: tuple[BaseSegment, ...]) -> None:
        self.model = model
        self.tool_frames = tool_frames
        self.frames = frames
        self.links = links
        #: segments ``0 .. n_default - 1`` of ``links`` are the default ones, then one per frame of ``frames``
        self.n_default = n_default
        self.base = base
        self.base_ball = enclosing_ball(base) if base else None
        self.bound_tables = BoundTables()
        self._default_pairs = tuple(default_pair_index(links, n_default, k)
                                    for k in range(1, PRECOMPUTED_BLOCKS + 1))
        from kinserve.ik.constraints import clearance_kernel

        self.kernel: ModuleType = clearance_kernel

    def matches(self, robot: Robot, tool_frames: Sequence[str], frames: Sequence[str]) -> bool:
        """True when this skeleton is ``robot``'s for these tool frames and frames."""
        return (self.model is robot.model and self.tool_frames == tuple(tool_frames)
                and self.frames == tuple(frames))

    def default_pairs(self, count: int) -> PairIndex:
        """The :class:`PairIndex` of ``count`` (>= 1) obstacles of one kind kept clear of the default
        segments."""
        if count <= len(self._default_pairs):
            return self._default_pairs[count - 1]
        return default_pair_index(self.links, self.n_default, count)

    def frame_segment(self, frame: str) -> int:
        """Index in ``links`` of the zero-length segment at the origin of ``frame`` (one of ``frames``)."""
        return self.n_default + self.frames.index(frame)

    def __repr__(self) -> str:
        return (f"RobotSkeleton({len(self.links)} segments, tool_frames={self.tool_frames}, "
                f"frames={self.frames}, "
                f"{len(self.base)} base segments)")


def enclosing_ball(segments: Sequence[BaseSegment]) -> Ball:
    """A ball enclosing the segments: centred on their end points' bounding box, reaching the farthest one."""
    pts = np.array([p for s in segments for p in (s.a, s.b)], dtype=float)
    c = 0.5 * (pts.min(axis=0) + pts.max(axis=0))
    return Ball(tuple(c.tolist()), float(np.linalg.norm(pts - c, axis=1).max()))


def build_robot_skeleton(robot: Robot, tool_frames: Sequence[str],
                         frames: Sequence[str] = ()) -> RobotSkeleton:
    """The :class:`RobotSkeleton` of ``robot`` with a tool segment per tool frame and a point per frame.

    Unknown frame names raise :class:`~kinserve.kinematics.errors.FrameError`.
    """
    tools, frames = tuple(tool_frames), tuple(frames)
    for f in tools:
        robot.frame_id(f)
    segs = skeleton_segments(robot, tools)
    moving = [s for s in segs if not s.fixed]
    base = tuple(BaseSegment(s.name, tuple(s.la.tolist()), tuple(s.lb.tolist())) for s in segs if s.fixed)
    points = skeleton_segments(robot, frames=frames) if frames else []
    return RobotSkeleton(robot.model, tools, frames, LinkSkeleton(robot, moving + points), len(moving), base)
