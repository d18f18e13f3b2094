"""``Robot``: one Pinocchio model, one Data workspace, a default tool frame.

Conventions (see ARCHITECTURE.md):

* joint vectors are 1-D float arrays of length ``nq`` (metres for prismatic,
  radians for revolute joints); ``nq == nv`` for every model kinserve loads
  (continuous joints are turned into revolute joints with +-2 pi limits by the
  loader);
* poses are homogeneous 4x4 arrays ``T = [[R, p], [0, 1]]`` of the frame in
  the world;
* ``jacobian`` returns the textbook *geometric* Jacobian ``J`` with rows
  ``[v; w]``: ``v`` the linear velocity of the frame origin and ``w`` the
  angular velocity, both in world axes (Pinocchio's LOCAL_WORLD_ALIGNED), so
  ``[v; w] = J(q) qdot``.

A ``Robot`` owns one ``pinocchio.Data``. It is not thread-safe: give every
thread its own ``robot.copy()`` (which shares the immutable model).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from . import singularity
from .batch_fk import ChainFK
from .errors import FrameError, ModelError, ShapeError, SingularityError, suggest
from .validation import MAX_ABS, as_matrix, as_vector, check_limits

#: Names of the six task components, in the row order of ``Robot.jacobian``.
TASK_AXES = ("x", "y", "z", "roll", "pitch", "yaw")

_REFERENCES = {
    "world": pin.LOCAL_WORLD_ALIGNED,
    "local_world_aligned": pin.LOCAL_WORLD_ALIGNED,
    "local": pin.LOCAL,
    "body": pin.LOCAL,
    "spatial": pin.WORLD,
}

_hypot = math.hypot
# bound once: the hot paths below skip the module attribute lookups
_forward_kinematics = pin.forwardKinematics
_update_frame_placement = pin.updateFramePlacement
_frame_jacobian = pin.computeFrameJacobian
_LWA = pin.LOCAL_WORLD_ALIGNED


def axis_rows(axes) -> list[int]:
    """Row indices (into ``TASK_AXES``) of task component names; ``phi`` = ``yaw``."""
    rows = []
    for a in axes:
        key = "yaw" if a == "phi" else a
        if key not in TASK_AXES:
            raise ShapeError(f"unknown task component {a!r}; expected some of {TASK_AXES} (or 'phi' for yaw)")
        rows.append(TASK_AXES.index(key))
    return rows


class Robot:
    """A kinematic chain (or tree) loaded into Pinocchio, with a default tool frame.

    Parameters
    ----------
    model:
        A ``pinocchio.Model`` whose configuration space is a vector space
        (``nq == nv``: revolute and prismatic joints).
    tip:
        Name of the default tool frame; the last frame of the model if omitted.
    name, description:
        Registry name and one-line description.
    visual_model, collision_model:
        Optional ``pinocchio.GeometryModel`` objects (meshes) for viewers.
    task_axes:
        The task components the mechanism can act on (``("x", "y", "yaw")``
        for a planar arm). Singularity measures use these rows by default.
    source:
        The URDF text the model was built from (for export and viewers).
    package_dirs:
        Directories used to resolve ``package://`` mesh URIs of ``source``.
    """

    def __init__(
        self,
        model: pin.Model,
        *,
        tip: str | None = None,
        name: str = "robot",
        description: str = "",
        visual_model: pin.GeometryModel | None = None,
        collision_model: pin.GeometryModel | None = None,
        task_axes=TASK_AXES,
        source: str | None = None,
        package_dirs=(),
    ):
        if model.nq != model.nv:
            raise ModelError(
                f"robot {name!r}: configuration space must be a vector space (nq == nv); "
                f"got nq={model.nq}, nv={model.nv} (continuous/floating/spherical joints are not supported "
                f"- load through robots.load, which turns continuous joints into bounded revolute joints)"
            )
        if model.nq == 0:
            raise ModelError(f"robot {name!r} has no movable joint")
        self.model = model
        self.data = model.createData()
        self.name = name
        self.description = description
        self.visual_model = visual_model
        self.collision_model = collision_model
        self.source = source
        self.package_dirs = tuple(package_dirs)
        self.task_axes = tuple("yaw" if a == "phi" else a for a in task_axes)
        axis_rows(self.task_axes)
        self._frame_ids: dict[str, int] = {}
        for i, f in enumerate(model.frames):
            self._frame_ids.setdefault(f.name, i)
        self.frame_names: list[str] = list(self._frame_ids)
        self.joint_names: list[str] = list(model.names)[1:]
        self.lower = np.array(model.lowerPositionLimit, dtype=float)
        self.upper = np.array(model.upperPositionLimit, dtype=float)
        # Shared by every copy(): read-only so no copy can change another's limits.
        self.lower.flags.writeable = False
        self.upper.flags.writeable = False
        if not np.all(np.isfinite(self.lower)) or not np.all(np.isfinite(self.upper)) or np.any(self.lower > self.upper):
            raise ModelError(
                f"robot {name!r}: every joint needs finite limits lower <= upper; got lower={self.lower}, upper={self.upper}"
            )
        self.nq = model.nq
        self._shape = (self.nq,)
        self.tip = tip if tip is not None else model.frames[model.nframes - 1].name
        self._tip_id = self.frame_id(self.tip)
        self._chains: dict[int, ChainFK] = {}

    # ------------------------------------------------------------------ basics
    def __repr__(self) -> str:
        return f"Robot({self.name!r}, nq={self.nq}, tip={self.tip!r})"

    def copy(self) -> "Robot":
        """A Robot sharing this (immutable) model with its own fresh ``Data``."""
        other = object.__new__(Robot)
        other.__dict__.update(self.__dict__)
        other.data = self.model.createData()
        other._chains = dict(self._chains)
        return other

    def __getstate__(self) -> dict:
        """Pickle the kinematic model only: no ``Data`` workspace, no batch-FK caches, no meshes.

        Meshes (``visual_model``/``collision_model``) can weigh hundreds of MB;
        a pickled Robot (sent to a worker process or a Ray node) is for
        kinematics. ``source`` and ``package_dirs`` travel, so a viewer on the
        other side can rebuild the geometry from them.
        """
        state = dict(self.__dict__)
        for key in ("data", "visual_model", "collision_model"):
            state[key] = None
        state["_chains"] = {}
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self.data = self.model.createData()

    def neutral(self) -> np.ndarray:
        """Mid-range configuration ``(lower + upper) / 2`` clipped to include 0 when 0 is in range."""
        q = pin.neutral(self.model).copy()
        return np.clip(q, self.lower, self.upper)

    def middle(self) -> np.ndarray:
        """Centre of the joint ranges, ``(lower + upper) / 2``."""
        return 0.5 * (self.lower + self.upper)

    def random_q(self, rng=None, n: int | None = None) -> np.ndarray:
        """Uniform random configuration(s) within the joint limits.

        ``rng`` is a ``numpy.random.Generator``, an int seed or None. With
        ``n`` given, returns an ``(n, nq)`` array.
        """
        rng = np.random.default_rng(rng) if not isinstance(rng, np.random.Generator) else rng
        size = self._shape if n is None else (int(n), self.nq)
        return rng.uniform(self.lower, self.upper, size=size)

    def frame_id(self, frame: str) -> int:
        """Pinocchio index of a frame name; :class:`FrameError` if unknown."""
        try:
            return self._frame_ids[frame]
        except (KeyError, TypeError):
            raise FrameError(
                f"unknown frame {frame!r} for robot {self.name!r}.{suggest(frame, self.frame_names)} "
                f"(robot.frame_names lists all {len(self.frame_names)})"
            ) from None

    def check_q(self, q, name: str = "q", check_limits: bool = False) -> np.ndarray:
        """Validate a joint vector: shape ``(nq,)``, finite; optionally within limits."""
        q = as_vector(q, self.nq, name)
        if check_limits:
            self.check_limits(q, name)
        return q

    def check_limits(self, q: np.ndarray, name: str = "q") -> None:
        """Raise :class:`JointLimitError` naming each joint outside its limits."""
        check_limits(q, self.lower, self.upper, self.joint_names, name)

    def within_limits(self, q: np.ndarray, tol: float = 1e-9) -> bool:
        """True when ``lower - tol <= q <= upper + tol`` for every joint."""
        return bool(np.all(q >= self.lower - tol) and np.all(q <= self.upper + tol))

    # ------------------------------------------------------------- kinematics
    def _forward(self, q, check_limits: bool) -> None:
        """Run forward kinematics into ``self.data`` after validating ``q``.

        Fast path: ``hypot(*q) < MAX_ABS`` implies every entry is finite with
        ``|q_i| <= MAX_ABS``; Pinocchio itself rejects a wrong length. Anything
        else falls through to the exact per-entry validation (``check_q``), which
        accepts e.g. ``[5e5] * 7`` and names the bad entries otherwise.
        """
        if check_limits:
            q = self.check_q(q, check_limits=True)
        try:
            if not _hypot(*q.tolist()) < MAX_ABS:
                raise ValueError
            pin.forwardKinematics(self.model, self.data, q)
        except (AttributeError, TypeError, ValueError):
            q = self.check_q(q)
            pin.forwardKinematics(self.model, self.data, q)
        return q

    def fk(self, q, frame: str | None = None, *, check_limits: bool = False) -> np.ndarray:
        """Pose ``T`` (4x4) of ``frame`` (default: the tool ``tip``) in the world at ``q``."""
        fid = self._tip_id if frame is None else self._frame_ids.get(frame) if type(frame) is str else None
        if fid is None:
            fid = self.frame_id(frame)  # raises FrameError naming the frame
        model, data = self.model, self.data
        if check_limits:
            q = self.check_q(q, check_limits=True)
        try:  # fast path, see _forward
            if _hypot(*q.tolist()) < MAX_ABS:
                _forward_kinematics(model, data, q)
                return _update_frame_placement(model, data, fid).homogeneous
        except (AttributeError, TypeError, ValueError):
            pass
        _forward_kinematics(model, data, self.check_q(q))
        return _update_frame_placement(model, data, fid).homogeneous

    def fk_all(self, q, *, check_limits: bool = False) -> dict[str, np.ndarray]:
        """Pose of every frame, ``{frame name: 4x4}``."""
        self._forward(q, check_limits)
        pin.updateFramePlacements(self.model, self.data)
        return {name: self.data.oMf[i].homogeneous for name, i in self._frame_ids.items()}

    def fk_batch(self, Q, frame: str | None = None) -> np.ndarray:
        """Poses ``(N, 4, 4)`` of ``frame`` for a batch ``Q`` of shape ``(N, nq)``.

        Vectorised over the batch with NumPy (see :mod:`kinematics.batch_fk`);
        agrees with :meth:`fk` to machine precision.
        """
        fid = self._tip_id if frame is None else self.frame_id(frame)
        Q = as_matrix(Q, (-1, self.nq), "Q")
        chain = self._chains.get(fid)
        if chain is None:
            chain = self._chains[fid] = ChainFK(self.model, fid)
        return chain(Q)

    def jacobian(self, q, frame: str | None = None, reference: str = "world", *, check_limits: bool = False) -> np.ndarray:
        """Frame Jacobian ``(6, nq)`` with rows ``[linear; angular]``.

        ``reference``:

        * ``"world"`` (default): geometric Jacobian - velocity of the frame
          origin and angular velocity, both in world axes (LOCAL_WORLD_ALIGNED);
        * ``"local"`` (alias ``"body"``): the same twist in the frame's own axes;
        * ``"spatial"``: the spatial twist (velocity of the body point at the
          world origin, world axes; Pinocchio's WORLD).
        """
        fid = self._tip_id if frame is None else self._frame_ids.get(frame) if type(frame) is str else None
        if fid is None:
            fid = self.frame_id(frame)  # raises FrameError naming the frame
        ref = _LWA if reference == "world" else _REFERENCES.get(reference)
        if ref is None:
            raise ShapeError(f"reference must be one of {sorted(_REFERENCES)}, got {reference!r}")
        if check_limits:
            q = self.check_q(q, check_limits=True)
        try:  # fast path, see _forward
            if _hypot(*q.tolist()) < MAX_ABS:
                return _frame_jacobian(self.model, self.data, q, fid, ref)
        except (AttributeError, TypeError, ValueError):
            pass
        return _frame_jacobian(self.model, self.data, self.check_q(q), fid, ref)

    def analytic_jacobian(self, q, frame: str | None = None, rotation: str = "rpy", *, singular_tol: float = 1e-6) -> np.ndarray:
        """Analytic Jacobian ``(6, nq)``: rows ``[pdot; rpy_dot]`` for ``rotation="rpy"``.

        With ``R = Rz(yaw) Ry(pitch) Rx(roll)`` and ``w = E(rpy) rpy_dot``
        (world axes), ``J_A = blockdiag(I, E^-1) J``. ``E`` is singular at
        ``pitch = +-pi/2`` (gimbal lock): then :class:`SingularityError`.
        """
        if rotation != "rpy":
            raise ShapeError(f"rotation must be 'rpy', got {rotation!r}")
        J = self.jacobian(q, frame)
        R = self.data.oMf[self._tip_id if frame is None else self.frame_id(frame)].rotation
        rpy = pin.rpy.matrixToRpy(R)
        if abs(math.cos(rpy[1])) < singular_tol:
            raise SingularityError(
                f"RPY rates are undefined at pitch = {rpy[1]:.6f} rad (|cos pitch| < {singular_tol:g}, gimbal lock); "
                "use the geometric Jacobian (reference='world') instead"
            )
        E = pin.rpy.computeRpyJacobian(rpy, pin.WORLD)
        JA = J.copy()
        JA[3:] = np.linalg.solve(E, J[3:])
        return JA

    # ------------------------------------------------------------ singularity
    def _task_jacobian(self, q, frame, axes) -> np.ndarray:
        J = self.jacobian(q, frame)
        return J[axis_rows(self.task_axes if axes is None else axes)]

    def singular_values(self, q, frame: str | None = None, axes=None) -> np.ndarray:
        """Singular values (descending) of the Jacobian rows ``axes`` (default ``task_axes``)."""
        return singularity.singular_values(self._task_jacobian(q, frame, axes))

    def manipulability(self, q, frame: str | None = None, axes=None) -> float:
        """Yoshikawa manipulability ``sqrt(det(J J^T))`` of the task rows (product of singular values)."""
        return singularity.manipulability(self._task_jacobian(q, frame, axes))

    def condition_number(self, q, frame: str | None = None, axes=None) -> float:
        """``sigma_max / sigma_min`` of the task rows (``inf`` at a singularity)."""
        return singularity.condition_number(self._task_jacobian(q, frame, axes))

    def is_singular(self, q, tol: float = 1e-6, frame: str | None = None, axes=None) -> bool:
        """True when the task Jacobian loses rank: ``sigma_min <= tol * max(1, sigma_max)``."""
        return singularity.is_singular(self._task_jacobian(q, frame, axes), tol)
