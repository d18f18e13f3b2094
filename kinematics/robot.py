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

A ``Robot`` is safe to share between threads: the ``pinocchio.Model`` is
immutable, and every thread works on its own ``pinocchio.Data`` workspace
(:attr:`Robot.data` is the calling thread's, created on its first use in that
thread and freed when the thread ends). Nothing else a ``Robot`` holds changes
after construction except caches of immutable objects (``fk_batch`` chains)
and what its owner changes on purpose: ``attach`` / ``detach`` (carried
objects) change that object, so a thread or request that carries something
works on its own ``robot.copy()``.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable, Iterable, Sequence
from types import MappingProxyType

import numpy as np
import pinocchio as pin

from . import singularity
from .batch_fk import ChainFK
from .collision_queries import CollisionQueries
from .errors import FrameError, InputError, ModelError, ShapeError, SingularityError, suggest
from .extensions import Extensions
from .geometry_reader import GeometryReader
from .types import MatrixLike, VectorLike
from .validation import (
    MAX_ABS,
    as_choice,
    as_count,
    as_flag,
    as_matrix,
    as_nonnegative,
    as_positive,
    as_vector,
    check_limits,
    describe,
)

#: Names of the six task components, in the row order of ``Robot.jacobian``.
TASK_AXES = ("x", "y", "z", "roll", "pitch", "yaw")

_REFERENCES = {
    "world": pin.LOCAL_WORLD_ALIGNED,
    "local_world_aligned": pin.LOCAL_WORLD_ALIGNED,
    "local": pin.LOCAL,
    "body": pin.LOCAL,
    "spatial": pin.WORLD,
}

#: The default ``reference`` of :meth:`Robot.jacobian` (the same interned string as the default argument:
#: compared by identity first).
_WORLD = "world"

_hypot = math.hypot
# bound once: the hot paths below skip the module attribute lookups
_forward_kinematics = pin.forwardKinematics
_update_frame_placement = pin.updateFramePlacement
_frame_jacobian = pin.computeFrameJacobian
_LWA = pin.LOCAL_WORLD_ALIGNED


class _PerThreadData(threading.local):
    """``.data``: a ``pinocchio.Data`` of ``model`` for the calling thread.

    ``threading.local`` runs ``__init__`` (with the constructor's arguments)
    the first time each thread touches the object, so every thread gets its
    own workspace lazily; a thread's workspace is freed when the thread ends.
    Reading ``.data`` costs about 50 ns more than a plain attribute.
    """

    def __init__(self, model: pin.Model):
        self.data = model.createData()


def axis_rows(axes: Iterable[str], name: str = "axes") -> list[int]:
    """Row indices (into ``TASK_AXES``) of task component names; ``phi`` = ``yaw``.

    :class:`ShapeError` naming ``name`` for a bare string (``"xyz"``: pass ``["x", "y", "z"]``), something
    that is not a sequence, an unknown component, a component given twice (``["x", "x"]``, ``["yaw",
    "phi"]``: the rows would be linearly dependent, so every measure would call it singular) or no
    component at all.
    """
    if isinstance(axes, (str, bytes)):
        raise ShapeError(f"{name} must be a sequence of task component names such as ['x', 'y', 'z'], got "
                         f"the string {axes!r}")
    try:
        items = list(axes)
    except TypeError:
        raise ShapeError(f"{name} must be a sequence of task component names from {TASK_AXES}, got "
                         f"{type(axes).__name__}") from None
    rows: list[int] = []
    for a in items:
        key = "yaw" if a == "phi" else a
        if type(key) is not str or key not in TASK_AXES:
            raise ShapeError(f"unknown task component {a!r} in {name}; expected some of {TASK_AXES} "
                             "(or 'phi' for yaw)")
        row = TASK_AXES.index(key)
        if row in rows:
            raise ShapeError(f"{name} names task component {key!r} twice ({items!r}); give each component "
                             "once")
        rows.append(row)
    if not rows:
        raise ShapeError(f"{name} must name at least one task component of {TASK_AXES}, got none")
    return rows


#: Largest integer seed of :meth:`Robot.random_q` (NumPy takes any integer >= 0; this bounds the text).
MAX_SEED = 2**128 - 1


def _seed(rng: object) -> object:
    """``rng`` for ``numpy.random.default_rng``: None, a ``BitGenerator`` / ``SeedSequence``, or an integer
    seed in ``[0, MAX_SEED]``; :class:`InputError` naming ``rng`` otherwise."""
    if rng is None or isinstance(rng, (np.random.BitGenerator, np.random.SeedSequence)):
        return rng
    try:
        return as_count(rng, "rng", minimum=0, maximum=MAX_SEED)
    except InputError:
        raise InputError(f"rng must be a numpy.random.Generator, an integer seed from 0 to 2**128 - 1 or "
                         f"None, got {describe(rng)}") from None


class Robot(CollisionQueries):
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
        Optional ``pinocchio.GeometryModel`` objects (meshes) for viewers and the
        collision model, or :class:`~.geometry_reader.GeometryReader` s that read
        them on first use (what the loader passes: see :attr:`visual_model`).
    task_axes:
        The task components the mechanism can act on (``("x", "y", "yaw")``
        for a planar arm). Singularity measures use these rows by default.
    source:
        The URDF text the model was built from (for export and viewers).
    package_dirs:
        Directories used to resolve ``package://`` mesh URIs of ``source``.
    resolve_meshes:
        The loader's mesh resolver for a collision model built later from
        ``source``: URDF text in, the same text with every collision mesh an
        absolute file path out (``kinserve.robots.mesh_resolver.MeshResolver.collision_urdf``),
        so the later build reads the files the load found. None: Pinocchio
        resolves ``package://`` URIs against ``package_dirs``.
    srdf:
        SRDF text whose ``<disable_collisions>`` name the link pairs not checked
        for self-collision (None: computed MoveIt-style, see
        :mod:`kinematics.collision_pairs`). Collision queries
        (``in_collision``, ``collisions``, ``distances``, ``min_distance``) come
        from :class:`~kinematics.collision_queries.CollisionQueries`.

    Attributes set by the loader from an SRDF (empty otherwise, see
    :mod:`kinserve.robots.srdf`): ``named_states`` (``{name: q}``, e.g.
    ``robot.named_states["default"]``), ``groups`` (``{group: joint names}``),
    ``srdf_path`` and ``srdf`` (its text, for the collision pairs).
    """

    #: Named configurations from the SRDF, ``{name: q (nq,)}`` (read-only).
    named_states = MappingProxyType({})
    #: Joint groups from the SRDF, ``{group: (joint name, ...)}`` (movable joints, model order).
    groups = MappingProxyType({})
    #: Where ``named_states`` and ``groups`` came from (None without an SRDF).
    srdf_path: str | None = None
    #: The compiled-LM chains of the model's frames (``kinserve.ik.lm.chains.CompiledChains``), set by
    #: ``kinserve.ik.lm.warm(robot)``; None until then (shared by copies, pickled with the robot).
    lm_chains: object | None = None

    def __init__(
        self,
        model: pin.Model,
        *,
        tip: str | None = None,
        name: str = "robot",
        description: str = "",
        visual_model: pin.GeometryModel | GeometryReader | None = None,
        collision_model: pin.GeometryModel | GeometryReader | None = None,
        task_axes: Sequence[str] = TASK_AXES,
        source: str | None = None,
        package_dirs: Sequence[str] = (),
        srdf: str | None = None,
        resolve_meshes: Callable[[str], str] | None = None,
    ) -> None:
        if model.nq != model.nv:
            raise ModelError(
                f"robot {name!r}: configuration space must be a vector space (nq == nv); "
                f"got nq={model.nq}, nv={model.nv} (continuous/floating/spherical joints are not supported "
                f"- load through robots.load, which turns continuous joints into bounded revolute joints)"
            )
        if model.nq == 0:
            raise ModelError(f"robot {name!r} has no movable joint")
        self.model = model
        self._tls = _PerThreadData(model)
        self.name = name
        self.description = description
        self._visual_model = visual_model
        self._collision_model = collision_model
        self.source = source
        self.package_dirs = tuple(package_dirs)
        self.resolve_meshes = resolve_meshes
        self.srdf = srdf
        self._collision_holder = [None]  # the CollisionModel, built on first use, shared by copies
        self.extensions = Extensions()  # higher layers' state (the IK's), shared by copies
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
        if (not np.all(np.isfinite(self.lower)) or not np.all(np.isfinite(self.upper))
                or np.any(self.lower > self.upper)):
            raise ModelError(
                f"robot {name!r}: every joint needs finite limits lower <= upper; "
                f"got lower={self.lower}, upper={self.upper}"
            )
        self.nq = model.nq
        self._shape = (self.nq,)
        self._span = self.upper - self.lower  # of random_q
        self._span.flags.writeable = False
        self.tip = tip if tip is not None else model.frames[model.nframes - 1].name
        self._tip_id = self.frame_id(self.tip)
        self._chains: dict[int, ChainFK] = {}

    # ------------------------------------------------------------------ basics
    def __repr__(self) -> str:
        return f"Robot({self.name!r}, nq={self.nq}, tip={self.tip!r})"

    @property
    def visual_model(self) -> pin.GeometryModel | None:
        """The visual ``pinocchio.GeometryModel`` (meshes and primitives for viewers), or None. A robot
        loaded with its geometry reads it here the first time it is asked for (a viewer drawing the robot;
        :mod:`.geometry_reader`), once for the robot and its copies; a mesh file coal cannot parse is then a
        :class:`ModelError`. Setting it replaces this robot's (not its copies')."""
        model = self._visual_model
        return model.get() if type(model) is GeometryReader else model

    @visual_model.setter
    def visual_model(self, model: pin.GeometryModel | GeometryReader | None) -> None:
        self._visual_model = model

    @property
    def collision_model(self) -> pin.GeometryModel | None:
        """The collision ``pinocchio.GeometryModel`` of the URDF's ``<collision>`` elements (the meshes as
        the files give them), or None; read on first use as :attr:`visual_model` is - when the robot's
        collision model (:attr:`collision`) is built from it, or a viewer draws it."""
        model = self._collision_model
        return model.get() if type(model) is GeometryReader else model

    @collision_model.setter
    def collision_model(self, model: pin.GeometryModel | GeometryReader | None) -> None:
        self._collision_model = model

    @property
    def data(self) -> pin.Data:
        """The calling thread's Pinocchio ``Data`` workspace (created on the thread's first use).

        Each thread sees only its own ``Data``, so one ``Robot`` can serve many
        threads; read ``robot.data`` in the thread that ran the kinematics.
        """
        return self._tls.data

    def copy(self) -> "Robot":
        """A Robot sharing this (immutable) model with its own workspaces.

        Not needed for threads (a ``Robot`` is already safe to share); useful
        to change a copy's attributes (e.g. ``visual_model``) independently, or
        to carry an object in one thread or request: the copy carries what this
        robot carries now (:meth:`attach`), and attaching to or detaching from
        either one afterwards leaves the other unchanged.
        """
        other = object.__new__(Robot)
        other.__dict__.update(self.__dict__)
        other._tls = _PerThreadData(self.model)
        other._chains = dict(self._chains)
        return other

    def __getstate__(self) -> dict:
        """Pickle the kinematic model only: no ``Data`` workspace, no batch-FK caches, no meshes.

        Meshes (``visual_model``/``collision_model``) can weigh hundreds of MB;
        a pickled Robot (sent to a worker process or a Ray node) is for
        kinematics. ``source`` and ``package_dirs`` travel, so a viewer on the
        other side can rebuild the geometry from them. Carried objects
        (:meth:`attach`) travel too; their collision model is rebuilt on first use.
        """
        state = dict(self.__dict__)
        del state["_tls"]
        for key in ("_visual_model", "_collision_model"):
            state[key] = None
        state["_chains"] = {}
        state["_collision_holder"] = [None]
        if state.get("_attached_holder") is not None:  # carried objects travel; their model is rebuilt
            state["_attached_holder"] = [None]
        state["extensions"] = Extensions()
        return state

    def __setstate__(self, state: dict) -> None:
        state.setdefault("_visual_model", state.pop("visual_model", None))
        state.setdefault("_collision_model", state.pop("collision_model", None))
        state.setdefault("srdf", None)
        state.setdefault("resolve_meshes", None)
        state.setdefault("_collision_holder", [None])
        state.setdefault("extensions", Extensions())
        self.__dict__.update(state)
        self._tls = _PerThreadData(self.model)

    def neutral(self) -> np.ndarray:
        """The model's zero configuration clipped into the limits: ``clip(0, lower, upper)``.

        This is the pose the URDF draws (every joint at 0) wherever 0 is
        allowed; a joint whose range excludes 0 sits at the limit nearest to
        0 (Panda's joint 4: ``-0.0698`` rad). It is the default IK seed, the
        default pose of viewers and of the CLI. For the centre of the ranges
        use :meth:`middle`; for the SRDF's poses, :attr:`named_states`.
        """
        q = pin.neutral(self.model).copy()
        return np.clip(q, self.lower, self.upper)

    def middle(self) -> np.ndarray:
        """Centre of the joint ranges, ``(lower + upper) / 2``."""
        return 0.5 * (self.lower + self.upper)

    def random_q(self, rng: np.random.Generator | int | None = None, n: int | None = None) -> np.ndarray:
        """Uniform random configuration(s) within the joint limits.

        ``rng`` is a ``numpy.random.Generator`` (or ``BitGenerator`` / ``SeedSequence``), an integer seed
        ``>= 0`` or None. With ``n`` given (an integer from 0 to 10**7), returns an ``(n, nq)`` array.
        :class:`InputError` naming the argument for anything else (a negative or fractional seed, text, NaN,
        a count beyond 10**7 that would allocate without bound).
        """
        if not isinstance(rng, np.random.Generator):
            rng = np.random.default_rng(_seed(rng))
        size = self._shape if n is None else (as_count(n, "n", minimum=0), self.nq)
        # ``rng.uniform(lower, upper, size)`` computes ``lower + (upper - lower) * u`` from the same doubles
        # ``u``: the same values, bit for bit, at a sixth of its cost (~1.4 instead of ~8 us per draw)
        return self.lower + self._span * rng.random(size)

    def frame_id(self, frame: str) -> int:
        """Pinocchio index of a frame name; :class:`FrameError` if unknown."""
        try:
            return self._frame_ids[frame]
        except (KeyError, TypeError):
            raise FrameError(
                f"unknown frame {frame!r} for robot {self.name!r}.{suggest(frame, self.frame_names)} "
                f"(`kinserve frames ROBOT` lists all {len(self.frame_names)}; robot.frame_names in Python)"
            ) from None

    def check_q(self, q: VectorLike, name: str = "q", check_limits: bool = False) -> np.ndarray:
        """Validate a joint vector: shape ``(nq,)``, finite; optionally within limits."""
        q = as_vector(q, self.nq, name)
        if check_limits is not False and as_flag(check_limits, "check_limits"):
            self.check_limits(q, name)
        return q

    def check_limits(self, q: VectorLike, name: str = "q") -> None:
        """Raise :class:`JointLimitError` naming each joint outside its limits.

        ``q``: ``nq`` finite real numbers (:class:`ShapeError` / :class:`NonFiniteError` naming ``name``
        otherwise: a NaN is never "within" the limits).
        """
        check_limits(as_vector(q, self.nq, name), self.lower, self.upper, self.joint_names, name)

    def within_limits(self, q: VectorLike, tol: float = 1e-9) -> bool:
        """True when ``lower - tol <= q <= upper + tol`` for every joint.

        ``q``: ``nq`` finite real numbers (:class:`ShapeError` / :class:`NonFiniteError` otherwise); ``tol``:
        a number in ``[0, 1e6]`` (joint units; :class:`InputError` / :class:`NonFiniteError` otherwise).
        """
        q = as_vector(q, self.nq)
        if type(tol) is not float or not 0.0 <= tol <= MAX_ABS:
            tol = as_nonnegative(tol, "tol")
        return bool(np.all(q >= self.lower - tol) and np.all(q <= self.upper + tol))

    # ------------------------------------------------------------- kinematics
    def _forward(self, q, check_limits: bool) -> None:
        """Run forward kinematics into this thread's ``data`` after validating ``q``.

        Fast path: ``hypot(*q) < MAX_ABS`` implies every entry is finite with
        ``|q_i| <= MAX_ABS``; Pinocchio itself rejects a wrong length. Anything
        else falls through to the exact per-entry validation (``check_q``), which
        accepts e.g. ``[5e5] * 7`` and names the bad entries otherwise.
        """
        if check_limits is not False and as_flag(check_limits, "check_limits"):
            q = self.check_q(q, check_limits=True)
        try:
            if not _hypot(*q.tolist()) < MAX_ABS:
                raise ValueError
            pin.forwardKinematics(self.model, self._tls.data, q)
        except (AttributeError, TypeError, ValueError):
            q = self.check_q(q)
            pin.forwardKinematics(self.model, self._tls.data, q)
        return q

    def fk(self, q: VectorLike, frame: str | None = None, *, check_limits: bool = False) -> np.ndarray:
        """Pose ``T`` (4x4) of ``frame`` (default: the tool ``tip``) in the world at ``q``."""
        fid = self._tip_id if frame is None else self._frame_ids.get(frame) if type(frame) is str else None
        if fid is None:
            fid = self.frame_id(frame)  # raises FrameError naming the frame
        model, data = self.model, self._tls.data
        if check_limits is not False and as_flag(check_limits, "check_limits"):
            q = self.check_q(q, check_limits=True)
        try:  # fast path, see _forward
            if _hypot(*q.tolist()) < MAX_ABS:
                _forward_kinematics(model, data, q)
                return _update_frame_placement(model, data, fid).homogeneous
        except (AttributeError, TypeError, ValueError):
            pass
        _forward_kinematics(model, data, self.check_q(q))
        return _update_frame_placement(model, data, fid).homogeneous

    def fk_all(self, q: VectorLike, *, check_limits: bool = False) -> dict[str, np.ndarray]:
        """Pose of every frame, ``{frame name: 4x4}``."""
        self._forward(q, check_limits)
        data = self._tls.data
        pin.updateFramePlacements(self.model, data)
        return {name: data.oMf[i].homogeneous for name, i in self._frame_ids.items()}

    def fk_batch(self, Q: MatrixLike, frame: str | None = None) -> np.ndarray:
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

    def jacobian(self, q: VectorLike, frame: str | None = None, reference: str = "world", *,
                 check_limits: bool = False) -> np.ndarray:
        """Frame Jacobian ``(6, nq)`` with rows ``[linear; angular]``.

        ``reference``:

        * ``"world"`` (default): geometric Jacobian - velocity of the frame
          origin and angular velocity, both in world axes (LOCAL_WORLD_ALIGNED);
        * ``"local"`` (alias ``"body"``): the same twist in the frame's own axes;
        * ``"spatial"``: the spatial twist (velocity of the body point at the
          world origin, world axes; Pinocchio's WORLD).

        (``"local_world_aligned"`` is an alias of ``"world"``.) Any other value, a name or not, raises
        :class:`ShapeError` naming the choices.
        """
        fid = self._tip_id if frame is None else self._frame_ids.get(frame) if type(frame) is str else None
        if fid is None:
            fid = self.frame_id(frame)  # raises FrameError naming the frame
        if reference is _WORLD:
            ref = _LWA
        else:
            ref = _REFERENCES.get(reference) if type(reference) is str else None
            if ref is None:
                ref = _REFERENCES[_name_choice(reference, "reference", tuple(_REFERENCES))]
        if check_limits is not False and as_flag(check_limits, "check_limits"):
            q = self.check_q(q, check_limits=True)
        try:  # fast path, see _forward
            if _hypot(*q.tolist()) < MAX_ABS:
                return _frame_jacobian(self.model, self._tls.data, q, fid, ref)
        except (AttributeError, TypeError, ValueError):
            pass
        return _frame_jacobian(self.model, self._tls.data, self.check_q(q), fid, ref)

    def analytic_jacobian(self, q: VectorLike, frame: str | None = None, rotation: str = "rpy", *,
                          singular_tol: float = 1e-6) -> np.ndarray:
        """Analytic Jacobian ``(6, nq)``: rows ``[pdot; rpy_dot]`` for ``rotation="rpy"``.

        With ``R = Rz(yaw) Ry(pitch) Rx(roll)`` and ``w = E(rpy) rpy_dot``
        (world axes), ``J_A = blockdiag(I, E^-1) J``. ``E`` is singular at
        ``pitch = +-pi/2`` (gimbal lock): then :class:`SingularityError`, raised when
        ``|cos pitch| < singular_tol``. ``singular_tol`` must be a number in ``(0, 1]``
        (:class:`InputError` / :class:`NonFiniteError` otherwise: 0, a negative number or NaN would let
        the gimbal lock through as a Jacobian of huge entries). ``rotation``: ``"rpy"`` only
        (:class:`ShapeError` for anything else).
        """
        if not (type(rotation) is str and rotation == "rpy"):
            _name_choice(rotation, "rotation", ("rpy",))
        singular_tol = as_positive(singular_tol, "singular_tol", maximum=1.0)
        J = self.jacobian(q, frame)
        R = self._tls.data.oMf[self._tip_id if frame is None else self.frame_id(frame)].rotation
        rpy = pin.rpy.matrixToRpy(R)
        if abs(math.cos(rpy[1])) < singular_tol:
            raise SingularityError(
                f"RPY rates are undefined at pitch = {rpy[1]:.6f} rad (|cos pitch| < {singular_tol:g}, "
                "gimbal lock); use the geometric Jacobian (reference='world') instead"
            )
        E = pin.rpy.computeRpyJacobian(rpy, pin.WORLD)
        JA = J.copy()
        JA[3:] = np.linalg.solve(E, J[3:])
        return JA

    # ------------------------------------------------------------ singularity
    def _task_jacobian(self, q, frame, axes) -> np.ndarray:
        rows = axis_rows(self.task_axes if axes is None else axes)
        return self.jacobian(q, frame)[rows]

    def singular_values(self, q: VectorLike, frame: str | None = None,
                        axes: Sequence[str] | None = None) -> np.ndarray:
        """Singular values (descending) of the Jacobian rows ``axes`` (default ``task_axes``).

        ``axes`` (here and in :meth:`manipulability`, :meth:`condition_number`, :meth:`is_singular`): a
        non-empty sequence of distinct names of :data:`TASK_AXES` (:func:`axis_rows`; :class:`ShapeError`
        for an empty, repeated, unknown or bare-string ``axes``).
        """
        return singularity.singular_values(self._task_jacobian(q, frame, axes))

    def manipulability(self, q: VectorLike, frame: str | None = None,
                       axes: Sequence[str] | None = None) -> float:
        """Yoshikawa manipulability ``sqrt(det(J J^T))`` of the task rows (product of singular values)."""
        return singularity.manipulability(self._task_jacobian(q, frame, axes))

    def condition_number(self, q: VectorLike, frame: str | None = None,
                         axes: Sequence[str] | None = None) -> float:
        """``sigma_max / sigma_min`` of the task rows (``inf`` at a singularity)."""
        return singularity.condition_number(self._task_jacobian(q, frame, axes))

    def is_singular(self, q: VectorLike, tol: float = 1e-6, frame: str | None = None,
                    axes: Sequence[str] | None = None) -> bool:
        """True when the task Jacobian loses rank: ``sigma_min <= tol * max(1, sigma_max)``.

        ``tol``: a number in ``[0, 1]`` (:class:`InputError` / :class:`NonFiniteError` otherwise: NaN,
        negative or huge tolerances give meaningless answers).
        """
        tol = singularity.check_tol(tol)
        return singularity.is_singular(self._task_jacobian(q, frame, axes), tol)


def _name_choice(value: object, name: str, choices: tuple[str, ...]) -> str:
    """:func:`~.validation.as_choice`, its error raised as the :class:`ShapeError` these methods have always
    raised for an unknown name."""
    try:
        return as_choice(value, name, choices)
    except InputError as exc:
        raise ShapeError(str(exc)) from None


def as_robot(value: object, name: str = "robot") -> Robot:
    """``value`` if it is a :class:`Robot`; else :class:`~.errors.InputError` naming ``name`` and how to make
    one (a robot's name is not a robot: ``robots.load(name)`` loads it)."""
    if isinstance(value, Robot):
        return value
    hint = f" (robots.load({value!r}) loads it)" if isinstance(value, str) else ""
    raise InputError(f"{name} must be a kinserve Robot (robots.load(...)), got {describe(value)}{hint}")
