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
import numpy as np
import pinocchio as pin
from typing import TYPE_CHECKING

from kinserve.kinematics.serial_chain import kinematic_tree

from kinserve.ik.constraints.link_segments import frame_points, robot_segments

if TYPE_CHECKING:  # annotations only
    from kinserve.kinematics.robot import Robot


class LinkSkeleton:
    """Segments of a robot as arrays, with their world end points and distance-gradient rows.

    ``segments`` is a list of :class:`~kinserve.ik.constraints.link_segments.LinkSegment`
    (from :func:`robot_segments` / :func:`frame_points`).
    """

    def __init__(self, robot: Robot, segments: list) -> None:
        model = robot.model
        self._model = model
        self.names = [s.name for s in segments]
        self.ja = np.array([s.ja for s in segments], dtype=int)
        self.jb = np.array([s.jb for s in segments], dtype=int)
        self.la = np.array([s.la for s in segments], dtype=float).reshape(-1, 3)
        self.lb = np.array([s.lb for s in segments], dtype=float).reshape(-1, 3)
        self.fixed = (self.ja == 0) & (self.jb == 0)
        # Every end point is read off Pinocchio as cheaply as possible: a joint origin (a translation),
        # the origin of a revolute child joint (its mount point: also a translation), or a point
        # transformed by its joint's placement (SE3.act); world points are constants.
        points: dict = {}
        self._translations: list[int] = []
        self._acts: list[tuple[int, np.ndarray]] = []
        self._world: list[np.ndarray] = []
        revolute_child = {}
        for c in range(1, model.njoints):
            if not model.joints[c].shortname().startswith("JointModelP"):
                revolute_child.setdefault((model.parents[c], tuple(np.round(model.jointPlacements[c].translation, 12))), c)

        def key_of(j, l):
            if j == 0:
                return ("w", tuple(l))
            if not l.any():
                return ("t", j)
            c = revolute_child.get((j, tuple(np.round(l, 12))))
            if c is not None:
                return ("t", c)
            return ("a", j, tuple(l))

        a_idx, b_idx = [], []
        for js, ls, out in ((self.ja, self.la, a_idx), (self.jb, self.lb, b_idx)):
            for j, l in zip(js, ls):
                k = key_of(int(j), l)
                if k not in points:
                    points[k] = len(points)
                out.append(points[k])
        order = sorted(points, key=points.get)
        # stack order: translations, acts, world points; remap indices accordingly
        groups = {"t": [], "a": [], "w": []}
        for k in order:
            groups[k[0]].append(k)
        stacked = groups["t"] + groups["a"] + groups["w"]
        pos = {k: i for i, k in enumerate(stacked)}
        self._a_idx = np.array([pos[order[i]] for i in a_idx], dtype=int)
        self._b_idx = np.array([pos[order[i]] for i in b_idx], dtype=int)
        self._translations = [k[1] for k in groups["t"]]
        self._acts = [(k[1], np.array(k[2])) for k in groups["a"]]
        self._world = [np.array(k[1]) for k in groups["w"]]
        nj = model.njoints
        # support mask: S[j, v] = 1 when velocity index v moves the body of joint j
        S = np.zeros((nj, model.nv))
        for j in range(1, nj):
            for k in model.supports[j]:
                if k == 0:
                    continue
                jm = model.joints[k]
                S[j, jm.idx_v: jm.idx_v + jm.nv] = 1.0
        self.support = S
        self._placements = None
        # segments whose ends sit on one body keep their length: 1 / |b - a|^2 once (0 for a point)
        self.rigid = self.ja == self.jb
        d0 = model.createData()
        pin.forwardKinematics(model, d0, robot.neutral())
        A, B = self.endpoints(d0)
        self._placements = None
        L2 = np.einsum("ij,ij->i", B - A, B - A)
        self.inv_len2 = np.divide(1.0, L2, out=np.zeros_like(L2), where=L2 > 1e-24)

    @classmethod
    def of_robot(cls, robot: Robot, tool_frames: Sequence[str] = (), frames: Sequence[str] | None = None) -> "LinkSkeleton":
        """The default skeleton (links, sliders, a tool segment per tool frame) or the origins of ``frames``."""
        return cls(robot, skeleton_segments(robot, tool_frames, frames))


    def __len__(self) -> int:
        return len(self.names)

    @property
    def tree(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The model's whole tree packed for compiled kernels (:func:`kinserve.kinematics.serial_chain.kinematic_tree`),
        or None when it has joints they do not model."""
        if "_tree" not in self.__dict__:
            self._tree = kinematic_tree(self._model)
        return self._tree

    @property
    def point_table(self) -> tuple[np.ndarray, np.ndarray]:
        """``(joint, local)``: the rows of :meth:`points` as ``(n_points,)`` Pinocchio joint indices and
        ``(n_points, 3)`` points in those joints' frames (joint 0: a world point), for compiled kernels."""
        table = self.__dict__.get("_point_table")
        if table is None:
            joint = [j for j in self._translations] + [j for j, _ in self._acts] + [0] * len(self._world)
            local = [np.zeros(3)] * len(self._translations) + [l for _, l in self._acts] + list(self._world)
            table = self._point_table = (np.array(joint, dtype=np.int64),
                                         np.array(local, dtype=float).reshape(len(joint), 3))
        return table

    def endpoints(self, data: pin.Data) -> tuple[np.ndarray, np.ndarray]:
        """World end points ``(A, B)``, each ``(S, 3)``, after forward kinematics in ``data``."""
        P = self.points(data)
        return P[self._a_idx], P[self._b_idx]

    def end_index(self, seg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Rows of :meth:`points` holding the two ends of the segments ``seg``."""
        return self._a_idx[seg], self._b_idx[seg]

    def points(self, data: pin.Data) -> np.ndarray:
        """The distinct end points of the segments ``(K, 3)`` (see :meth:`end_index`), after forward kinematics."""
        cached = self._placements
        if cached is None or cached[0] is not data:
            # references into data.oMi (they follow every forward-kinematics pass): indexing the
            # Pinocchio vector costs more than reading a placement. The translations are NumPy views
            # of the placements' memory (they follow too); the tuple keeps ``data``, their owner, alive.
            oMi = list(data.oMi)
            cached = self._placements = (data, oMi, [oMi[j].translation for j in self._translations])
        oMi = cached[1]
        pts = cached[2] + [oMi[j].act(l) for j, l in self._acts]
        return np.array(pts + self._world) if self._world else np.array(pts)

    @property
    def all_rigid(self) -> bool:
        """True when no segment slides (every segment's ends on one body), cached."""
        v = self.__dict__.get("_all_rigid")
        if v is None:
            v = self._all_rigid = bool(self.rigid.all())
        return v

    @property
    def n_points(self) -> int:
        """Number of rows of :meth:`points`."""
        return len(self._translations) + len(self._acts) + len(self._world)

    def points_into(self, data: pin.Data, out: np.ndarray) -> None:
        """:meth:`points` written into ``out`` (``(n_points, 3)``): no list of rows, no new array."""
        cached = self._placements
        if cached is None or cached[0] is not data:
            self.points(data)  # (makes the references into data.oMi)
            cached = self._placements
        nt = len(cached[2])
        out[:nt] = cached[2]
        oMi = cached[1]
        for r, (j, l) in enumerate(self._acts, nt):
            out[r] = oMi[j].act(l)
        if self._world:
            out[nt + len(self._acts):] = self._world

    def gradient_rows(self, data: pin.Data, seg: np.ndarray, s: np.ndarray, A: np.ndarray, B: np.ndarray,
                      N: np.ndarray) -> np.ndarray:
        """Rows ``(P, nv)``: ``n_i . xdot_i / qdot`` for the point ``(1 - s_i) a + s_i b`` of segment ``seg_i``.

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


_I1 = [1, 2, 0]
_I2 = [2, 0, 1]


def _cross(U: np.ndarray, V: np.ndarray) -> np.ndarray:
    """Row-wise cross products of ``(P, 3)`` arrays (cheaper than ``np.cross`` on small inputs)."""
    return U[:, _I1] * V[:, _I2] - U[:, _I2] * V[:, _I1]


def skeleton_segments(robot: Robot, tool_frames: Sequence[str] = (), frames: Sequence[str] | None = None) -> list:
    """Segments of the default skeleton (a tool segment per tool frame), or the origins of ``frames``."""
    if frames is not None:
        return frame_points(robot, frames)
    tools = list(dict.fromkeys(tool_frames or (robot.tip,)))
    segs = robot_segments(robot, tools[0])
    for t in tools[1:]:
        segs.append(robot_segments(robot, t)[-1])
    return segs
