"""``ObstacleAvoidance``: any solid shape kept clear of the robot's links, hard on every iterate.

The robot body is its skeleton of segments, each the core of a capsule of
radius ``link_radius`` (:mod:`.link_capsules`; ``link_radius=0`` = bare
segments). An obstacle with ``frames`` set is kept clear of those frame
origins only. For every (obstacle, segment) pair the **clearance** is

    c = d(segment core, obstacle) - link_radius - margin        (m)

where ``d`` is the Euclidean distance (negative when they overlap):

* sphere (centre ``o``, radius ``r``): point-segment closed form,
  ``d = |x - o| - r``;
* capsule (core ``[p, q]``, radius ``r``): segment-segment closed form,
  ``d = |x - y| - r``;
* box, cylinder, mesh (convex hull): coal's GJK/EPA distance between the
  obstacle and the segment, with witness points and normal. A bounding
  sphere gives a cheap lower bound first; pairs farther than ``influence``
  by that bound are not sent to coal.

Both closed forms are evaluated for all pairs at once (NumPy, no loop over
pairs). With ``x`` the witness point on the segment (parameter ``s``) and
``n`` the unit normal pointing from the obstacle to ``x``, the clearance
gradient is ``g = n^T ((1 - s) J_a + s J_b)`` (:meth:`LinkSkeleton.gradient_rows`)
and the constraint row is the velocity damper

    g^T dq >= -xi c                    (xi = ``gain``, default 0.5)

so a step consumes at most the fraction ``xi`` of the clearance, and a
negative clearance (a start in collision) must grow. Rows are returned for
the pairs with ``c < influence`` only (the others cannot bind a step of
reasonable size; the true check after the step covers every pair).
``margin(q)`` is the smallest clearance over all pairs.

An obstacle that contains a part of the robot fixed to the world (its base
segments) makes the problem infeasible: :class:`InputError` at ``bind``.
"""

from __future__ import annotations

import math

import numpy as np

from kinserve.kinematics.errors import InputError
from kinserve.kinematics.shapes import Box, Capsule, Cylinder, Mesh, Shape, Sphere, as_shape

from .base import DAMPER_GAIN, Constraint
from .link_capsules import LinkSkeleton
from .segment_distance import point_segment, segment_segment

#: Pairs whose clearance is below this (m) contribute rows to the QP.
INFLUENCE = 0.3

_EPS = 1e-12


def as_obstacle(value, name: str = "obstacle") -> Shape:
    """A shape from a shape, a ``{"kind": ...}`` dict, a ``{"center", "radius"}`` dict or a ``(center, radius)`` pair."""
    if isinstance(value, Shape):
        return value
    if isinstance(value, dict) and "kind" not in value:
        if "center" in value and "radius" in value:
            return Sphere(value["center"], value["radius"], value.get("frames"))
        raise InputError(f"{name} dict needs a 'kind' ({', '.join(('sphere', 'box', 'capsule', 'cylinder', 'mesh'))}) "
                         f"or 'center' and 'radius', got keys {sorted(value)}")
    if isinstance(value, dict):
        return as_shape(value, name)
    try:
        center, radius = value
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a shape (ik.Sphere, ik.Box, ik.Capsule, ik.Cylinder, ik.Mesh), "
                         f"a dict or a (center, radius) pair, got {value!r}") from None
    return Sphere(center, radius)


def _bounding_radius(shape: Shape) -> float:
    if isinstance(shape, Box):
        return float(np.linalg.norm(shape.half_extents))
    if isinstance(shape, Cylinder):
        return math.hypot(shape.radius, 0.5 * shape.length)
    if isinstance(shape, Mesh):
        return float(np.linalg.norm(shape.hull_vertices, axis=1).max())
    raise TypeError(type(shape).__name__)


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

    def __init__(self, obstacles, link_radius: float = 0.0, margin: float = 0.0, gain: float = DAMPER_GAIN,
                 tool_frames=None, influence: float = INFLUENCE):
        super().__init__(name="obstacles")
        if isinstance(obstacles, (Shape, dict)):
            obstacles = [obstacles]
        try:
            items = list(obstacles)
        except TypeError:
            raise InputError(f"obstacles must be a sequence of shapes, got {obstacles!r}") from None
        self.obstacles = [as_obstacle(o, f"obstacles[{i}]") for i, o in enumerate(items)]
        self.link_radius = _non_negative(link_radius, "link_radius")
        self.margin_required = _non_negative(margin, "margin")
        if isinstance(gain, bool) or not isinstance(gain, (int, float)) or not (0.0 < gain <= 1.0):
            raise InputError(f"gain (velocity damper xi) must be in (0, 1], got {gain!r}")
        self.gain = float(gain)
        if isinstance(tool_frames, str):
            tool_frames = (tool_frames,)
        self.tool_frames = None if tool_frames is None else tuple(tool_frames)
        self.influence = _non_negative(influence, "influence")
        self._model = None

    # ---------------------------------------------------------------------------------------- binding
    def bind(self, robot) -> "ObstacleAvoidance":
        if self._model is robot.model:
            return self
        tools = self.tool_frames or (robot.tip,)
        for f in tools:
            robot.frame_id(f)
        body = LinkSkeleton.of_robot(robot, tools)
        segs_default = [i for i in range(len(body)) if not body.fixed[i]]
        # one skeleton holding the default segments and the frame points of obstacles with `frames`
        extra = []
        for ob in self.obstacles:
            if ob.frames is not None:
                extra.extend(ob.frames)
        all_segs = list(_segments_of(body))
        frame_index = {}
        if extra:
            pts = LinkSkeleton.of_robot(robot, frames=list(dict.fromkeys(extra)))
            for k, name in enumerate(dict.fromkeys(extra)):
                frame_index[name] = len(all_segs)
                all_segs.append(_segments_of(pts)[k])
        self.skeleton = sk = LinkSkeleton(robot, all_segs)
        sph, cap, other = ([], [], []), ([], [], [], []), ([], [], [])
        fixed_pairs = []
        self.pair_names = []
        pair_obstacle = []
        for k, ob in enumerate(self.obstacles):
            seg_ids = segs_default if ob.frames is None else [frame_index[f] for f in ob.frames]
            if ob.frames is None:
                fixed_pairs.extend((k, i) for i in range(len(body)) if body.fixed[i])
            for i in seg_ids:
                pair_obstacle.append(k)
                self.pair_names.append((k, sk.names[i]))
                if isinstance(ob, Sphere):
                    sph[0].append(i), sph[1].append(ob.center), sph[2].append(ob.radius)
                elif isinstance(ob, Capsule):
                    cap[0].append(i), cap[1].append(ob.a), cap[2].append(ob.b), cap[3].append(ob.radius)
                else:
                    other[0].append(i), other[1].append(ob), other[2].append(_bounding_radius(ob))
        # pairs are ordered: spheres, capsules, others (the order of the clearance vector)
        order = ([p for p, k in enumerate(pair_obstacle) if isinstance(self.obstacles[k], Sphere)]
                 + [p for p, k in enumerate(pair_obstacle) if isinstance(self.obstacles[k], Capsule)]
                 + [p for p, k in enumerate(pair_obstacle) if not isinstance(self.obstacles[k], (Sphere, Capsule))])
        self.pair_names = [self.pair_names[p] for p in order]
        self._sph_seg = np.array(sph[0], dtype=int)
        self._sph_c = np.array(sph[1], dtype=float).reshape(-1, 3)
        self._sph_r = np.array(sph[2], dtype=float)
        self._cap_seg = np.array(cap[0], dtype=int)
        self._cap_a = np.array(cap[1], dtype=float).reshape(-1, 3)
        self._cap_b = np.array(cap[2], dtype=float).reshape(-1, 3)
        self._cap_r = np.array(cap[3], dtype=float)
        self._oth_seg = np.array(other[0], dtype=int)
        self._oth = other[1]
        self._oth_center = np.array([o.pose[:3, 3] for o in other[1]], dtype=float).reshape(-1, 3)
        self._oth_bound = np.array(other[2], dtype=float)
        self._oth_tf = [_coal_transform(o.pose) for o in other[1]]
        self.m = len(self.pair_names)
        self._offset = self.link_radius + self.margin_required
        self._model = robot.model
        self._check_base(robot, body, fixed_pairs)
        return self

    def _check_base(self, robot, body, fixed_pairs):
        if not fixed_pairs:
            return
        data = robot.model.createData()
        A, B = body.endpoints(data)  # fixed segments do not depend on q
        for k, i in fixed_pairs:
            ob = self.obstacles[k]
            pts = A[i] + np.linspace(0.0, 1.0, 33)[:, None] * (B[i] - A[i])
            if float(ob.signed_distance(pts).min()) < self.link_radius:
                raise InputError(
                    f"obstacles[{k}] ({ob!r}) contains the robot base ({body.names[i]}); the base cannot move out of it"
                )

    # ------------------------------------------------------------------------------------- distances
    def _pairs(self, data, witness: bool, cutoff: float = math.inf):
        """Clearances ``(m,)`` and, with ``witness``, ``(seg, s, N)`` of every pair (see the module docstring)."""
        A, B = self.skeleton.endpoints(data)
        clear, segs, ss, Ns = [], [], [], []
        if self._sph_seg.size:
            i = self._sph_seg
            s, X = point_segment(A[i], B[i], self._sph_c)
            V = X - self._sph_c
            d = np.sqrt(np.einsum("ij,ij->i", V, V))
            clear.append(d - self._sph_r)
            if witness:
                segs.append(i), ss.append(s), Ns.append(_unit(V, d))
        if self._cap_seg.size:
            i = self._cap_seg
            s, _, X, Y = segment_segment(A[i], B[i], self._cap_a, self._cap_b)
            V = X - Y
            d = np.sqrt(np.einsum("ij,ij->i", V, V))
            clear.append(d - self._cap_r)
            if witness:
                segs.append(i), ss.append(s), Ns.append(_unit(V, d))
        if self._oth_seg.size:
            c, s, N = self._coal_pairs(A, B, cutoff)
            clear.append(c)
            if witness:
                segs.append(self._oth_seg), ss.append(s), Ns.append(N)
        c = np.concatenate(clear) - self._offset if clear else np.zeros(0)
        if not witness:
            return c, A, B
        return c, A, B, np.concatenate(segs), np.concatenate(ss), np.concatenate(Ns)

    def _coal_pairs(self, A, B, cutoff):
        import coal

        i = self._oth_seg
        # lower bound: distance from the segment to the bounding sphere
        _, X = point_segment(A[i], B[i], self._oth_center)
        lb = np.linalg.norm(X - self._oth_center, axis=1) - self._oth_bound
        c = lb.copy()
        s = np.zeros(len(i))
        N = np.zeros((len(i), 3))
        req = coal.DistanceRequest()
        res = coal.DistanceResult()
        far = cutoff + self._offset
        for p in np.flatnonzero(lb < far):
            a, b = A[i[p]], B[i[p]]
            ab = b - a
            L = math.sqrt(ab.dot(ab))
            geom = coal.Capsule(0.0, L)
            res.clear()
            d = coal.distance(self._oth[p].geometry(), self._oth_tf[p], geom, _segment_transform(a, ab, L), req, res)
            c[p] = d
            x = res.getNearestPoint2()
            s[p] = 0.0 if L < _EPS else min(max(float((x - a).dot(ab)) / (L * L), 0.0), 1.0)
            N[p] = res.normal
        return c, s, N

    def clearances(self, data) -> np.ndarray:
        """Clearance ``c`` (m) of every pair after forward kinematics (far coal pairs: their lower bound)."""
        return self._pairs(data, False, self.influence)[0]

    # ------------------------------------------------------------------------------------- protocol
    def margin(self, robot, data, q) -> float:
        c = self._pairs(data, False, self.influence)[0]
        return float(c.min()) if c.size else math.inf

    def rows(self, robot, data, q, dt=None):
        c, A, B, seg, s, N = self._pairs(data, True, self.influence)
        near = np.flatnonzero(c < self.influence)
        if near.size == 0:
            return np.zeros((0, robot.model.nv)), np.zeros(0), np.zeros(0)
        seg, s, N = seg[near], s[near], N[near]
        G = self.skeleton.gradient_rows(data, seg, s, A[seg], B[seg], N)
        lower = -self.gain * c[near]
        return G, lower, np.full(near.size, np.inf)

    def rows_all(self, robot, data):
        """``(c, G)`` for every pair (tests, diagnostics); needs ``computeJointJacobians``."""
        c, A, B, seg, s, N = self._pairs(data, True, math.inf)
        return c, self.skeleton.gradient_rows(data, seg, s, A[seg], B[seg], N)

    def describe(self, robot, data, q) -> str:
        c = self._pairs(data, False, math.inf)[0]
        parts = []
        for p in np.flatnonzero(c < 0.0):
            k, seg = self.pair_names[p]
            parts.append(f"obstacles[{k}] ({self.obstacles[k].kind}) is entered by {seg} by {-c[p]:.4g} m")
        return "; ".join(parts)

    def __repr__(self) -> str:
        return (f"ObstacleAvoidance({len(self.obstacles)} obstacles, link_radius={self.link_radius:g}, "
                f"margin={self.margin_required:g})")


def _segments_of(skeleton: LinkSkeleton):
    from .sphere_set import _Segment

    return [_Segment(skeleton.names[i], skeleton.ja[i], skeleton.la[i], skeleton.jb[i], skeleton.lb[i])
            for i in range(len(skeleton))]


def _unit(V: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Rows of ``V`` divided by ``d`` (zero rows where ``d`` is 0: no defined direction)."""
    out = np.zeros_like(V)
    np.divide(V, d[:, None], out=out, where=d[:, None] > _EPS)
    return out


def _non_negative(value, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise InputError(f"{name} must be a number >= 0 (m), got {value!r}")
    v = float(value)
    if not math.isfinite(v) or v < 0.0:
        raise InputError(f"{name} must be a finite number >= 0 (m), got {value!r}")
    return v


def _coal_transform(T: np.ndarray):
    import coal

    tf = coal.Transform3s()
    tf.setRotation(np.ascontiguousarray(T[:3, :3]))
    tf.setTranslation(np.ascontiguousarray(T[:3, 3]))
    return tf


def _segment_transform(a: np.ndarray, ab: np.ndarray, L: float):
    """coal placement of a capsule core ``[a, a + ab]``: centre at the midpoint, local z along ``ab``."""
    import coal

    tf = coal.Transform3s()
    if L > _EPS:
        z = ab / L
        helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        x = np.cross(helper, z)
        x /= np.linalg.norm(x)
        tf.setRotation(np.column_stack([x, np.cross(z, x), z]))
    tf.setTranslation(a + 0.5 * ab)
    return tf
