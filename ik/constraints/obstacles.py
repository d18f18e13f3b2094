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
* box (pose ``(R, t)``, half extents ``h``): the exact closed form of
  :func:`.segment_distance.segment_box` on the segment in the box's frame
  (``a = R^T (A - t)``), vectorised over all pairs; a segment that meets the
  box gets coal's signed (penetration) distance instead;
* cylinder, mesh (convex hull): coal's GJK/EPA distance between the
  obstacle and the segment, with witness points and normal. Two cheap lower
  bounds come first - the distance to a bounding sphere and the largest gap
  between the segment's and the obstacle's extents along the obstacle's own
  axes (separating axes); pairs farther than ``influence``
  by that bound are not sent to coal (``margin`` uses :data:`MARGIN_EXACT`: it is
  exact below 5 cm and a lower bound above, which is all the step back-off needs).

The closed forms are evaluated for all pairs at once (NumPy, no loop over
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

from collections.abc import Sequence
import math
from typing import TYPE_CHECKING, Any
import weakref

import numpy as np

from kinserve.kinematics.errors import InputError
from kinserve.kinematics.shapes import Box, Capsule, Cylinder, Mesh, Shape, Sphere, as_shape

from kinserve.ik import numpy_fast
from kinserve.ik.constraints.base import DAMPER_GAIN, Constraint
from kinserve.ik.constraints.link_capsules import LinkSkeleton, skeleton_segments
from kinserve.ik.constraints.segment_distance import point_segment, segment_box, segment_box_distance, segment_segment

#: Pairs whose clearance is below this (m) contribute rows to the QP.
INFLUENCE = 0.3
#: The true check computes coal distances exactly only for pairs whose bounding-sphere bound is below this (m).
MARGIN_EXACT = 0.05
#: Coal pairs (box, cylinder, mesh) give rows when their bounding-sphere bound is below this (m).
COAL_INFLUENCE = 0.15

_EPS = 1e-12
_NO_INT, _NO_1, _NO_3, _NO_R = np.zeros(0, dtype=int), np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3, 3))
for _a in (_NO_INT, _NO_1, _NO_3, _NO_R):  # shared empty arrays of absent pair groups (read-only)
    _a.flags.writeable = False
_INF = np.full(4096, np.inf)
_INF.flags.writeable = False  # shared upper bounds of the damper rows (read-only)
_einsum = numpy_fast.einsum
_min = np.minimum.reduce
_matmul = np.matmul
_sqrt = np.sqrt
_fmax = np.fmax
_clip = numpy_fast.clip

if TYPE_CHECKING:  # annotations only
    import pinocchio as pin

    from kinserve.kinematics.robot import Robot


def as_obstacle(value: Any, name: str = "obstacle") -> Shape:
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


def _local_extent(shape: Shape) -> tuple[np.ndarray, np.ndarray]:
    """Corners ``(lo, hi)`` of the shape's bounding box in its own frame."""
    if isinstance(shape, Box):
        h = shape.half_extents
    elif isinstance(shape, Cylinder):
        h = np.array([shape.radius, shape.radius, 0.5 * shape.length])
    else:  # mesh: the hull's vertices
        return shape.hull_vertices.min(axis=0), shape.hull_vertices.max(axis=0)
    return -h, h


def _bounding_radius(shape: Shape) -> float:
    if isinstance(shape, Box):
        x, y, z = shape.size  # half the diagonal, on floats (a NumPy norm costs more than the rest of the check)
        return 0.5 * math.sqrt(x * x + y * y + z * z)
    if isinstance(shape, Cylinder):
        return math.hypot(shape.radius, 0.5 * shape.length)
    if isinstance(shape, Mesh):
        return float(np.linalg.norm(shape.hull_vertices, axis=1).max())
    raise TypeError(type(shape).__name__)


_kernel_module = None


def _clearance_kernel():
    """:mod:`.clearance_kernel`, imported on first use (it imports Numba and loads its compiled code)."""
    global _kernel_module
    if _kernel_module is None:
        from kinserve.ik.constraints import clearance_kernel

        _kernel_module = clearance_kernel
    return _kernel_module


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

    def __init__(self, obstacles: Any, link_radius: float = 0.0, margin: float = 0.0, gain: float = DAMPER_GAIN,
                 tool_frames: Sequence[str] | str | None = None, influence: float = INFLUENCE) -> None:
        super().__init__(name="obstacles")
        if isinstance(obstacles, (Shape, dict)):
            obstacles = [obstacles]
        try:
            items = list(obstacles)
        except TypeError:
            raise InputError(f"obstacles must be a sequence of shapes, got {obstacles!r}") from None
        self.obstacles = [o if isinstance(o, Shape) else as_obstacle(o, f"obstacles[{i}]") for i, o in enumerate(items)]
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
        self._last = None  # (data, q, witness pairs) of the last margin() without coal pairs
        self._shared = None  # the cached products of bind (see bind)

    # ---------------------------------------------------------------------------------------- binding
    def bind(self, robot: Robot) -> "ObstacleAvoidance":
        """Validate against ``robot`` and prepare the pair arrays (cached per model and obstacle set).

        Shapes are immutable, so two constraints with the same obstacle objects
        (identity: hashing a shape by value costs more than a cache miss saves),
        link radius, margin and tool frames on one model share their arrays: a
        solve that builds its constraint afresh around a scene's shapes binds it
        by one dictionary look-up. The cache entry holds the shapes, so their ids
        cannot be reused while it lives. Only successful binds are cached (an
        obstacle containing the base raises every time); nothing writes into the
        shared arrays.
        """
        if self._model is robot.model:
            return self
        tools = self.tool_frames or (robot.tip,)
        per_model = _bound.get(robot.model)
        if per_model is None:
            per_model = _bound[robot.model] = {}
        key = (tuple(map(id, self.obstacles)), self.link_radius, self.margin_required, tuple(tools))
        entry = per_model.get(key)
        if entry is None:
            self._bind_arrays(robot, tools)
            hit = self.__dict__.copy()  # the arrays are shared from now on: nothing writes into them
            if len(per_model) >= _BOUND_CACHE:
                per_model.pop(next(iter(per_model)))
            per_model[key] = (tuple(self.obstacles), hit)
        else:
            hit = entry[1]
            d = self.__dict__
            own = {k: d[k] for k in _UNBOUND if k in d}  # this instance's arguments and state
            d.update(hit)
            d.update(own)
        self._shared = hit
        self._model = robot.model
        return self

    def _bind_arrays(self, robot: Robot, tools: tuple) -> None:
        """The body of :meth:`bind`: skeleton, base check and the per-pair arrays."""
        for f in tools:
            robot.frame_id(f)
        extra = tuple(dict.fromkeys(f for ob in self.obstacles if ob.frames is not None for f in ob.frames))
        sk, n_default, fixed = _skeleton(robot, tools, extra)
        self.skeleton = sk
        if sk.tree is not None:
            _clearance_kernel()  # imported (Numba, the compiled code) now, not inside the first solve's time budget
        frame_index = {name: n_default + k for k, name in enumerate(extra)}
        segs_default = list(range(n_default))
        # per kind: (obstacle index, obstacle, segment ids); pairs are ordered spheres, capsules, boxes,
        # others (the order of the clearance vector), obstacle by obstacle
        kinds: tuple = ([], [], [], [])
        for k, ob in enumerate(self.obstacles):
            if ob.frames is None:
                self._check_base(k, ob, fixed)
                seg_ids = segs_default
            else:
                seg_ids = [frame_index[f] for f in ob.frames]
            g = 0 if isinstance(ob, Sphere) else 1 if isinstance(ob, Capsule) else 2 if isinstance(ob, Box) else 3
            kinds[g].append((k, ob, seg_ids))
        self._kinds = kinds  # (pair_names is made from it on first use)
        sph, cap, box = kinds[0], kinds[1], kinds[2]
        other = ([i for _, _, ids in kinds[3] for i in ids], [ob for _, ob, ids in kinds[3] for _ in ids],
                 [k for k, _, ids in kinds[3] for _ in ids])

        n_pts = sk.n_points

        def seg_and_rows(group):
            """``(seg, row, ia, ib, iab, iab_grouped)``: segment ids of the group's pairs, the row of each pair's
            obstacle in the group, the pairs' end-point rows (:meth:`LinkSkeleton.end_index`), both ends in one
            index (``[ia, ib]``) and the same rows of a per-obstacle stack of the points (``row * points + ia``,
            then ``+ ib``); cached per skeleton and count when every obstacle of the group is kept clear of the
            default segments (the usual case)."""
            if not group:
                return _NO_INT, _NO_INT, _NO_INT, _NO_INT, _NO_INT, _NO_INT
            if all(ids is segs_default for _, _, ids in group):
                key = (n_default, len(group))
                hit = sk.__dict__.setdefault("_pair_index", {}).get(key)
                if hit is None:
                    seg = np.tile(np.arange(n_default), len(group))
                    hit = sk._pair_index[key] = _pair_index(sk, seg, np.repeat(np.arange(len(group)), n_default), n_pts)
                return hit
            seg = np.array([i for _, _, ids in group for i in ids], dtype=int)
            return _pair_index(sk, seg, np.array([r for r, (_, _, ids) in enumerate(group) for _ in ids], dtype=int),
                               n_pts)

        # _box_iab: rows of (boxes * points) holding each pair's ends, a's then b's (one gather in _box_local)
        self._box_seg, row, self._box_ia, self._box_ib, _, self._box_iab = seg_and_rows(box)
        self._box_ob = [ob for _, ob, ids in box for _ in ids]
        if box:
            poses = np.array([ob.pose for _, ob, _ in box], dtype=float)
            self._boxes_R, self._boxes_t = poses[:, :3, :3], poses[:, None, :3, 3]  # per box (t: (boxes, 1, 3))
            self._box_row = row  # per pair: its box
            self._box_R = self._boxes_R[row]
            self._box_t = poses[row, :3, 3]
            self._box_h = 0.5 * np.array([ob.size for _, ob, _ in box], dtype=float)[row]
        else:
            self._box_R, self._box_t, self._box_h = _NO_R, _NO_3, _NO_3
        self._sph_seg, row, self._sph_ia, self._sph_ib, self._sph_iab, _ = seg_and_rows(sph)
        # (spheres, segments) when the sphere pairs are whole blocks of the default segments, sphere by sphere
        self._sph_blocks = (len(sph), n_default) if sph and all(ids is segs_default for _, _, ids in sph) else None
        if sph:
            self._sph_c = np.array([ob.center for _, ob, _ in sph], dtype=float)[row]
            self._sph_r = np.array([ob.radius for _, ob, _ in sph], dtype=float)[row]
        else:
            self._sph_c, self._sph_r = _NO_3, _NO_1
        self._cap_seg, row, self._cap_ia, self._cap_ib, _, _ = seg_and_rows(cap)
        if cap:
            self._cap_a = np.array([ob.a for _, ob, _ in cap], dtype=float)[row]
            self._cap_b = np.array([ob.b for _, ob, _ in cap], dtype=float)[row]
            self._cap_r = np.array([ob.radius for _, ob, _ in cap], dtype=float)[row]
        else:
            self._cap_a, self._cap_b, self._cap_r = _NO_3, _NO_3, _NO_1
        self._oth_seg = np.array(other[0], dtype=int) if other[0] else _NO_INT
        # 1 / |b - a|^2 of every sphere pair: constant when no segment slides (rigid link segments)
        rigid = bool(self._sph_seg.size) and (sk.all_rigid or bool(sk.rigid[self._sph_seg].all()))
        self._sph_inv = sk.inv_len2[self._sph_seg] if rigid else None
        if other[0]:
            self._oth_ia, self._oth_ib = sk.end_index(self._oth_seg)
            self._oth = other[1]
            # per obstacle once, then one row per pair
            kinds = list(dict.fromkeys(other[2]))
            row = np.array([kinds.index(k) for k in other[2]], dtype=int)
            obs = [self.obstacles[k] for k in kinds]
            tfs = [_coal_transform(o.pose) for o in obs]
            self._oth_tf = [tfs[r] for r in row.tolist()]
            poses = np.array([o.pose for o in obs], dtype=float).reshape(-1, 4, 4)
            ext = [_local_extent(o) for o in obs]
            self._oth_center = poses[row, :3, 3]
            self._oth_t = self._oth_center
            self._oth_R = poses[row, :3, :3]
            self._oth_bound = np.array([_bounding_radius(o) for o in obs], dtype=float).reshape(-1)[row]
            self._oth_lo = np.array([e[0] for e in ext], dtype=float).reshape(-1, 3)[row]
            self._oth_hi = np.array([e[1] for e in ext], dtype=float).reshape(-1, 3)[row]
            # rigid segments: the capsule core's placement in its joint's frame and its coal geometry, once
            self._oth_local = [_local_core(sk, i) for i in other[0]]
        else:  # no coal pairs (spheres and capsules only): empty arrays, nothing to prepare
            self._oth_ia = self._oth_ib = self._oth_seg
            self._oth, self._oth_tf, self._oth_local = [], [], []
            self._oth_center = self._oth_t = self._oth_lo = self._oth_hi = _NO_3
            self._oth_R = _NO_R
            self._oth_bound = _NO_1
        self.m = self._sph_seg.size + self._cap_seg.size + self._box_seg.size + self._oth_seg.size  # pairs
        self._offset = self.link_radius + self.margin_required
        # only spheres on rigid segments: rows() takes the fused path of _sphere_rows
        self._sph_only = self._sph_inv is not None and not self._cap_seg.size and not self._box_seg.size \
            and not self._oth_seg.size
        self._sph_r_off = self._sph_r + self._offset
        self._sph_r_off2 = self._sph_r_off * self._sph_r_off  # (r + offset)^2: violations() compares squares
        self._cap_r_off = self._cap_r + self._offset
        self._sph_W = self._sph_S = self._sph_Wk = None  # made by _sphere_rows on first use

    @property
    def pair_names(self) -> list[tuple[int, str]]:
        """``(obstacle index, segment name)`` of every pair, in the order of the clearance vector."""
        names = self.__dict__.get("_pair_names")
        if names is None:
            seg_names = self.skeleton.names
            names = self._pair_names = [(k, seg_names[i]) for group in self._kinds for k, _, ids in group for i in ids]
        return names

    def _check_base(self, k, ob, fixed):
        """InputError when obstacle ``k`` reaches a segment fixed to the world (the base)."""
        if not fixed:
            return
        # cheap rejection: the obstacle's bounding ball does not reach the base's bounding ball
        (cx, cy, cz), R = fixed_ball(fixed)
        if isinstance(ob, Sphere):
            (ox, oy, oz), rad = ob.center, ob.radius
        elif isinstance(ob, Capsule):
            (ox, oy, oz), rad = ob.pose[:3, 3].tolist(), 0.5 * ob.length + ob.radius
        else:
            (ox, oy, oz), rad = ob.pose[:3, 3].tolist(), _bounding_radius(ob)
        if math.sqrt((ox - cx) ** 2 + (oy - cy) ** 2 + (oz - cz) ** 2) > R + rad + self.link_radius:
            return
        if isinstance(ob, Box):  # exact rejection: every fixed segment separated from the box grown by link_radius
            T, h = ob.pose.tolist(), [0.5 * v for v in ob.size]
            if all(_separated(_to_local(T, a), _to_local(T, b), h, self.link_radius) for _, a, b in fixed):
                return
        if isinstance(ob, Sphere):  # point-segment closed form, on plain floats (a few fixed segments)
            for name, a, b in fixed:
                if _point_segment_distance(a, b, ob.center) - ob.radius < self.link_radius:
                    raise InputError(f"obstacles[{k}] ({ob!r}) contains the robot base ({name}); "
                                     "the base cannot move out of it")
            return
        if isinstance(ob, Capsule):
            A, B = np.array([f[1] for f in fixed]), np.array([f[2] for f in fixed])
            _, _, X, Y = segment_segment(A, B, np.broadcast_to(np.asarray(ob.a), A.shape),
                                         np.broadcast_to(np.asarray(ob.b), A.shape))
            d = np.linalg.norm(X - Y, axis=1) - ob.radius
        else:
            A, B = np.array([f[1] for f in fixed]), np.array([f[2] for f in fixed])
            t = np.linspace(0.0, 1.0, 33)[None, :, None]
            d = ob.signed_distance((A[:, None] + t * (B - A)[:, None]).reshape(-1, 3)).reshape(len(A), -1).min(axis=1)
        bad = np.flatnonzero(d < self.link_radius)
        if bad.size:
            raise InputError(f"obstacles[{k}] ({ob!r}) contains the robot base ({fixed[bad[0]][0]}); "
                             "the base cannot move out of it")

    # ------------------------------------------------------------------------------------- distances
    def _pairs(self, data, witness: bool, cutoff: float = math.inf, min_only: bool = False):
        """Clearances ``(m,)`` and, with ``witness``, ``(seg, s, N, A, B)`` of every pair (module docstring).

        ``A``, ``B`` are the end points of each pair's segment, ``N`` the unit
        normals from the obstacle to the witness point ``(1 - s) A + s B``.
        ``min_only``: only the smallest entry must be right (coal pairs whose lower
        bound exceeds the smallest distance found keep their bound; see :meth:`_coal_pairs`).
        """
        P = self.skeleton.points(data)
        clear, segs, ss, Ns, As, Bs = [], [], [], [], [], []
        if self._sph_seg.size:
            A = P[self._sph_ia]
            AB = P[self._sph_ib] - A
            AC = self._sph_c - A
            inv = self._sph_inv if self._sph_inv is not None else self._inv_len2(AB)
            s = _einsum("ij,ij->i", AC, AB) * inv
            _clip(s, 0.0, 1.0, out=s)
            V = s[:, None] * AB - AC  # x - c
            d = _sqrt(_einsum("ij,ij->i", V, V))
            clear.append(d - self._sph_r)
            if witness:
                segs.append(self._sph_seg), ss.append(s), Ns.append(_unit(V, d)), As.append(A), Bs.append(A + AB)
        if self._cap_seg.size:
            A, B = P[self._cap_ia], P[self._cap_ib]
            s, _, X, Y = segment_segment(A, B, self._cap_a, self._cap_b)
            V = X - Y
            d = _sqrt(_einsum("ij,ij->i", V, V))
            clear.append(d - self._cap_r)
            if witness:
                segs.append(self._cap_seg), ss.append(s), Ns.append(_unit(V, d)), As.append(A), Bs.append(B)
        if self._box_seg.size:
            if min_only and not witness:
                best = float(min((x.min() for x in clear if x.size), default=math.inf))
                c, s, N = self._box_min(P, best), None, None
            else:
                A, B = P[self._box_ia], P[self._box_ib]
                c, s, N = self._box_pairs(A, B, witness, cutoff=cutoff + self._offset, local=self._box_local(P))
            clear.append(c)
            if witness:
                segs.append(self._box_seg), ss.append(s), Ns.append(N), As.append(A), Bs.append(B)
        if self._oth_seg.size:
            A, B = P[self._oth_ia], P[self._oth_ib]
            best = float(min((x.min() for x in clear if x.size), default=math.inf)) if min_only else math.inf
            c, s, N = self._coal_pairs(A, B, cutoff, best if min_only else None)
            clear.append(c)
            if witness:
                segs.append(self._oth_seg), ss.append(s), Ns.append(N), As.append(A), Bs.append(B)
        if not clear:
            c = np.zeros(0)
        else:
            c = (clear[0] if len(clear) == 1 else np.concatenate(clear)) - self._offset
        if not witness:
            return c
        if not segs:
            return c, np.zeros(0, dtype=int), np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3))
        if len(segs) == 1:
            return c, segs[0], ss[0], Ns[0], As[0], Bs[0]
        cat = np.concatenate
        return c, cat(segs), cat(ss), cat(Ns), cat(As), cat(Bs)

    def _box_pairs(self, A, B, witness: bool, cutoff: float = math.inf, rows: np.ndarray | None = None,
                   local: tuple | None = None):
        """``(d, s, N)`` of the box pairs (or of the pairs ``rows``): closed-form distances (:func:`segment_box`).

        The segments are expressed in each box's frame, ``a = R^T (A - t)``; the
        normal is ``N = R (x - y) / d`` (from the box to the witness point). A
        segment that meets its box (``d = 0``) gets coal's signed distance (the
        penetration depth, negative) and normal instead. Pairs whose separating-axis
        bound (:func:`_box_gap`, ``<= d``) is at least ``cutoff`` keep that bound,
        with ``s = 0`` and ``N = 0`` (no row). ``local``: the ends already in the boxes' frames
        (:meth:`_box_local`).
        """
        R, t, h = self._box_R, self._box_t, self._box_h
        if rows is not None:
            R, t, h = R[rows], t[rows], h[rows]
        if local is None:
            a = _matmul((A - t)[:, None, :], R)[:, 0]  # R^T (A - t) per pair
            b = _matmul((B - t)[:, None, :], R)[:, 0]
        else:
            a, b = local
        near = None
        if cutoff < math.inf:
            gap = _box_gap(a, b, h)
            near = gap < cutoff
            if 2 * np.count_nonzero(near) > near.shape[0]:
                near = None  # mostly near: one pass over all pairs costs less than picking them out
        if near is None:
            d, s, idx = np.empty(len(a)), np.empty(len(a)), None
        else:
            d, s, idx = gap, np.zeros(len(gap)), np.flatnonzero(near)
        n_exact = len(a) if idx is None else idx.size
        if n_exact > _SCALAR_PAIRS:
            sel = slice(None) if idx is None else idx
            s[sel], d[sel] = segment_box(a[sel], b[sel], h[sel])[:2]
        elif n_exact:  # a few pairs: the same closed form on floats (less fixed cost than the arrays)
            al, bl, hl = a.tolist(), b.tolist(), h.tolist()
            for p in (range(n_exact) if idx is None else idx.tolist()):
                s[p], d[p] = segment_box_distance(al[p], bl[p], hl[p])
        N = None
        if witness:
            x = a + s[:, None] * (b - a)
            V = x - _clip(x, -h, h)  # x - y (0 for the pairs left at their bound: s = 0 ... no row)
            if idx is not None:
                V[~near] = 0.0
            N = _einsum("pij,pj->pi", R, V)
            N /= _fmax(d, _EPS)[:, None]
        meet = np.flatnonzero(d <= 0.0)
        if meet.size:  # inside: the penetration depth from coal
            import coal

            req, res = coal.DistanceRequest(), coal.DistanceResult()
            for r in meet.tolist():
                ab = B[r] - A[r]
                L = math.sqrt(ab.dot(ab))
                res.clear()
                ob = self._box_ob[r if rows is None else rows[r]]
                d[r] = coal.distance(ob.geometry(), _coal_transform(ob.pose), _core(L),
                                     _segment_transform(A[r], ab, L), req, res)
                if witness:
                    N[r] = res.normal
                    w = res.getNearestPoint2() - A[r]
                    s[r] = min(max(float(w.dot(ab)) / max(L * L, 1e-24), 0.0), 1.0)
        return d, s, N

    def _box_local(self, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(a, b)``: the box pairs' segment ends in their boxes' frames, ``R^T (x - t)``.

        ``P`` holds the skeleton's points, ``(points, 3)`` or ``(K, points, 3)``; every
        point is moved into every box's frame at once (one small product per box and
        configuration) and the pairs' ends are picked out of that.
        """
        L = _matmul(P[..., None, :, :] - self._boxes_t, self._boxes_R)  # (..., boxes, points, 3)
        L = L.reshape(L.shape[:-3] + (-1, 3)).take(self._box_iab, -2)  # (..., 2 pairs, 3): a's then b's
        n = self._box_row.shape[0]
        return L[..., :n, :], L[..., n:, :]

    def _box_min(self, P, best: float) -> np.ndarray:
        """Distances of the box pairs where only the smallest (and the others' lower bounds) must be right.

        Pairs are visited in increasing order of their separating-axis bound
        (:func:`_box_gap`) and get their exact distance until the bound reaches the
        smallest distance found (``best``: e.g. the sphere pairs' smallest); the
        others keep their bound, so ``min`` is exact. ``min_only`` of :meth:`_pairs`.
        """
        h = self._box_h
        a, b = self._box_local(P)
        c = _box_gap(a, b, h)
        order = np.argsort(c, kind="stable").tolist()
        al, bl, hl, lb = a.tolist(), b.tolist(), h.tolist(), c.tolist()
        for p in order:
            if lb[p] >= best:
                break
            d = segment_box_distance(al[p], bl[p], hl[p])[1]
            if d <= 0.0:  # the segment meets the box: coal's penetration depth
                ia, ib = self._box_ia[p:p + 1], self._box_ib[p:p + 1]
                d = float(self._box_pairs(P[ia], P[ib], False, rows=np.array([p]))[0][0])
            c[p] = d
            if d < best:
                best = d
        return c

    def _inv_len2(self, AB):
        """``1 / |b - a|^2`` per pair (0 for a point-like segment)."""
        L2 = _einsum("ij,ij->i", AB, AB)
        out = np.zeros_like(L2)
        np.divide(1.0, L2, out=out, where=L2 > 1e-24)
        return out

    def _coal_lower_bound(self, A, B, K: int) -> np.ndarray:
        """Lower bounds on the coal pairs' distances for ``K`` stacked copies of the pairs (rows of ``A``, ``B``).

        The larger of the distance from the segment to the obstacle's bounding
        sphere and the largest gap between the segment's and the obstacle's
        extents along the obstacle's own axes (separating axes).
        """
        tile = (lambda x: x) if K == 1 else (lambda x: np.tile(x, (K,) + (1,) * (x.ndim - 1)))
        centre, t, R = tile(self._oth_center), tile(self._oth_t), tile(self._oth_R)
        _, X = point_segment(A, B, centre)
        lb = np.linalg.norm(X - centre, axis=1) - tile(self._oth_bound)
        a = _einsum("pi,pij->pj", A - t, R)
        b = _einsum("pi,pij->pj", B - t, R)
        gap = np.maximum(np.minimum(a, b) - tile(self._oth_hi), tile(self._oth_lo) - np.maximum(a, b)).max(axis=1)
        return np.maximum(lb, gap, out=lb)

    def _coal_pairs(self, A, B, cutoff, best=None):
        """``(c, s, N)`` of the coal pairs: exact distances where the lower bound is below ``cutoff`` (+ offset).

        ``best`` (a distance already known, e.g. the closed-form pairs' smallest): only the smallest
        distance is wanted - the pairs are visited in increasing order of their lower bound and the
        visit stops once the bound reaches the smallest distance found (the others cannot be smaller;
        they keep their bound). ``c.min()`` is then the same as with every pair computed.
        """
        import coal

        i = self._oth_seg
        lb = self._coal_lower_bound(A, B, 1)
        c = lb.copy()
        s = np.zeros(len(i))
        N = np.zeros((len(i), 3))
        req = coal.DistanceRequest()
        res = coal.DistanceResult()
        far = cutoff + self._offset
        oMi = self.skeleton._placements[1]  # joint placements of the data just read by points()
        todo = np.flatnonzero(lb < far)
        if best is not None and todo.size > 1:
            todo = todo[np.argsort(lb[todo], kind="stable")]
        todo = todo.tolist()
        X = np.zeros((len(i), 3))
        done = []
        for p in todo:
            if best is not None:
                if lb[p] >= best:
                    break
                done.append(p)
            local = self._oth_local[p]
            if local is not None:
                j, M, geom = local
                tf = coal.Transform3s(oMi[j] * M)
            else:
                a, b = A[p], B[p]
                ab = b - a
                L = math.sqrt(ab.dot(ab))
                geom = _core(L)
                tf = _segment_transform(a, ab, L)
            res.clear()
            c[p] = coal.distance(self._oth[p].geometry(), self._oth_tf[p], geom, tf, req, res)
            X[p] = res.getNearestPoint2()
            N[p] = res.normal
            if best is not None and c[p] < best:
                best = c[p]
        if best is not None:
            todo = done
        if todo:
            AB = B[todo] - A[todo]
            L2 = _einsum("ij,ij->i", AB, AB)
            num = _einsum("ij,ij->i", X[todo] - A[todo], AB)
            s[todo] = np.clip(np.divide(num, L2, out=np.zeros_like(num), where=L2 > 1e-24), 0.0, 1.0)
        return c, s, N

    def clearances(self, data: pin.Data) -> np.ndarray:
        """Clearance ``c`` (m) of every pair after forward kinematics (far coal pairs: their lower bound)."""
        return self._pairs(data, False, MARGIN_EXACT)

    def first_violation(self, robot: Robot, Q: np.ndarray) -> int | None:
        """Index of the first configuration of ``Q`` (``(K, nq)``) with a negative clearance, or None."""
        hits = np.flatnonzero(self.violations(robot, Q, first_only=True))
        return int(hits[0]) if hits.size else None

    def violations(self, robot: Robot, Q: np.ndarray, first_only: bool = False) -> np.ndarray:
        """``(K,)`` booleans: True where configuration ``k`` of ``Q`` (``(K, nq)``, or a list of ``(nq,)`` arrays)
        has a negative clearance.

        The segments' end points of all ``K`` configurations come from one compiled forward kinematics
        (:func:`.clearance_kernel.skeleton_points`; Pinocchio per configuration for joints it does not
        model), and their sphere, capsule and box pairs are decided in one compiled call
        (:func:`.clearance_kernel.violations`: the same closed forms, box pairs past a separating-axis
        test only, and a segment that meets a box counts as a violation - the penetration depth is not
        needed for the verdict); coal pairs (cylinders, meshes) are checked per configuration where their
        bounding-sphere bound is negative.
        ``first_only``: only the first True entry must be right (coal pairs of later configurations are
        skipped).
        """
        sk = self.skeleton
        kernel = _clearance_kernel()
        P = np.empty((len(Q), sk.n_points, 3))
        tree = sk.tree
        if tree is not None:  # forward kinematics of every configuration in one compiled call
            Qa = Q if type(Q) is np.ndarray and Q.flags.c_contiguous else np.array(Q, dtype=float)
            kernel.skeleton_points(*tree, *sk.point_table, Qa, P)
        else:  # joints the compiled tree does not model: Pinocchio, configuration by configuration
            model, data = robot.model, robot.data
            fk = _pin().forwardKinematics
            into = sk.points_into
            for k, q in enumerate(Q):
                fk(model, data, q)
                into(data, P[k])
        bad = np.zeros(len(Q), dtype=bool)
        off = self._offset
        if self._sph_seg.size or self._cap_seg.size or self._box_seg.size:
            kernel.violations(P, self._sph_ia, self._sph_ib, self._sph_c, self._sph_r_off2, self._cap_ia,
                                           self._cap_ib, self._cap_a, self._cap_b, self._cap_r_off, self._box_ia,
                                           self._box_ib, self._box_R, self._box_t, self._box_h, off, bad)
        if self._oth_seg.size:
            import coal

            K, n = len(Q), self._oth_seg.size
            A, B = P[:, self._oth_ia].reshape(-1, 3), P[:, self._oth_ib].reshape(-1, 3)
            lb = self._coal_lower_bound(A, B, K)
            req, res = coal.DistanceRequest(), coal.DistanceResult()
            hits = np.flatnonzero(bad)
            first = int(hits[0]) if hits.size and first_only else K  # with first_only: only the first matters
            for r in np.flatnonzero(lb < off).tolist():  # in order of the configuration
                k, p = divmod(r, n)
                if k >= first:
                    break
                if bad[k]:
                    continue
                ab = B[r] - A[r]
                L = math.sqrt(ab.dot(ab))
                res.clear()
                d = coal.distance(self._oth[p].geometry(), self._oth_tf[p], _core(L), _segment_transform(A[r], ab, L),
                                  req, res)
                if d - off < 0.0:
                    bad[k] = True
                    if first_only:
                        first = k
        return bad

    # ------------------------------------------------------------------------------------- protocol
    def margin(self, robot: Robot, data: pin.Data, q: np.ndarray) -> float:
        """Smallest clearance (m), exact (box and coal pairs: only the smallest is computed exactly).

        With spheres and capsules only, the witness points are kept: :meth:`rows` at the same ``q``
        (same array object, same ``data``) reuses them instead of computing the distances again. With
        spheres only (on rigid segments) that is the lean :meth:`_sphere_geometry` (clearances, unit
        normals, near mask), whose ``c = d - (r + offset)`` equals ``(d - r) - offset`` to ~1e-17 m.
        """
        if self._sph_only:  # the clearances, normals and near mask of _sphere_rows, kept for rows() at this q
            w = self._sphere_geometry(data, q)
            self._last = (data, q, w)
            c = w[0]
            return float(_min(c)) if c.size else math.inf
        if not self._oth_seg.size and not self._box_seg.size:
            w = self._pairs(data, True)
            self._last = (data, q, w)
            c = w[0]
            return float(c.min()) if c.size else math.inf
        c = self._pairs(data, False, MARGIN_EXACT, min_only=True)
        return float(c.min()) if c.size else math.inf

    def rows(self, robot: Robot, data: pin.Data, q: np.ndarray, dt: float | None = None) -> tuple[np.ndarray | None, np.ndarray, np.ndarray]:
        last = self._last
        if self._sph_only:
            return self._sphere_rows(data, q, last[2] if last is not None and last[0] is data and last[1] is q else None)
        if last is not None and last[0] is data and last[1] is q:
            c, seg, s, N, A, B = last[2]
        else:
            c, seg, s, N, A, B = self._pairs(data, True, min(self.influence, COAL_INFLUENCE))
        # rows of the pairs within reach; a witness exactly at the obstacle's core has no direction (skipped)
        near = (c < self.influence) & (_einsum("ij,ij->i", N, N) > 0.5)
        if not near.all():
            if not near.any():
                return np.zeros((0, robot.model.nv)), np.zeros(0), np.zeros(0)
            c, seg, s, N, A, B = c[near], seg[near], s[near], N[near], A[near], B[near]
        G = self.skeleton.gradient_rows(data, seg, s, A, B, N)
        return G, -self.gain * c, _INF[: c.shape[0]] if c.shape[0] <= _INF.shape[0] else np.full(c.shape[0], np.inf)

    def _sphere_constants(self) -> None:
        """Per sphere pair: ``W = [I, -[o]x]`` (3 x 6, so ``n^T W = [n, o x n]``) and the support mask of its joint."""
        W = np.zeros((len(self._sph_c), 3, 6))
        W[:, [0, 1, 2], [0, 1, 2]] = 1.0
        ox, oy, oz = self._sph_c.T
        W[:, 0, 4], W[:, 0, 5], W[:, 1, 3], W[:, 1, 5], W[:, 2, 3], W[:, 2, 4] = oz, -oy, -oz, ox, oy, -ox
        self._sph_S = self.skeleton.support[self.skeleton.ja[self._sph_seg]]
        self._sph_W = W
        if self._sph_blocks is not None:  # one W per sphere (the first pair of each block), stacked (3 spheres, 6)
            self._sph_Wk = np.ascontiguousarray(W[:: self._sph_blocks[1]].reshape(-1, 6))
        shared = self.__dict__.get("_shared")
        if shared is not None:  # the next constraint bound to the same obstacles reuses them
            for k in ("_sph_S", "_sph_W", "_sph_Wk"):
                shared[k] = getattr(self, k)

    def _sphere_geometry(self, data: pin.Data, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(c, N, near)`` of every sphere pair (rigid segments) at ``q``: clearances ``c = d - r - offset`` (m),
        unit normals ``N`` (rows, from the centre to the witness point) and the mask of the pairs that give rows
        (``c < influence`` and a defined normal). One compiled call
        (:func:`.clearance_kernel.sphere_geometry`); forward kinematics in ``data`` when the tree has joints it
        does not model."""
        sk = self.skeleton
        tree = sk.tree
        if tree is not None:
            n = self._sph_seg.shape[0]
            c, V, near = np.empty(n), np.empty((n, 3)), np.empty(n, dtype=bool)
            _clearance_kernel().sphere_geometry(*tree, *sk.point_table, q, self._sph_ia, self._sph_ib, self._sph_c,
                                                self._sph_inv, self._sph_r_off, self.influence, c, V, near)
            return c, V, near
        P = sk.points(data)
        n = self._sph_seg.shape[0]
        X = P.take(self._sph_iab, 0)  # both ends of every pair in one gather (take: cheaper than fancy indexing)
        A = X[:n]
        AB = X[n:] - A
        AC = self._sph_c - A
        s = _einsum("ij,ij->i", AC, AB) * self._sph_inv
        _clip(s, 0.0, 1.0, out=s)
        V = s[:, None] * AB
        V -= AC  # x - o
        d = _sqrt(_einsum("ij,ij->i", V, V))
        c = d - self._sph_r_off
        near = c < self.influence
        if _min(d) > _EPS:
            V /= d[:, None]  # unit normals
        else:  # a witness at a sphere's centre has no direction: no row for it
            near &= d > _EPS
            V /= _fmax(d, _EPS)[:, None]
        return c, V, near

    def _sphere_rows(self, data: pin.Data, q: np.ndarray,
                     geometry: tuple | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`rows` when every pair is a sphere on a rigid segment: the same rows in fewer array passes.

        With ``V = x - o = d n`` the witness point is ``x = o + V``, so ``x x n = o x n``
        (``V x n = 0``): the moment arm of every row is the sphere centre, a constant.
        ``geometry``: :meth:`_sphere_geometry` at this configuration (kept by :meth:`margin`), or None.
        """
        if self._sph_W is None:
            self._sphere_constants()
        c, V, near = self._sphere_geometry(data, q) if geometry is None else geometry
        if self.skeleton.tree is not None:  # the rows of the near pairs in one compiled call
            G = np.empty((c.shape[0], data.J.shape[1]))
            k = _clearance_kernel().sphere_rows(V, self._sph_c, data.J, self._sph_S, near, G)
            c = c.compress(near)
            return G[:k], -self.gain * c, _INF[:k] if k <= _INF.shape[0] else np.full(k, np.inf)
        # row p: n^T [I, -[o]x] J = n^T J_v + (o x n)^T J_w, masked by the support of the segment's joint;
        # computed for every pair (a few more rows of small products), then the far pairs are dropped
        blocks = self._sph_blocks
        if blocks is not None:
            # per sphere k once: M_k = W_k J (3 x nv, the Jacobian of a point at o_k moved by every joint), then
            # the rows of its block n^T M_k in one batched product (the same sums as (n^T W) J, grouped otherwise:
            # equal to ~1e-16 of the row)
            K, n_seg = blocks
            M = self._sph_Wk.dot(data.J)
            G = _matmul(V.reshape(K, n_seg, 3), M.reshape(K, 3, -1)).reshape(c.shape[0], -1)
        else:
            G = _einsum("pi,pij->pj", V, self._sph_W).dot(data.J)
        G *= self._sph_S
        G, c = G.compress(near, 0), c.compress(near)
        k = c.shape[0]
        return G, -self.gain * c, _INF[:k] if k <= _INF.shape[0] else np.full(k, np.inf)

    def rows_all(self, robot: Robot, data: pin.Data) -> tuple[np.ndarray, np.ndarray]:
        """``(c, G)`` for every pair (tests, diagnostics); needs ``computeJointJacobians``."""
        c, seg, s, N, A, B = self._pairs(data, True, math.inf)
        return c, self.skeleton.gradient_rows(data, seg, s, A, B, N)

    def describe(self, robot: Robot, data: pin.Data, q: np.ndarray) -> str:
        c = self._pairs(data, False, math.inf)
        parts = []
        for p in np.flatnonzero(c < 0.0):
            k, seg = self.pair_names[p]
            parts.append(f"obstacles[{k}] ({self.obstacles[k].kind}) is entered by {seg} by {-c[p]:.4g} m")
        return "; ".join(parts)

    def __repr__(self) -> str:
        return (f"ObstacleAvoidance({len(self.obstacles)} obstacles, link_radius={self.link_radius:g}, "
                f"margin={self.margin_required:g})")


_skeletons: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()
#: bound pair arrays per model, then per (obstacle ids, link radius, margin, tool frames) -> (obstacles, arrays);
#: see ObstacleAvoidance.bind
_bound: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()
_BOUND_CACHE = 64
#: attributes of an ObstacleAvoidance that are not products of bind (its arguments and per-instance state)
_UNBOUND = frozenset(("name", "obstacles", "link_radius", "margin_required", "gain", "tool_frames", "influence",
                      "_model", "_last", "_shared"))
#: coal capsule cores by length (segment lengths repeat from one call to the next)
_CORES: dict = {}
_balls: dict = {}


def _pair_index(sk: LinkSkeleton, seg: np.ndarray, row: np.ndarray, n_pts: int) -> tuple:
    """The tuple of ``seg_and_rows`` in :meth:`ObstacleAvoidance._bind_arrays` for pairs ``(seg, row)``."""
    ia, ib = sk.end_index(seg)
    return seg, row, ia, ib, np.concatenate((ia, ib)), np.concatenate((row * n_pts + ia, row * n_pts + ib))


def fixed_ball(fixed: list) -> tuple[tuple[float, float, float], float]:
    """A ball ``(centre, radius)`` enclosing the fixed segments ``(name, a, b)`` (cached per list)."""
    hit = _balls.get(id(fixed))
    if hit is None or hit[0] is not fixed:
        pts = np.array([p for _, a, b in fixed for p in (a, b)])
        c = 0.5 * (pts.min(axis=0) + pts.max(axis=0))
        hit = _balls[id(fixed)] = (fixed, tuple(c.tolist()), float(np.linalg.norm(pts - c, axis=1).max()))
    return hit[1], hit[2]


def _skeleton(robot, tools, frames):
    """``(skeleton, n_default, fixed)``: the moving default segments then the frame points, cached per model.

    ``fixed`` lists ``(name, a, b)`` of the segments fixed to the world (checked against the obstacles).
    """
    key = (tuple(tools), tuple(frames))
    last = _last_skeleton[0]
    if last is not None and last[0]() is robot.model and last[1] == key:  # the usual case: no weak-key look-up
        return last[2]
    per_model = _skeletons.get(robot.model)
    if per_model is None:
        per_model = _skeletons[robot.model] = {}
    hit = per_model.get(key)
    if hit is None:
        segs = skeleton_segments(robot, tools)
        moving = [s for s in segs if not s.fixed]
        fixed = [(s.name, tuple(s.la.tolist()), tuple(s.lb.tolist())) for s in segs if s.fixed]  # (floats)
        pts = skeleton_segments(robot, frames=frames) if frames else []
        hit = per_model[key] = (LinkSkeleton(robot, moving + pts), len(moving), fixed)
    _last_skeleton[0] = (weakref.ref(robot.model), key, hit)
    return hit


_last_skeleton: list = [None]  # (weak reference to the model, key, skeleton entry) of the last _skeleton call


_pin_module = None


def _pin():
    """The ``pinocchio`` module, imported on first use (this module loads without it)."""
    global _pin_module
    if _pin_module is None:
        import pinocchio

        _pin_module = pinocchio
    return _pin_module


def _to_local(T: list, p) -> list:
    """``R^T (p - t)`` for the pose ``T`` (4x4 nested lists) and a 3-point ``p``, on plain floats."""
    x, y, z = p[0] - T[0][3], p[1] - T[1][3], p[2] - T[2][3]
    return [T[0][0] * x + T[1][0] * y + T[2][0] * z, T[0][1] * x + T[1][1] * y + T[2][1] * z,
            T[0][2] * x + T[1][2] * y + T[2][2] * z]


def _point_segment_distance(a, b, c) -> float:
    """Distance from the point ``c`` to the segment ``[a, b]`` (3-sequences; the closed form of :func:`point_segment`)."""
    ax, ay, az = a
    ux, uy, uz = b[0] - ax, b[1] - ay, b[2] - az
    wx, wy, wz = c[0] - ax, c[1] - ay, c[2] - az
    L2 = ux * ux + uy * uy + uz * uz
    s = min(max((wx * ux + wy * uy + wz * uz) / L2, 0.0), 1.0) if L2 > 1e-24 else 0.0
    vx, vy, vz = wx - s * ux, wy - s * uy, wz - s * uz
    return math.sqrt(vx * vx + vy * vy + vz * vz)


#: up to this many box pairs get their exact distance on floats (segment_box_distance), more at once on arrays
_SCALAR_PAIRS = 12


def _separated(a, b, h, off: float) -> bool:
    """True when the segment ``[a, b]`` is separated from the box ``|y| <= h + off`` (its frame) by an axis.

    The separating-axis test of a segment and a box (Ericson, *Real-Time
    Collision Detection*, 5.3.3): with the midpoint ``c``, the half-extent
    ``w = (b - a) / 2`` and ``|w|`` padded by 1e-12 (parallel cases), the axes
    are the box's (``|c_i| > e_i + |w_i|``) and their cross products with ``w``.
    Separated from the box grown by ``off`` on every side implies a distance
    ``>= off`` from the box (the grown box contains all points within ``off``).
    """
    e0, e1, e2 = h[0] + off, h[1] + off, h[2] + off
    c0, c1, c2 = 0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2])
    w0, w1, w2 = 0.5 * (b[0] - a[0]), 0.5 * (b[1] - a[1]), 0.5 * (b[2] - a[2])
    v0, v1, v2 = abs(w0) + 1e-12, abs(w1) + 1e-12, abs(w2) + 1e-12
    return (abs(c0) > e0 + v0 or abs(c1) > e1 + v1 or abs(c2) > e2 + v2
            or abs(c1 * w2 - c2 * w1) > e1 * v2 + e2 * v1
            or abs(c2 * w0 - c0 * w2) > e0 * v2 + e2 * v0
            or abs(c0 * w1 - c1 * w0) > e0 * v1 + e1 * v0)


def _box_gap(a: np.ndarray, b: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Lower bound on the distance from segments ``[a, b]`` to boxes ``|y| <= h`` (their frames; ``(..., 3)``).

    The largest gap between the segment's and the box's extents along the box's axes (a
    separating axis): ``max_i max(min(a_i, b_i) - h_i, -h_i - max(a_i, b_i))``.
    """
    return np.maximum(np.minimum(a, b) - h, -h - np.maximum(a, b)).max(axis=-1)


def _unit(V: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Rows of ``V`` divided by ``d`` (zero rows where ``d`` is 0: no defined direction)."""
    out = np.zeros_like(V)
    np.divide(V, d[:, None], out=out, where=d[:, None] > _EPS)
    return out


def _non_negative(value, name: str) -> float:
    if type(value) is float and 0.0 <= value < math.inf:  # the common case, checked in one test
        return value
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


def _local_core(sk: LinkSkeleton, i: int):
    """``(joint, placement in the joint frame, coal core)`` of rigid segment ``i`` (cached on the skeleton), or None."""
    cache = sk.__dict__.setdefault("_local_cores", {})
    if i not in cache:
        if sk.rigid[i] and sk.ja[i] != 0:
            la, lb = sk.la[i], sk.lb[i]
            L = float(np.linalg.norm(lb - la))
            cache[i] = (int(sk.ja[i]), _axis_placement(la, lb - la, L), _core(L))
        else:
            cache[i] = None
    return cache[i]


def _core(L: float):
    """The coal capsule core (radius 0) of length ``L``, cached by length."""
    import coal

    geom = _CORES.get(L)
    if geom is None:
        if len(_CORES) > 4096:
            _CORES.clear()
        geom = _CORES[L] = coal.Capsule(0.0, L)
    return geom


def _axis_placement(a: np.ndarray, ab: np.ndarray, L: float):
    """``pinocchio.SE3`` at the midpoint of ``[a, a + ab]`` with its z axis along ``ab``."""
    import pinocchio as pin

    tf = _segment_transform(a, ab, L)
    return pin.SE3(np.array(tf.getRotation()), np.array(tf.getTranslation()))


def _segment_transform(a: np.ndarray, ab: np.ndarray, L: float):
    """coal placement of a capsule core ``[a, a + ab]``: centre at the midpoint, local z along ``ab``.

    Plain floats: on one 3-vector they are several times cheaper than NumPy's cross products.
    """
    import coal

    tf = coal.Transform3s()
    if L > _EPS:
        zx, zy, zz = (ab / L).tolist()
        hx, hy = (1.0, 0.0) if abs(zx) < 0.9 else (0.0, 1.0)
        xx, xy, xz = hy * zz, -hx * zz, hx * zy - hy * zx  # h x z with h = (hx, hy, 0)
        n = math.sqrt(xx * xx + xy * xy + xz * xz)
        xx, xy, xz = xx / n, xy / n, xz / n
        yx, yy, yz = zy * xz - zz * xy, zz * xx - zx * xz, zx * xy - zy * xx  # z x x
        tf.setRotation(np.array([[xx, yx, zx], [xy, yy, zy], [xz, yz, zz]]))
    tf.setTranslation(a + 0.5 * ab)
    return tf
