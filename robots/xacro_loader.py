"""Expand a ``.xacro`` file with arguments into URDF text, and load it as a Robot.

Arguments are checked before xacro runs, so a mistake names the file and
the argument:

* an argument name that the file does not declare with
  ``<xacro:arg name=... default=...>`` (the message lists the declared ones);
* a value that is not a string, number or bool;
* a value for an argument whose declared default is a number that does not
  parse as a finite number (e.g. ``l1="abc"``);
* a numeric value beyond ``kinematics.validation.MAX_ABS`` in magnitude
  (e.g. ``l1="1e308"``; the expanded URDF's origins and limits are bounded
  the same way by ``urdf_loader.validate_urdf``);
* a declared argument without default that is not given.

Anything xacro itself rejects (bad expressions, undefined properties, ...) is
re-raised as :class:`ModelError` naming the file.

Xacro runs in a separate process (:mod:`robots.xacro_worker`) with a wall
time limit (:data:`XACRO_TIME_LIMIT`, killed when exceeded) and a memory cap
(:data:`XACRO_MEMORY_LIMIT`): a xacro file is a program (``${10**10**8}``
never returns) and a model file from elsewhere must not hang the caller.
Each call has its own process, so no lock is held while xacro runs.
``$(find PKG)`` is answered by :class:`robots.packages.PackageFinder`
(``package_dirs``, ``$ROS_PACKAGE_PATH``, ``$AMENT_PREFIX_PATH``, ...).

When the file reads other files (``xacro:include``, ``load_yaml``), xacro's
error text is not shown (it may quote those files); the message names the
file and the kind of error, and says how to see the details.
"""

from __future__ import annotations

import json
import math
import numbers
import os
import subprocess
import sys
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

from lxml import etree

from kinserve.kinematics.errors import ModelError, suggest
from kinserve.kinematics.robot import Robot
from kinserve.kinematics.validation import MAX_ABS, as_flag

from . import packages
from .mesh_resolver import check_package_dirs, default_package_dirs
from .packages import AMENT_PREFIX_PATH, ROS_PACKAGE_PATH
from .urdf_loader import UrdfSource, check_loader_options, load_urdf

XACRO_NS = "http://www.ros.org/wiki/xacro"

#: Wall-clock limit (s) of one xacro expansion.
XACRO_TIME_LIMIT = 20.0
#: Longest accepted ``time_limit`` (s) of a xacro expansion.
MAX_XACRO_TIME_LIMIT = 3600.0

#: Address-space cap (bytes) of the xacro process (POSIX only).
XACRO_MEMORY_LIMIT = 2 * 1024**3

_WORKER = Path(__file__).resolve().with_name("xacro_worker.py")
_SAFE_PARSER = etree.XMLParser(resolve_entities=False, no_network=True, huge_tree=False)


def _existing(path) -> Path:
    if not isinstance(path, (str, Path)):
        raise ModelError(f"xacro path must be a str or Path, got {type(path).__name__}")
    p = Path(path).expanduser()
    if not p.is_file():
        raise ModelError(f"xacro file {str(p)!r} does not exist")
    return p.resolve()


def declared_args(path: str | os.PathLike) -> dict[str, str | None]:
    """``{name: default}`` of the ``<xacro:arg>`` elements of a xacro file (None = no default)."""
    p = _existing(path)
    try:
        root = etree.parse(str(p), _SAFE_PARSER).getroot()
    except etree.XMLSyntaxError as exc:
        line, col = exc.position if exc.position else (exc.lineno, 0)
        raise ModelError(f"{p}: malformed XML at line {line}, column {col}: {exc.msg}") from None
    out: dict[str, str | None] = {}
    for el in root.iter(f"{{{XACRO_NS}}}arg"):
        name = el.get("name")
        if name:
            out[name] = el.get("default")
    return out


def _is_number(text) -> bool:
    try:
        return math.isfinite(float(text))
    except (TypeError, ValueError):
        return False


def _arg_text(path: Path, name: str, value, default: str | None) -> str:
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, (int, float)) or type(value).__module__ == "numpy":
        try:
            f = float(value)
        except (TypeError, ValueError):
            raise ModelError(f"{path}: xacro arg {name!r} = {value!r} is not a number") from None
        if not math.isfinite(f):
            raise ModelError(f"{path}: xacro arg {name!r} = {value!r} must be a finite number")
        text = repr(f)
    elif isinstance(value, str):
        text = value
    else:
        raise ModelError(f"{path}: xacro arg {name!r} must be a number or a string, "
                         f"got {type(value).__name__} {value!r}")
    if default is not None and _is_number(default) and not _is_number(text):
        raise ModelError(f"{path}: xacro arg {name!r} = {value!r} does not parse as a finite number (its "
                         f"default is {default})")
    if _is_number(text) and abs(float(text)) > MAX_ABS:
        raise ModelError(f"{path}: xacro arg {name!r} = {value!r} is beyond any physical size (|value| <= "
                         f"{MAX_ABS:g})")
    return text


def check_args(path: str | os.PathLike, args: Mapping | None) -> dict[str, str]:
    """Validate ``args`` against the file's declared ``<xacro:arg>`` s; return the string mappings."""
    p = _existing(path)
    declared = declared_args(p)
    args = dict(args or {})
    mappings = {}
    for name, value in args.items():
        if name not in declared:
            listed = ", ".join(sorted(declared)) or "(none)"
            raise ModelError(
                f"{p}: unknown xacro arg {name!r}; the file declares: {listed}.{suggest(str(name), declared)}"
            )
        mappings[name] = _arg_text(p, name, value, declared[name])
    missing = [n for n, d in declared.items() if d is None and n not in mappings]
    if missing:
        raise ModelError(f"{p}: xacro arg(s) {missing} have no default and must be given")
    return mappings


def xacro_time_limit(time_limit: object) -> float:
    """The seconds a xacro expansion may take: :data:`XACRO_TIME_LIMIT` for None, else ``time_limit`` if it
    is a number in ``(0, MAX_XACRO_TIME_LIMIT]``; :class:`ModelError` naming ``time_limit`` otherwise (NaN,
    zero, negative, huge, text, a bool)."""
    if time_limit is None:
        return XACRO_TIME_LIMIT
    if (isinstance(time_limit, bool) or not isinstance(time_limit, numbers.Real)
            or not 0.0 < float(time_limit) <= MAX_XACRO_TIME_LIMIT):  # NaN fails the comparison
        raise ModelError(f"time_limit must be a positive number of seconds, at most {MAX_XACRO_TIME_LIMIT:g} "
                         f"(None: {XACRO_TIME_LIMIT:g} s), got {time_limit!r}")
    return float(time_limit)


def process_xacro(path: str | os.PathLike, args: Mapping | None = None, *,
                  package_dirs: str | os.PathLike | Iterable[str | os.PathLike] | None = (),
                  time_limit: float | None = None, allow_outside: bool = False) -> str:
    """URDF text of a xacro file expanded with ``args`` (``{name: value}``).

    ``package_dirs`` (existing folders: :func:`~robots.mesh_resolver.check_package_dirs`) resolve
    ``$(find PKG)`` (see :mod:`robots.packages`);
    ``time_limit`` (s, default :data:`XACRO_TIME_LIMIT`, at most :data:`MAX_XACRO_TIME_LIMIT`:
    :func:`xacro_time_limit`) bounds the expansion. Files it includes or loads must lie in the model's
    folders or the package folders unless ``allow_outside``.
    """
    text, _ = expand_xacro(path, args, package_dirs=package_dirs, time_limit=time_limit,
                           allow_outside=allow_outside)
    return text


def expand_xacro(path: str | os.PathLike, args: Mapping | None = None, *,
                 package_dirs: str | os.PathLike | Iterable[str | os.PathLike] | None = (),
                 time_limit: float | None = None, allow_outside: bool = False) -> tuple[str, list[Path]]:
    """``(URDF text, folders of the packages $(find) resolved)`` of a xacro file (see
    :func:`process_xacro`)."""
    allow_outside = as_flag(allow_outside, "allow_outside")
    dirs = check_package_dirs(package_dirs)
    p = _existing(path)
    mappings = check_args(p, args)
    limit = xacro_time_limit(time_limit)
    request = {
        "path": str(p), "mappings": mappings, "packages_module": packages.__file__,
        "package_dirs": list(dirs),
        "model_dir": str(p.parent), "extra_dirs": [str(d) for d in default_package_dirs()],
        "environ": {k: os.environ[k] for k in (ROS_PACKAGE_PATH, AMENT_PREFIX_PATH) if k in os.environ},
        "memory_limit": XACRO_MEMORY_LIMIT, "allow_outside": allow_outside,
    }
    try:
        done = subprocess.run([sys.executable, "-I", str(_WORKER)], input=json.dumps(request),
                              capture_output=True, text=True, timeout=limit, check=False)
    except subprocess.TimeoutExpired:  # subprocess.run killed the process
        raise ModelError(f"{p}: xacro expansion took longer than {limit:g} s and was stopped") from None
    try:
        answer = json.loads(done.stdout)
    except ValueError:
        raise ModelError(f"{p}: xacro expansion stopped without an answer (exit status "
                         f"{done.returncode})") from None
    if answer["ok"]:
        return answer["xml"], [Path(f) for f in answer["found"].values()]
    raise ModelError(_failure_message(p, answer))


def _failure_message(p: Path, answer: dict) -> str:
    kind = answer["error"]
    if kind == "OutsideError":
        what = "a file it includes" if answer["reads_other_files"] else repr(answer["message"])
        return (f"{p}: xacro would read {what}, which resolves outside the folders this model may read from "
                f"({', '.join(answer['roots'])}); refused. If you trust this model, pass allow_outside=True "
                "(CLI: --allow-outside) or add its folder to package_dirs (CLI: --package-dir)")
    if kind == "MemoryError":
        return f"{p}: xacro expansion ran out of memory (limit {XACRO_MEMORY_LIMIT / 1024**3:g} GiB)"
    if answer["reads_other_files"]:
        where = answer["file"] if answer["file"] != str(p) else "it or a file it reads"
        return (f"{p}: xacro processing failed ({kind} in {where}); the details are not shown because they "
                f"may quote files this one includes or loads - run `xacro {p}` to see them")
    return f"{p}: xacro processing failed: {kind}: {answer['message']}"


def load_xacro(
    path: str | os.PathLike,
    *,
    args: Mapping | None = None,
    tip: str | None = None,
    name: str | None = None,
    description: str = "",
    locked_joints: Mapping[str, float] | None = None,
    package_dirs: str | os.PathLike | Iterable[str | os.PathLike] | None = (),
    geometry: bool = True,
    task_axes: str | Sequence[str] | None = None,
    allow_outside: bool = False,
    time_limit: float | None = None,
) -> Robot:
    """Expand a xacro file with ``args`` and load the result (see :func:`robots.urdf_loader.load_urdf`, which
    takes the other arguments; they are checked before xacro runs)."""
    tip, name, description, locked_joints, package_dirs, task_axes, geometry, allow_outside = \
        check_loader_options(tip, name, description, locked_joints, package_dirs, task_axes, geometry,
                             allow_outside)
    p = _existing(path)
    text, found = expand_xacro(p, args, package_dirs=package_dirs, time_limit=time_limit,
                               allow_outside=allow_outside)
    label = f"{p} (expanded xacro)"
    # the packages $(find) resolved may hold the meshes the expanded text names by absolute path
    dirs = [*package_dirs, *found]
    return load_urdf(
        UrdfSource(text, label, p.parent),
        tip=tip,
        name=name,
        description=description,
        locked_joints=locked_joints,
        package_dirs=dirs,
        geometry=geometry,
        task_axes=task_axes,
        allow_outside=allow_outside,
    )
