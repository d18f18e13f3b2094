"""Find ROS packages: what ``package://<pkg>/...`` and xacro's ``$(find <pkg>)`` refer to.

A *package* is a folder with a ``package.xml`` whose ``<name>`` is the package
name (ROS conventions). Packages are searched, first hit wins, in:

1. the ``package_dirs`` the caller gives (``robots.load(..., package_dirs=[...])``,
   ``kinserve ... --package-dir DIR``). Each entry may be a package folder
   itself, a folder whose subfolder ``<pkg>`` holds the files (Pinocchio's
   convention, no ``package.xml`` needed), or a workspace searched
   recursively for ``package.xml`` files;
2. the folder that holds the model file and its ancestors (a ROS package
   that contains its own URDF, e.g. ``my_robot/urdf/robot.urdf`` with
   ``package://my_robot/...``): the nearest one whose ``package.xml`` names
   the package, else the nearest one named like the package;
3. ``$ROS_PACKAGE_PATH`` (ROS 1): colon-separated folders, each searched
   recursively for ``package.xml`` files;
4. ``$AMENT_PREFIX_PATH`` (ROS 2): colon-separated install prefixes; package
   ``<pkg>`` is ``<prefix>/share/<pkg>``;
5. example-robot-data's ``share`` folder when it is installed.

Meshes are resolved with this order by :mod:`robots.mesh_resolver`.

The recursive search does not enter hidden folders, stops at a folder that
is a package (packages do not nest, as in ``rospack``), and stops at depth
:data:`MAX_DEPTH`.

This module imports only the standard library: the xacro sandbox process
(:mod:`robots.xacro_worker`) receives the package map built here.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

#: Environment variables read for package folders (see the module docstring).
ROS_PACKAGE_PATH = "ROS_PACKAGE_PATH"
AMENT_PREFIX_PATH = "AMENT_PREFIX_PATH"

#: How deep the recursive ``package.xml`` search goes below a search folder.
MAX_DEPTH = 6

#: Folders never entered by the recursive search.
_SKIP = {"node_modules", "__pycache__", "build", "log", "devel"}


def package_name(folder: Path) -> str | None:
    """The ``<name>`` of ``folder/package.xml``, or None when there is none (or it is unreadable)."""
    manifest = folder / "package.xml"
    if not manifest.is_file():
        return None
    try:
        el = ET.parse(manifest).getroot().find("name")
    except (ET.ParseError, OSError):
        return None
    name = (el.text or "").strip() if el is not None else ""
    return name or None


def scan_packages(root: Path, max_depth: int = MAX_DEPTH) -> dict[str, Path]:
    """``{package name: folder}`` of every ``package.xml`` below ``root`` (first found wins)."""
    found: dict[str, Path] = {}
    stack = [(root, 0)]
    while stack:
        folder, depth = stack.pop()
        name = package_name(folder)
        if name is not None:
            found.setdefault(name, folder)
            continue  # packages do not nest
        if depth >= max_depth:
            continue
        try:
            children = sorted((p for p in folder.iterdir() if p.is_dir()), reverse=True)
        except OSError:
            continue
        stack.extend((c, depth + 1) for c in children if not c.name.startswith(".") and c.name not in _SKIP)
    return found


def env_dirs(variable: str, environ: Mapping[str, str] | None = None) -> list[Path]:
    """The existing folders listed (colon-separated) in an environment variable."""
    text = (os.environ if environ is None else environ).get(variable, "")
    listed = [Path(p).expanduser() for p in text.split(os.pathsep) if p.strip()]
    return [p for p in listed if p.is_dir()]


@dataclass
class PackageFinder:
    """Resolves package names to folders (see the module docstring for the search order).

    ``package_dirs`` are the caller's folders, ``model_dir`` the folder of the
    model file (None for a URDF string), ``extra_dirs`` folders searched last
    with Pinocchio's ``<dir>/<pkg>`` convention (example-robot-data's share).
    """

    package_dirs: tuple[Path, ...] = ()
    model_dir: Path | None = None
    extra_dirs: tuple[Path, ...] = ()
    environ: Mapping[str, str] | None = None
    _scanned: dict[Path, dict[str, Path]] = field(default_factory=dict, repr=False)
    found: dict[str, Path] = field(default_factory=dict, repr=False)  #: packages resolved so far

    def __post_init__(self) -> None:
        self.package_dirs = tuple(Path(d).expanduser().resolve() for d in self.package_dirs)
        self.extra_dirs = tuple(Path(d).expanduser().resolve() for d in self.extra_dirs)
        self.ros_dirs = tuple(d.resolve() for d in env_dirs(ROS_PACKAGE_PATH, self.environ))
        self.ament_prefixes = tuple(d.resolve() for d in env_dirs(AMENT_PREFIX_PATH, self.environ))

    def _scan(self, root: Path) -> dict[str, Path]:
        if root not in self._scanned:
            self._scanned[root] = scan_packages(root)
        return self._scanned[root]

    def find(self, pkg: str) -> Path | None:
        """Folder of package ``pkg``, or None (remembered in :attr:`found`)."""
        if not pkg or "/" in pkg or "\\" in pkg or pkg in (".", ".."):
            return None
        if pkg not in self.found:
            hit = self._lookup(pkg)
            if hit is None:
                return None
            self.found[pkg] = hit.resolve()
        return self.found[pkg]

    def _lookup(self, pkg: str) -> Path | None:
        for d in self.package_dirs:
            if package_name(d) == pkg or (d.name == pkg and not (d / pkg).is_dir()):
                return d
            if (d / pkg).is_dir():
                return d / pkg
            hit = self._scan(d).get(pkg)
            if hit is not None:
                return hit
        hit = self._model_package(pkg)
        if hit is not None:
            return hit
        for d in self.ros_dirs:
            hit = self._scan(d).get(pkg)
            if hit is not None:
                return hit
        for prefix in self.ament_prefixes:
            if (prefix / "share" / pkg).is_dir():
                return prefix / "share" / pkg
        for d in self.extra_dirs:
            if (d / pkg).is_dir():
                return d / pkg
        return None

    def _model_package(self, pkg: str) -> Path | None:
        """The model's folder or an ancestor: the nearest whose package.xml names ``pkg``, else named so."""
        if self.model_dir is None:
            return None
        ancestors = (self.model_dir, *self.model_dir.parents)
        for anc in ancestors:
            if package_name(anc) == pkg:
                return anc
        for anc in ancestors:
            if anc.name == pkg:
                return anc
        return None

    def searched(self) -> list[str]:
        """Human-readable list of where packages are searched, in search order (for messages)."""
        given = ", ".join(map(str, self.package_dirs)) or "(none given)"
        out = [f"package_dirs= (CLI: --package-dir): {given}"]
        if self.model_dir is not None:
            out.append(f"the folder holding the model and its ancestors ({self.model_dir})")
        out.append(f"${ROS_PACKAGE_PATH}: {', '.join(map(str, self.ros_dirs)) or '(not set)'}")
        shares = ", ".join(str(p / "share") for p in self.ament_prefixes) or "(not set)"
        out.append(f"${AMENT_PREFIX_PATH}: {shares}")
        out.extend(f"searched last (example-robot-data share): {d}" for d in self.extra_dirs)
        return out

    def roots(self) -> list[Path]:
        """Folders a model may read files from: the model's folder and package, and every search folder."""
        roots: list[Path] = []
        if self.model_dir is not None:
            roots.append(self.model_dir)
            for anc in self.model_dir.parents:
                if package_name(anc) is not None:
                    roots.append(anc)
                    break
        roots += [*self.package_dirs, *self.ros_dirs, *(p / "share" for p in self.ament_prefixes)]
        roots += self.extra_dirs
        roots += list(self.found.values())
        return list(dict.fromkeys(r.resolve() for r in roots))


def is_within(path: Path | str, roots: Iterable[Path]) -> bool:
    """True when ``path`` (made absolute, symlinks followed, ``..`` removed) lies in one of ``roots``.

    Only the path text and existing symlinks are looked at: the answer does
    not depend on whether the file itself exists.
    """
    real = Path(os.path.realpath(os.path.abspath(str(path))))
    return any(real == r or r in real.parents for r in (Path(os.path.realpath(str(r))) for r in roots))
