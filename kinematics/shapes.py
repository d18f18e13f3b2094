"""Solid 3-D shapes: the one vocabulary of obstacles and collision bodies.

``Sphere``, ``Box``, ``Capsule``, ``Cylinder`` and ``Mesh`` are used by the IK
constraints (``kinserve.ik`` re-exports them), by the robot's collision queries
(``Robot.distances(q, obstacles=...)``), by the service and by the viewer. Each
shape is immutable, validated on construction, and knows

* ``pose`` - its 4x4 placement in the world (m);
* ``geometry()`` - the matching `coal` collision geometry, built with the shape
  (coal ships with Pinocchio; distances with witness points come from it), as are
  its bounding ball, its hash, its ``signature_key`` (the bytes of its ``signature``,
  what a collision scene's layout depends on: the kind and sizes, not the pose) and
  its ``obstacle_bytes`` (the row of the compiled collision pre-check,
  :mod:`.obstacle_table`, as bytes; ``obstacle_row`` reads it) - the shape is
  immutable, so a scene of new shapes is built from these without computing them;
* ``signed_distance(points)`` - the exact Euclidean signed distance (m) from
  world points, ``(N, 3) -> (N,)``, negative inside (closed forms below; the
  mesh uses its convex hull's face planes, exact inside and a lower bound on the
  true distance outside - see :class:`Mesh`);
* ``to_dict()`` - plain JSON-able data (``kind`` plus the constructor arguments).

Closed forms (``p`` a point in the shape's own frame):

* sphere, centre ``c``, radius ``r``:       ``|p - c| - r``;
* box, half extents ``h``:                  ``q = |p| - h``; ``|max(q, 0)| + min(max_i q_i, 0)``;
* capsule, segment ``[a, b]``, radius ``r``: ``|p - closest(p, [a, b])| - r``;
* cylinder along local z, radius ``r``, length ``L``: the 2-D box formula on
  ``(sqrt(x^2 + y^2) - r, |z| - L/2)``.

``frames`` (optional, every shape): names of robot frames whose origins alone
are kept clear of this obstacle by the IK; ``None`` (default) means the whole
robot (its links, or its collision geometry when it has one).
"""

from __future__ import annotations

import math
import numbers
import os
import struct
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .errors import InputError, ModelError, NonFiniteError, ShapeError
from .obstacle_table import obstacle_row
from .validation import MAX_ABS, as_pose, as_vector

#: A bounding ball's centre and radius (m) as the bytes a shape keeps (:meth:`Shape.bounding_ball`): one
#: block, where a tuple of tuple and floats would be six objects to make and to free with the shape.
_BALL = struct.Struct("4d")

if TYPE_CHECKING:
    import coal
    import pinocchio as pin

__all__ = ["MAX_EXTENT", "Shape", "Sphere", "Box", "Capsule", "Cylinder", "Mesh", "as_shape", "as_obstacles",
           "SHAPE_KINDS"]


def _positive(value: Any, name: str) -> float:
    """A finite, strictly positive length in metres (a number: text and bools are refused, not read)."""
    if isinstance(value, (bool, np.bool_, str, bytes)):
        raise ShapeError(f"{name} must be a number (m), got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ShapeError(f"{name} must be a number (m), got {value!r}") from None
    if not math.isfinite(v) or abs(v) > MAX_ABS:
        raise NonFiniteError(f"{name} must be finite and at most {MAX_ABS:g} m, got {value!r}")
    if v <= 0.0:
        raise InputError(f"{name} must be positive (m), got {v!r}")
    return v


def _mesh_scale(scale: Any) -> tuple[float, float, float]:
    """A mesh's ``scale``: one positive number (the same on every axis) or three, each finite, positive and
    at most :data:`MAX_ABS`; the error naming ``mesh scale`` otherwise."""
    if isinstance(scale, numbers.Real) and not isinstance(scale, bool):
        v = _positive(scale, "mesh scale")
        return (v, v, v)
    if isinstance(scale, (bool, str, bytes)) or scale is None or np.ndim(scale) == 0:
        raise ShapeError(f"mesh scale must be a positive number or three of them, got {scale!r}")
    s = as_vector(scale, 3, "mesh scale")
    return tuple(_positive(v, "mesh scale entries") for v in s.tolist())


def _frames(frames: Any, kind: str) -> tuple[str, ...] | None:
    if frames is None:
        return None
    if isinstance(frames, str):
        frames = (frames,)
    try:
        frames = tuple(frames)
    except TypeError:
        raise InputError(f"{kind} frames must be a sequence of frame names, got {frames!r}") from None
    if not frames or not all(isinstance(f, str) and f for f in frames):
        raise InputError(f"{kind} frames must be a non-empty sequence of frame names, got {frames!r}")
    return frames


def _points(points: Any) -> np.ndarray:
    p = np.asarray(points, dtype=float)
    if p.ndim == 1:
        p = p[None, :]
    if p.ndim != 2 or p.shape[1] != 3:
        raise ShapeError(f"points must have shape (N, 3) or (3,), got shape {np.shape(points)}")
    return p


def _translation(t: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = t
    return T


def _plain_bytes(kind: str, frames: tuple[str, ...] | None, values: Iterable[Any]) -> bytes:
    """A shape's plain data (its kind, frames and :meth:`Shape._fields`' ``values``) as one bytes object,
    equal for equal data: the ``repr`` of the kind, the frames and the fields that are not lists (numbers,
    a path), then each list of numbers (of lists: a pose's rows) as the bytes of its float64 values with
    ``-0.0`` made ``0.0`` (the fields hold no NaN). A kind's lists have fixed lengths, so two shapes of one
    kind are equal exactly when their bytes are. One object, not one per field: a shape is freed as fast as
    it is made."""
    scalars, blocks = [], []
    for value in values:
        if type(value) is list:
            blocks.append((np.asarray(value, dtype=np.float64) + 0.0).tobytes())
        else:
            scalars.append(value)
    return repr((kind, frames, *scalars)).encode() + b"".join(blocks)


#: What a shape makes from its fields (:meth:`Shape._set`): never pickled, made again when unpickled.
_DERIVED = frozenset(("_geometry", "_hash", "_plain", "_ball", "signature_key", "obstacle_bytes"))


def _fields_of(cls: type) -> tuple[str, ...]:
    """The slots of ``cls`` and its bases that hold a shape's constructor fields (:data:`_DERIVED` aside):
    what a shape pickles."""
    slots = (k for c in reversed(cls.__mro__) for k in c.__dict__.get("__slots__", ()))
    return tuple(k for k in slots if k not in _DERIVED)


#: Farthest a shape may reach from the world origin (m): its bounding ball lies within this distance. coal's
#: distances lose precision on larger shapes (a sphere of radius 1e5 m beside the Panda is misjudged by 7 cm,
#: a box of 2e5 m by 1 cm; at 1e4 m they agree with those of a 10 m sphere or box to 0.1 mm).
MAX_EXTENT = 1e4


def _check_extent(kind: str, ball: tuple[float, float, float, float]) -> None:
    """:class:`ShapeError` unless the bounding ball ``(x, y, z, r)`` lies within :data:`MAX_EXTENT` of the
    origin."""
    x, y, z, r = ball
    reach = math.sqrt(x * x + y * y + z * z) + r
    if not reach <= MAX_EXTENT:
        raise ShapeError(f"{kind}: a shape must lie within {MAX_EXTENT:g} m of the world origin (coal's "
                         f"distances lose precision beyond), this one reaches {reach:.3g} m (bounding ball "
                         f"centre ({x:.3g}, {y:.3g}, {z:.3g}), radius {r:.3g})")


class Shape:
    """Common behaviour of the solid shapes (not instantiated directly).

    Every field lives in a slot, the subclasses' too (no instance dictionary): a scene's shapes are freed in
    the call that makes the next scene, and a slotted shape is one block of memory, not two."""

    __slots__ = ("pose", "frames", "_ball", "_plain", "_hash", "signature_key", "obstacle_bytes")
    kind: str = "shape"
    pose: np.ndarray
    frames: tuple[str, ...] | None
    #: :attr:`signature` as bytes (its ``repr``, exact for floats): equal for equal signatures, and the part
    #: of a layout's look-up key this shape brings (one block of memory to hash and compare, where the tuple
    #: would be a dozen objects).
    signature_key: bytes
    #: The shape's row ``(16,)`` of the compiled pre-check's obstacle table at its pose
    #: (:func:`~.obstacle_table.obstacle_row`) as the bytes of its float64 values, native order: a scene
    #: joins its obstacles' rows with one ``bytes.join``, and a shape freed with its scene frees one plain
    #: block, not an array.
    obstacle_bytes: bytes

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(f"{type(self).__name__} is immutable")

    #: Whether the shape keeps the coal geometry it makes (a mesh's hull: costly to build, shared); the
    #: primitives make theirs on each :meth:`geometry` call, so a shape holds no coal object.
    _keeps_geometry = False

    def _set(self, **fields: Any) -> None:
        """Set the constructor's ``fields`` (arrays copied read-only), then what follows from them: the
        bounding ball, the hash, the signature and the obstacle row (the shape is immutable, so they never
        change); a mesh also keeps its coal geometry."""
        for k, v in fields.items():
            if isinstance(v, np.ndarray):  # immutable all the way down: hashes and cached scenes stay valid
                v = v.copy()
                v.setflags(write=False)
            object.__setattr__(self, k, v)
        geometry = self._make_geometry()
        if self._keeps_geometry:
            object.__setattr__(self, "_geometry", geometry)
        ball = self._world_ball()
        _check_extent(self.kind, ball)
        object.__setattr__(self, "_ball", _BALL.pack(*ball))
        plain = _plain_bytes(self.kind, self.frames, self._fields().values())
        object.__setattr__(self, "_plain", plain)
        object.__setattr__(self, "_hash", hash(plain))
        object.__setattr__(self, "signature_key", repr(self._signature()).encode())
        object.__setattr__(self, "obstacle_bytes", obstacle_row(geometry, self.pose).tobytes())

    @property
    def signature(self) -> tuple:
        """What makes two obstacles interchangeable up to their pose (a collision scene's layout is shared by
        the scenes whose obstacles have the same signatures): the kind and sizes; a mesh: the object itself.
        Made on each read; :attr:`signature_key`, its bytes, is kept."""
        return self._signature()

    def _signature(self) -> tuple:
        """:attr:`signature`: this very object (a mesh; the subclasses with sizes override it)."""
        return (self.kind, id(self))

    @property
    def obstacle_row(self) -> np.ndarray:
        """The shape's row ``(16,)`` of the compiled pre-check's obstacle table at its pose, float64,
        read-only: a view of :attr:`obstacle_bytes` made on each read."""
        return np.frombuffer(self.obstacle_bytes)

    # -- coal ------------------------------------------------------------------------------------------
    def geometry(self) -> coal.CollisionGeometry:
        """The coal collision geometry in the shape's own frame: a new one on each call (a sphere, box,
        capsule or cylinder; the objects that query coal make theirs once and own them: a scene's layout, a
        bound constraint's tables), or a mesh's convex hull, built with the mesh and shared."""
        return self._make_geometry()

    def _make_geometry(self):  # pragma: no cover - every subclass overrides
        raise NotImplementedError

    def bounding_ball(self) -> tuple[tuple[float, float, float], float]:
        """``(centre, radius)`` (world, m) of a ball that contains the shape (made with the shape): the local
        ball of :meth:`_local_ball` moved by the pose. Cheap tests of "certainly apart" (the base-overlap
        check)."""
        x, y, z, r = _BALL.unpack(self._ball)
        return (x, y, z), r

    def _world_ball(self) -> tuple[float, float, float, float]:
        """The bounding ball's centre ``x, y, z`` and radius (world, m)."""
        c, r = self._local_ball()
        t = self.pose[:3, 3] if c is None else self.pose[:3, 3] + self.pose[:3, :3] @ c
        return (*t.tolist(), float(r))

    def _local_ball(self) -> tuple[np.ndarray | None, float]:
        """Centre (shape frame; None: the origin) and radius (m) of a ball containing the shape."""
        return None, self._radius_about_origin()

    def _radius_about_origin(self) -> float:  # pragma: no cover - every subclass overrides one of the two
        raise NotImplementedError

    def placement(self) -> pin.SE3:
        """The pose as a ``pinocchio.SE3``."""
        import pinocchio as pin

        return pin.SE3(self.pose[:3, :3].copy(), self.pose[:3, 3].copy())

    # -- geometry ------------------------------------------------------------------------------------
    def local_points(self, points: Any) -> np.ndarray:
        """World points ``(N, 3)`` expressed in the shape's frame."""
        p = _points(points)
        R, t = self.pose[:3, :3], self.pose[:3, 3]
        return (p - t) @ R

    def signed_distance(self, points: Any) -> np.ndarray:
        """Signed distance (m) from world points ``(N, 3)``: > 0 outside, < 0 inside."""
        return self._local_signed_distance(self.local_points(points))

    def _local_signed_distance(self, p: np.ndarray) -> np.ndarray:  # pragma: no cover - overridden
        raise NotImplementedError

    def contains(self, points: Any) -> np.ndarray:
        """True where a world point lies inside (or on) the shape."""
        return self.signed_distance(points) <= 0.0

    def to_dict(self) -> dict:
        """Plain data: ``{"kind": ..., <constructor arguments>}`` (JSON-able)."""
        d = {"kind": self.kind, **self._fields()}
        if self.frames is not None:
            d["frames"] = list(self.frames)
        return d

    def _fields(self) -> dict:  # pragma: no cover - overridden
        raise NotImplementedError

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self._fields().items())
        return f"{type(self).__name__}({args})"

    def __eq__(self, other: object) -> bool:
        """Same type and the same plain data (:meth:`to_dict`'s values, made with the shape as one bytes
        object, :func:`_plain_bytes`): value-keyed look-ups (the IK state's bound scenes) compare one bytes
        object per shape."""
        return type(other) is type(self) and other._plain == self._plain

    def __hash__(self) -> int:
        """Hash of the plain data (the kind, the frames and the constructor's numbers, consistent with
        ``==``), computed with the shape: it is immutable and value-keyed caches hash it per solve."""
        return self._hash

    def __getstate__(self) -> dict:  # the hash of a str differs between processes: not pickled
        return {k: getattr(self, k) for k in _fields_of(type(self)) if hasattr(self, k)}

    def __setstate__(self, state: dict) -> None:
        self._set(**state)


class Sphere(Shape):
    """A ball: ``center`` (3,) in metres (world), ``radius`` > 0 (m)."""

    __slots__ = ("center", "radius")
    kind = "sphere"
    center: tuple[float, float, float]
    radius: float

    def __init__(self, center: Sequence[float], radius: float, frames: Iterable[str] | None = None) -> None:
        c = as_vector(center, 3, "sphere center")
        self._set(center=tuple(float(v) for v in c), radius=_positive(radius, "sphere radius"),
                  frames=_frames(frames, "sphere"), pose=_translation(c))

    def _make_geometry(self):
        import coal

        return coal.Sphere(self.radius)

    def _signature(self) -> tuple:
        return ("sphere", self.radius)

    def _radius_about_origin(self) -> float:
        return self.radius

    def _local_signed_distance(self, p: np.ndarray) -> np.ndarray:
        return np.linalg.norm(p, axis=1) - self.radius

    def distance(self, point: Sequence[float]) -> float:
        """Distance (m) from a point to the sphere's centre."""
        return float(np.linalg.norm(np.asarray(point, dtype=float) - np.asarray(self.center)))

    def _fields(self) -> dict:
        return {"center": list(self.center), "radius": self.radius}


class Box(Shape):
    """A box: 4x4 ``pose`` of its centre (world), ``size`` = full edge lengths (m), as URDF's ``<box
    size>``."""

    __slots__ = ("size",)
    kind = "box"
    size: tuple[float, float, float]

    def __init__(self, pose: Any, size: Sequence[float], frames: Iterable[str] | None = None) -> None:
        T = as_pose(pose, "box pose")
        s = as_vector(size, 3, "box size")
        self._set(pose=T, size=tuple(_positive(v, "box size entries") for v in s),
                  frames=_frames(frames, "box"))

    @property
    def half_extents(self) -> np.ndarray:
        """Half the edge lengths (m), along the box's own axes."""
        return 0.5 * np.asarray(self.size)

    def _make_geometry(self):
        import coal

        return coal.Box(*self.size)

    def _signature(self) -> tuple:
        return ("box", self.size)

    def _radius_about_origin(self) -> float:  # half the diagonal
        return 0.5 * math.sqrt(sum(v * v for v in self.size))

    def _local_signed_distance(self, p: np.ndarray) -> np.ndarray:
        q = np.abs(p) - self.half_extents
        outside = np.linalg.norm(np.maximum(q, 0.0), axis=1)
        inside = np.minimum(q.max(axis=1), 0.0)
        return outside + inside

    def _fields(self) -> dict:
        return {"pose": self.pose.tolist(), "size": list(self.size)}


class Capsule(Shape):
    """All points within ``radius`` (m) of the segment from ``a`` to ``b`` (world, m)."""

    __slots__ = ("a", "b", "radius")
    kind = "capsule"
    a: tuple[float, float, float]
    b: tuple[float, float, float]
    radius: float

    def __init__(self, a: Sequence[float], b: Sequence[float], radius: float,
                 frames: Iterable[str] | None = None) -> None:
        pa, pb = as_vector(a, 3, "capsule a"), as_vector(b, 3, "capsule b")
        self._set(a=tuple(float(v) for v in pa), b=tuple(float(v) for v in pb),
                  radius=_positive(radius, "capsule radius"), frames=_frames(frames, "capsule"),
                  pose=_axis_pose(pa, pb))

    @property
    def length(self) -> float:
        """Length (m) of the core segment (0 for a sphere-like capsule)."""
        return float(np.linalg.norm(np.subtract(self.b, self.a)))

    def _make_geometry(self):
        import coal

        return coal.Capsule(self.radius, self.length)

    def _signature(self) -> tuple:
        return ("capsule", self.radius, self.length)

    def _radius_about_origin(self) -> float:  # the pose's origin is the segment's midpoint
        return 0.5 * self.length + self.radius

    def _local_signed_distance(self, p: np.ndarray) -> np.ndarray:
        half = 0.5 * self.length
        z = np.clip(p[:, 2], -half, half)
        return np.sqrt(p[:, 0] ** 2 + p[:, 1] ** 2 + (p[:, 2] - z) ** 2) - self.radius

    def _fields(self) -> dict:
        return {"a": list(self.a), "b": list(self.b), "radius": self.radius}


class Cylinder(Shape):
    """A solid cylinder along its local z axis: 4x4 ``pose`` of its centre, ``radius`` and ``length`` (m), as
    URDF."""

    __slots__ = ("radius", "length")
    kind = "cylinder"
    radius: float
    length: float

    def __init__(self, pose: Any, radius: float, length: float, frames: Iterable[str] | None = None) -> None:
        self._set(pose=as_pose(pose, "cylinder pose"), radius=_positive(radius, "cylinder radius"),
                  length=_positive(length, "cylinder length"), frames=_frames(frames, "cylinder"))

    def _make_geometry(self):
        import coal

        return coal.Cylinder(self.radius, self.length)

    def _signature(self) -> tuple:
        return ("cylinder", self.radius, self.length)

    def _radius_about_origin(self) -> float:  # a rim point
        return math.hypot(self.radius, 0.5 * self.length)

    def _local_signed_distance(self, p: np.ndarray) -> np.ndarray:
        q = np.stack([np.hypot(p[:, 0], p[:, 1]) - self.radius, np.abs(p[:, 2]) - 0.5 * self.length], axis=1)
        return np.linalg.norm(np.maximum(q, 0.0), axis=1) + np.minimum(q.max(axis=1), 0.0)

    def _fields(self) -> dict:
        return {"pose": self.pose.tolist(), "radius": self.radius, "length": self.length}


class Mesh(Shape):
    """A triangle mesh read from ``path`` (STL, OBJ, PLY, ...), placed at 4x4 ``pose``, scaled by ``scale``.

    Collision queries use the mesh's **convex hull** (coal ``Convex``): exact for
    convex meshes, conservative (never reports "clear" when the solid mesh is hit)
    for concave ones; split a concave obstacle into convex parts for tighter
    clearance. The mesh must be a closed surface (watertight), otherwise "inside"
    has no meaning and :class:`~kinserve.kinematics.errors.ModelError` is raised.

    ``path``: a non-empty ``str`` or ``os.PathLike`` naming a readable file; ``scale``: one positive number
    or three (each finite, at most 1e6). :class:`~kinserve.kinematics.errors.InputError` (or its
    ``ShapeError`` / ``NonFiniteError``) naming the argument otherwise.
    """

    __slots__ = ("path", "scale", "hull_vertices", "hull_planes", "_geometry")
    kind = "mesh"
    path: str
    scale: tuple[float, float, float]
    _keeps_geometry = True

    def __init__(self, path: str | Path, pose: Any = None, scale: float | Sequence[float] = 1.0,
                 frames: Iterable[str] | None = None) -> None:
        if isinstance(path, bytes) or not isinstance(path, (str, os.PathLike)) or not str(path):
            given = repr(path) if isinstance(path, (str, bytes)) or path is None else type(path).__name__
            raise InputError(f"mesh path must be a file path (a non-empty str or pathlib.Path), got {given}")
        T = np.eye(4) if pose is None else as_pose(pose, "mesh pose")
        sc = _mesh_scale(scale)
        vertices, planes = _load_hull(Path(path), np.asarray(sc))
        self._set(path=str(path), pose=T, scale=sc, frames=_frames(frames, "mesh"),
                  hull_vertices=vertices, hull_planes=planes)

    def geometry(self) -> coal.CollisionGeometry:
        """The convex hull (coal ``Convex``) in the mesh's own frame, built with the mesh and shared."""
        return self._geometry

    def _make_geometry(self):
        import coal

        hull = coal.BVHModelOBBRSS()
        hull.beginModel(0, len(self.hull_vertices))
        hull.addVertices(np.ascontiguousarray(self.hull_vertices))
        hull.endModel()
        hull.buildConvexHull(False, "Qt")
        return hull.convex

    def _local_ball(self) -> tuple[np.ndarray, float]:  # about the hull's bounding-box centre
        V = self.hull_vertices
        c = 0.5 * (V.min(axis=0) + V.max(axis=0))
        return c, float(np.sqrt(((V - c) ** 2).sum(axis=1).max()))

    def _local_signed_distance(self, p: np.ndarray) -> np.ndarray:
        # signed distance to the hull's planes n.x - d: exact inside, a lower bound outside (face planes only)
        n, d = self.hull_planes[:, :3], self.hull_planes[:, 3]
        return (p @ n.T - d).max(axis=1)

    def _fields(self) -> dict:
        return {"path": self.path, "pose": self.pose.tolist(), "scale": list(self.scale)}


def _load_hull(path: Path, scale: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vertices ``(V, 3)`` and face planes ``(F, 4)`` (unit normal, offset) of a mesh file's convex hull."""
    import trimesh

    if not path.is_file():
        raise InputError(f"mesh path must name a readable mesh file, got {str(path)!r}")
    try:
        mesh = trimesh.load(str(path), force="mesh")
    except Exception as exc:  # noqa: BLE001 - trimesh raises many types for a bad file
        raise ModelError(f"mesh file {path.name!r} could not be read as a triangle mesh "
                         f"({type(exc).__name__})") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise ModelError(f"mesh file {path.name!r} holds no triangles")
    if not mesh.is_watertight:
        raise ModelError(f"mesh file {path.name!r} is not a closed surface (watertight mesh expected for an "
                         "obstacle)")
    mesh.apply_scale(scale)
    hull = mesh.convex_hull
    normals = np.asarray(hull.face_normals)
    offsets = np.einsum("ij,ij->i", normals, hull.vertices[hull.faces[:, 0]])
    return np.asarray(hull.vertices, dtype=float), np.column_stack([normals, offsets])


def _axis_pose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """A pose at the midpoint of ``[a, b]`` whose z axis points from ``a`` to ``b`` (any z if ``a == b``)."""
    T = np.eye(4)
    T[:3, 3] = 0.5 * (a + b)
    axis = b - a
    n = np.linalg.norm(axis)
    if n < 1e-12:
        return T
    z = axis / n
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    T[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    return T


SHAPE_KINDS: dict[str, type[Shape]] = {c.kind: c for c in (Sphere, Box, Capsule, Cylinder, Mesh)}


def as_shape(value: Any, name: str = "obstacle") -> Shape:
    """A :class:`Shape` from a shape, or from its ``to_dict()`` form ``{"kind": "box", "pose": ..., "size":
    ...}``."""
    if isinstance(value, Shape):
        return value
    if not isinstance(value, dict):
        raise InputError(f"{name} must be a shape (Sphere, Box, Capsule, Cylinder, Mesh) or a dict with a "
                         "'kind', "
                         f"got {type(value).__name__}")
    kind = value.get("kind")
    cls = SHAPE_KINDS.get(kind) if isinstance(kind, str) else None
    if cls is None:
        raise InputError(f"{name} kind must be one of {sorted(SHAPE_KINDS)}, got {kind!r}")
    args = {k: v for k, v in value.items() if k != "kind"}
    try:
        return cls(**args)
    except TypeError:
        import inspect

        params = [p for p in inspect.signature(cls.__init__).parameters if p != "self"]
        raise InputError(f"{name} of kind {kind!r} takes {params}, got {sorted(args)}") from None


def as_obstacles(obstacles: Any, name: str = "obstacles") -> tuple[Shape, ...]:
    """A tuple of shapes from a shape, a sequence of shapes / shape dicts, or None."""
    if obstacles is None:
        return ()
    if isinstance(obstacles, (Shape, dict)):
        return (as_shape(obstacles, f"{name}[0]"),)
    if isinstance(obstacles, (str, bytes)):
        raise InputError(f"{name} must be a sequence of shapes (Sphere, Box, Capsule, Cylinder, Mesh), "
                         "got a string")
    try:
        items = tuple(obstacles)
    except TypeError:
        raise InputError(f"{name} must be a sequence of shapes, got {type(obstacles).__name__}") from None
    for o in items:
        if not isinstance(o, Shape):
            break
    else:
        return items
    return tuple(as_shape(o, f"{name}[{k}]") for k, o in enumerate(items))


def as_sphere(value: Any, name: str = "spheres") -> Sphere:
    """A :class:`Sphere` from a sphere, a ``(center, radius)`` pair or a ``{"center", "radius", "frames"}``
    dict."""
    if isinstance(value, Sphere):
        return value
    if isinstance(value, dict):
        try:
            return Sphere(value["center"], value["radius"], value.get("frames"))
        except KeyError as exc:
            raise InputError(f"{name}: a sphere dict needs 'center' and 'radius', missing {exc}") from None
    try:
        center, radius = value
    except (TypeError, ValueError):
        raise InputError(f"{name} must be ik.Sphere objects or (center, radius) pairs, "
                         f"got {value!r}") from None
    return Sphere(center, radius)
