"""Self-collision and obstacles against the robot's real collision geometry (convex hulls, through coal).

``SelfCollision(margin)`` keeps the checked link pairs of the robot's collision
model (:mod:`kinserve.kinematics.collision_model`: SRDF or MoveIt-style pairs)
apart by ``margin`` (m); ``SceneCollision(obstacles, margin)`` keeps every
moving collision geometry ``margin`` away from the obstacles (any
:mod:`~kinserve.kinematics.shapes` shape). ``CollisionConstraint`` does both at
once (one coal pass over all pairs).

Math. For a pair with signed distance ``d(q)`` (coal, negative = penetration),
witness points ``p1`` on the first body (joint ``j1``) and ``p2`` on the second
(joint ``j2``) and unit normal ``n`` with ``p2 - p1 = d n``, moving the bodies by
``dq`` changes the distance to first order by

    d(q + dq) ~= d + n^T (J_p2 - J_p1) dq,

where ``J_p = Jv_j + [w_j] x (p - o_j)`` is the Jacobian of the witness point
``p`` held fixed on joint ``j``'s body (world axes; zero for the universe: an
obstacle or the fixed base). Writing ``(p - o_j) x n`` for the angular part,
``n^T J_p dq = n^T Jv_j dq + ((p - o_j) x n)^T Jw_j dq``. The QP row is the
velocity damper of :mod:`.base`:

    g dq >= -xi (d - margin),   g = n^T (J_p2 - J_p1).

Rows are built for the pairs whose distance is below ``margin + influence``
(found by one ``pinocchio.computeCollisions`` with that security margin; only
those pairs get a GJK distance); the true check after each step is
:meth:`CollisionConstraint.margin` (broad-phase collision check, then distances
of the near pairs), and the solver halves the step until it holds.
"""

from __future__ import annotations

import math

import coal
import numpy as np
import pinocchio as pin

from kinserve.kinematics.collision_queries import as_obstacles
from kinserve.kinematics.errors import InputError, NonFiniteError

from .base import DAMPER_GAIN, Constraint

#: Pairs closer than ``margin + INFLUENCE`` (m) contribute rows.
INFLUENCE = 0.05
#: An obstacle may overlap the fixed base by at most this much (m) (the Panda's base mesh reaches 0.03 mm
#: below its mounting plane, so a table under it touches it); deeper means the base is inside it.
BASE_TOLERANCE = 1e-3
_LWA = pin.LOCAL_WORLD_ALIGNED


def _length(value, name: str, positive: bool = False) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a number (m), got {value!r}") from None
    if not math.isfinite(v) or abs(v) > 1e3:
        raise NonFiniteError(f"{name} must be finite (m), got {value!r}")
    if v < 0.0 or (positive and v == 0.0):
        raise InputError(f"{name} must be {'positive' if positive else '>= 0'} (m), got {v!r}")
    return v


class CollisionConstraint(Constraint):
    """Keep the robot's collision geometry ``margin`` (m) clear of itself and/or of ``obstacles``.

    Parameters
    ----------
    obstacles:
        Shapes (or their dicts) fixed in the world.
    self_collision:
        Also keep the model's checked link pairs apart.
    margin:
        Required clearance (m), ``>= 0``.
    influence:
        Pairs closer than ``margin + influence`` (m) get QP rows.
    """

    def __init__(self, obstacles=(), *, self_collision: bool = True, margin: float = 0.0,
                 influence: float = INFLUENCE, name: str | None = None) -> None:
        super().__init__(name=name or ("self-collision" if self_collision and not obstacles else "collision"))
        self.obstacles = as_obstacles(obstacles)
        self.self_collision = bool(self_collision)
        self.clearance = _length(margin, "collision margin")
        self.influence = _length(influence, "collision influence", positive=True)
        self.scene = None

    # ------------------------------------------------------------------ protocol
    def bind(self, robot) -> "CollisionConstraint":
        """Build the robot's collision scene; :class:`InputError` when an obstacle contains the fixed base."""
        scene = robot.collision_scene(self.obstacles, self.self_collision)
        _check_base(robot, scene)
        bound = object.__new__(type(self))
        bound.__dict__.update(self.__dict__)
        bound.scene = scene
        bound.robot = robot
        bound._threshold = self.clearance + self.influence
        return bound

    def _near(self, q: np.ndarray | None = None, data=None) -> list[int]:
        """Pairs closer than ``margin + influence`` (one computeCollisions with that security margin)."""
        return self.scene.near(self._threshold, q, data)

    def _distance(self, k: int):
        return self.scene.near_distance(self._threshold, k)

    def pair_rows(self, robot, data):
        """``(d, G, pairs)``: distances ``(k,)`` and rows ``g`` ``(k, nv)`` of the near pairs.

        ``data`` holds ``pinocchio.computeJointJacobians(model, data, q)`` at the configuration of interest.
        """
        scene = self.scene
        near = self._near(data=data)
        nv = robot.model.nv
        d = np.empty(len(near))
        G = np.zeros((len(near), nv))
        jac: dict[int, np.ndarray] = {}
        model = robot.model
        for r, k in enumerate(near):
            dist, p1, p2, n = self._distance(k)
            d[r] = dist
            j1, j2 = scene.pair_joints[k]
            for j, p, sign in ((j2, p2, 1.0), (j1, p1, -1.0)):
                if j == 0:
                    continue
                J = jac.get(j)
                if J is None:
                    J = jac[j] = pin.getJointJacobian(model, data, int(j), _LWA)
                arm = p - data.oMi[int(j)].translation
                G[r] += sign * (n @ J[:3] + np.cross(arm, n) @ J[3:])
        return d, G, near

    def rows(self, robot, data, q: np.ndarray, dt: float | None = None):
        """``G dq >= -xi (d - margin)`` for the near pairs (see the module docstring)."""
        d, G, _ = self.pair_rows(robot, data)
        lower = -DAMPER_GAIN * (d - self.clearance)
        return G, lower, np.full(len(d), np.inf)

    def margin(self, robot, data, q: np.ndarray) -> float:
        """Smallest ``d - margin`` (m) over the pairs, or ``influence`` when no pair is that close."""
        near = self._near(q)
        if not near:
            return self.influence
        return min(self._distance(k)[0] for k in near) - self.clearance

    def describe(self, robot, data, q: np.ndarray) -> str:
        near = self._near(q)
        bad = []
        for k in near:
            dist = self._distance(k)[0]
            if dist < self.clearance:
                a, b = self.scene.pair_names[k]
                bad.append(f"{a}/{b} at {dist:.4g} m")
        return f"{self.name}: " + ", ".join(bad) + f" (margin {self.clearance:g} m)" if bad else ""

    def in_collision(self, q: np.ndarray) -> bool:
        """True when ``q`` violates the constraint (the broad-phase check when the margin is 0)."""
        if self.clearance == 0.0:
            return self.scene.in_collision(q)
        return self.margin(self.robot, None, q) < 0.0


def _check_base(robot, scene) -> None:
    """InputError when an obstacle overlaps a geometry fixed to the world by more than BASE_TOLERANCE."""
    gm = scene.geometry
    base = [i for i in range(scene.n_robot) if gm.geometryObjects[i].parentJoint == 0]
    if not base or scene.n_robot == gm.ngeoms:
        return
    req, res = coal.DistanceRequest(), coal.DistanceResult()
    for k in range(scene.n_robot, gm.ngeoms):
        ob = gm.geometryObjects[k]
        for i in base:
            g = gm.geometryObjects[i]
            res.clear()
            d = coal.distance(g.geometry, coal.Transform3s(g.placement.rotation, g.placement.translation),
                              ob.geometry, coal.Transform3s(ob.placement.rotation, ob.placement.translation), req, res)
            if d < -BASE_TOLERANCE:
                raise InputError(
                    f"{scene.geometry_owner[k]} overlaps the robot's fixed base ({scene.geometry_owner[i]}) by "
                    f"{-d:.4g} m; the base cannot move out of it"
                )


class SelfCollision(CollisionConstraint):
    """The robot's checked link pairs (SRDF / MoveIt-style) kept ``margin`` (m) apart, on every iterate."""

    def __init__(self, margin: float = 0.0, influence: float = INFLUENCE) -> None:
        super().__init__((), self_collision=True, margin=margin, influence=influence, name="self-collision")


class SceneCollision(CollisionConstraint):
    """The robot's moving collision geometry kept ``margin`` (m) clear of ``obstacles``, on every iterate."""

    def __init__(self, obstacles, margin: float = 0.0, influence: float = INFLUENCE) -> None:
        super().__init__(obstacles, self_collision=False, margin=margin, influence=influence, name="obstacles")

