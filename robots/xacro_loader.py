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
re-raised as :class:`ModelError` naming the file. Processing is serialised
with a lock: the ``xacro`` package keeps global state.
"""

from __future__ import annotations

import math
import threading
import xml.parsers.expat
from collections.abc import Mapping
from pathlib import Path

import xacro
from lxml import etree

from kinserve.kinematics.errors import ModelError, suggest
from kinserve.kinematics.robot import TASK_AXES, Robot
from kinserve.kinematics.validation import MAX_ABS

from .urdf_loader import UrdfSource, load_urdf

XACRO_NS = "http://www.ros.org/wiki/xacro"

_XACRO_LOCK = threading.Lock()


def _existing(path) -> Path:
    if not isinstance(path, (str, Path)):
        raise ModelError(f"xacro path must be a str or Path, got {type(path).__name__}")
    p = Path(path).expanduser()
    if not p.is_file():
        raise ModelError(f"xacro file {str(p)!r} does not exist")
    return p.resolve()


def declared_args(path) -> dict[str, str | None]:
    """``{name: default}`` of the ``<xacro:arg>`` elements of a xacro file (None = no default)."""
    p = _existing(path)
    try:
        root = etree.parse(str(p)).getroot()
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
        raise ModelError(f"{path}: xacro arg {name!r} must be a number or a string, got {type(value).__name__} {value!r}")
    if default is not None and _is_number(default) and not _is_number(text):
        raise ModelError(f"{path}: xacro arg {name!r} = {value!r} does not parse as a finite number (its default is {default})")
    if _is_number(text) and abs(float(text)) > MAX_ABS:
        raise ModelError(f"{path}: xacro arg {name!r} = {value!r} is beyond any physical size (|value| <= {MAX_ABS:g})")
    return text


def check_args(path, args: Mapping | None) -> dict[str, str]:
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


def process_xacro(path, args: Mapping | None = None) -> str:
    """URDF text of a xacro file expanded with ``args`` (``{name: value}``)."""
    p = _existing(path)
    mappings = check_args(p, args)
    with _XACRO_LOCK:
        try:
            doc = xacro.process_file(str(p), mappings=mappings, verbosity=0)
            text = doc.toprettyxml(indent="  ")
        except xml.parsers.expat.ExpatError as exc:
            raise ModelError(f"{p}: malformed XML: {exc}") from None
        except Exception as exc:  # noqa: BLE001 - xacro raises XacroException, NameError, ...
            raise ModelError(f"{p}: xacro processing failed: {type(exc).__name__}: {exc}") from None
    return text


def load_xacro(
    path,
    *,
    args: Mapping | None = None,
    tip: str | None = None,
    name: str | None = None,
    description: str = "",
    locked_joints: Mapping[str, float] | None = None,
    package_dirs=(),
    geometry: bool = True,
    task_axes=TASK_AXES,
) -> Robot:
    """Expand a xacro file with ``args`` and load the result (see :func:`robots.urdf_loader.load_urdf`)."""
    p = _existing(path)
    text = process_xacro(p, args)
    label = f"{p} (expanded xacro)"
    return load_urdf(
        UrdfSource(text, label, p.parent),
        tip=tip,
        name=name,
        description=description,
        locked_joints=locked_joints,
        package_dirs=package_dirs,
        geometry=geometry,
        task_axes=task_axes,
    )
