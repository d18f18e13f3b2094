"""SRDF (MoveIt's semantic robot description): joint groups and named states of a loaded robot.

    panda = robots.load("panda")
    panda.named_states["default"]     # full joint vector (nq,), rad / m
    panda.groups["arm"]               # ("panda_joint1", ..., "panda_joint7")

What is read
------------
* ``<group name=G>`` with ``<joint name=J>``, ``<link name=L>`` (the joint
  whose child is ``L``), ``<chain base_link=B tip_link=T>`` (the joints from
  ``B`` to ``T``) and ``<group name=H>`` (a subgroup, resolved recursively).
  ``robot.groups[G]`` lists the group's *movable* joints of the loaded model,
  in model order (joints locked by the loader are left out).
* ``<group_state name=S group=G>`` with ``<joint name=J value=V>``:
  ``robot.named_states[S]`` is the robot's ``neutral()`` configuration with
  the state's values written into the joints it names. Values of joints the
  loader locked (gripper fingers) are not part of the joint vector and are
  skipped; a state that names no movable joint is left out. When two groups
  define a state of the same name, the later one is ``"G/S"``.

Checks (each a :class:`ModelError` naming the SRDF file, the element and its
line): malformed XML, a joint, link or group the URDF does not define, a
value that is not one finite number or exceeds 1e6 in magnitude, a group nested
more than 100 subgroups deep, a value outside the joint's limits (a
revolute value is first moved by whole turns into the limits: example-robot-data's
Kinova SRDF gives ``-1.5707`` for a joint limited to ``[0.33, 5.95]``, the
same angle as ``4.7124``).

``<disable_collisions link1= link2=>``: the link pairs the robot's collision
model does not check (``robot.srdf`` keeps the text; see
:mod:`kinserve.kinematics.collision_pairs`); a link name the model does not have
is a :class:`ModelError` here too.

Where the SRDF comes from: ``robots.load(..., srdf=PATH)``, or found next
to the model file as example-robot-data lays them out
(``<pkg>/urdf/<name>.urdf`` -> ``<pkg>/srdf/<name>.srdf``, see :func:`find_srdf`).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from lxml import etree

from kinserve.kinematics.collision_pairs import srdf_disabled_pairs
from kinserve.kinematics.errors import InputError, ModelError, suggest
from kinserve.kinematics.robot import Robot, as_robot

#: Tolerance (rad / m) on a named-state value outside the joint limits.
LIMIT_TOL = 1e-6

#: Largest accepted magnitude of a ``<group_state>`` joint value (rad / m).
MAX_VALUE = 1e6

#: Deepest accepted nesting of ``<group>`` subgroups.
MAX_GROUP_DEPTH = 100

_PARSER = etree.XMLParser(resolve_entities=False, no_network=True, huge_tree=False)


@dataclass(frozen=True)
class Srdf:
    """The groups and named states of one SRDF, resolved against one robot."""

    label: str
    groups: dict[str, tuple[str, ...]]
    named_states: dict[str, np.ndarray]
    state_groups: dict[str, str | None]  #: group of each named state (None when not given)
    text: str = ""  #: the SRDF text (its ``<disable_collisions>`` give the robot's self-collision pairs)


def find_srdf(model_path: Path) -> Path | None:
    """The SRDF beside a model file: ``<dir>/<stem>.srdf`` or ``<dir>/../srdf/<stem>.srdf``.

    ``<stem>`` is the file name without ``.urdf`` / ``.xacro``; a trailing
    ``_robot`` may be dropped (example-robot-data's ``ur5_robot.urdf`` has
    ``srdf/ur5.srdf``).
    """
    name = model_path.name
    for suffix in (".xacro", ".urdf", ".xml"):
        if name.endswith(suffix):
            name = name[: -len(suffix)]
    stems = [name] + ([name[: -len("_robot")]] if name.endswith("_robot") else [])
    for folder in (model_path.parent, model_path.parent.parent / "srdf"):
        for stem in stems:
            cand = folder / f"{stem}.srdf"
            if cand.is_file():
                return cand
    return None


def _where(label: str, el) -> str:
    return f"{label}, line {el.sourceline}" if getattr(el, "sourceline", None) else label


class SrdfWarning(UserWarning):
    """The SRDF found beside a model file is unusable; the robot loads without named states."""


class _UrdfTree:
    """Joint table of the robot's URDF text: name -> (parent link, child link)."""

    def __init__(self, robot: Robot):
        if not robot.source:
            raise ModelError(f"robot {robot.name!r} has no URDF source to check an SRDF against")
        root = etree.fromstring(robot.source.encode("utf-8"), _PARSER)
        self.joints = {j.get("name"): (j.find("parent").get("link"), j.find("child").get("link"))
                       for j in root.findall("joint")}
        self.types = {j.get("name"): j.get("type") for j in root.findall("joint")}
        self.links = {link.get("name") for link in root.findall("link")}
        self.joint_of_child = {child: name for name, (_, child) in self.joints.items()}

    def chain(self, base: str, tip: str) -> list[str] | None:
        """Joints from link ``base`` down to link ``tip`` (None when ``tip`` is not below ``base``)."""
        out, link = [], tip
        while link != base:
            joint = self.joint_of_child.get(link)
            if joint is None:
                return None
            out.append(joint)
            link = self.joints[joint][0]
        return out[::-1]


def read_srdf(source: str | os.PathLike, robot: Robot) -> Srdf:
    """Parse an SRDF (path or XML text) and resolve it against ``robot`` (see the module docstring).

    ``robot`` must be a loaded :class:`Robot` (:class:`InputError` otherwise, saying so when the two
    arguments seem swapped).
    """
    robot = _check_robot(source, robot)
    if isinstance(source, (str, Path)) and not str(source).lstrip().startswith("<"):
        path = Path(source).expanduser()
        if not path.is_file():
            raise ModelError(f"SRDF file {str(path)!r} does not exist")
        label, text = str(path), path.read_bytes()
    elif isinstance(source, str):
        label, text = "<SRDF string>", source.encode("utf-8")
    else:
        raise ModelError(f"srdf must be a file path or SRDF XML text, got {type(source).__name__}")
    try:
        root = etree.fromstring(text, _PARSER)
    except etree.XMLSyntaxError as exc:
        line, col = exc.position if exc.position else (exc.lineno, 0)
        raise ModelError(f"{label}: malformed XML at line {line}, column {col}: {exc.msg}") from None
    if root.tag != "robot":
        raise ModelError(f"{_where(label, root)}: the root element of an SRDF must be <robot>, "
                         f"got <{root.tag}>")
    urdf = _UrdfTree(robot)
    groups = _groups(root, label, urdf, robot)
    states, state_groups = _states(root, label, urdf, robot, groups)
    frame_names = [f.name for f in robot.model.frames]
    # unknown links in <disable_collisions>: ModelError
    srdf_disabled_pairs(text.decode("utf-8"), frame_names, label)
    return Srdf(label, groups, states, state_groups, text.decode("utf-8"))


def _check_robot(source: object, robot: object) -> Robot:
    """``robot`` if it is a :class:`Robot`; :class:`InputError` otherwise, naming the argument order when the
    SRDF seems to be given second (the robot first, or an SRDF path / text as ``robot``)."""
    if not isinstance(robot, Robot) and (isinstance(source, Robot) or _looks_like_srdf(robot)):
        raise InputError("read_srdf takes (source, robot): the SRDF path or XML text first, then the loaded "
                         f"Robot; got source={_short(source)}, robot={_short(robot)} - swapped?")
    return as_robot(robot)


def _looks_like_srdf(value: object) -> bool:
    """Whether ``value`` is SRDF text or a path to a ``.srdf`` file (what ``source`` takes)."""
    text = str(value) if isinstance(value, (str, Path)) else ""
    return text.lstrip().startswith("<") or text.endswith(".srdf")


def _short(value: object) -> str:
    return f"Robot {value.name!r}" if isinstance(value, Robot) else repr(value)[:60]


def _check_joint(name, el, label: str, urdf: _UrdfTree) -> str:
    if name not in urdf.joints:
        raise ModelError(f"{_where(label, el)}: joint {name!r} is not a joint of the "
                         f"URDF.{suggest(str(name), urdf.joints)}")
    return name


def _chain_joints(el, label: str, urdf: _UrdfTree) -> list[str]:
    """The joints of a ``<chain base_link= tip_link=>`` element, from base to tip (:class:`ModelError`
    when a link is unknown or the tip is not below the base)."""
    base, tip = el.get("base_link"), el.get("tip_link")
    for link in (base, tip):
        if link not in urdf.links:
            raise ModelError(f"{_where(label, el)}: <chain> link {link!r} is not a link of the "
                             f"URDF.{suggest(str(link), urdf.links)}")
    chain = urdf.chain(base, tip)
    if chain is None:
        raise ModelError(f"{_where(label, el)}: <chain> tip_link {tip!r} is not below base_link {base!r}")
    return chain


def _groups(root, label: str, urdf: _UrdfTree, robot: Robot) -> dict[str, tuple[str, ...]]:
    elements = {}
    for g in root.findall("group"):
        name = g.get("name")
        if not name:
            raise ModelError(f"{_where(label, g)}: <group> without a name attribute")
        elements.setdefault(name, g)
    resolved: dict[str, list[str]] = {}

    def resolve(name: str, stack: tuple[str, ...]) -> list[str]:
        if name in resolved:
            return resolved[name]
        if name in stack:
            raise ModelError(f"{_where(label, elements[name])}: group {name!r} contains itself "
                             f"({' -> '.join((*stack, name))})")
        if len(stack) > MAX_GROUP_DEPTH:
            raise ModelError(f"{_where(label, elements[name])}: group {name!r} is nested more than "
                             f"{MAX_GROUP_DEPTH} subgroups deep (via {stack[0]!r}; at most "
                             f"{MAX_GROUP_DEPTH} levels are accepted)")
        joints: list[str] = []
        for el in elements[name]:
            if el.tag == "joint":
                joints.append(_check_joint(el.get("name"), el, label, urdf))
            elif el.tag == "link":
                link = el.get("name")
                if link not in urdf.links:
                    raise ModelError(f"{_where(label, el)}: link {link!r} is not a link of the "
                                     f"URDF.{suggest(str(link), urdf.links)}")
                if link in urdf.joint_of_child:
                    joints.append(urdf.joint_of_child[link])
            elif el.tag == "chain":
                joints += _chain_joints(el, label, urdf)
            elif el.tag == "group":
                sub = el.get("name")
                if sub not in elements:
                    raise ModelError(f"{_where(label, el)}: "
                                     f"subgroup {sub!r} is not defined.{suggest(str(sub), elements)}")
                joints += resolve(sub, (*stack, name))
        joints = list(dict.fromkeys(joints))  # each joint once: repeated subgroups do not multiply
        resolved[name] = joints
        return joints

    movable = robot.joint_names
    return {name: tuple(j for j in movable if j in set(resolve(name, ()))) for name in elements}


def _value(el, label: str, joint: str) -> float:
    text = el.get("value")
    try:
        v = float(text)
    except (TypeError, ValueError):
        raise ModelError(f"{_where(label, el)}: joint {joint!r} value {text!r} must be one number "
                         "(rad or m)") from None
    if not math.isfinite(v):
        raise ModelError(f"{_where(label, el)}: joint {joint!r} value {text!r} must be finite")
    if abs(v) > MAX_VALUE:
        raise ModelError(f"{_where(label, el)}: joint {joint!r} value {text!r} must be at most "
                         f"{MAX_VALUE:g} in magnitude (rad or m)")
    return v


def _wrap_into(v: float, lo: float, hi: float) -> float:
    """``v + 2 pi k`` inside ``[lo, hi]`` for the integer ``k`` that puts it nearest ``lo``, or ``v``."""
    k = math.ceil((lo - LIMIT_TOL - v) / (2.0 * math.pi))
    w = v + 2.0 * math.pi * k
    return w if w <= hi + LIMIT_TOL else v


def _states(root, label: str, urdf: _UrdfTree, robot: Robot, groups: dict) -> tuple[dict, dict]:
    states: dict[str, np.ndarray] = {}
    state_groups: dict[str, str | None] = {}
    index = {name: i for i, name in enumerate(robot.joint_names)}
    for st in root.findall("group_state"):
        name, group = st.get("name"), st.get("group")
        if not name:
            raise ModelError(f"{_where(label, st)}: <group_state> without a name attribute")
        if group is not None and group not in groups:
            raise ModelError(f"{_where(label, st)}: <group_state name={name!r}> names group {group!r}, "
                             f"which is not defined.{suggest(group, groups)}")
        q = robot.neutral()
        touched = False
        for el in st.findall("joint"):
            joint = _check_joint(el.get("name"), el, label, urdf)
            i = index.get(joint)
            if i is None:  # a fixed or locked joint: not part of the joint vector
                continue
            v = _value(el, label, joint)
            lo, hi = robot.lower[i], robot.upper[i]
            if urdf.types.get(joint) == "revolute" and not (lo - LIMIT_TOL <= v <= hi + LIMIT_TOL):
                v = _wrap_into(v, lo, hi)  # the same angle, 2 pi k away, when that lies within the limits
            if not (lo - LIMIT_TOL <= v <= hi + LIMIT_TOL):
                raise ModelError(f"{_where(label, el)}: <group_state name={name!r}>: "
                                 f"joint {joint!r} = {v!r} is outside its limits [{lo}, {hi}]")
            q[i] = min(max(v, lo), hi)
            touched = True
        if not touched:
            continue
        key = name if name not in states else f"{group}/{name}"
        q.flags.writeable = False
        states[key] = q
        state_groups[key] = group
    return states, state_groups


class ReadOnlyDict(dict):
    """A dict that refuses changes (shared by every ``Robot.copy()``) and still pickles."""

    def _refuse(self, *args, **kwargs):
        raise TypeError("this mapping is read-only (it is shared by every copy of the robot)")

    __setitem__ = __delitem__ = clear = pop = popitem = setdefault = update = __ior__ = _refuse

    def __reduce__(self):
        return (type(self), (dict(self),))


def attach_srdf(robot: Robot, srdf: Srdf) -> Robot:
    """Give ``robot`` the SRDF's ``groups`` and ``named_states`` (read-only mappings); returns ``robot``."""
    robot.groups = ReadOnlyDict(srdf.groups)
    robot.named_states = ReadOnlyDict(srdf.named_states)
    robot.srdf_path = srdf.label
    robot.srdf = srdf.text or None
    robot._collision_holder = [None]  # the collision pairs follow this SRDF (not shared with other copies)
    return robot


def detach_srdf(robot: Robot) -> Robot:
    """Forget the SRDF of ``robot`` (back to the class defaults: no states, no groups)."""
    for attr in ("groups", "named_states", "srdf_path"):
        robot.__dict__.pop(attr, None)
    robot.srdf = None
    robot._collision_holder = [None]
    return robot
