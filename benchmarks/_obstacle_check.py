"""Independent validity checks of IK answers for the benchmarks: obstacles and collisions.

Nothing here calls kinserve's IK, its constraint code or any peer solver: every
benchmark answer is judged by this code alone. Two models of the robot:

1. **Skeleton** (the model every contender is asked to keep clear): the
   polyline through the world origin, the origins of joints 1..n and the
   flange frame, from Pinocchio's own forward kinematics. Each consecutive
   pair of points is a segment of zero radius.

   * segment ``[a, b]`` vs sphere ``(c, r)``: closest point
     ``x = a + s (b - a)``, ``s = clamp((c - a).(b - a) / |b - a|^2, 0, 1)``,
     clearance ``|x - c| - r``;
   * segment vs box (pose ``T``, half extents ``h``): in the box frame the
     point is ``p(s) = a' + s d'``; its squared distance to the box,
     ``sum_i max(|p_i(s)| - h_i, 0)^2``, is a convex piecewise quadratic in
     ``s`` whose pieces end where some ``p_i(s) = +-h_i`` (at most 6
     breakpoints). On each piece every term is either 0 or a fixed quadratic,
     so the minimum on the piece is at an end or at the vertex of the sum -
     exact, no iteration. Clearance = ``sqrt(min)``, or ``-depth`` when the
     segment enters the box (the slab test of Liang-Barsky clipping; depth is
     the largest penetration ``min_i (h_i - |p_i|)`` over the clipped part,
     sampled at the clip ends and midpoint - used only to report how deep).

2. **Collision geometry** (coal through Pinocchio): the URDF's ``<collision>``
   elements (``pin.buildGeomFromUrdf``), the obstacles added as coal shapes
   fixed in the world, pairs (robot geometry, obstacle) and optionally the
   robot's self-collision pairs minus the SRDF's disabled ones
   (``removeCollisionPairs``); ``pin.computeCollisions`` decides.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
import pinocchio as pin


# --------------------------------------------------------------------------- obstacles as plain data
@dataclass(frozen=True)
class SphereSpec:
    center: tuple
    radius: float

    def to_dict(self) -> dict:
        return {"kind": "sphere", "center": list(self.center), "radius": self.radius}


@dataclass(frozen=True)
class BoxSpec:
    pose: tuple  #: 4x4 world pose, row-major, 16 values
    size: tuple  #: full edge lengths (m), as URDF's <box size>

    @property
    def T(self) -> np.ndarray:
        return np.asarray(self.pose, dtype=float).reshape(4, 4)

    def to_dict(self) -> dict:
        return {"kind": "box", "pose": self.T.tolist(), "size": list(self.size)}


def spec_from_dict(d: dict):
    if d["kind"] == "sphere":
        return SphereSpec(tuple(d["center"]), float(d["radius"]))
    if d["kind"] == "box":
        return BoxSpec(tuple(np.asarray(d["pose"], dtype=float).reshape(16)), tuple(d["size"]))
    raise ValueError(f"unknown obstacle kind {d['kind']!r}")


# --------------------------------------------------------------------------- closed-form distances
def segment_sphere_clearance(a: np.ndarray, b: np.ndarray, c: np.ndarray, r: float) -> float:
    """``min_s |a + s (b - a) - c| - r`` over ``s in [0, 1]`` (m; negative inside)."""
    ab = b - a
    L2 = float(ab @ ab)
    s = 0.0 if L2 < 1e-24 else min(1.0, max(0.0, float((c - a) @ ab) / L2))
    x = a + s * ab
    return float(np.linalg.norm(x - c)) - r


def _segment_enters_box(p0: np.ndarray, d: np.ndarray, h: np.ndarray) -> tuple[float, float] | None:
    """Liang-Barsky: the parameter interval ``[t0, t1]`` of ``p0 + t d``, t in [0, 1], inside ``|p| <= h``."""
    t0, t1 = 0.0, 1.0
    for i in range(3):
        if abs(d[i]) < 1e-15:
            if abs(p0[i]) > h[i]:
                return None
            continue
        ta = (-h[i] - p0[i]) / d[i]
        tb = (h[i] - p0[i]) / d[i]
        if ta > tb:
            ta, tb = tb, ta
        t0, t1 = max(t0, ta), min(t1, tb)
        if t0 > t1:
            return None
    return t0, t1


def segment_box_clearance(a: np.ndarray, b: np.ndarray, T_box: np.ndarray, size) -> float:
    """Euclidean distance (m) from segment ``[a, b]`` to a box; negative (penetration depth) if it enters."""
    R, t = T_box[:3, :3], T_box[:3, 3]
    h = 0.5 * np.asarray(size, dtype=float)
    p0 = R.T @ (a - t)
    d = R.T @ (b - a)
    inside = _segment_enters_box(p0, d, h)
    if inside is not None:
        depth = 0.0
        for s in (inside[0], 0.5 * (inside[0] + inside[1]), inside[1]):
            p = p0 + s * d
            depth = max(depth, float(np.min(h - np.abs(p))))
        return -depth
    # breakpoints where a coordinate crosses a face plane
    bps = [0.0, 1.0]
    for i in range(3):
        if abs(d[i]) > 1e-15:
            for face in (-h[i], h[i]):
                s = (face - p0[i]) / d[i]
                if 0.0 < s < 1.0:
                    bps.append(s)
    bps.sort()

    def sq(s: float) -> float:
        p = p0 + s * d
        e = np.maximum(np.abs(p) - h, 0.0)
        return float(e @ e)

    best = min(sq(s) for s in bps)
    for lo, hi in zip(bps[:-1], bps[1:]):
        mid = 0.5 * (lo + hi)
        pm = p0 + mid * d
        # on this piece, term i is (p_i(s) - sign_i h_i)^2 if |p_i| > h_i at the midpoint, else 0
        A = B = 0.0  # sum of d_i^2 and of d_i * (p0_i - sign_i h_i)
        for i in range(3):
            if abs(pm[i]) > h[i]:
                off = p0[i] - math.copysign(h[i], pm[i])
                A += d[i] * d[i]
                B += d[i] * off
        if A > 1e-30:
            s = -B / A
            if lo < s < hi:
                best = min(best, sq(s))
    return math.sqrt(best)


# --------------------------------------------------------------------------- skeleton model
class Skeleton:
    """The robot as the polyline world origin -> joint origins -> flange, from Pinocchio FK."""

    def __init__(self, model: pin.Model, flange: str):
        self.model = model
        self.data = model.createData()
        self.flange_id = model.getFrameId(flange)
        if self.flange_id >= model.nframes:
            raise ValueError(f"no frame {flange!r}")

    def points(self, q: np.ndarray) -> np.ndarray:
        """``(njoints + 1, 3)``: the world origin, every joint origin, the flange origin."""
        pin.forwardKinematics(self.model, self.data, q)
        pin.updateFramePlacement(self.model, self.data, self.flange_id)
        pts = [np.zeros(3)]
        pts += [self.data.oMi[j].translation.copy() for j in range(1, self.model.njoints)]
        pts.append(self.data.oMf[self.flange_id].translation.copy())
        return np.asarray(pts)

    def clearance(self, q: np.ndarray, obstacles) -> float:
        """Smallest clearance (m) of any skeleton segment to any obstacle; negative = inside."""
        P = self.points(q)
        best = math.inf
        for ob in obstacles:
            for a, b in zip(P[:-1], P[1:]):
                if isinstance(ob, SphereSpec):
                    c = segment_sphere_clearance(a, b, np.asarray(ob.center), ob.radius)
                else:
                    c = segment_box_clearance(a, b, ob.T, ob.size)
                best = min(best, c)
        return best


# --------------------------------------------------------------------------- coal collision model
def coal_shape(ob):
    import coal

    if isinstance(ob, SphereSpec):
        return coal.Sphere(ob.radius), pin.SE3(np.eye(3), np.asarray(ob.center, dtype=float))
    T = ob.T
    return coal.Box(*[float(s) for s in ob.size]), pin.SE3(T[:3, :3].copy(), T[:3, 3].copy())


class CoalChecker:
    """Collision test on the URDF's collision geometry (coal), built here from the URDF and SRDF.

    ``q`` of the checked robot may be a reduced configuration: ``to_full``
    maps it to the full URDF model's configuration (locked joints at their
    values). ``self_collision`` adds every pair of robot geometries except
    the SRDF's disabled pairs and pairs of the same or adjacent bodies.
    """

    def __init__(self, urdf_path: str, package_dirs, obstacles=(), *, srdf_path: str | None = None,
                 self_collision: bool = False, locked: dict | None = None, convex: bool = False):
        self.model = pin.buildModelFromUrdf(urdf_path)
        self.data = self.model.createData()
        with warnings.catch_warnings():  # pin 4 warns about package_dirs given twice; harmless
            warnings.simplefilter("ignore")
            self.geom = pin.buildGeomFromUrdf(self.model, urdf_path, pin.GeometryType.COLLISION, package_dirs)
        if convex:
            self._to_convex()
        self.n_robot_geoms = self.geom.ngeoms
        self.obstacle_ids = []
        for k, ob in enumerate(obstacles):
            shape, placement = coal_shape(ob)
            go = pin.GeometryObject(f"obstacle_{k}", 0, 0, placement, shape)
            self.obstacle_ids.append(self.geom.addGeometryObject(go))
        for gid in range(self.n_robot_geoms):
            for oid in self.obstacle_ids:
                self.geom.addCollisionPair(pin.CollisionPair(gid, oid))
        self.n_scene_pairs = len(self.geom.collisionPairs)
        if self_collision:
            self._add_self_pairs(srdf_path)
        self.gdata = pin.GeometryData(self.geom)
        locked = locked or {}
        self._arm_idx = []
        self._q_template = pin.neutral(self.model)
        for j in range(1, self.model.njoints):
            name = self.model.names[j]
            if name in locked:
                self._q_template[self.model.idx_qs[j]] = locked[name]
            else:
                self._arm_idx.append(self.model.idx_qs[j])
        self._arm_idx = np.asarray(self._arm_idx)

    def _to_convex(self) -> None:
        import coal

        for go in self.geom.geometryObjects:
            g = go.geometry
            if isinstance(g, coal.BVHModelBase):
                g.buildConvexRepresentation(False)
                go.geometry = g.convex

    def _add_self_pairs(self, srdf_path: str | None) -> None:
        model, geom = self.model, self.geom
        for i in range(self.n_robot_geoms):
            for j in range(i + 1, self.n_robot_geoms):
                gi, gj = geom.geometryObjects[i], geom.geometryObjects[j]
                ji, jj = gi.parentJoint, gj.parentJoint
                if ji == jj or model.parents[ji] == jj or model.parents[jj] == ji:
                    continue  # same or adjacent bodies (as the SRDF 'Adjacent' entries)
                geom.addCollisionPair(pin.CollisionPair(i, j))
        if srdf_path:
            pin.removeCollisionPairs(model, geom, srdf_path)
        # removeCollisionPairs may drop scene pairs only if an obstacle name matched a link: re-count
        self.n_scene_pairs = sum(1 for cp in geom.collisionPairs if cp.second in self.obstacle_ids
                                 or cp.first in self.obstacle_ids)

    def full_q(self, q: np.ndarray) -> np.ndarray:
        """The URDF model's configuration for the checked robot's ``q`` (locked joints at their values)."""
        qf = self._q_template.copy()
        qf[self._arm_idx] = q
        return qf

    def in_collision(self, q: np.ndarray, extra_obstacles=()) -> bool:
        """Any active pair in collision at ``q``; ``extra_obstacles`` are tested against every robot geometry
        with ``coal.collide`` (obstacles that change from call to call need no new model)."""
        hit = bool(pin.computeCollisions(self.model, self.data, self.geom, self.gdata, self.full_q(q), True))
        if hit or not extra_obstacles:
            return hit
        import coal

        req = coal.CollisionRequest()
        for ob in extra_obstacles:
            shape, placement = coal_shape(ob)
            tf = coal.Transform3s(placement.rotation, placement.translation)
            for gid in range(self.n_robot_geoms):
                go = self.geom.geometryObjects[gid]
                M = self.gdata.oMg[gid]
                res = coal.CollisionResult()
                if coal.collide(go.geometry, coal.Transform3s(M.rotation, M.translation), shape,
                                tf, req, res):
                    return True
        return False

    def colliding_pairs(self, q: np.ndarray) -> list[tuple[str, str]]:
        pin.computeCollisions(self.model, self.data, self.geom, self.gdata, self.full_q(q), False)
        out = []
        for k, cp in enumerate(self.geom.collisionPairs):
            if self.gdata.collisionResults[k].isCollision():
                out.append((self.geom.geometryObjects[cp.first].name,
                            self.geom.geometryObjects[cp.second].name))
        return out
