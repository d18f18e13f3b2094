"""The robot registry: a name, a model file path or a URDF string in, a :class:`Robot` out.

``load(name_or_path, **params)`` accepts

* a **built-in name** (see :func:`available`):

  - arms of example-robot-data (ERD). Their parameters are the values of the
    joints the entry locks (gripper fingers, the other arm, ...), e.g.
    ``load("panda", panda_finger_joint1=0.04, panda_finger_joint2=0.04)``;
  - kinserve's seed robots from ``robots/models``: ``planar4r``, ``pr``,
    ``scara`` (parametric xacro files: parameters are their xacro args, e.g.
    ``load("planar4r", l1=1.2)``) and ``youbot`` (DH-generated URDF, no parameters);

* a path to a ``.urdf`` file (parameters = ``{joint: value}`` to lock) or to a
  ``.xacro`` file (parameters = xacro args);
* URDF XML text (parameters = joints to lock).

Keyword-only options for every form: ``tip=`` overrides the default tool
frame, ``geometry=False`` skips building the mesh geometry (faster; FK and
Jacobians do not need it).

Parsed models are cached (keyed on the name or file + modification time,
parameters and options): every call returns a fresh ``Robot`` with its own
``Data`` sharing the immutable Pinocchio model (``Robot.copy()``).
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path

from kinserve.kinematics.errors import ModelError, UnknownRobotError, suggest
from kinserve.kinematics.robot import TASK_AXES, Robot

from . import paths
from .urdf_loader import is_xml_text, load_urdf
from .xacro_loader import declared_args, load_xacro

PLANAR_XY_YAW = ("x", "y", "yaw")


@dataclass(frozen=True)
class RobotEntry:
    """One built-in robot: where its model lives and how to load it."""

    name: str
    description: str
    file: str  #: path relative to the ERD robots directory ("erd") or to robots/models ("models")
    origin: str  #: "erd" or "models"
    tip: str
    locked: dict = field(default_factory=dict)  #: default values (rad / m) of the joints locked by default
    task_axes: tuple = TASK_AXES
    nq: int = 0  #: number of joints after locking (checked by the tests)
    srdf: str | None = None  #: SRDF path relative to the ERD robots directory when not found by convention

    def path(self) -> Path:
        if self.origin == "erd":
            return paths.erd_file(self.file)
        return paths.models_dir() / self.file

    @property
    def is_xacro(self) -> bool:
        return self.file.endswith(".xacro")


def _erd(name, description, file, tip, nq, locked=None, task_axes=TASK_AXES, srdf=None) -> RobotEntry:
    return RobotEntry(name, description, file, "erd", tip, dict(locked or {}), tuple(task_axes), nq, srdf)


_BAXTER_ARM = ("s0", "s1", "e0", "e1", "w0", "w1", "w2")


def _baxter_locks(keep: str) -> dict:
    other = "right" if keep == "left" else "left"
    locks = {"head_pan": 0.0}
    locks.update({f"{other}_{j}": 0.0 for j in _BAXTER_ARM})
    locks.update({f"{s}_gripper_{f}_finger_joint": 0.0 for s in "lr" for f in "lr"})
    return locks


#: Built-in robots, in the order :func:`available` lists them.
ENTRIES: dict[str, RobotEntry] = {
    e.name: e
    for e in (
        # ---- kinserve seed robots (SCENARIOS.md)
        RobotEntry("planar4r", "S1 planar 4R arm, joints about z, links l1..l4 = 1.0/0.8/0.6/0.4 m",
                   "planar4r.urdf.xacro", "models", "tool", {}, PLANAR_XY_YAW, 4),
        RobotEntry("youbot", "S2 KUKA youBot 5-DOF arm from its DH table (DH convention: joint 1 about +z)",
                   "youbot.urdf", "models", "tool", {}, TASK_AXES, 5),
        RobotEntry("pr", "S5 planar PR robot T = Tx(d1) Rz(theta2) Tx(d2), d2 = 1.0 m",
                   "pr.urdf.xacro", "models", "tool", {}, ("x", "y"), 2),
        RobotEntry("scara", "S9 SCARA RRPR arm, a1 = a2 = 0.5 m, base at z = 1.0 m, d3 in [0.25, 1.0] m",
                   "scara.urdf.xacro", "models", "tool", {}, ("x", "y", "z", "yaw"), 4),
        # ---- example-robot-data arms
        _erd("panda", "Franka Emika Panda 7-DOF arm (fingers locked; flange panda_link8, tool panda_hand)",
             "panda_description/urdf/panda.urdf", "panda_hand", 7,
             {"panda_finger_joint1": 0.0, "panda_finger_joint2": 0.0}),
        _erd("ur3", "Universal Robots UR3 6-DOF arm (tool flange tool0)", "ur_description/urdf/ur3_robot.urdf", "tool0", 6),
        _erd("ur5", "Universal Robots UR5 6-DOF arm (tool flange tool0)", "ur_description/urdf/ur5_robot.urdf", "tool0", 6,
             srdf="ur_description/srdf/ur5.srdf"),
        _erd("ur10", "Universal Robots UR10 6-DOF arm (tool flange tool0)", "ur_description/urdf/ur10_robot.urdf", "tool0", 6),
        _erd("xarm7", "UFactory xArm7 7-DOF arm (end effector link_eef)", "xarm_description/urdf/xarm7.urdf", "link_eef", 7),
        _erd("kinova", "Kinova Jaco2 j2s6s200 6-DOF arm (continuous joints bounded to +-2 pi)",
             "kinova_description/robots/kinova.urdf", "j2s6s200_end_effector", 6),
        _erd("z1", "Unitree Z1 6-DOF arm (gripper locked; tool gripperStator)", "z1_description/urdf/z1.urdf",
             "gripperStator", 6, {"jointGripper": 0.0}),
        _erd("so100", "SO-ARM100 5-DOF arm (gripper jaw locked; tool = gripper link)", "so_arm_description/urdf/so100.urdf",
             "gripper", 5, {"gripper": 0.0}),
        _erd("so101", "SO-101 5-DOF arm (gripper jaw locked; tool gripper_frame_link)", "so_arm_description/urdf/so101.urdf",
             "gripper_frame_link", 5, {"gripper": 0.0}),
        _erd("talos_left_arm", "PAL TALOS left arm, 6 DOF (gripper locked; tool wrist_left_ft_tool_link)",
             "talos_data/robots/talos_left_arm.urdf", "wrist_left_ft_tool_link", 6, {"gripper_left_joint": 0.0}),
        _erd("baxter", "Rethink Baxter, both 7-DOF arms free (14 joints; head and grippers locked; tip left_gripper, "
             "the other hand is right_gripper)", "baxter_description/urdf/baxter.urdf", "left_gripper", 14,
             {"head_pan": 0.0, **{f"{s}_gripper_{f}_finger_joint": 0.0 for s in "lr" for f in "lr"}}),
        _erd("baxter_left", "Rethink Baxter left 7-DOF arm (head, right arm, grippers locked)",
             "baxter_description/urdf/baxter.urdf", "left_gripper", 7, _baxter_locks("left")),
        _erd("baxter_right", "Rethink Baxter right 7-DOF arm (head, left arm, grippers locked)",
             "baxter_description/urdf/baxter.urdf", "right_gripper", 7, _baxter_locks("right")),
        _erd("finger_edu", "TriFinger-edu single 3-DOF finger (tool finger_tip_link)",
             "finger_edu_description/robots/finger_edu.urdf", "finger_tip_link", 3, task_axes=("x", "y", "z")),
        _erd("twodof", "ASR planar 2R arm, joints about z (tool Tip)", "asr_twodof_description/urdf/TwoDofs.urdf",
             "Tip", 2, task_axes=PLANAR_XY_YAW),
        _erd("double_pendulum", "double pendulum, 2 joints about x (continuous, bounded to +-2 pi)",
             "double_pendulum_description/urdf/double_pendulum_continuous.urdf", "link2", 2,
             task_axes=("y", "z", "roll")),
    )
}

#: Maximum number of parsed models kept in the cache.
CACHE_SIZE = 64

_cache: OrderedDict = OrderedDict()
_cache_lock = threading.Lock()


def clear_cache() -> None:
    """Forget every cached model (the next load parses again)."""
    with _cache_lock:
        _cache.clear()


def _cached(key, build) -> Robot:
    with _cache_lock:
        proto = _cache.get(key)
        if proto is not None:
            _cache.move_to_end(key)
            return proto.copy()
    proto = build()
    with _cache_lock:
        _cache[key] = proto
        while len(_cache) > CACHE_SIZE:
            _cache.popitem(last=False)
    return proto.copy()


_args_cache: dict = {}


def _declared(path: Path) -> dict:
    """``declared_args`` of a xacro file, re-read only when the file changes."""
    st = path.stat()
    key = (str(path), st.st_mtime_ns, st.st_size)
    args = _args_cache.get(key)
    if args is None:
        args = _args_cache[key] = declared_args(path)
    return dict(args)


def parameters(name: str) -> dict:
    """Parameters of a built-in robot and their defaults (xacro args, or locked joint values)."""
    entry = _entry(name)
    if entry.is_xacro:
        return {k: _number_or_text(v) for k, v in _declared(entry.path()).items()}
    return dict(entry.locked)


def available() -> dict[str, str]:
    """``{name: one-line description}`` of every built-in robot."""
    out = {}
    for name, entry in ENTRIES.items():
        desc = entry.description
        if entry.is_xacro:
            desc += f" [params: {', '.join(_declared(entry.path()))}]"
        out[name] = desc
    return out


def _number_or_text(v):
    try:
        return float(v)
    except (TypeError, ValueError):
        return v


def _entry(name) -> RobotEntry:
    entry = ENTRIES.get(name) if isinstance(name, str) else None
    if entry is None:
        raise UnknownRobotError(
            f"unknown robot {name!r}.{suggest(str(name), ENTRIES)} Built-in robots: {', '.join(ENTRIES)}; "
            "or pass a path to a .urdf / .xacro file, or URDF XML text"
        )
    return entry


def _locks(entry_label: str, defaults: dict, params: dict) -> dict:
    """Locked joint values: ``defaults`` overridden by ``params`` (which must name locked joints)."""
    unknown = [k for k in params if k not in defaults]
    if unknown:
        accepted = ", ".join(defaults) or "none"
        raise ModelError(
            f"{entry_label}: unknown parameter(s) {unknown}; accepted parameters (locked joint values): {accepted}."
            f"{suggest(str(unknown[0]), defaults)}"
        )
    locks = dict(defaults)
    for k, v in params.items():
        try:
            f = float(v)
        except (TypeError, ValueError):
            raise ModelError(f"{entry_label}: parameter {k!r} must be a number (joint value), got {v!r}") from None
        if not math.isfinite(f):
            raise ModelError(f"{entry_label}: parameter {k!r} must be finite, got {v!r}")
        locks[k] = f
    return locks


def _freeze(params: dict):
    return tuple(sorted((k, repr(v)) for k, v in params.items()))


def _load_entry(entry: RobotEntry, tip, geometry: bool, params: dict) -> Robot:
    tip = tip or entry.tip
    if entry.is_xacro:
        path = entry.path()
        key = ("entry", entry.name, _freeze(params), tip, geometry)
        return _cached(key, lambda: load_xacro(
            path, args=params, tip=tip, name=entry.name, description=entry.description,
            geometry=geometry, task_axes=entry.task_axes,
        ))
    locks = _locks(f"robot {entry.name!r}", entry.locked, params)
    key = ("entry", entry.name, _freeze(locks), tip, geometry)
    srdf = paths.erd_file(entry.srdf) if entry.srdf else None
    return _cached(key, lambda: load_urdf(
        entry.path(), tip=tip, name=entry.name, description=entry.description, locked_joints=locks,
        geometry=geometry, task_axes=entry.task_axes, srdf=srdf,
    ))


def _looks_like_path(s: str) -> bool:
    return "/" in s or "\\" in s or s.endswith((".urdf", ".xacro", ".xml")) or Path(s).expanduser().is_file()


def load(name_or_path, *, tip: str | None = None, geometry: bool = True, **params) -> Robot:
    """A :class:`Robot` from a built-in name, a ``.urdf`` / ``.xacro`` path, or URDF text.

    See the module docstring for what ``params`` mean for each form. Raises
    :class:`UnknownRobotError` (listing the built-in names) for an unknown
    name and :class:`ModelError` for a bad parameter or an unusable model.
    """
    if isinstance(name_or_path, str) and name_or_path in ENTRIES:
        return _load_entry(ENTRIES[name_or_path], tip, geometry, params)
    if isinstance(name_or_path, str) and is_xml_text(name_or_path):
        locks = _locks("URDF string", {k: None for k in params}, params) if params else {}
        key = ("string", name_or_path, _freeze(locks), tip, geometry)
        return _cached(key, lambda: load_urdf(name_or_path, tip=tip, locked_joints=locks, geometry=geometry))
    if isinstance(name_or_path, Path) or (isinstance(name_or_path, str) and _looks_like_path(name_or_path)):
        path = Path(name_or_path).expanduser()
        if not path.is_file():
            raise ModelError(f"robot model file {str(path)!r} does not exist")
        path = path.resolve()
        st = path.stat()
        stamp = (str(path), st.st_mtime_ns, st.st_size)
        if path.name.endswith(".xacro"):
            key = ("xacro", stamp, _freeze(params), tip, geometry)
            return _cached(key, lambda: load_xacro(path, args=params, tip=tip, geometry=geometry))
        locks = _locks(str(path), {k: None for k in params}, params) if params else {}
        key = ("urdf", stamp, _freeze(locks), tip, geometry)
        return _cached(key, lambda: load_urdf(path, tip=tip, locked_joints=locks, geometry=geometry))
    _entry(name_or_path)  # raises UnknownRobotError
    raise AssertionError("unreachable")  # pragma: no cover
