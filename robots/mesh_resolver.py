"""The one mesh resolver: the file a URDF ``<mesh filename=...>`` names, for every load and later build.

Every loader (a URDF file or string, a xacro file, a built-in robot of the
registry) makes one :class:`MeshResolver` per load (:meth:`MeshResolver.for_model`)
and the :class:`~kinserve.kinematics.robot.Robot` it returns keeps it
(``Robot.resolve_meshes`` is :meth:`MeshResolver.collision_urdf`): a collision
model built later from ``Robot.source`` (a robot loaded with
``geometry=False``, as the CLI loads) reads the files the load itself would
have read, from the same search path, with the same refusals.

A filename resolves as follows:

* ``package://<pkg>/<sub>``: ``<folder of pkg>/<sub>``, the folder found by
  :class:`robots.packages.PackageFinder` in this order, first hit wins:

  1. the caller's ``package_dirs=`` (CLI: ``--package-dir``): a package, a
     folder of packages or a workspace;
  2. the folder holding the model file and its ancestors: the nearest one
     whose ``package.xml`` names ``pkg``, else the nearest one named ``pkg``;
  3. ``$ROS_PACKAGE_PATH`` (then ``$AMENT_PREFIX_PATH``'s ``share/<pkg>``);
  4. example-robot-data's ``share`` folder (``<share>/<pkg>``);

* ``file://<path>`` and plain paths: an absolute path as it is, a relative
  one against the model's folder (a URDF string has none).

Unless ``allow_outside``, a file outside the folders the model may read from
(its own folder and package, every package folder found) is refused with a
message that does not depend on whether the file exists. A mesh that cannot
be found is reported with where it was looked for and how to add a folder
(``package_dirs=``, ``--package-dir``, ``$ROS_PACKAGE_PATH``).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple
from urllib.parse import unquote

from lxml import etree

from kinserve.kinematics.errors import ModelError
from kinserve.kinematics.validation import as_flag

from . import paths
from .packages import PackageFinder, is_within
from .urdf_elements import attribute_floats, describe, where

#: Radius (m) of the sphere drawn in place of a visual mesh that cannot be found.
PLACEHOLDER_RADIUS = 0.02

#: The URDF elements that hold geometry, in the order they are checked.
GEOMETRY_KINDS = ("visual", "collision")

#: How to make a mesh that cannot be found findable (ends every "could not be found" message).
HOW_TO_ADD_A_FOLDER = (
    "pass the folder holding its package (or the package itself) in package_dirs= "
    "(CLI: --package-dir DIR), or add it to $ROS_PACKAGE_PATH"
)

_SAFE_PARSER = etree.XMLParser(resolve_entities=False, no_network=True, huge_tree=False)


class MissingMeshWarning(UserWarning):
    """A mesh file of a model cannot be found; a placeholder shape is drawn instead."""


class MissingMesh(NamedTuple):
    """A ``<mesh>`` whose file could not be found."""

    kind: str  #: "visual" or "collision"
    uri: str  #: its ``filename`` attribute
    message: str  #: where it is, where it was looked for, how to add a folder


class MeshElement(NamedTuple):
    """A ``<mesh>`` element with the link and geometry kind holding it."""

    link: etree._Element
    kind: str  #: "visual" or "collision"
    mesh: etree._Element


def default_package_dirs() -> list[Path]:
    """Package folders always searched last: example-robot-data's ``share`` when it is installed."""
    try:
        return [paths.example_robot_data_package_dir()]
    except ModelError:
        return []


def check_package_dirs(package_dirs: object) -> tuple[str, ...]:
    """The ``package_dirs=`` of every loader (``robots.load``, :func:`~robots.urdf_loader.load_urdf`,
    :func:`~robots.xacro_loader.load_xacro`) as absolute folder paths: None (none), one folder (a str or
    ``os.PathLike``) or an iterable of folders. :class:`ModelError` naming ``package_dirs`` for anything else
    and for an entry that is not an existing folder."""
    if package_dirs is None:
        return ()
    if isinstance(package_dirs, (str, os.PathLike)):
        package_dirs = (package_dirs,)
    elif isinstance(package_dirs, bytes) or not isinstance(package_dirs, Iterable):
        raise ModelError(f"package_dirs must be a folder or a list of folders, got "
                         f"{type(package_dirs).__name__} {str(package_dirs)[:60]!r}")
    dirs = []
    for d in package_dirs:
        if not isinstance(d, (str, os.PathLike)) or not Path(d).expanduser().is_dir():
            raise ModelError(f"package_dirs: {d!r} is not a folder")
        dirs.append(str(Path(d).expanduser().resolve()))
    return tuple(dirs)


def mesh_elements(root: etree._Element, kinds: Iterable[str] = GEOMETRY_KINDS) -> Iterator[MeshElement]:
    """Every ``<link>/<kind>/<geometry>/<mesh>`` of a parsed URDF, link by link."""
    for link in root.findall("link"):
        for kind in kinds:
            for mesh in link.findall(f"{kind}/geometry/mesh"):
                yield MeshElement(link, kind, mesh)


@dataclass
class MeshResolver:
    """Resolves mesh ``filename`` URIs to files (see the module docstring for the search order).

    ``finder`` finds package folders (and remembers them), ``base_dir`` is
    the model file's folder (None for a URDF string), ``label`` names the
    model in messages.
    """

    finder: PackageFinder
    base_dir: Path | None
    allow_outside: bool = False
    label: str = "<URDF string>"
    #: collision mesh URIs the load reported missing and left out; a later build leaves them out too
    dropped: frozenset[str] = frozenset()

    def __post_init__(self) -> None:
        self.allow_outside = as_flag(self.allow_outside, "allow_outside")

    @classmethod
    def for_model(cls, base_dir: Path | None, package_dirs: Iterable[str | os.PathLike] = (), *,
                  allow_outside: bool = False, label: str = "<URDF string>") -> "MeshResolver":
        """The resolver of a model in ``base_dir``: ``package_dirs`` (:func:`check_package_dirs`) first,
        example-robot-data last.

        ``$ROS_PACKAGE_PATH`` and ``$AMENT_PREFIX_PATH`` are read now: a later
        build searches the folders this load searched.
        """
        dirs = check_package_dirs(package_dirs)
        finder = PackageFinder(tuple(map(Path, dirs)), base_dir, tuple(default_package_dirs()))
        return cls(finder, base_dir, allow_outside, label)

    # ------------------------------------------------------------ one filename
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

    def check_inside(self, uri: str, place: str) -> None:
        """Raise ModelError when ``uri`` resolves outside the allowed folders (existence is not looked at)."""
        if self.allow_outside:
            return
        cands = self.candidates(uri)  # first: a package found here becomes one of the roots
        roots = self.finder.roots()
        for cand in cands:
            if not is_within(cand, roots):
                raise ModelError(
                    f"{place}: mesh file {uri!r} resolves outside the folders this model may read from "
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

    def not_found_message(self, uri: str, place: str, owner: str, kind: str) -> str:
        """Why ``uri`` (a ``kind`` mesh of ``owner``, at ``place``) could not be found, and what to do."""
        looked = [str(c) for c in self.candidates(uri)]
        if looked:
            detail = "looked in: " + ", ".join(looked)
        elif uri.startswith("package://"):
            pkg = uri[len("package://"):].partition("/")[0]
            detail = f"package {pkg!r} not found in: " + "; ".join(self.finder.searched())
        else:
            detail = "a relative path in a URDF string has no folder to resolve it against"
        return (f"{place}: mesh file {uri!r} of {owner} ({kind}) could not be found ({detail}); "
                + HOW_TO_ADD_A_FOLDER)

    def package_dirs(self) -> list[Path]:
        """Folders that resolve every package found so far with Pinocchio's ``<dir>/<pkg>`` convention
        (the package folder itself when it is not named after its package)."""
        return [folder.parent if folder.name == pkg else folder for pkg, folder in self.finder.found.items()]

    # ------------------------------------------------------------- a whole URDF
    def check_meshes(self, root: etree._Element, label: str, kinds: Iterable[str] = GEOMETRY_KINDS, *,
                     lines: bool = True) -> list[MissingMesh]:
        """Check every ``<mesh>`` of ``kinds``: the meshes that could not be found, in file order.

        Messages start with ``label`` and, with ``lines``, the element's line
        number (off for text that is not the file the user has). Raises
        :class:`ModelError` for a ``<mesh>`` without filename, a bad ``scale``
        and (unless ``allow_outside``) a file outside the allowed folders.
        """
        missing = []
        for link, kind, mesh in mesh_elements(root, kinds):
            uri = mesh.get("filename")
            place = where(label, mesh) if lines else label
            if not uri:
                raise ModelError(f"{place}: <mesh> in {kind} of {describe(link)} has no filename")
            attribute_floats(mesh, "scale", 3, label, link)
            self.check_inside(uri, place)
            if self.resolve(uri) is None:
                message = self.not_found_message(uri, place, describe(link), kind)
                missing.append(MissingMesh(kind, uri, message))
        return missing

    def find_packages(self, root: etree._Element) -> None:
        """Look up the folder of every package a ``package://`` mesh URI names (no mesh file is read)."""
        for _, _, mesh in mesh_elements(root):
            uri = mesh.get("filename") or ""
            if uri.startswith("package://"):
                self.finder.find(uri[len("package://"):].partition("/")[0])

    def absolutise(self, root: etree._Element) -> bool:
        """Replace relative / ``file://`` mesh filenames found by absolute paths; True when one changed.

        ``package://`` URIs stay (``Robot.package_dirs`` and this resolver resolve them).
        """
        changed = False
        for mesh in root.iter("mesh"):
            uri = mesh.get("filename") or ""
            if uri.startswith("package://") or (Path(uri).is_absolute() and not uri.startswith("file://")):
                continue
            found = self.resolve(uri)
            if found is not None:
                mesh.set("filename", str(found.resolve()))
                changed = True
        return changed

    def geometry_xml(self, root: etree._Element) -> str:
        """URDF text for Pinocchio's geometry builder: every mesh an absolute path, missing meshes replaced.

        A visual mesh that cannot be found becomes a sphere of radius
        :data:`PLACEHOLDER_RADIUS`; a collision mesh that cannot be found is
        left out (a made-up shape would give made-up collision answers).
        Pinocchio then never searches package folders itself: this resolver
        (and its refusal of files outside the model's folders) is the only one.
        """
        root = etree.fromstring(etree.tostring(root))
        for mesh in list(root.iter("mesh")):
            found = self.resolve(mesh.get("filename") or "")
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

    def collision_urdf(self, urdf: str) -> str:
        """``urdf`` (a robot's ``source``) with every collision mesh an absolute path, for a later build.

        Raises :class:`ModelError` when a collision mesh could not be found
        (the message names the first one, where it was looked for, and
        ``package_dirs=`` / ``--package-dir`` / ``$ROS_PACKAGE_PATH``) or lies
        outside the allowed folders. A mesh the load itself reported missing
        (a :class:`MissingMeshWarning`, listed in :attr:`dropped`) is left out
        instead, so the later build has the shapes the load built.
        """
        try:
            root = etree.fromstring(urdf.encode("utf-8"), _SAFE_PARSER)
        except (etree.XMLSyntaxError, AttributeError) as exc:
            raise ModelError(f"{self.label}: the robot's URDF text cannot be parsed again: {exc}") from None
        missing = [m for m in self.check_meshes(root, self.label, kinds=("collision",), lines=False)
                   if m.uri not in self.dropped]
        if missing:
            more = f" ({len(missing) - 1} more collision mesh(es) not found)" if len(missing) > 1 else ""
            raise ModelError(f"cannot build the collision model: {missing[0].message}{more}")
        return self.geometry_xml(root)
