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
``ik.step`` has no back-off: bound the step with :class:`ik.VelocityLimits` so
that no point moves more than ``influence`` in one period (farther pairs have
no row and could be crossed in one long step).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from kinserve.ik.constraints.base import DAMPER_GAIN, Constraint
from kinserve.ik.constraints.base_overlap import BaseClearance, check_base_overlap
from kinserve.kinematics.collision_scene import CollisionScene
from kinserve.kinematics.errors import InputError, NonFiniteError
from kinserve.kinematics.robot import Robot
from kinserve.kinematics.shapes import as_obstacles
from kinserve.kinematics.validation import as_flag

#: Pairs closer than ``margin + INFLUENCE`` (m) contribute rows.
INFLUENCE = 0.05
_LWA = pin.LOCAL_WORLD_ALIGNED


#: Largest accepted collision margin / influence distance (m).
MAX_LENGTH = 1e3


def check_length(value: object, name: str, positive: bool = False) -> float:
    """``value`` as a finite length in metres (>= 0, or > 0 with ``positive``; at most :data:`MAX_LENGTH`);
    errors name ``name``. Refused: text, bools and other non-numbers (:class:`InputError`), NaN, infinities
    and lengths above :data:`MAX_LENGTH` (:class:`NonFiniteError`), negative (or zero) values."""
    if isinstance(value, (bool, str, bytes)) or not isinstance(value, numbers.Real):
        raise InputError(f"{name} must be a number (m), got {value!r}")
    v = float(value)
    if not math.isfinite(v) or abs(v) > MAX_LENGTH:
        raise NonFiniteError(f"{name} must be finite with magnitude <= {MAX_LENGTH:g} (m), got {value!r}")
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
    name:
        The label in messages: a non-empty str, or None for ``"self-collision"`` (no obstacles) /
        ``"collision"``.
    """

    def __init__(self, obstacles: Sequence = (), *, self_collision: bool = True, margin: float = 0.0,
                 influence: float = INFLUENCE, name: str | None = None) -> None:
        self_collision = as_flag(self_collision, "self_collision")
        obstacles = as_obstacles(obstacles)
        if name is None:
            name = "self-collision" if self_collision and not obstacles else "collision"
        super().__init__(name=name)
        self.obstacles = obstacles
        self.self_collision = self_collision
        self.clearance = check_length(margin, "collision margin")
        self.influence = check_length(influence, "collision influence", positive=True)
        self.scene = None
        self._memo: tuple | None = None  # (q bytes, near pairs) of the last near_pairs call

    # ------------------------------------------------------------------ protocol
    def bind(self, robot: Robot) -> "CollisionConstraint":
        """Build the robot's collision scene; :class:`InputError` when an obstacle contains the fixed base
        (:func:`~kinserve.ik.constraints.base_overlap.check_base_overlap`, with the robot's memory of the
        obstacles found clear of it)."""
        scene = robot.collision.scene(self.obstacles, self.self_collision)  # obstacles validated by __init__
        check_base_overlap(robot, scene, clear=_base_clearance(robot))  # (primitives found clear: remembered)
        return self._on_scene(robot, scene)

    def moved(self, obstacles: tuple) -> "CollisionConstraint":
        """This bound constraint with ``obstacles`` instead of its own: validated shapes, each the same shape
        and size as the obstacle in its place here (the same :attr:`~kinserve.kinematics.shapes.Shape.
        signature`), at any pose. Its scene shares this one's layout and is built without the collision
        model's scene caches (a few microseconds); the base-overlap check runs on the obstacles that are not
        this constraint's own objects."""
        old = self.scene
        scene = CollisionScene(old.layout, obstacles)
        check_base_overlap(self.robot, scene, known=old.obstacles)
        bound = self._on_scene(self.robot, scene)
        bound.obstacles = obstacles
        return bound

    def _on_scene(self, robot: Robot, scene) -> "CollisionConstraint":
        """A constraint with this one's settings (its public attributes) bound to ``robot`` and ``scene``; no
        state of another scene comes along (memos, caches kept on a bound constraint by its users)."""
        bound = object.__new__(type(self))
        bound.__dict__.update({k: v for k, v in self.__dict__.items()
                               if not k.startswith("_") and k not in ("in_collision", "first_collision")})
        bound.scene = scene
        bound.robot = robot
        bound._threshold = self.clearance + self.influence
        bound._memo = None
        # margin 0: the checks are the scene's own, one call less per check (loops check every iterate)
        if self.clearance == 0.0:
            bound.in_collision = scene.in_collision
            bound.first_collision = scene.first_collision
        return bound

    def near_pairs(self, q: np.ndarray, data: pin.Data | None = None) -> list[tuple]:
        """``[(k, d, p1, p2, n), ...]`` for the pairs closer than ``margin + influence`` at ``q``.

        One ``computeCollisions`` with that security margin, then a GJK distance per near pair.
        Memoised for the last ``q`` (the solvers ask for the rows and the margin at the same
        configuration). ``data``, when given, holds the joint placements of ``q``.
        """
        key = q.tobytes()
        memo = self._memo
        if memo is not None and memo[0] == key:
            return memo[1]
        scene, th = self.scene, self._threshold
        ks = scene.near(th, q if data is None else None, data)
        out = [(k, *scene.near_distance(th, k)) for k in ks]
        self._memo = (key, out)
        return out

    def pair_rows(self, robot: Robot, data: pin.Data,
                  q: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[int]]:
        """``(d, G, pairs)``: distances ``(k,)`` and rows ``g`` ``(k, nv)`` of the near pairs at ``q``.

        ``data`` holds ``pinocchio.computeJointJacobians(model, data, q)``.
        """
        scene = self.scene
        near = self.near_pairs(q, data)
        nv = robot.model.nv
        d = np.empty(len(near))
        G = np.zeros((len(near), nv))
        jac: dict[int, np.ndarray] = {}
        model = robot.model
        for r, (k, dist, p1, p2, n) in enumerate(near):
            d[r] = dist
            j1, j2 = scene.pair_joints[k]
            for j, p, sign in ((j2, p2, 1.0), (j1, p1, -1.0)):
                if j == 0:
                    continue
                J = jac.get(j)
                if J is None:
                    J = jac[j] = pin.getJointJacobian(model, data, int(j), _LWA)
                a = p - data.oMi[int(j)].translation
                # a x n
                axn = (a[1] * n[2] - a[2] * n[1], a[2] * n[0] - a[0] * n[2], a[0] * n[1] - a[1] * n[0])
                G[r] += sign * (n @ J[:3] + np.dot(axn, J[3:]))
        return d, G, [k for k, *_ in near]

    def rows(self, robot: Robot, data: pin.Data, q: np.ndarray,
             dt: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``G dq >= -xi (d - margin)`` for the near pairs (see the module docstring)."""
        d, G, _ = self.pair_rows(robot, data, q)
        lower = -DAMPER_GAIN * (d - self.clearance)
        return G, lower, np.full(len(d), np.inf)

    def margin(self, robot: Robot, data: pin.Data | None, q: np.ndarray) -> float:
        """The slack at ``q``: ``>= 0`` iff the constraint holds (the solvers use its sign and negative
        values).

        Negative: the smallest ``d - margin`` (m) over the violating pairs. Otherwise ``influence`` when
        the margin is 0 and the broad-phase check finds no collision (the fast path of every step
        back-off), else the smallest ``d - margin`` of the pairs closer than ``margin + influence``.
        """
        if self.clearance == 0.0 and not self.scene.in_collision(q):
            return self.influence
        near = self.near_pairs(q)
        if not near:
            return self.influence
        return min(item[1] for item in near) - self.clearance

    def describe(self, robot: Robot, data: pin.Data | None, q: np.ndarray) -> str:
        """The pairs closer than the margin at ``q``, in words ("" when there is none)."""
        bad = []
        for k, dist, *_ in self.near_pairs(q):
            if dist < self.clearance:
                a, b = self.scene.pair_names[k]
                bad.append(f"{a}/{b} at {dist:.4g} m")
        return f"{self.name}: " + ", ".join(bad) + f" (margin {self.clearance:g} m)" if bad else ""

    def in_collision(self, q: np.ndarray) -> bool:
        """True when ``q`` violates the constraint (the broad-phase check when the margin is 0)."""
        if self.clearance == 0.0:
            return self.scene.in_collision(q)
        return self.margin(self.robot, None, q) < 0.0

    def first_collision(self, qs: Sequence[np.ndarray]) -> int:
        """Index of the first configuration of ``qs`` (in the given order) that violates the constraint, or -1
        (with margin 0: :meth:`CollisionScene.first_collision`, one loop of broad-phase checks)."""
        if self.clearance == 0.0:
            return self.scene.first_collision(qs)
        for k, q in enumerate(qs):
            if self.in_collision(q):
                return k
        return -1


def _base_clearance(robot: Robot) -> BaseClearance | None:
    """The robot's memory of the obstacles found clear of its fixed base: the one its IK state holds
    (``robot.extensions.ik``: :class:`kinserve.ik.state.IKState`; None before the robot has one)."""
    state = robot.extensions.ik
    return None if state is None else state.base_clearance


class SelfCollision(CollisionConstraint):
    """The robot's checked link pairs (SRDF / MoveIt-style) kept ``margin`` (m) apart, on every iterate."""

    def __init__(self, margin: float = 0.0, influence: float = INFLUENCE) -> None:
        super().__init__((), self_collision=True, margin=margin, influence=influence, name="self-collision")


class SceneCollision(CollisionConstraint):
    """The robot's moving collision geometry kept ``margin`` (m) clear of ``obstacles``, on every iterate."""

    def __init__(self, obstacles: Sequence, margin: float = 0.0, influence: float = INFLUENCE) -> None:
        super().__init__(obstacles, self_collision=False, margin=margin, influence=influence,
                         name="obstacles")

