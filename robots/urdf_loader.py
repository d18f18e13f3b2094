"""Load a URDF (file path or XML string) into a :class:`kinserve.kinematics.Robot`.

Pipeline
--------
1. **Read** the text (a path that does not exist is a :class:`ModelError`).
2. **Validate** with lxml before Pinocchio sees it, so every problem is a
   ``ModelError`` naming the file, the element and its line number:
   malformed XML, a joint whose parent/child link does not exist, duplicate
   names, a kinematic graph that is not one tree, unsupported joint types
   (``floating``/``planar``), malformed ``origin``/``axis``/``limit``
   attributes, leftover xacro markup. When meshes are wanted
   (``geometry=True``), every mesh URI is resolved (:class:`MeshResolver`,
   :mod:`robots.packages`) and a path outside the model's folders and the
   package folders is refused unless ``allow_outside``; a mesh that cannot
   be found is a :class:`MissingMeshWarning`. Kinematics-only loads never
   look at meshes.
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
   :func:`geometry_xml`; meshes are cached across loads). Relative and
   ``file://`` mesh paths are rewritten as absolute paths in ``Robot.source``
   (a string has no directory of its own to resolve them against later);
   ``package://`` URIs stay, with ``Robot.package_dirs`` resolving them.

``Robot.source`` is the original text when nothing had to change, otherwise
the normalised XML that was actually built.
"""

from __future__ import annotations

import math
import os
import threading
import warnings
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import unquote

import numpy as np
import pinocchio as pin
from lxml import etree

from kinserve.kinematics.errors import InputError, ModelError, suggest
from kinserve.kinematics.robot import Robot
from kinserve.kinematics.task_axes import detect_task_axes
from kinserve.kinematics.validation import MAX_ABS, is_bounded

from . import paths
from .packages import PackageFinder, is_within

#: Limits (rad) given to a ``continuous`` joint when it is turned into a revolute one.
CONTINUOUS_LIMIT = 2.0 * math.pi

#: Effort / velocity written into a ``<limit>`` that lacks them (URDF requires both;
#: kinematics never reads them). Large = "not specified", like Pinocchio's +inf.
UNSPECIFIED_RATE_LIMIT = 1.0e9

#: Joint types kinserve accepts (configuration space is a vector space).
SUPPORTED_JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed")
_UNSUPPORTED_JOINT_TYPES = ("floating", "planar", "spherical")

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
def _where(label: str, el) -> str:
    line = getattr(el, "sourceline", None)
    return f"{label}, line {line}" if line else label


def _desc(el) -> str:
    name = el.get("name")
    return f"<{el.tag} name={name!r}>" if name is not None else f"<{el.tag}>"


def _floats(el, attr: str, n: int, label: str, owner, default=None) -> np.ndarray | None:
    text = el.get(attr)
    if text is None:
        return None if default is None else np.array(default, dtype=float)
    try:
        vals = np.array([float(v) for v in text.split()], dtype=float)
    except ValueError:
        vals = None
    if vals is None or vals.shape != (n,) or not is_bounded(vals):
        raise ModelError(
            f"{_where(label, el)}: {_desc(owner)}: <{el.tag} {attr}={text!r}> must be {n} finite number(s) "
            f"with magnitude <= {MAX_ABS:g}"
        )
    return vals


class MissingMeshWarning(UserWarning):
    """A mesh file of a model cannot be found; a placeholder shape is drawn instead."""


#: Radius (m) of the sphere drawn in place of a visual mesh that cannot be found.
PLACEHOLDER_RADIUS = 0.02


@dataclass
class MeshResolver:
    """Resolves mesh ``filename`` URIs to files, refusing files outside the model's folders.

    ``package://<pkg>/<sub>`` is looked up with ``finder`` (see
    :mod:`robots.packages`), ``file://<path>`` and plain paths are taken as
    they are (relative ones against the model's folder). Unless
    ``allow_outside`` is set, a path that resolves outside
    ``finder.roots()`` (the model's folder and package, every package
    folder searched) is refused with a message that does not depend on
    whether the file exists, so a model cannot be used to probe for files.
    """

    finder: PackageFinder
    base_dir: Path | None
    allow_outside: bool = False
    missing: list[str] = field(default_factory=list)  #: messages of meshes not found (one per mesh)

    def candidates(self, uri: str) -> list[Path]:
        """Files a mesh URI may refer to, in search order (empty when nothing can be looked up)."""
        if uri.startswith("package://"):
            pkg, _, sub = uri[len("package://"):].partition("/")
            folder = self.finder.find(pkg)
            return [folder / unquote(sub)] if folder is not None and sub else []
        if uri.startswith("file://"):
            uri = unquote(uri[len("file://"):])
        path = Path(uri)
        if path.is_absolute():
            return [path]
        return [self.base_dir / path] if self.base_dir is not None else []

    def check_inside(self, uri: str, where: str) -> None:
        """Raise ModelError when ``uri`` resolves outside the allowed folders (existence is not looked at)."""
        if self.allow_outside:
            return
        cands = self.candidates(uri)  # first: a package found here becomes one of the roots
        roots = self.finder.roots()
        for cand in cands:
            if not is_within(cand, roots):
                raise ModelError(
                    f"{where}: mesh file {uri!r} resolves outside the folders this model may read from "
                    f"({', '.join(map(str, roots)) or 'none: a URDF string with no package_dirs'}); refused. "
                    "If you trust this model, pass allow_outside=True (CLI: --allow-outside) or add its "
                    "folder to package_dirs (CLI: --package-dir)"
                )

    def resolve(self, uri: str) -> Path | None:
        """The existing file ``uri`` refers to, or None."""
        for cand in self.candidates(uri):
            if cand.is_file():
                return cand
        return None

    def package_dirs(self) -> list[Path]:
        """Folders that resolve every package found so far: ``<dir>/<pkg>`` when the folder is named
        after its package (Pinocchio's convention), else the package folder itself."""
        out = []
        for pkg, folder in self.finder.found.items():
            out.append(folder.parent if folder.name == pkg else folder)
        return out


def validate_urdf(root: etree._Element, label: str, resolver: MeshResolver | None) -> None:
    """Check a parsed URDF tree; raise :class:`ModelError` naming file, element and line.

    With ``resolver=None`` mesh files are not checked.
    """
    if not isinstance(root.tag, str) or root.tag != "robot":
        raise ModelError(f"{_where(label, root)}: the root element must be <robot>, got <{root.tag}>")
    for el in root.iter():
        if not isinstance(el.tag, str):
            continue
        if el.tag.startswith("{" + _XACRO_NS) or any("${" in v or "$(" in v for v in el.attrib.values()):
            raise ModelError(
                f"{_where(label, el)}: {_desc(el)} contains unprocessed xacro markup; "
                "load the .xacro file (robots.load('file.urdf.xacro', arg=value)) instead"
            )
    links: dict[str, etree._Element] = {}
    for link in root.findall("link"):
        name = link.get("name")
        if not name:
            raise ModelError(f"{_where(label, link)}: <link> without a name attribute")
        if name in links:
            raise ModelError(f"{_where(label, link)}: duplicate link name {name!r} (first at line {links[name].sourceline})")
        links[name] = link
    if not links:
        raise ModelError(f"{label}: the URDF defines no <link>")

    joints: dict[str, etree._Element] = {}
    parent_of: dict[str, str] = {}
    for joint in root.findall("joint"):
        name = joint.get("name")
        if not name:
            raise ModelError(f"{_where(label, joint)}: <joint> without a name attribute")
        if name in joints:
            raise ModelError(f"{_where(label, joint)}: duplicate joint name {name!r} (first at line {joints[name].sourceline})")
        joints[name] = joint
        jtype = joint.get("type")
        if jtype in _UNSUPPORTED_JOINT_TYPES:
            raise ModelError(
                f"{_where(label, joint)}: {_desc(joint)} has type {jtype!r}; kinserve supports "
                f"{', '.join(SUPPORTED_JOINT_TYPES)} joints (a fixed-base arm; nq == nv)"
            )
        if jtype not in SUPPORTED_JOINT_TYPES:
            raise ModelError(f"{_where(label, joint)}: {_desc(joint)} has unknown type {jtype!r}; expected one of {SUPPORTED_JOINT_TYPES}")
        ends = {}
        for role in ("parent", "child"):
            el = joint.find(role)
            if el is None or not el.get("link"):
                raise ModelError(f"{_where(label, joint)}: {_desc(joint)} needs a <{role} link=...> element")
            lname = el.get("link")
            if lname not in links:
                raise ModelError(
                    f"{_where(label, el)}: {_desc(joint)} names {role} link {lname!r}, which is not defined."
                    f"{suggest(lname, links)}"
                )
            ends[role] = lname
        if ends["child"] in parent_of:
            raise ModelError(
                f"{_where(label, joint)}: link {ends['child']!r} is the child of two joints "
                f"({joints[parent_of[ends['child']]].get('name')!r} and {name!r}); a URDF must be a tree"
            )
        if ends["child"] == ends["parent"]:
            raise ModelError(f"{_where(label, joint)}: {_desc(joint)} connects link {ends['child']!r} to itself")
        parent_of[ends["child"]] = name
        origin = joint.find("origin")
        if origin is not None:
            _floats(origin, "xyz", 3, label, joint)
            _floats(origin, "rpy", 3, label, joint)
        if jtype != "fixed":
            axis = joint.find("axis")
            if axis is not None:
                xyz = _floats(axis, "xyz", 3, label, joint)
                if xyz is not None and np.linalg.norm(xyz) < 1e-12:
                    raise ModelError(f"{_where(label, axis)}: {_desc(joint)}: joint axis must be non-zero, got {axis.get('xyz')!r}")
            limit = joint.find("limit")
            if jtype in ("revolute", "prismatic") and limit is None:
                raise ModelError(f"{_where(label, joint)}: {jtype} {_desc(joint)} needs a <limit lower= upper= effort= velocity=> element")
            if limit is not None:
                lo = _floats(limit, "lower", 1, label, joint, default=[0.0])
                hi = _floats(limit, "upper", 1, label, joint, default=[0.0])
                for attr in ("effort", "velocity"):
                    if limit.get(attr) is None and jtype != "continuous":
                        raise ModelError(f"{_where(label, limit)}: {_desc(joint)}: <limit> needs a {attr}= attribute (URDF requires it)")
                    _floats(limit, attr, 1, label, joint)
                if jtype != "continuous" and lo[0] > hi[0]:
                    raise ModelError(f"{_where(label, limit)}: {_desc(joint)}: lower limit {lo[0]} > upper limit {hi[0]}")
    for joint in joints.values():
        mimic = joint.find("mimic")
        if mimic is not None and mimic.get("joint") not in joints:
            raise ModelError(
                f"{_where(label, mimic)}: {_desc(joint)} mimics joint {mimic.get('joint')!r}, which is not defined."
                f"{suggest(str(mimic.get('joint')), joints)}"
            )
    roots = [n for n in links if n not in parent_of]
    if len(roots) != 1:
        what = "no root link (the joints form a cycle)" if not roots else f"{len(roots)} root links {roots}"
        raise ModelError(f"{label}: the links must form one tree, found {what}; connect them with joints")

    if resolver is not None:
        for link in links.values():
            for kind in ("visual", "collision"):
                for geo in link.findall(f"{kind}/geometry"):
                    for mesh in geo.findall("mesh"):
                        uri = mesh.get("filename")
                        if not uri:
                            raise ModelError(f"{_where(label, mesh)}: <mesh> in {kind} of {_desc(link)} has no filename")
                        if mesh.get("scale") is not None:
                            _floats(mesh, "scale", 3, label, link)
                        resolver.check_inside(uri, _where(label, mesh))
                        if resolver.resolve(uri) is None:
                            looked = [str(c) for c in resolver.candidates(uri)]
                            if not looked and uri.startswith("package://"):
                                looked = [f"package {uri[10:].partition('/')[0]!r} not found in: " + "; ".join(resolver.finder.searched())]
                            resolver.missing.append(
                                f"{_where(label, mesh)}: mesh file {uri!r} of {_desc(link)} ({kind}) not found; looked in: "
                                + (", ".join(looked) or "(a relative path in a URDF string has no base directory)")
                            )


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
                f"{label}: cannot lock {name!r}: it {why} of the model; movable joints: {movable}.{suggest(name, movable)}"
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
        axis = np.array([float(a) for a in axis_el.get("xyz").split()]) if axis_el is not None else np.array([1.0, 0, 0])
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


def _absolutise_meshes(root, resolver: MeshResolver) -> bool:
    """Replace relative / file:// mesh filenames by absolute paths (a string has no folder to resolve them)."""
    changed = False
    for mesh in root.iter("mesh"):
        uri = mesh.get("filename") or ""
        if uri.startswith("package://") or (Path(uri).is_absolute() and not uri.startswith("file://")):
            continue
        found = resolver.resolve(uri)
        if found is not None:
            mesh.set("filename", str(found.resolve()))
            changed = True
    return changed


def geometry_xml(root: etree._Element, resolver: MeshResolver) -> str:
    """URDF text for Pinocchio's geometry builder: every mesh an absolute path, missing meshes replaced.

    A visual mesh that cannot be found becomes a sphere of radius
    :data:`PLACEHOLDER_RADIUS`; a collision mesh that cannot be found is left
    out (a made-up shape would give made-up collision answers). Pinocchio
    then never searches package folders itself: kinserve's resolution (and
    its refusal of files outside the model's folders) is the only one.
    """
    root = etree.fromstring(etree.tostring(root))
    for mesh in list(root.iter("mesh")):
        found = resolver.resolve(mesh.get("filename") or "")
        if found is not None:
            mesh.set("filename", str(found.resolve()))
            continue
        geometry = mesh.getparent()
        element = geometry.getparent()
        if element.tag == "visual":
            geometry.replace(mesh, etree.Element("sphere", radius=repr(PLACEHOLDER_RADIUS)))
        else:
            element.getparent().remove(element)
    return etree.tostring(root, encoding="unicode")


# ----------------------------------------------------------------------- building
def build_model(xml: str, label: str) -> pin.Model:
    """``pinocchio.buildModelFromXML`` with its failures turned into ModelError."""
    try:
        return pin.buildModelFromXML(xml)
    except (ValueError, RuntimeError) as exc:
        raise ModelError(f"{label}: Pinocchio could not build a model from the URDF: {exc}") from None


def build_geometry(model: pin.Model, xml: str, package_dirs: Iterable[Path],
                   label: str) -> tuple[pin.GeometryModel, pin.GeometryModel]:
    """Visual and collision ``GeometryModel`` s of ``xml`` (meshes cached across calls)."""
    global _MESH_LOADER
    dirs = [str(d) for d in package_dirs]
    with _MESH_LOCK:
        if _MESH_LOADER is None:
            import coal

            _MESH_LOADER = coal.CachedMeshLoader()
        try:
            visual = pin.buildGeomFromUrdfString(model, xml, pin.GeometryType.VISUAL, package_dirs=dirs, mesh_loader=_MESH_LOADER)
            collision = pin.buildGeomFromUrdfString(model, xml, pin.GeometryType.COLLISION, package_dirs=dirs, mesh_loader=_MESH_LOADER)
        except (ValueError, RuntimeError, OSError) as exc:
            raise ModelError(f"{label}: cannot build the visual/collision geometry: {exc}") from None
    return visual, collision


def default_package_dirs() -> list[Path]:
    """Package dirs always searched: example-robot-data's ``share`` when installed."""
    try:
        return [paths.example_robot_data_package_dir()]
    except ModelError:
        return []


@dataclass
class PreparedUrdf:
    """A validated, normalised URDF ready for Pinocchio."""

    xml: str  #: the URDF text of the model (``Robot.source``)
    label: str
    package_dirs: tuple[Path, ...]  #: folders that resolve its ``package://`` URIs (``Robot.package_dirs``)
    robot_name: str
    continuous: tuple[str, ...]
    geometry_xml: str | None = None  #: for the geometry builder (see :func:`geometry_xml`); None without meshes
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

    With ``check_meshes`` every mesh URI is resolved (``package_dirs``,
    ``$ROS_PACKAGE_PATH``, ``$AMENT_PREFIX_PATH``, the model's folders,
    example-robot-data), refused when it lies outside those folders (unless
    ``allow_outside``), and a missing file is recorded in ``missing_meshes``.
    Without it meshes are not looked at at all (kinematics never needs them).
    """
    src = read_urdf(source)
    root = parse_xml(src.text, src.label)
    if isinstance(package_dirs, (str, Path)):
        package_dirs = [package_dirs]
    finder = PackageFinder(tuple(package_dirs), src.base_dir, tuple(default_package_dirs()))
    resolver = MeshResolver(finder, src.base_dir, allow_outside)
    validate_urdf(root, src.label, resolver if check_meshes else None)
    continuous = continuous_to_revolute(root)
    if locked_joints:
        if not isinstance(locked_joints, Mapping):
            raise ModelError(f"locked_joints must be a mapping joint name -> value, got {type(locked_joints).__name__}")
        lock_joints(root, locked_joints, src.label)
    changed = bool(continuous or locked_joints)
    if check_meshes:
        changed |= _absolutise_meshes(root, resolver)
    xml = etree.tostring(root, encoding="unicode") if changed else src.text
    name = root.get("name") or (Path(src.label).stem if src.base_dir else "robot")
    used = [*resolver.package_dirs(), *finder.package_dirs, *finder.extra_dirs]
    if src.base_dir is not None:
        used.append(src.base_dir)  # absolutised relative meshes stay readable when `xml` is loaded again
    return PreparedUrdf(
        xml, src.label, tuple(dict.fromkeys(used)), name, tuple(continuous),
        geometry_xml(root, resolver) if check_meshes else None, tuple(resolver.missing), src.base_dir,
    )


def load_urdf(
    source: str | os.PathLike,
    *,
    tip: str | None = None,
    name: str | None = None,
    description: str = "",
    locked_joints: Mapping[str, float] | None = None,
    package_dirs: Iterable[str | os.PathLike] = (),
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
        Default tool frame (the model's last frame if omitted).
    name, description:
        Registry name (default: the ``<robot name=...>``) and one-line description.
    locked_joints:
        ``{joint name: value}`` (rad or m) of joints to freeze, e.g. gripper fingers.
    package_dirs:
        Folders resolving ``package://<pkg>/...`` mesh URIs, searched before
        ``$ROS_PACKAGE_PATH``, ``$AMENT_PREFIX_PATH``, the folders holding the
        file and example-robot-data (see :mod:`robots.packages`).
    geometry:
        Build the visual and collision geometry (meshes) for viewers. A mesh
        file that cannot be found is a :class:`MissingMeshWarning` and a
        placeholder (see :func:`geometry_xml`); with ``geometry=False`` meshes
        are never looked at.
    task_axes:
        Task components the mechanism can act on (see :class:`Robot`); None
        detects them from the model (:func:`kinematics.task_axes.detect_task_axes`).
    allow_outside:
        Read mesh files outside the model's folders and the package folders
        (refused by default: a model file from elsewhere could name any file).

    Every problem with the model is a :class:`ModelError` naming the file and
    the offending element (with its line number).
    """
    prep = prepare_urdf(source, locked_joints=locked_joints, package_dirs=package_dirs, check_meshes=geometry,
                        allow_outside=allow_outside)
    model = build_model(prep.xml, prep.label)
    visual = collision = None
    if geometry:
        for message in prep.missing_meshes:
            warnings.warn(f"{message}; drawing a {PLACEHOLDER_RADIUS} m sphere instead (no collision shape)",
                          MissingMeshWarning, stacklevel=2)
        visual, collision = build_geometry(model, prep.geometry_xml, (), prep.label)
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
        )
    except InputError as exc:  # unknown tip frame, bad task axes
        raise type(exc)(f"{prep.label}: {exc}") from None
