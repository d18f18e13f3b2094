"""Load a URDF (file path or XML string) into a :class:`kinserve.kinematics.Robot`.

Pipeline
--------
1. **Read** the text (a path that does not exist is a :class:`ModelError`).
2. **Validate** with lxml before Pinocchio sees it, so every problem is a
   ``ModelError`` naming the file, the element and its line number:
   malformed XML, a joint whose parent/child link does not exist, duplicate
   names, a kinematic graph that is not one tree, unsupported joint types
   (``floating``/``planar``), malformed ``origin``/``axis``/``limit``
   attributes, malformed ``<collision>`` / ``<visual>`` geometry (a shape
   urdfdom does not know, sizes not positive or not finite, a bad ``origin``:
   :mod:`~robots.urdf_geometry`), leftover xacro markup. When meshes are wanted
   (``geometry=True``), every mesh URI is resolved by the model's
   :class:`~robots.mesh_resolver.MeshResolver` and a path outside the model's
   folders and the package folders is refused unless ``allow_outside``; a
   mesh that cannot be found is a :class:`MissingMeshWarning`.
   Kinematics-only loads read no mesh file; the ``Robot`` keeps the resolver
   for a collision model built later.
3. **Normalise** the joint types, because ``Robot`` needs ``nq == nv``:
   every ``continuous`` joint becomes a ``revolute`` joint with limits
   ``[-2 pi, +2 pi]`` (two full turns of travel, so every orientation is
   reachable from every other without wrapping; the joint value is then an
   ordinary angle in radians). Pinocchio would otherwise model it by
   ``(cos q, sin q)`` with ``nq = 2``, ``nv = 1``.
4. **Lock** named joints at given values (e.g. gripper fingers): a locked
   joint is rewritten as a ``fixed`` joint whose origin is
   ``origin * motion(value)`` (``Rot(axis, value)`` for revolute,
   ``Trans(value * axis)`` for prismatic). This yields the same kinematics as
   ``pinocchio.buildReducedModel`` and keeps ``Robot.source`` an exact
   description of the model.
5. **Build** the Pinocchio model from the XML string and, when asked, the
   visual and collision ``GeometryModel`` s from a copy whose mesh paths are
   the files kinserve resolved (missing ones replaced, see
   :meth:`MeshResolver.geometry_xml`; meshes are cached across loads). Relative and
   ``file://`` mesh paths are rewritten as absolute paths in ``Robot.source``
   (a string has no directory of its own to resolve them against later);
   ``package://`` URIs stay, with ``Robot.package_dirs`` resolving them.

``Robot.source`` is the original text when nothing had to change, otherwise
the normalised XML that was actually built.
"""

from __future__ import annotations

import functools
import math
import os
import threading
import warnings
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin
from lxml import etree

from kinserve.kinematics.errors import InputError, ModelError, suggest
from kinserve.kinematics.geometry_reader import GeometryReader
from kinserve.kinematics.mesh_hulls import coal_message
from kinserve.kinematics.robot import Robot, axis_rows
from kinserve.kinematics.task_axes import detect_task_axes
from kinserve.kinematics.validation import as_flag, as_text
from kinserve.kinematics.validation import describe as describe_value

from .mesh_resolver import PLACEHOLDER_RADIUS, MeshResolver, MissingMeshWarning, check_package_dirs
from .urdf_elements import attribute_floats, describe, where
from .urdf_geometry import validate_geometry, validate_inertial

#: Limits (rad) given to a ``continuous`` joint when it is turned into a revolute one.
CONTINUOUS_LIMIT = 2.0 * math.pi

#: Effort / velocity written into a ``<limit>`` that lacks them (URDF requires both;
#: kinematics never reads them). Large = "not specified", like Pinocchio's +inf.
UNSPECIFIED_RATE_LIMIT = 1.0e9

#: Joint types kinserve accepts (configuration space is a vector space).
SUPPORTED_JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed")
_UNSUPPORTED_JOINT_TYPES = ("floating", "planar", "spherical")

#: Most ``<link>`` (and most ``<joint>``) elements a URDF may have. The largest model of example-robot-data
#: (TIAGo dual) has 130 links; Pinocchio crashes on a chain of 10**4 links and spends minutes on 10**5.
MAX_LINKS = 2000

#: Most movable (non-``fixed``) joints a URDF may have. TIAGo dual, the largest of example-robot-data, has
#: 101. Every ``pinocchio.Data`` holds second-order derivative tensors of nv x nv x nv floats (about 40 nv**3
#: bytes in all: 43 MB at nv = 100, 320 MB at 200, 1.1 GB at 300), and a robot makes several (its own, one
#: per thread for its collision queries, one per motion plan, ...).
MAX_MOVABLE_JOINTS = 200

#: Tolerance on a locked joint value outside its limits.
LOCK_TOL = 1e-9

_XACRO_NS = "http://www.ros.org/wiki/xacro"

_MESH_LOADER = None
_MESH_LOCK = threading.Lock()


# --------------------------------------------------------------------------- reading
@dataclass
class UrdfSource:
    """URDF text plus where it came from (for messages and relative mesh paths)."""

    text: str
    label: str  #: file path, or "<URDF string>"
    base_dir: Path | None = None  #: directory of the file (None for a string)


def is_xml_text(source: object) -> bool:
    """True when ``source`` is XML text rather than a path (it starts with ``<``)."""
    return isinstance(source, str) and source.lstrip().startswith("<")


def read_urdf(source: str | os.PathLike) -> UrdfSource:
    """Read a URDF path or XML string; :class:`ModelError` if the file cannot be read.

    A :class:`UrdfSource` is passed through (used by the xacro loader to keep
    the xacro file's name and directory).
    """
    if isinstance(source, UrdfSource):
        return source
    if isinstance(source, bytes):
        source = source.decode("utf-8")
    if is_xml_text(source):
        return UrdfSource(source, "<URDF string>", None)
    if not isinstance(source, (str, Path)):
        raise ModelError(f"URDF source must be a file path or an XML string, got {type(source).__name__}")
    path = Path(source).expanduser()
    if not path.exists():
        raise ModelError(f"URDF file {str(path)!r} does not exist")
    if not path.is_file():
        raise ModelError(f"URDF path {str(path)!r} is not a file")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ModelError(f"cannot read URDF file {str(path)!r}: {exc}") from None
    return UrdfSource(text, str(path), path.resolve().parent)


def parse_xml(text: str, label: str) -> etree._Element:
    """Parse XML text with lxml; malformed XML is a ModelError with line and column."""
    parser = etree.XMLParser(remove_blank_text=False, resolve_entities=False, huge_tree=False)
    try:
        return etree.fromstring(text.encode("utf-8"), parser)
    except etree.XMLSyntaxError as exc:
        line, col = exc.position if exc.position else (exc.lineno, 0)
        raise ModelError(f"{label}: malformed XML at line {line}, column {col}: {exc.msg}") from None


# ------------------------------------------------------------------------ validation
def validate_urdf(root: etree._Element, label: str) -> None:
    """Check a parsed URDF tree; raise :class:`ModelError` naming file, element and line.

    Every ``<collision>`` / ``<visual>`` element's origin and shape are checked by
    :func:`~robots.urdf_geometry.validate_geometry` (urdfdom would drop a bad one silently); mesh files by
    :meth:`MeshResolver.check_meshes` (only when meshes are wanted); every ``<inertial>`` by
    :func:`~robots.urdf_geometry.validate_inertial`. Refused besides: more than :data:`MAX_LINKS` links or
    joints or more than :data:`MAX_MOVABLE_JOINTS` movable joints, a negative ``<limit velocity=>`` or
    ``effort=``.
    """
    if not isinstance(root.tag, str) or root.tag != "robot":
        raise ModelError(f"{where(label, root)}: the root element must be <robot>, got <{root.tag}>")
    for tag in ("link", "joint"):
        count = sum(1 for _ in root.iterchildren(tag))
        if count > MAX_LINKS:
            raise ModelError(f"{label}: the URDF has {count} <{tag}> elements; at most {MAX_LINKS} are "
                             "accepted")
    movable = sum(1 for joint in root.iterchildren("joint") if joint.get("type") != "fixed")
    if movable > MAX_MOVABLE_JOINTS:
        raise ModelError(f"{label}: the URDF has {movable} movable (non-fixed) joints; at most "
                         f"{MAX_MOVABLE_JOINTS} are accepted")
    for el in root.iter():
        if not isinstance(el.tag, str):
            continue
        if el.tag.startswith("{" + _XACRO_NS) or any("${" in v or "$(" in v for v in el.attrib.values()):
            raise ModelError(
                f"{where(label, el)}: {describe(el)} contains unprocessed xacro markup; "
                "load the .xacro file (robots.load('file.urdf.xacro', arg=value)) instead"
            )
    links: dict[str, etree._Element] = {}
    for link in root.findall("link"):
        name = link.get("name")
        if not name:
            raise ModelError(f"{where(label, link)}: <link> without a name attribute")
        if name in links:
            raise ModelError(f"{where(label, link)}: duplicate link name {name!r} (first at line "
                             f"{links[name].sourceline})")
        links[name] = link
    if not links:
        raise ModelError(f"{label}: the URDF defines no <link>")
    validate_geometry(root, label)
    validate_inertial(root, label)

    joints: dict[str, etree._Element] = {}
    parent_of: dict[str, str] = {}
    for joint in root.findall("joint"):
        name = joint.get("name")
        if not name:
            raise ModelError(f"{where(label, joint)}: <joint> without a name attribute")
        if name in joints:
            raise ModelError(f"{where(label, joint)}: duplicate joint name {name!r} (first at line "
                             f"{joints[name].sourceline})")
        joints[name] = joint
        jtype = joint.get("type")
        if jtype in _UNSUPPORTED_JOINT_TYPES:
            raise ModelError(
                f"{where(label, joint)}: {describe(joint)} has type {jtype!r}; kinserve supports "
                f"{', '.join(SUPPORTED_JOINT_TYPES)} joints (a fixed-base arm; nq == nv)"
            )
        if jtype not in SUPPORTED_JOINT_TYPES:
            raise ModelError(f"{where(label, joint)}: {describe(joint)} has unknown type {jtype!r}; "
                             f"expected one of {SUPPORTED_JOINT_TYPES}")
        ends = {}
        for role in ("parent", "child"):
            el = joint.find(role)
            if el is None or not el.get("link"):
                raise ModelError(f"{where(label, joint)}: {describe(joint)} needs a <{role} link=...> "
                                 "element")
            lname = el.get("link")
            if lname not in links:
                raise ModelError(
                    f"{where(label, el)}: {describe(joint)} names {role} link {lname!r}, "
                    f"which is not defined.{suggest(lname, links)}"
                )
            ends[role] = lname
        if ends["child"] in parent_of:
            raise ModelError(
                f"{where(label, joint)}: link {ends['child']!r} is the child of two joints "
                f"({joints[parent_of[ends['child']]].get('name')!r} and {name!r}); a URDF must be a tree"
            )
        if ends["child"] == ends["parent"]:
            raise ModelError(f"{where(label, joint)}: {describe(joint)} connects link {ends['child']!r} to "
                             "itself")
        parent_of[ends["child"]] = name
        origin = joint.find("origin")
        if origin is not None:
            attribute_floats(origin, "xyz", 3, label, joint)
            attribute_floats(origin, "rpy", 3, label, joint)
        if jtype != "fixed":
            axis = joint.find("axis")
            if axis is not None:
                xyz = attribute_floats(axis, "xyz", 3, label, joint)
                if xyz is not None and np.linalg.norm(xyz) < 1e-12:
                    raise ModelError(f"{where(label, axis)}: {describe(joint)}: joint axis must be non-zero, "
                                     f"got {axis.get('xyz')!r}")
            limit = joint.find("limit")
            if jtype in ("revolute", "prismatic") and limit is None:
                raise ModelError(f"{where(label, joint)}: {jtype} {describe(joint)} needs a <limit lower= "
                                 "upper= effort= velocity=> element")
            if limit is not None:
                lo = attribute_floats(limit, "lower", 1, label, joint, default=[0.0])
                hi = attribute_floats(limit, "upper", 1, label, joint, default=[0.0])
                for attr in ("effort", "velocity"):
                    if limit.get(attr) is None and jtype != "continuous":
                        raise ModelError(f"{where(label, limit)}: {describe(joint)}: "
                                         f"<limit> needs a {attr}= attribute (URDF requires it)")
                    value = attribute_floats(limit, attr, 1, label, joint)
                    if value is not None and value[0] < 0:
                        raise ModelError(f"{where(label, limit)}: {describe(joint)}: <limit {attr}="
                                         f"{limit.get(attr)!r}> must be >= 0")
                if jtype != "continuous" and lo[0] > hi[0]:
                    raise ModelError(f"{where(label, limit)}: {describe(joint)}: "
                                     f"lower limit {lo[0]} > upper limit {hi[0]}")
    for joint in joints.values():
        mimic = joint.find("mimic")
        if mimic is not None and mimic.get("joint") not in joints:
            raise ModelError(
                f"{where(label, mimic)}: {describe(joint)} mimics joint {mimic.get('joint')!r}, "
                f"which is not defined.{suggest(str(mimic.get('joint')), joints)}"
            )
    roots = [n for n in links if n not in parent_of]
    if len(roots) != 1:
        what = "no root link (the joints form a cycle)" if not roots else f"{len(roots)} root links {roots}"
        raise ModelError(f"{label}: the links must form one tree, found {what}; connect them with joints")


# ------------------------------------------------------------------ loader arguments
def check_tip(tip: object) -> str | None:
    """``tip`` if it is None or a frame name (a str; the robot refuses a name it does not have, listing
    close matches); else :class:`InputError`."""
    if tip is None or isinstance(tip, str):
        return tip
    raise InputError(f"tip must be None or the name of a frame (a str), got {describe_value(tip)}")


def check_task_axes(task_axes: object) -> tuple[str, ...] | None:
    """``task_axes`` as a tuple of task component names (``phi`` read as ``yaw``), or None (detect them).

    Accepted: None, a sequence of names from :data:`kinserve.kinematics.robot.TASK_AXES` (``("x", "y",
    "yaw")``) or one comma-separated str (``"x,y,yaw"``); each component at most once.
    :class:`ShapeError` (:func:`kinserve.kinematics.robot.axis_rows`) naming ``task_axes`` otherwise.
    """
    if task_axes is None:
        return None
    if isinstance(task_axes, str):
        task_axes = [a.strip() for a in task_axes.split(",")]
    elif isinstance(task_axes, Iterable) and not isinstance(task_axes, bytes):
        task_axes = list(task_axes)  # (an iterator is read once)
    axis_rows(task_axes, "task_axes")  # anything else (a number, bytes, an unknown name) is named there
    return tuple("yaw" if a == "phi" else a for a in task_axes)


def check_joint_values(values: object, name: str = "locked_joints") -> Mapping | None:
    """``values`` if it is None or a mapping ``{joint name: value}`` (the values are checked where the
    joints are known); else :class:`ModelError` naming ``name``."""
    if values is None or isinstance(values, Mapping):
        return values
    raise ModelError(f"{name} must be a mapping joint name -> value, got {type(values).__name__}")


def check_loader_options(tip: object, name: object, description: object, locked_joints: object,
                         package_dirs: object, task_axes: object, geometry: object, allow_outside: object
                         ) -> tuple:
    """The options of :func:`load_urdf` and :func:`~robots.xacro_loader.load_xacro`, checked (in this order)
    before any model is read: :func:`check_tip`, ``as_text``, :func:`check_joint_values`,
    :func:`~robots.mesh_resolver.check_package_dirs`, :func:`check_task_axes`, ``as_flag``."""
    return (check_tip(tip), as_text(name, "name", optional=True), as_text(description, "description"),
            check_joint_values(locked_joints), check_package_dirs(package_dirs), check_task_axes(task_axes),
            as_flag(geometry, "geometry"), as_flag(allow_outside, "allow_outside"))


# -------------------------------------------------------------------- normalisation
def continuous_to_revolute(root: etree._Element) -> list[str]:
    """Turn every ``continuous`` joint into ``revolute`` with limits +-2 pi; return their names."""
    changed = []
    for joint in root.findall("joint"):
        if joint.get("type") != "continuous":
            continue
        joint.set("type", "revolute")
        limit = joint.find("limit")
        if limit is None:
            limit = etree.SubElement(joint, "limit")
        limit.set("lower", repr(-CONTINUOUS_LIMIT))
        limit.set("upper", repr(CONTINUOUS_LIMIT))
        for attr in ("effort", "velocity"):
            if limit.get(attr) is None:
                limit.set(attr, repr(UNSPECIFIED_RATE_LIMIT))
        changed.append(joint.get("name"))
    return changed


def _origin_matrix(joint) -> np.ndarray:
    T = np.eye(4)
    origin = joint.find("origin")
    if origin is not None:
        xyz = [float(v) for v in origin.get("xyz", "0 0 0").split()]
        rpy = [float(v) for v in origin.get("rpy", "0 0 0").split()]
        T[:3, :3] = pin.rpy.rpyToMatrix(*rpy)
        T[:3, 3] = xyz
    return T


def lock_joints(root: etree._Element, locked: Mapping[str, float], label: str) -> None:
    """Rewrite each named joint as a fixed joint at the given value (see module docstring).

    Raises :class:`ModelError` for an unknown or non-movable joint and for a
    value that is not a finite number within the joint limits.
    """
    joints = {j.get("name"): j for j in root.findall("joint")}
    movable = [n for n, j in joints.items() if j.get("type") in ("revolute", "prismatic")]
    for name, value in locked.items():
        joint = joints.get(name)
        if joint is None or joint.get("type") not in ("revolute", "prismatic"):
            why = "is not a joint" if joint is None else f"is a {joint.get('type')} joint"
            raise ModelError(
                f"{label}: cannot lock {name!r}: it {why} of the model; movable joints: "
                f"{movable}.{suggest(name, movable)}"
            )
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise ModelError(f"{label}: locked joint {name!r} needs a number, got {value!r}") from None
        limit = joint.find("limit")
        lo, hi = float(limit.get("lower", 0.0)), float(limit.get("upper", 0.0))
        if not math.isfinite(v) or v < lo - LOCK_TOL or v > hi + LOCK_TOL:
            raise ModelError(f"{label}: locked joint {name!r} = {v!r} is outside its limits [{lo}, {hi}]")
        axis_el = joint.find("axis")
        axis = (np.array([float(a) for a in axis_el.get("xyz").split()]) if axis_el is not None
                else np.array([1.0, 0, 0]))
        axis = axis / np.linalg.norm(axis)
        motion = np.eye(4)
        unit = "rad" if joint.get("type") == "revolute" else "m"
        if unit == "rad":
            motion[:3, :3] = pin.AngleAxis(v, axis).matrix()
        else:
            motion[:3, 3] = v * axis
        T = _origin_matrix(joint) @ motion
        origin = joint.find("origin")
        if origin is None:
            origin = etree.Element("origin")
            joint.insert(0, origin)
        origin.set("xyz", " ".join(repr(float(x)) for x in T[:3, 3]))
        origin.set("rpy", " ".join(repr(float(x)) for x in pin.rpy.matrixToRpy(T[:3, :3])))
        for tag in ("limit", "mimic", "dynamics", "safety_controller", "calibration"):
            for el in joint.findall(tag):
                joint.remove(el)
        joint.set("type", "fixed")
        joint.insert(0, etree.Comment(f" locked by kinserve: {name} = {v!r} {unit} "))
    # joints that mimic a locked joint keep moving independently: fine for kinematics


# ----------------------------------------------------------------------- building
def build_model(xml: str, label: str) -> pin.Model:
    """``pinocchio.buildModelFromXML`` with its failures turned into ModelError."""
    try:
        return pin.buildModelFromXML(xml)
    except (ValueError, RuntimeError) as exc:
        raise ModelError(f"{label}: Pinocchio could not build a model from the URDF: {exc}") from None


def clear_mesh_cache() -> None:
    """Forget the meshes :func:`read_geometry` read (coal's ``CachedMeshLoader``, which reloads a file only
    when its modification time changes); the next build reads them again (:func:`kinserve.clear_caches`)."""
    global _MESH_LOADER
    with _MESH_LOCK:
        _MESH_LOADER = None


def read_geometry(model: pin.Model, xml: str, kind: str, label: str) -> pin.GeometryModel:
    """The ``kind`` (``"visual"`` or ``"collision"``) ``GeometryModel`` of ``xml``, whose mesh URIs the loader
    made absolute (meshes cached across calls); a failure (a mesh file coal cannot parse) is a
    :class:`ModelError` naming ``label``."""
    global _MESH_LOADER
    geometry_type = pin.GeometryType.VISUAL if kind == "visual" else pin.GeometryType.COLLISION
    with _MESH_LOCK:
        if _MESH_LOADER is None:
            import coal

            _MESH_LOADER = coal.CachedMeshLoader()
        try:
            return pin.buildGeomFromUrdfString(model, xml, geometry_type, package_dirs=[],
                                               mesh_loader=_MESH_LOADER)
        except (ValueError, RuntimeError, OSError) as exc:
            raise ModelError(f"{label}: cannot build the {kind} geometry: {coal_message(exc)}") from None


def geometry_readers(model: pin.Model, xml: str, label: str) -> tuple[GeometryReader, GeometryReader]:
    """The visual and collision :class:`~kinserve.kinematics.geometry_reader.GeometryReader` s of ``xml``
    (:func:`read_geometry` on first use)."""
    return tuple(GeometryReader(functools.partial(read_geometry, model, xml, kind, label))
                 for kind in ("visual", "collision"))


@dataclass
class PreparedUrdf:
    """A validated, normalised URDF ready for Pinocchio."""

    xml: str  #: the URDF text of the model (``Robot.source``)
    label: str
    package_dirs: tuple[Path, ...]  #: folders that resolve its ``package://`` URIs (``Robot.package_dirs``)
    robot_name: str
    continuous: tuple[str, ...]
    #: resolves its meshes, now and for a later geometry build (``Robot.resolve_meshes``)
    resolver: MeshResolver
    #: for the geometry builder (:meth:`MeshResolver.geometry_xml`); None without meshes
    geometry_xml: str | None = None
    missing_meshes: tuple[str, ...] = ()  #: one message per mesh file that was not found
    base_dir: Path | None = None  #: folder of the model file


def prepare_urdf(
    source: str | os.PathLike,
    *,
    locked_joints: Mapping[str, float] | None = None,
    package_dirs: Iterable[str | os.PathLike] = (),
    check_meshes: bool = True,
    allow_outside: bool = False,
) -> PreparedUrdf:
    """Read, validate, normalise (continuous joints, locks) a URDF; no Pinocchio yet.

    With ``check_meshes`` every mesh URI is resolved by the model's
    :class:`MeshResolver` (``package_dirs``, the model's folders,
    ``$ROS_PACKAGE_PATH``, ``$AMENT_PREFIX_PATH``, example-robot-data), refused
    when it lies outside those folders (unless ``allow_outside``), and a
    missing file is recorded in ``missing_meshes``. Without it no mesh file is
    looked at (kinematics never needs them); only the folders of the packages
    the mesh URIs name are looked up, for ``package_dirs`` and a later build.
    """
    locked_joints = check_joint_values(locked_joints)
    src = read_urdf(source)
    root = parse_xml(src.text, src.label)
    resolver = MeshResolver.for_model(src.base_dir, package_dirs, allow_outside=allow_outside,
                                      label=src.label)
    finder = resolver.finder
    validate_urdf(root, src.label)
    missing = resolver.check_meshes(root, src.label) if check_meshes else []
    resolver.dropped = frozenset(m.uri for m in missing if m.kind == "collision")
    if not check_meshes:
        resolver.find_packages(root)
    continuous = continuous_to_revolute(root)
    if locked_joints:
        lock_joints(root, locked_joints, src.label)
    changed = bool(continuous or locked_joints)
    if check_meshes:
        changed |= resolver.absolutise(root)
    xml = etree.tostring(root, encoding="unicode") if changed else src.text
    name = root.get("name") or (Path(src.label).stem if src.base_dir else "robot")
    used = [*resolver.package_dirs(), *finder.package_dirs, *finder.extra_dirs]
    if src.base_dir is not None:
        used.append(src.base_dir)  # absolutised relative meshes stay readable when `xml` is loaded again
    return PreparedUrdf(
        xml, src.label, tuple(dict.fromkeys(used)), name, tuple(continuous), resolver,
        resolver.geometry_xml(root) if check_meshes else None, tuple(m.message for m in missing),
        src.base_dir,
    )


def load_urdf(
    source: str | os.PathLike,
    *,
    tip: str | None = None,
    name: str | None = None,
    description: str = "",
    locked_joints: Mapping[str, float] | None = None,
    package_dirs: str | os.PathLike | Iterable[str | os.PathLike] | None = (),
    geometry: bool = True,
    task_axes: str | Sequence[str] | None = None,
    allow_outside: bool = False,
) -> Robot:
    """Load a URDF file path or XML string as a :class:`Robot`.

    Parameters
    ----------
    source:
        Path to a ``.urdf`` file, the URDF XML text itself, or a :class:`UrdfSource`.
    tip:
        Default tool frame, a frame name (the model's last frame if None).
    name, description:
        Registry name (a str; default: the ``<robot name=...>``) and one-line description (a str).
    locked_joints:
        ``{joint name: value}`` (rad or m) of joints to freeze, e.g. gripper fingers (a mapping or None).
    package_dirs:
        Existing folders (one, a list, or None: :func:`~robots.mesh_resolver.check_package_dirs`)
        resolving ``package://<pkg>/...`` mesh URIs, searched before
        the folders holding the file, ``$ROS_PACKAGE_PATH``,
        ``$AMENT_PREFIX_PATH`` and example-robot-data (see :mod:`robots.mesh_resolver`).
    geometry:
        Resolve the visual and collision meshes now (a mesh file that cannot be
        found is a :class:`MissingMeshWarning` and a placeholder, see
        :meth:`MeshResolver.geometry_xml`) and read them on first use: the
        visual ``GeometryModel`` when a viewer draws the robot, the collision
        one when its collision model is built (``Robot.visual_model``,
        :mod:`kinserve.kinematics.geometry_reader`); a mesh file coal cannot
        parse is a :class:`ModelError` then. With
        ``geometry=False`` no mesh file is read now, and a collision model
        built later (``robot.in_collision``) resolves its meshes with the
        same resolver (``Robot.resolve_meshes``).
    task_axes:
        Task components the mechanism can act on (see :class:`Robot`), names or one comma-separated str
        (:func:`check_task_axes`); None detects them from the model
        (:func:`kinematics.task_axes.detect_task_axes`).
    allow_outside:
        Read mesh files outside the model's folders and the package folders
        (refused by default: a model file from elsewhere could name any file).

    Every problem with the model is a :class:`ModelError` naming the file and
    the offending element (with its line number); an argument of the wrong kind (``geometry`` or
    ``allow_outside`` not True or False, ``tip``, ``name`` or ``description`` not a str, bad ``task_axes``) is
    an :class:`InputError`, bad ``package_dirs`` or ``locked_joints`` a :class:`ModelError`.
    """
    tip, name, description, locked_joints, package_dirs, task_axes, geometry, allow_outside = \
        check_loader_options(tip, name, description, locked_joints, package_dirs, task_axes, geometry,
                             allow_outside)
    prep = prepare_urdf(source, locked_joints=locked_joints, package_dirs=package_dirs, check_meshes=geometry,
                        allow_outside=allow_outside)
    model = build_model(prep.xml, prep.label)
    visual = collision = None
    if geometry:
        for message in prep.missing_meshes:
            warnings.warn(f"{message}; drawing a {PLACEHOLDER_RADIUS} m sphere instead (no collision shape)",
                          MissingMeshWarning, stacklevel=2)
        visual, collision = geometry_readers(model, prep.geometry_xml, prep.label)  # read on first use
    if task_axes is None:
        task_axes = detect_task_axes(model).axes
    try:
        return Robot(
            model,
            tip=tip,
            name=name or prep.robot_name,
            description=description,
            visual_model=visual,
            collision_model=collision,
            task_axes=task_axes,
            source=prep.xml,
            package_dirs=[str(d) for d in prep.package_dirs],
            resolve_meshes=prep.resolver.collision_urdf,
        )
    except (InputError, ModelError) as exc:  # unknown tip frame, bad task axes, no movable joint
        raise type(exc)(f"{prep.label}: {exc}") from None
