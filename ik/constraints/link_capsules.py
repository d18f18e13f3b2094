"""The robot body used for obstacle avoidance: its skeleton segments as capsules of radius ``link_radius``.

Segments (see :mod:`.link_segments`): every link
between consecutive joint origins, the sliding segment of each prismatic
joint, and a tool segment from each tool frame's parent joint to the tool
frame origin. Each segment is the core of a capsule of radius
``link_radius`` (m); ``link_radius = 0`` keeps the historical behaviour
(bare segments: inflate the obstacles by hand to account for link
thickness). A segment is a pair of body points ``(joint j_a, local point
l_a)``, ``(joint j_b, local point l_b)``; joint 0 is the world.

Kinematics of a point: a point ``x`` fixed to the body of joint ``j``
moves with ``xdot = sum_k (v_k + w_k x x) qdot_k`` over the joints ``k``
supporting ``j``, where ``(v_k; w_k)`` is column ``k`` of Pinocchio's
WORLD joint Jacobian ``data.J`` (after ``computeJointJacobians``). So for a
unit direction ``n``

    n . xdot = sum_k (n . v_k + (x x n) . w_k) qdot_k,

computed for all pairs at once as ``N J_v + (X x N) J_w`` masked by the
support of ``j``. For the closest point ``x = (1 - s) a + s b`` of a
segment whose ends sit on different bodies (a slider), ``s`` held fixed,
``xdot = (1 - s) adot + s bdot`` (the envelope theorem makes the distance
gradient exact to first order with ``s`` frozen).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import pinocchio as pin

from kinserve.ik.constraints.link_segments import frame_points, robot_segments
from kinserve.kinematics.serial_chain import kinematic_tree

if TYPE_CHECKING:  # annotations only
    from kinserve.kinematics.robot import Robot


class LinkSkeleton:
    """Segments of a robot as arrays, with their world end points and distance-gradient rows.

    ``segments`` is a list of :class:`~kinserve.ik.constraints.link_segments.LinkSegment`
    (from :func:`robot_segments` / :func:`frame_points`).
    """

    def __init__(self, robot: Robot, segments: list) -> None:
        model = robot.model
        self.model = model
        self.names = [s.name for s in segments]
        self.ja = np.array([s.ja for s in segments], dtype=int)
        self.jb = np.array([s.jb for s in segments], dtype=int)
        self.la = np.array([s.la for s in segments], dtype=float).reshape(-1, 3)
        self.lb = np.array([s.lb for s in segments], dtype=float).reshape(-1, 3)
        self.fixed = (self.ja == 0) & (self.jb == 0)
        layout = _point_layout(model, self.ja, self.la, self.jb, self.lb)
        self._translations, self._acts, self._world = layout.translations, layout.acts, layout.world
        self._a_idx, self._b_idx = layout.a_idx, layout.b_idx
        self.support = support_mask(model)
        #: ``(data, joint placements, translations)``: references into the ``data.oMi`` read last
        #: (:meth:`points`)
        self._placements: tuple | None = None
        # segments whose ends sit on one body keep their length: 1 / |b - a|^2 once (0 for a point)
        self.rigid = self.ja == self.jb
        self.all_rigid = bool(self.rigid.all())
        d0 = model.createData()
        pin.forwardKinematics(model, d0, robot.neutral())
        A, B = self.endpoints(d0)
        self._placements = None
        L2 = np.einsum("ij,ij->i", B - A, B - A)
        self.inv_len2 = np.divide(1.0, L2, out=np.zeros_like(L2), where=L2 > 1e-24)
        #: the model's whole tree packed for compiled kernels (:func:`kinematic_tree`), or None when it has
        #: joints they do not model
        self.tree: tuple[np.ndarray, np.ndarray] | None = kinematic_tree(model)
        joint = list(self._translations) + [j for j, _ in self._acts] + [0] * len(self._world)
        local = [np.zeros(3)] * len(self._translations) + [p for _, p in self._acts] + list(self._world)
        #: ``(joint, local)``: the rows of :meth:`points` as ``(n_points,)`` Pinocchio joint indices and
        #: ``(n_points, 3)`` points in those joints' frames (joint 0: a world point), for compiled kernels
        self.point_table: tuple[np.ndarray, np.ndarray] = (
            np.array(joint, dtype=np.int64), np.array(local, dtype=float).reshape(len(joint), 3))
        for a in (*self.point_table, *(self.tree or ()), self.support, self.inv_len2, self.rigid, self.ja,
                  self.jb, self.la, self.lb, self._a_idx, self._b_idx):
            a.setflags(write=False)  # shared by every constraint bound with this skeleton

    @classmethod
    def of_robot(cls, robot: Robot, tool_frames: Sequence[str] = (),
                 frames: Sequence[str] | None = None) -> LinkSkeleton:
        """The default skeleton (links, sliders, a tool segment per tool frame) or the origins of
        ``frames``."""
        return cls(robot, skeleton_segments(robot, tool_frames, frames))

    def __len__(self) -> int:
        return len(self.names)

    def endpoints(self, data: pin.Data) -> tuple[np.ndarray, np.ndarray]:
        """World end points ``(A, B)``, each ``(S, 3)``, after forward kinematics in ``data``."""
        P = self.points(data)
        return P[self._a_idx], P[self._b_idx]

    def end_index(self, seg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Rows of :meth:`points` holding the two ends of the segments ``seg``."""
        return self._a_idx[seg], self._b_idx[seg]

    def _references(self, data: pin.Data) -> tuple:
        """``(data, joint placements, translations)``: references into ``data.oMi``, made once per ``data``.

        They follow every forward-kinematics pass: indexing the Pinocchio vector costs more than reading a
        placement. The translations are NumPy views of the placements' memory (they follow too); the tuple
        keeps ``data``, their owner, alive.
        """
        cached = self._placements
        if cached is None or cached[0] is not data:
            oMi = list(data.oMi)
            cached = self._placements = (data, oMi, [oMi[j].translation for j in self._translations])
        return cached

    def joint_placements(self, data: pin.Data) -> list[pin.SE3]:
        """The joints' world placements ``data.oMi`` as a list (references: they follow forward
        kinematics)."""
        return self._references(data)[1]

    def points(self, data: pin.Data) -> np.ndarray:
        """The distinct end points of the segments ``(K, 3)`` (see :meth:`end_index`), after forward
        kinematics."""
        _, oMi, translations = self._references(data)
        pts = translations + [oMi[j].act(p) for j, p in self._acts]
        return np.array(pts + self._world) if self._world else np.array(pts)

    @property
    def n_points(self) -> int:
        """Number of rows of :meth:`points`."""
        return len(self._translations) + len(self._acts) + len(self._world)

    def points_into(self, data: pin.Data, out: np.ndarray) -> None:
        """:meth:`points` written into ``out`` (``(n_points, 3)``): no list of rows, no new array."""
        _, oMi, translations = self._references(data)
        nt = len(translations)
        out[:nt] = translations
        for r, (j, p) in enumerate(self._acts, nt):
            out[r] = oMi[j].act(p)
        if self._world:
            out[nt + len(self._acts):] = self._world

    def gradient_rows(self, data: pin.Data, seg: np.ndarray, s: np.ndarray, A: np.ndarray, B: np.ndarray,
                      N: np.ndarray) -> np.ndarray:
        """Rows ``(P, nv)``: ``n_i . xdot_i / qdot`` for the point ``(1 - s_i) a + s_i b`` of segment
        ``seg_i``.

        ``A``, ``B`` are the end points of the segments ``seg`` (``(P, 3)``),
        ``N`` the unit directions. Needs ``computeJointJacobians`` in ``data``.
        """
        Jv, Jw = data.J[:3], data.J[3:]
        ja, jb = self.ja[seg], self.jb[seg]
        if (ja == jb).all():  # both ends on one body (no slider): the witness point itself
            X = A + s[:, None] * (B - A)
            return (N.dot(Jv) + _cross(X, N).dot(Jw)) * self.support[ja]
        NJv = N.dot(Jv)
        rows_a = (NJv + _cross(A, N).dot(Jw)) * self.support[ja]
        rows_b = (NJv + _cross(B, N).dot(Jw)) * self.support[jb]
        return (1.0 - s)[:, None] * rows_a + s[:, None] * rows_b


class PointLayout(NamedTuple):
    """The distinct end points of a skeleton's segments, stacked: joint origins (``translations``: joint
    indices), points moved by their joint's placement (``acts``: ``(joint, local point)``), world points; and
    the row of each segment's two ends (``a_idx``, ``b_idx``)."""

    translations: list[int]
    acts: list[tuple[int, np.ndarray]]
    world: list[np.ndarray]
    a_idx: np.ndarray
    b_idx: np.ndarray


def _point_layout(model: pin.Model, ja: np.ndarray, la: np.ndarray, jb: np.ndarray,
                  lb: np.ndarray) -> PointLayout:
    """Every end point read off Pinocchio as cheaply as possible: a joint origin (a translation), the origin
    of a revolute child joint (its mount point: also a translation), or a point transformed by its joint's
    placement (SE3.act); world points are constants."""
    revolute_child = {}
    for c in range(1, model.njoints):
        if not model.joints[c].shortname().startswith("JointModelP"):
            mount = tuple(np.round(model.jointPlacements[c].translation, 12))
            revolute_child.setdefault((model.parents[c], mount), c)

    def key_of(j: int, p: np.ndarray) -> tuple:
        if j == 0:
            return ("w", tuple(p))
        if not p.any():
            return ("t", j)
        c = revolute_child.get((j, tuple(np.round(p, 12))))
        return ("t", c) if c is not None else ("a", j, tuple(p))

    points: dict = {}
    a_idx, b_idx = [], []
    for js, ps, out in ((ja, la, a_idx), (jb, lb, b_idx)):
        for j, p in zip(js, ps):
            k = key_of(int(j), p)
            if k not in points:
                points[k] = len(points)
            out.append(points[k])
    order = sorted(points, key=points.get)
    # stack order: translations, acts, world points; remap indices accordingly
    groups: dict = {"t": [], "a": [], "w": []}
    for k in order:
        groups[k[0]].append(k)
    pos = {k: i for i, k in enumerate(groups["t"] + groups["a"] + groups["w"])}
    return PointLayout([k[1] for k in groups["t"]], [(k[1], np.array(k[2])) for k in groups["a"]],
                       [np.array(k[1]) for k in groups["w"]],
                       np.array([pos[order[i]] for i in a_idx], dtype=int),
                       np.array([pos[order[i]] for i in b_idx], dtype=int))


def support_mask(model: pin.Model) -> np.ndarray:
    """``S`` ``(njoints, nv)``: ``S[j, v] = 1`` when velocity index ``v`` moves the body of joint ``j``."""
    S = np.zeros((model.njoints, model.nv))
    for j in range(1, model.njoints):
        for k in model.supports[j]:
            if k == 0:
                continue
            jm = model.joints[k]
            S[j, jm.idx_v: jm.idx_v + jm.nv] = 1.0
    return S


_I1 = [1, 2, 0]
_I2 = [2, 0, 1]


def _cross(U: np.ndarray, V: np.ndarray) -> np.ndarray:
    """Row-wise cross products of ``(P, 3)`` arrays (cheaper than ``np.cross`` on small inputs)."""
    return U[:, _I1] * V[:, _I2] - U[:, _I2] * V[:, _I1]


def skeleton_segments(robot: Robot, tool_frames: Sequence[str] = (),
                      frames: Sequence[str] | None = None) -> list:
    """Segments of the default skeleton (a tool segment per tool frame), or the origins of ``frames``."""
    if frames is not None:
        return frame_points(robot, frames)
    tools = list(dict.fromkeys(tool_frames or (robot.tip,)))
    segs = robot_segments(robot, tools[0])
    for t in tools[1:]:
        segs.append(robot_segments(robot, t)[-1])
    return segs
