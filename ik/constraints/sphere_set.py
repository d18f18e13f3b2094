"""Sphere obstacles against the robot's link segments, pair by pair (the ``"qp"`` method's original constraint).

Joint limits
------------
A step ``dq`` from ``q`` must keep ``lower <= q + dq <= upper``; with a trust
region ``|dq_i| <= max_step`` the QP box is

    max(lower - q, -max_step) <= dq <= min(upper - q, max_step).

Spheres
-------
``Sphere(center, radius, frames=None)`` (:class:`kinserve.kinematics.shapes.Sphere`) is an obstacle the robot must stay
outside of. By default the whole arm is checked as *segments* (capsules of
zero radius - inflate the sphere radius to account for link thickness):

* every link between consecutive joint origins (the segment from a joint's
  origin to the point where its child joint is mounted);
* the sliding segment of each prismatic joint (from where it is mounted to
  where its moving body is now - the quill of a SCARA);
* the tool segment from the tool's parent joint to the tool frame origin.

With ``frames=[...]`` only the origins of the listed frames are checked.

For a segment ``[a, b]`` and centre ``c`` the closest point is
``x = a + s (b - a)`` with ``s = clamp((c - a).(b - a) / |b - a|^2, 0, 1)``
and the distance ``d = |x - c|``, unit normal ``n = (x - c) / d``. With
``s`` held fixed (the envelope theorem makes this exact to first order),
``x`` moves as ``(1 - s) xdot_a + s xdot_b`` where each end point is a point
of some body: ``xdot = J_v dq - [r]_x J_w dq`` (``r`` from the body's joint
origin to the point, world axes; ``J`` the joint Jacobian, world axes). So

    d(q + dq) ~= d + g^T dq,    g^T = n^T ((1 - s) J_a + s J_b).

Velocity damper: the QP row is ``g^T dq >= -xi (d - r)`` with ``0 < xi <= 1``
(:data:`DAMPER_GAIN`): each step may consume at most the fraction ``xi`` of
the current clearance, so the linearised clearance never reaches zero. The
linearisation can still be wrong for a large step, so the solver also checks
the true clearance after every step and halves the step until every
distance is ``>= r`` - the constraint holds on every iterate, not only at the
end.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from kinserve.kinematics.errors import InputError
from kinserve.kinematics.shapes import Sphere

if TYPE_CHECKING:
    from kinserve.kinematics.robot import Robot
    from kinserve.kinematics.types import VectorLike

_LWA = pin.LOCAL_WORLD_ALIGNED


def joint_step_bounds(q: np.ndarray, lower: np.ndarray, upper: np.ndarray, max_step: float) -> tuple[np.ndarray, np.ndarray]:
    """Box ``(lb, ub)`` on ``dq`` that keeps ``q + dq`` in the limits and ``|dq| <= max_step``."""
    lb = np.maximum(lower - q, -max_step)
    ub = np.minimum(upper - q, max_step)
    # q is inside the limits, so lb <= 0 <= ub; guard against round-off
    np.minimum(lb, 0.0, out=lb)
    np.maximum(ub, 0.0, out=ub)
    return lb, ub


def as_sphere(value: Any) -> Sphere:
    """Accept a :class:`Sphere`, a ``(center, radius)`` pair or a ``{"center", "radius", "frames"}`` dict."""
    if isinstance(value, Sphere):
        return value
    if isinstance(value, dict):
        try:
            return Sphere(value["center"], value["radius"], value.get("frames"))
        except KeyError as exc:
            raise InputError(f"sphere dict needs 'center' and 'radius', missing {exc}") from None
    try:
        center, radius = value
    except (TypeError, ValueError):
        raise InputError(f"spheres must be ik.Sphere objects or (center, radius) pairs, got {value!r}") from None
    return Sphere(center, radius)


class _Segment:
    """A segment between two body points ``(joint, local point)``; joint 0 = fixed in the world."""

    __slots__ = ("name", "ja", "la", "jb", "lb")

    def __init__(self, name, ja, la, jb, lb):
        self.name = name
        self.ja, self.la = int(ja), np.asarray(la, dtype=float).copy()
        self.jb, self.lb = int(jb), np.asarray(lb, dtype=float).copy()

    @property
    def fixed(self) -> bool:
        return self.ja == 0 and self.jb == 0


def robot_segments(robot: Robot, tool_frame: str) -> list[_Segment]:
    """The default checked geometry of ``robot``: link, prismatic and tool segments (module docstring)."""
    model = robot.model
    segs = []
    for j in range(1, model.njoints):
        p = model.parents[j]
        mount = model.jointPlacements[j].translation
        pname = "base" if p == 0 else model.names[p]
        segs.append(_Segment(f"link {pname} -> {model.names[j]}", p, np.zeros(3), p, mount))
        if model.joints[j].shortname().startswith("JointModelP"):
            segs.append(_Segment(f"slider {model.names[j]}", p, mount, j, np.zeros(3)))
    f = model.frames[robot.frame_id(tool_frame)]
    segs.append(_Segment(f"tool {tool_frame}", f.parentJoint, np.zeros(3), f.parentJoint, f.placement.translation))
    return segs


def frame_points(robot: Robot, frames: Iterable[str]) -> list[_Segment]:
    """Zero-length segments at the origins of the named frames."""
    segs = []
    for name in frames:
        f = robot.model.frames[robot.frame_id(name)]
        t = f.placement.translation
        segs.append(_Segment(f"frame {name}", f.parentJoint, t, f.parentJoint, t))
    return segs


def _closest(a, b, c):
    """(s, x) of the point ``x = a + s (b - a)`` of segment ``[a, b]`` closest to ``c``."""
    ab = b - a
    L2 = ab.dot(ab)
    if L2 < 1e-24:
        return 0.0, a
    s = (c - a).dot(ab) / L2
    s = 0.0 if s < 0.0 else (1.0 if s > 1.0 else s)
    return s, a + s * ab


class SphereSet:
    """All (sphere, segment) pairs of one solve, bound to a robot and tool frame.

    ``clearances`` and ``rows`` read ``robot.data`` after forward kinematics
    (``rows`` also needs ``computeJointJacobians``) - the QP solver calls them
    right after its own kinematics pass.
    """

    def __init__(self, robot: Robot, spheres: Iterable[Sphere], tool_frame: str) -> None:
        self.robot = robot
        self.spheres = [as_sphere(s) for s in spheres]
        pairs = []
        default = None
        for k, sph in enumerate(self.spheres):
            if sph.frames is None:
                if default is None:
                    default = robot_segments(robot, tool_frame)
                segs = default
            else:
                segs = frame_points(robot, sph.frames)
            c = np.array(sph.center)
            for seg in segs:
                if seg.fixed:
                    a = seg.la + 0.0
                    b = seg.lb + 0.0
                    _, x = _closest(a, b, c)
                    if np.linalg.norm(x - c) < sph.radius:
                        raise InputError(
                            f"sphere {k} (center {list(sph.center)}, radius {sph.radius:g}) contains the robot base "
                            f"({seg.name}); the base cannot move out of it"
                        )
                    continue
                pairs.append((k, c, sph.radius, seg))
        self.pairs = pairs
        self.m = len(pairs)

    def _points(self, data, seg):
        oa, ob = data.oMi[seg.ja], data.oMi[seg.jb]
        a = oa.act(seg.la) if seg.ja else seg.la + 0.0
        b = ob.act(seg.lb) if seg.jb else seg.lb + 0.0
        return a, b

    def clearances(self, data: pin.Data) -> np.ndarray:
        """``d - r`` (m) for every pair at the configuration of ``data`` (after FK)."""
        out = np.empty(self.m)
        for i, (_, c, r, seg) in enumerate(self.pairs):
            a, b = self._points(data, seg)
            _, x = _closest(a, b, c)
            out[i] = math.sqrt((x - c).dot(x - c)) - r
        return out

    def clearances_at(self, q: VectorLike) -> np.ndarray:
        """``d - r`` at ``q`` (runs forward kinematics on the robot's data)."""
        pin.forwardKinematics(self.robot.model, self.robot.data, q)
        return self.clearances(self.robot.data)

    def rows(self, data: pin.Data) -> tuple[np.ndarray, np.ndarray]:
        """``(d - r, G)``: clearances ``(m,)`` and their gradients ``G`` ``(m, nq)`` (after computeJointJacobians)."""
        model = self.robot.model
        n = model.nv
        G = np.zeros((self.m, n))
        clear = np.empty(self.m)
        jac = {}
        for i, (_, c, r, seg) in enumerate(self.pairs):
            a, b = self._points(data, seg)
            s, x = _closest(a, b, c)
            v = x - c
            d = math.sqrt(v.dot(v))
            clear[i] = d - r
            if d < 1e-12:
                continue
            nrm = v / d
            for j, pt, w in ((seg.ja, a, 1.0 - s), (seg.jb, b, s)):
                if j == 0 or w == 0.0:
                    continue
                J = jac.get(j)
                if J is None:
                    J = jac[j] = pin.getJointJacobian(model, data, j, _LWA)
                rvec = pt - data.oMi[j].translation
                # n . (v_o + w x r) = n . v_o + (r x n) . w
                G[i] += w * (nrm.dot(J[:3]) + np.cross(rvec, nrm).dot(J[3:]))
        return clear, G

    def describe_violation(self, clear: np.ndarray) -> str:
        """Human-readable list of the pairs with negative clearance."""
        parts = []
        for i in np.flatnonzero(clear < 0.0):
            k, c, r, seg = self.pairs[i]
            parts.append(f"sphere {k} (center {c.tolist()}, radius {r:g}) is entered by {seg.name} by {-clear[i]:.4g} m")
        return "; ".join(parts)
