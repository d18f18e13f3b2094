"""Denavit-Hartenberg tables to URDF and to a :class:`kinserve.kinematics.Robot`.

Convention: standard (distal) DH. Row ``i`` (1-based) is ``(a_i, alpha_i, d_i, theta_i)`` and

    A_i(q_i) = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)

with the joint variable added to ``theta_i`` for a revolute joint (``R``) and
to ``d_i`` for a prismatic joint (``P``): the constant ``theta_i`` / ``d_i``
of the row is the offset at ``q_i = 0``. Joint ``i`` moves about / along the
``z`` axis of frame ``i-1``. The tool pose is

    T(q) = base * A_1(q_1) ... A_n(q_n) * tool.

Units: metres and radians.

URDF layout written by :func:`dh_to_urdf` (so the DH frames are frames of the model):

* ``world`` --(fixed ``base_joint``, origin ``base``)--> ``link0`` (DH frame 0);
* for each row: ``link{i-1}`` --(joint ``i``, origin ``Rz(theta_i) Tz(d_i)``,
  axis ``z``)--> ``joint{i}_link`` --(fixed ``joint{i}_dh``, origin
  ``Tx(a_i) Rx(alpha_i)``)--> ``link{i}`` (DH frame ``i``). This is exact for
  both joint types because ``Rz`` and ``Tz`` commute;
* ``link{n}`` --(fixed ``tool_joint``, origin ``tool``)--> ``tip_name``.

Each link gets simple visual geometry (cylinders along the ``d`` and ``a``
offsets, a drum for every revolute joint, a block for every prismatic joint,
a sphere at the tool) so a browser viewer shows the mechanism; the cylinders
along ``d`` and ``a`` are also its ``<collision>`` shapes (self-collision and
obstacle checks, :mod:`kinserve.kinematics.collision_model`).
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Sequence
from typing import NamedTuple

import numpy as np
import pinocchio as pin
from lxml import etree

from kinserve.kinematics.errors import InputError, ModelError, NonFiniteError
from kinserve.kinematics.robot import TASK_AXES, Robot
from kinserve.kinematics.types import ArrayLike, PoseLike, VectorLike
from kinserve.kinematics.validation import (
    MAX_ABS,
    as_flag,
    as_numbers,
    as_pose,
    as_positive,
    as_real,
    as_text,
    as_vector,
    describe,
)

from .urdf_loader import UrdfSource, check_task_axes, load_urdf, parse_xml, validate_urdf

#: Default limits of a revolute joint when none are given (rad).
DEFAULT_REVOLUTE_LIMITS = (-math.pi, math.pi)

#: Nominal joint velocity (rad/s or m/s) and effort (N m or N) written into <limit>
#: (URDF requires them; kinematics does not use them).
DEFAULT_VELOCITY = 1.0
DEFAULT_EFFORT = 100.0

#: Most rows a DH table may have (the loader's ``MAX_MOVABLE_JOINTS``): building the robot needs memory
#: growing faster than n**2 (0.76 GB for 200 rows, about 24 GB for 1000).
MAX_DH_ROWS = 200

#: Largest ``radius`` of :func:`dh_to_urdf` (m): its largest drawn shape (a prismatic joint's block, a
#: revolute joint's drum) is 3 radii long, and every URDF size is at most ``MAX_ABS``.
MAX_RADIUS = MAX_ABS / 3.0

#: How :func:`dh_to_urdf` names its output in the messages of the final check.
GENERATED = "DH table (generated URDF)"

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_.\-]*$")
_COLUMNS = ("a", "alpha", "d", "theta")

_COLORS = {
    "kinserve_link": "0.70 0.72 0.76 1",
    "kinserve_revolute": "0.95 0.55 0.15 1",
    "kinserve_prismatic": "0.20 0.50 0.90 1",
    "kinserve_tool": "0.20 0.75 0.30 1",
}


def dh_matrix(a: float, alpha: float, d: float, theta: float) -> np.ndarray:
    """``A = Rz(theta) Tz(d) Tx(a) Rx(alpha)`` as a 4x4 array.

    Each parameter (m or rad) must be a real number, finite with magnitude at most
    :data:`~kinserve.kinematics.validation.MAX_ABS` (:class:`InputError` / :class:`NonFiniteError` naming it).
    """
    values = (a, alpha, d, theta)
    if not all(type(v) is float and abs(v) <= MAX_ABS for v in values):  # (NaN fails the comparison)
        values = [as_real(v, name) for v, name in zip(values, _COLUMNS)]
    return _dh_matrix(*values)


def _dh_matrix(a: float, alpha: float, d: float, theta: float) -> np.ndarray:
    """:func:`dh_matrix` of checked numbers."""
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array(
        [
            [ct, -st * ca, st * sa, a * ct],
            [st, ct * ca, -ct * sa, a * st],
            [0.0, sa, ca, d],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


def _dh(check, *args):
    """``check(*args)`` (a :mod:`kinserve.kinematics.validation` check) with its :class:`InputError` as a
    :class:`ModelError` ``"DH table: ..."``: every problem of a DH table is one."""
    try:
        return check(*args)
    except InputError as exc:
        raise ModelError(f"DH table: {exc}") from None


def _numbers(value, name: str, table: bool = False) -> np.ndarray:
    """``value`` as a float array of real numbers, finite with magnitude <= ``MAX_ABS`` (``as_numbers``);
    :class:`ModelError` naming ``name`` and, for a number out of bounds, its place (row and column when
    ``table``)."""
    try:
        return as_numbers(value, name)
    except NonFiniteError as exc:
        try:
            arr = np.asarray(value, dtype=float)  # numbers (as_numbers read them), some out of bounds
        except OverflowError:  # an integer too large for a float
            raise ModelError(f"DH table: {name}: {exc}") from None
        where = _place(arr.reshape(-1, 4) if table and arr.size % 4 == 0 else arr)
        raise ModelError(f"DH table: {name}: {where} is {float(arr.flat[_flat_bad(arr)])!r}; entries must be "
                         f"finite with magnitude <= {MAX_ABS:g}") from None
    except InputError as exc:
        raise ModelError(f"DH table: {exc}") from None


def _flat_bad(arr: np.ndarray) -> int:
    """Flat index of the first entry of ``arr`` that is not finite or has magnitude above ``MAX_ABS``."""
    return int(np.flatnonzero(~(np.abs(arr) <= MAX_ABS))[0])


def _place(arr: np.ndarray) -> str:
    """Where :func:`_flat_bad` is, in words: row and column of an ``(n, 4)`` table, else the entry."""
    i = _flat_bad(arr)
    if arr.ndim == 2 and arr.shape[1] == 4:
        return f"entry row {i // 4 + 1}, column {_COLUMNS[i % 4]}"
    return f"entry {i + 1}" if arr.ndim else "the value"


def _vector(value, n: int, name: str, default=None) -> np.ndarray:
    """One number per row: ``value`` (a number for all rows, or ``n`` numbers; ``default`` when None and a
    default is given) as an ``(n,)`` float array, or :class:`ModelError` naming ``name``."""
    if value is None and default is not None:
        return np.array(default, dtype=float)
    arr = _numbers(value, name)
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    if arr.shape != (n,):
        raise ModelError(f"DH table: {name} must have {n} entries (one per row), got shape {arr.shape}")
    return arr


def _rates(value, n: int, name: str) -> np.ndarray:
    """``velocity`` / ``effort`` of the URDF ``<limit>``: :func:`_vector` of numbers >= 0."""
    arr = _vector(value, n, name)
    if (arr < 0).any():
        raise ModelError(f"DH table: {name} must be >= 0 (the URDF <limit {name}=>), got {arr.tolist()}")
    return arr


def check_dh_rows(rows: ArrayLike, joint_types: str | None = None) -> tuple[np.ndarray, str]:
    """Validate the rows ``(n, 4)`` and the ``R``/``P`` letters (default all ``R``).

    Refused (:class:`ModelError`): entries that are not real numbers (text, bools, None), not finite or of
    magnitude above :data:`~kinserve.kinematics.validation.MAX_ABS`, a shape other than ``(n, 4)``, more than
    :data:`MAX_DH_ROWS` rows, letters other than ``R``/``P`` or not one per row.
    """
    table = _numbers(rows, "rows", table=True)
    if table.ndim == 1 and table.size == 4:
        table = table.reshape(1, 4)
    if table.ndim != 2 or table.shape[1] != 4 or table.shape[0] == 0:
        raise ModelError("DH table: rows must have shape (n, 4) with columns (a, alpha, d, theta), "
                         f"got shape {table.shape}")
    if table.shape[0] > MAX_DH_ROWS:
        raise ModelError(f"DH table: at most {MAX_DH_ROWS} rows (joints) are accepted, got "
                         f"{table.shape[0]}")
    n = table.shape[0]
    if joint_types is None:
        joint_types = "R" * n
    if not isinstance(joint_types, str):
        try:
            joint_types = "".join(str(t) for t in joint_types)
        except TypeError:
            raise ModelError("DH table: joint_types must be a string of R/P letters, "
                             f"got {joint_types!r}") from None
    types = joint_types.upper()
    if len(types) != n:
        raise ModelError(f"DH table: joint_types {joint_types!r} has {len(types)} letters for {n} rows")
    bad = [f"{i + 1}:{c!r}" for i, c in enumerate(types) if c not in "RP"]
    if bad:
        raise ModelError("DH table: joint_types letters must be R (revolute) or P (prismatic); bad: "
                         f"{', '.join(bad)}")
    return table, types


def check_dh_table(rows: ArrayLike, joint_types: str | None = None, lower: VectorLike | None = None,
                   upper: VectorLike | None = None) -> tuple[np.ndarray, str, np.ndarray, np.ndarray]:
    """Validate a DH table; return ``(rows (n, 4), joint_types "RP..", lower (n,), upper (n,))``.

    ``joint_types`` defaults to all revolute. ``lower`` / ``upper``: a number for every joint or one per
    row (rad or m), finite with magnitude at most ``MAX_ABS``; revolute limits default to ``[-pi, pi]``,
    prismatic joints need explicit limits. Raises :class:`ModelError` naming the problem (shape, entries
    that are not numbers - text, bools - or not finite or too large, joint type letters, lengths,
    ``lower > upper``).
    """
    table, types = check_dh_rows(rows, joint_types)
    n = len(types)
    if lower is None or upper is None:
        missing = [i + 1 for i, c in enumerate(types) if c == "P"]
        if missing:
            raise ModelError(f"DH table: prismatic joint(s) {missing} need explicit lower and upper limits "
                             "(metres)")
    lo = _vector(lower, n, "lower", [DEFAULT_REVOLUTE_LIMITS[0]] * n)
    hi = _vector(upper, n, "upper", [DEFAULT_REVOLUTE_LIMITS[1]] * n)
    wrong = [i + 1 for i in range(n) if lo[i] > hi[i]]
    if wrong:
        raise ModelError(f"DH table: lower > upper for joint(s) {wrong}: lower={lo.tolist()}, "
                         f"upper={hi.tolist()}")
    return table, types, lo, hi


def dh_fk(rows: ArrayLike, joint_types: str | None, q: VectorLike, base: PoseLike | None = None,
          tool: PoseLike | None = None) -> np.ndarray:
    """Reference DH product ``base * prod A_i(q_i) * tool`` (4x4) with NumPy.

    The table, joint types, ``base`` and ``tool`` are checked as :func:`dh_to_urdf` checks them
    (:class:`ModelError`); ``q`` (one value per row, rad or m) by
    :func:`~kinserve.kinematics.validation.as_vector` (:class:`InputError`).
    """
    table, types = check_dh_rows(rows, joint_types)
    base_T, tool_T = _pose(base, "base"), _pose(tool, "tool")
    q = as_vector(q, len(types), "q")
    T = base_T
    for (a, alpha, d, theta), kind, qi in zip(table.tolist(), types, q.tolist()):
        T = T @ (_dh_matrix(a, alpha, d, theta + qi) if kind == "R" else _dh_matrix(a, alpha, d + qi, theta))
    return T @ tool_T


def _pose(value: PoseLike | None, name: str) -> np.ndarray:
    """``base`` / ``tool`` of a DH chain: the identity for None, else a pose (``as_pose``: orthonormal
    rotation, bounded translation) or :class:`ModelError`."""
    return np.eye(4) if value is None else _dh(as_pose, value, name)


# ---------------------------------------------------------------------- URDF writing
def _num(x: float) -> str:
    x = float(x)
    return "0" if x == 0.0 else repr(x)


def _nums(xs) -> str:
    return " ".join(_num(x) for x in xs)


def _origin(parent, xyz=(0.0, 0.0, 0.0), rpy=(0.0, 0.0, 0.0)):
    return etree.SubElement(parent, "origin", xyz=_nums(xyz), rpy=_nums(rpy))


def _pose_origin(parent, T: np.ndarray):
    return _origin(parent, T[:3, 3], pin.rpy.matrixToRpy(T[:3, :3]))


def _vnum(x: float) -> str:
    """Visual-only numbers: 9 significant digits are plenty for a picture."""
    x = float(x)
    return "0" if abs(x) < 1e-12 else f"{x:.9g}"


def _visual(link, shape: str, material: str, xyz=(0, 0, 0), rpy=(0, 0, 0), **dims):
    vis = etree.SubElement(link, "visual")
    etree.SubElement(vis, "origin", xyz=" ".join(map(_vnum, xyz)), rpy=" ".join(map(_vnum, rpy)))
    geo = etree.SubElement(vis, "geometry")
    etree.SubElement(geo, shape,
                     **{k: (" ".join(map(_vnum, v)) if isinstance(v, (tuple, list))
                            else _vnum(v)) for k, v in dims.items()})
    etree.SubElement(vis, "material", name=material)


def _collision(link, shape: str, xyz=(0, 0, 0), rpy=(0, 0, 0), **dims):
    col = etree.SubElement(link, "collision")
    etree.SubElement(col, "origin", xyz=" ".join(map(_vnum, xyz)), rpy=" ".join(map(_vnum, rpy)))
    geo = etree.SubElement(col, "geometry")
    etree.SubElement(geo, shape, **{k: _vnum(v) for k, v in dims.items()})


def _segment(link, p0, p1, radius: float) -> None:
    """A cylinder from point ``p0`` to ``p1`` (link frame), visual and collision; nothing if they coincide."""
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    u = p1 - p0
    length = float(np.linalg.norm(u))
    if length < 1e-9:
        return
    u /= length
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(z, u)
    s, c = float(np.linalg.norm(axis)), float(z @ u)
    if s < 1e-12:
        R = np.eye(3) if c > 0 else pin.rpy.rpyToMatrix(math.pi, 0.0, 0.0)
    else:
        R = pin.AngleAxis(math.atan2(s, c), axis / s).matrix()
    xyz, rpy = 0.5 * (p0 + p1), pin.rpy.matrixToRpy(R)
    _visual(link, "cylinder", "kinserve_link", xyz, rpy, radius=radius, length=length)
    _collision(link, "cylinder", xyz, rpy, radius=radius, length=length)


def _check_name(value: str, what: str) -> str:
    if not isinstance(value, str) or not _NAME.match(value):
        raise ModelError(f"DH table: {what} must be a name of letters, digits, '_', '-', '.', got {value!r}")
    return value


def dh_to_urdf(
    rows: ArrayLike,
    joint_types: str | None = None,
    lower: VectorLike | None = None,
    upper: VectorLike | None = None,
    name: str = "dh_robot",
    base: PoseLike | None = None,
    tool: PoseLike | None = None,
    tip_name: str = "tool",
    joint_names: Sequence[str] | None = None,
    velocity: float | VectorLike = DEFAULT_VELOCITY,
    effort: float | VectorLike = DEFAULT_EFFORT,
    radius: float | None = None,
) -> str:
    """URDF text of the chain described by a standard DH table (see the module docstring).

    Parameters
    ----------
    rows:
        ``(n, 4)`` table of ``(a, alpha, d, theta)``; ``theta`` (revolute) or
        ``d`` (prismatic) is the offset at ``q = 0``.
    joint_types:
        String of ``R``/``P`` letters (default: all revolute).
    lower, upper:
        Joint limits (rad or m), scalars or ``n`` values. Revolute default
        ``[-pi, pi]``; prismatic joints need them.
    name:
        ``<robot name>``.
    base, tool:
        Constant 4x4 poses of DH frame 0 in the world and of the tool in DH frame ``n``.
    tip_name:
        Name of the tool link.
    joint_names:
        Names of the ``n`` joints (default ``joint1..jointn``).
    velocity, effort:
        Values for ``<limit velocity= effort=>`` (scalar or ``n`` values, >= 0).
    radius:
        Radius (m) of the visual cylinders, a positive number up to :data:`MAX_RADIUS`; default (None)
        3.5 % of the summed ``|a| + |d|``.

    Every number must be finite with magnitude at most ``MAX_ABS`` (1e6), every name a str of letters,
    digits, ``_``, ``-``, ``.``; anything else is a :class:`ModelError` naming the argument. The text is
    checked as :func:`from_dh` loads it (:func:`~robots.urdf_loader.validate_urdf`), so what one refuses
    the other refuses too.
    """
    chain = _check_chain(rows, joint_types, lower, upper, name, base, tool, tip_name, joint_names, velocity,
                         effort, radius)
    xml = _urdf_text(chain)
    validate_urdf(parse_xml(xml, GENERATED), GENERATED)  # what from_dh loads (sizes of the drawn shapes too)
    return xml


class _Chain(NamedTuple):
    """The checked arguments of :func:`dh_to_urdf`."""

    table: np.ndarray
    types: str
    lower: np.ndarray
    upper: np.ndarray
    name: str
    base: np.ndarray
    tool: np.ndarray
    tip_name: str
    joint_names: list[str]
    velocity: np.ndarray
    effort: np.ndarray
    radius: float


def _check_chain(rows, joint_types, lower, upper, name, base, tool, tip_name, joint_names, velocity, effort,
                 radius) -> _Chain:
    """Every argument of :func:`dh_to_urdf` checked (:class:`ModelError` naming it)."""
    table, types, lo, hi = check_dh_table(rows, joint_types, lower, upper)
    n = len(types)
    _check_name(name, "name")
    _check_name(tip_name, "tip_name")
    base_T, tool_T = _pose(base, "base"), _pose(tool, "tool")
    names = _joint_names(joint_names, n, tip_name)
    vel, eff = _rates(velocity, n, "velocity"), _rates(effort, n, "effort")
    if radius is None:
        reach = float(np.abs(table[:, 0]).sum() + np.abs(table[:, 2]).sum() + np.abs(tool_T[:3, 3]).sum())
        r = max(0.035 * reach, 0.005)
    else:
        r = _dh(as_positive, radius, "radius", MAX_RADIUS)
    return _Chain(table, types, lo, hi, name, base_T, tool_T, tip_name, names, vel, eff, r)


def _joint_names(joint_names, n: int, tip_name: str) -> list[str]:
    """The ``n`` joint names (default ``joint1..jointn``): unique names that no generated name takes; a
    ``tip_name`` that is no generated link name."""
    if joint_names is None:
        names = [f"joint{i + 1}" for i in range(n)]
    elif isinstance(joint_names, (str, bytes)) or not isinstance(joint_names, Iterable):
        raise ModelError(f"DH table: joint_names must be a list of {n} names (one per row), got "
                         f"{describe(joint_names)}")
    else:
        names = list(joint_names)
    if len(names) != n:
        raise ModelError(f"DH table: joint_names has {len(names)} names for {n} rows")
    for jn in names:
        _check_name(jn, "joint name")
    links = ["world"] + [f"link{i}" for i in range(n + 1)] + [f"joint{i + 1}_link" for i in range(n)]
    generated = links + [f"joint{i + 1}_dh" for i in range(n)] + ["base_joint", "tool_joint"]
    if tip_name in links:
        raise ModelError(f"DH table: tip_name {tip_name!r} collides with a generated link name "
                         f"({', '.join(links)})")
    if len(set(names)) != n or set(names) & set(generated):
        raise ModelError("DH table: joint_names must be unique and differ from the generated names, "
                         f"got {names}")
    return names


def _urdf_text(chain: _Chain) -> str:
    """The URDF text of a checked chain (layout: the module docstring)."""
    table, types, lo, hi, name, base_T, tool_T, tip_name, names, vel, eff, r = chain
    robot = etree.Element("robot", name=name)
    robot.append(etree.Comment(
        " Generated by kinserve robots.dh.dh_to_urdf from a standard DH table: "
        "A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i); link{i} is DH frame i. "
    ))
    for mat, rgba in _COLORS.items():
        m = etree.SubElement(robot, "material", name=mat)
        etree.SubElement(m, "color", rgba=rgba)

    def link(lname):
        return etree.SubElement(robot, "link", name=lname)

    def joint(jname, jtype, parent, child, T=None, xyz=(0, 0, 0), rpy=(0, 0, 0)):
        j = etree.SubElement(robot, "joint", name=jname, type=jtype)
        if T is not None:
            _pose_origin(j, T)
        else:
            _origin(j, xyz, rpy)
        etree.SubElement(j, "parent", link=parent)
        etree.SubElement(j, "child", link=child)
        return j

    link("world")
    link0 = link("link0")
    _visual(link0, "cylinder", "kinserve_link", (0, 0, -0.5 * r), radius=2.2 * r, length=r)
    joint("base_joint", "fixed", "world", "link0", T=base_T)
    prev = link0
    for i, ((a, alpha, d, theta), kind) in enumerate(zip(table, types)):
        # constant part before the joint: Rz(theta) Tz(d) -> a segment along z of frame i-1
        _segment(prev, (0, 0, 0), (0, 0, d), r)
        moving = link(f"joint{i + 1}_link")
        if kind == "R":
            _visual(moving, "cylinder", "kinserve_revolute", radius=1.5 * r, length=3.0 * r)
        else:
            _visual(moving, "box", "kinserve_prismatic", size=(2.6 * r, 2.6 * r, 3.0 * r))
        _segment(moving, (0, 0, 0), (a, 0, 0), r)
        j = joint(names[i], "revolute" if kind == "R" else "prismatic", prev.get("name"), moving.get("name"),
                  xyz=(0.0, 0.0, d), rpy=(0.0, 0.0, theta))
        etree.SubElement(j, "axis", xyz="0 0 1")
        etree.SubElement(j, "limit", lower=_num(lo[i]), upper=_num(hi[i]), effort=_num(eff[i]),
                         velocity=_num(vel[i]))
        nxt = link(f"link{i + 1}")
        joint(f"joint{i + 1}_dh", "fixed", moving.get("name"), nxt.get("name"), xyz=(a, 0.0, 0.0),
              rpy=(alpha, 0.0, 0.0))
        prev = nxt
    _segment(prev, (0, 0, 0), tool_T[:3, 3], r)
    tip = link(tip_name)
    _visual(tip, "sphere", "kinserve_tool", radius=1.2 * r)
    joint("tool_joint", "fixed", prev.get("name"), tip_name, T=tool_T)
    etree.indent(robot, space="  ")
    return '<?xml version="1.0"?>\n' + etree.tostring(robot, encoding="unicode") + "\n"


def from_dh(
    rows: ArrayLike,
    joint_types: str | None = None,
    lower: VectorLike | None = None,
    upper: VectorLike | None = None,
    name: str = "dh_robot",
    base: PoseLike | None = None,
    tool: PoseLike | None = None,
    tip_name: str = "tool",
    joint_names: Sequence[str] | None = None,
    *,
    description: str = "",
    task_axes: Sequence[str] = TASK_AXES,
    velocity: float | VectorLike = DEFAULT_VELOCITY,
    effort: float | VectorLike = DEFAULT_EFFORT,
    radius: float | None = None,
    geometry: bool = True,
) -> Robot:
    """A :class:`Robot` from a standard DH table: the URDF text of :func:`dh_to_urdf` (the same checks of the
    table arguments: :class:`ModelError`) loaded by :func:`~robots.urdf_loader.load_urdf`.

    ``robot.source`` is the generated URDF, so saving it and loading it again
    gives the same model. The default tool frame is ``tip_name``; the DH
    frames are ``link0`` ... ``link{n}``. ``description`` is a str, ``task_axes`` names task components
    (:func:`~robots.urdf_loader.check_task_axes`), ``geometry`` is True or False (:class:`InputError`
    otherwise, before anything is built).
    """
    description, geometry = as_text(description, "description"), as_flag(geometry, "geometry")
    task_axes = check_task_axes(task_axes)
    xml = _urdf_text(_check_chain(rows, joint_types, lower, upper, name, base, tool, tip_name, joint_names,
                                  velocity, effort, radius))
    # load_urdf checks the text with validate_urdf, as dh_to_urdf does (messages name GENERATED alike)
    return load_urdf(UrdfSource(xml, GENERATED), tip=tip_name, name=name, description=description,
                     task_axes=task_axes, geometry=geometry)
