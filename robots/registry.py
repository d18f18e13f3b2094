"""The robot registry: a name, a model file path or a URDF string in, a :class:`Robot` out.

``load(name_or_path, params={...}, locks={...}, **options)`` accepts

* a **built-in name** (see :func:`available`; case is ignored):

  - arms of example-robot-data (ERD). Their parameters are the values of the
    joints the entry locks (gripper fingers, the other arm, ...), e.g.
    ``load("panda", panda_finger_joint1=0.04, panda_finger_joint2=0.04)``;
  - kinserve's seed robots from ``robots/models``: ``planar4r``, ``pr``,
    ``scara`` (parametric xacro files: parameters are their xacro args, e.g.
    ``load("planar4r", l1=1.2)``) and ``youbot`` (DH-generated URDF, no parameters);

* a path to a ``.urdf`` file (parameters = ``{joint: value}`` to lock) or to a
  ``.xacro`` file (parameters = xacro args);
* URDF XML text (parameters = joints to lock).

Parameters go in ``params={...}`` (or, for short, as keywords:
``load("planar4r", l1=1.2)``); options are the named keywords of :func:`load`
(``tip``, ``geometry``, ``package_dirs``, ``task_axes``, ``srdf``,
``allow_outside``, ``time_limit``), so ``package_dirs=`` is never read as a
joint value.

Parsed models are cached (keyed on the name or file + modification time,
parameters and options): every call returns a fresh ``Robot`` with its own
``Data`` sharing the immutable Pinocchio model (``Robot.copy()``).
"""

from __future__ import annotations

import difflib
import math
import os
import threading
import warnings
from collections import OrderedDict
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from kinserve.kinematics.errors import ModelError, UnknownRobotError, suggest
from kinserve.kinematics.robot import TASK_AXES, Robot
from kinserve.kinematics.validation import as_flag

from . import paths
from .mesh_resolver import check_package_dirs
from .packages import AMENT_PREFIX_PATH, ROS_PACKAGE_PATH
from .srdf import SrdfWarning, attach_srdf, detach_srdf, find_srdf, read_srdf
from .urdf_loader import check_joint_values, check_task_axes, check_tip, is_xml_text, load_urdf
from .xacro_loader import declared_args, load_xacro, xacro_time_limit

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
    srdf: bool = True  #: read the SRDF found beside the model file (False when it does not fit the URDF)

    def path(self) -> Path:
        """Absolute path of the model file (inside example-robot-data or ``robots/models``)."""
        if self.origin == "erd":
            return paths.erd_file(self.file)
        return paths.models_dir() / self.file

    @property
    def is_xacro(self) -> bool:
        """True when the model file is a xacro file."""
        return self.file.endswith(".xacro")


def _erd(name, description, file, tip, nq, locked=None, task_axes=TASK_AXES, srdf=True) -> RobotEntry:
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
        _erd("ur3", "Universal Robots UR3 6-DOF arm (tool flange tool0)",
             "ur_description/urdf/ur3_robot.urdf", "tool0", 6),
        _erd("ur5", "Universal Robots UR5 6-DOF arm (tool flange tool0)",
             "ur_description/urdf/ur5_robot.urdf", "tool0", 6),
        _erd("ur10", "Universal Robots UR10 6-DOF arm (tool flange tool0)",
             "ur_description/urdf/ur10_robot.urdf", "tool0", 6),
        _erd("xarm7", "UFactory xArm7 7-DOF arm (end effector link_eef)", "xarm_description/urdf/xarm7.urdf",
             "link_eef", 7),
        _erd("kinova", "Kinova Jaco2 j2s6s200 6-DOF arm (continuous joints bounded to +-2 pi)",
             "kinova_description/robots/kinova.urdf", "j2s6s200_end_effector", 6),
        # ERD's z1.srdf has a <chain base_link="base"> but z1.urdf has no link "base": not read
        _erd("z1", "Unitree Z1 6-DOF arm (gripper locked; tool gripperStator)", "z1_description/urdf/z1.urdf",
             "gripperStator", 6, {"jointGripper": 0.0}, srdf=False),
        _erd("so100", "SO-ARM100 5-DOF arm (gripper jaw locked; tool = gripper link)",
             "so_arm_description/urdf/so100.urdf", "gripper", 5, {"gripper": 0.0}),
        _erd("so101", "SO-101 5-DOF arm (gripper jaw locked; tool gripper_frame_link)",
             "so_arm_description/urdf/so101.urdf", "gripper_frame_link", 5, {"gripper": 0.0}),
        _erd("talos_left_arm", "PAL TALOS left arm, 6 DOF (gripper locked; tool wrist_left_ft_tool_link)",
             "talos_data/robots/talos_left_arm.urdf", "wrist_left_ft_tool_link", 6,
             {"gripper_left_joint": 0.0}),
        _erd("baxter", "Rethink Baxter, both 7-DOF arms free (14 joints; head and grippers locked; "
                       "tip left_gripper, the other hand is right_gripper)",
             "baxter_description/urdf/baxter.urdf", "left_gripper", 14,
             {"head_pan": 0.0, **{f"{s}_gripper_{f}_finger_joint": 0.0 for s in "lr" for f in "lr"}}),
        _erd("baxter_left", "Rethink Baxter left 7-DOF arm (head, right arm, grippers locked)",
             "baxter_description/urdf/baxter.urdf", "left_gripper", 7, _baxter_locks("left")),
        _erd("baxter_right", "Rethink Baxter right 7-DOF arm (head, left arm, grippers locked)",
             "baxter_description/urdf/baxter.urdf", "right_gripper", 7, _baxter_locks("right")),
        _erd("finger_edu", "TriFinger-edu single 3-DOF finger (tool finger_tip_link)",
             "finger_edu_description/robots/finger_edu.urdf", "finger_tip_link", 3,
             task_axes=("x", "y", "z")),
        _erd("twodof", "ASR planar 2R arm, joints about z (tool Tip)",
             "asr_twodof_description/urdf/TwoDofs.urdf", "Tip", 2, task_axes=PLANAR_XY_YAW),
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


def canonical_name(name: str) -> str:
    """The built-in name matching ``name`` exactly or ignoring case; :class:`UnknownRobotError` otherwise."""
    if isinstance(name, str):
        if name in ENTRIES:
            return name
        for known in ENTRIES:
            if known.lower() == name.strip().lower():
                return known
    raise UnknownRobotError(
        f"unknown robot {name!r}.{suggest(str(name), ENTRIES)} Built-in robots: {', '.join(ENTRIES)}; "
        "or pass a path to a .urdf / .xacro file, or URDF XML text"
    )


def _entry(name) -> RobotEntry:
    return ENTRIES[canonical_name(name)]


def _locks(entry_label: str, defaults: dict, params: dict) -> dict:
    """Locked joint values: ``defaults`` overridden by ``params`` (which must name locked joints)."""
    unknown = [k for k in params if k not in defaults]
    if unknown:
        accepted = ", ".join(defaults) or "none"
        raise ModelError(
            f"{entry_label}: unknown parameter(s) {unknown}; accepted parameters (locked joint values): "
            f"{accepted}.{suggest(str(unknown[0]), defaults)}"
        )
    locks = dict(defaults)
    for k, v in params.items():
        try:
            f = float(v)
        except (TypeError, ValueError):
            raise ModelError(f"{entry_label}: parameter {k!r} must be a number (joint value), "
                             f"got {v!r}") from None
        if not math.isfinite(f):
            raise ModelError(f"{entry_label}: parameter {k!r} must be finite, got {v!r}")
        locks[k] = f
    return locks


def _freeze(params: dict):
    return tuple(sorted((k, repr(v)) for k, v in params.items()))


#: Keyword options of :func:`load` (everything else given as a keyword is a model parameter).
OPTIONS = ("params", "locks", "tip", "geometry", "package_dirs", "task_axes", "srdf", "allow_outside",
           "time_limit")


@dataclass(frozen=True)
class LoadOptions:
    """How to load a model, apart from its parameters (see :func:`load`)."""

    tip: str | None = None
    geometry: bool = True
    package_dirs: tuple[str, ...] = ()
    allow_outside: bool = False
    time_limit: float | None = None

    def key(self) -> tuple:
        # they resolve packages too
        """What a loaded model depends on besides its name and parameters, for the registry's cache

        (``$ROS_PACKAGE_PATH`` and ``$AMENT_PREFIX_PATH`` resolve packages too, so they are part of it).
        """
        env = tuple(os.environ.get(v) for v in (ROS_PACKAGE_PATH, AMENT_PREFIX_PATH))
        return (self.tip, self.geometry, self.package_dirs, self.allow_outside, env)

    def loader_kwargs(self) -> dict:
        """The keyword arguments these options give the URDF / xacro loaders."""
        return {"tip": self.tip, "geometry": self.geometry, "package_dirs": self.package_dirs,
                "allow_outside": self.allow_outside}


def _auto_srdf(robot: Robot, model_path: Path | None) -> Robot:
    """Attach the SRDF found beside ``model_path`` (see :func:`srdf.find_srdf`), if any.

    An SRDF that was not asked for never stops a model from loading: when it
    is unusable, a :class:`SrdfWarning` says why (``srdf=PATH`` raises instead).
    """
    found = find_srdf(model_path) if model_path is not None else None
    if found is None:
        return robot
    try:
        return attach_srdf(robot, read_srdf(found, robot))
    except ModelError as exc:
        warnings.warn(f"{str(exc).rstrip('.')}; loading without named states (pass srdf=False to skip it, "
                      "srdf=PATH to choose one)",
                      SrdfWarning, stacklevel=4)
        return robot


def _load_entry(entry: RobotEntry, opts: LoadOptions, params: dict, locks: dict) -> Robot:
    tip = opts.tip or entry.tip
    kwargs = {**opts.loader_kwargs(), "tip": tip, "name": entry.name, "description": entry.description,
              "task_axes": entry.task_axes}
    if entry.is_xacro:
        path = entry.path()
        key = ("entry", entry.name, _freeze(params), _freeze(locks), opts.key(), tip)
        return _cached(key, lambda: _auto_srdf(load_xacro(path, args=params, locked_joints=locks or None,
                                                          time_limit=opts.time_limit, **kwargs), path))
    locks = {**_locks(f"robot {entry.name!r}", entry.locked, params),
             **_numbers(f"robot {entry.name!r}", locks)}
    key = ("entry", entry.name, _freeze(locks), opts.key(), tip)
    srdf_near = entry.path() if entry.srdf else None
    return _cached(key, lambda: _auto_srdf(load_urdf(entry.path(), locked_joints=locks, **kwargs), srdf_near))


def _numbers(label: str, values: Mapping) -> dict:
    """``values`` checked as finite joint values (the accepted names are checked by the loader)."""
    return _locks(label, dict.fromkeys(values), dict(values)) if values else {}


def _short(path: Path, limit: int = 200) -> str:
    """``repr`` of ``path``, cut to ``limit`` characters for a message."""
    text = str(path)
    return repr(text) if len(text) <= limit else repr(text[:limit]) + f"... ({len(text)} characters)"


def _looks_like_path(s: str) -> bool:
    """Whether ``s`` names a file rather than a registry entry (False for a name the OS cannot look up,
    e.g. longer than the file-system limit or holding a NUL: it is then reported as an unknown robot)."""
    if "/" in s or "\\" in s or s.endswith((".urdf", ".xacro", ".xml")):
        return True
    try:
        return Path(s).expanduser().is_file()
    except (OSError, ValueError):
        return False


def _merge_params(params: Mapping | None, legacy: dict) -> dict:
    """``params`` and the legacy keyword form ``load(name, l1=1.2)`` in one dict."""
    if params is not None and not isinstance(params, Mapping):
        raise ModelError(f"params must be a mapping name -> value, got {type(params).__name__}")
    for key in legacy:
        close = difflib.get_close_matches(key, OPTIONS, n=1, cutoff=0.75)
        if close:
            raise ModelError(
                f"unknown option {key!r} of robots.load; did you mean {close[0]}=? "
                f"(options: {', '.join(OPTIONS)}; joint values and xacro args go in params={{...}})"
            )
    both = sorted(set(params or {}) & set(legacy))
    if both:
        raise ModelError(f"parameter(s) {both} given both in params= and as keywords")
    return {**dict(params or {}), **legacy}


def load(
    name_or_path: str | os.PathLike,
    *,
    params: Mapping | None = None,
    locks: Mapping | None = None,
    tip: str | None = None,
    geometry: bool = True,
    package_dirs: str | os.PathLike | Iterable[str | os.PathLike] | None = None,
    task_axes: str | Sequence[str] | None = None,
    srdf: str | os.PathLike | bool | None = None,
    allow_outside: bool = False,
    time_limit: float | None = None,
    **legacy_params: Any,
) -> Robot:
    """A :class:`Robot` from a built-in name (any case), a ``.urdf`` / ``.xacro`` path, or URDF text.

    Model values and loading options never share a namespace:

    * ``params``: the model's parameters - xacro args of a xacro file or
      parametric built-in (``params={"l1": 1.2}``), joint values to lock of
      a URDF or built-in arm (see the module docstring and :func:`parameters`).
      For short, ``load("planar4r", l1=1.2)`` is the same as
      ``load("planar4r", params={"l1": 1.2})``; a keyword that is (close to)
      an option name below is always the option.
    * ``locks``: ``{joint: value}`` to freeze, for every form (also after a
      xacro expansion).
    * ``tip``: default tool frame, a frame name of the model (None: the built-in's, else the model's last
      frame); ``geometry``: build the meshes for viewers
      (kinematics never needs them; a missing mesh is then a warning and a
      placeholder); ``package_dirs``: existing folders (one or a list) resolving ``package://`` URIs
      and ``$(find)``, searched before the model's own folders,
      ``$ROS_PACKAGE_PATH`` and ``$AMENT_PREFIX_PATH`` (:mod:`robots.mesh_resolver`).
    * ``task_axes``: the task components singularity measures use, each at most once (e.g.
      ``("x", "y", "z")`` or ``"x,y,z"``: :func:`robots.urdf_loader.check_task_axes`); default: the
      built-in's, or detected from the model (:mod:`kinematics.task_axes`).
    * ``srdf``: SRDF path or text for ``robot.named_states`` / ``robot.groups``;
      default: the SRDF found beside the model file; ``False``: none.
    * ``allow_outside``: let the model read mesh files outside its own
      folders and the package folders (refused by default). It and ``geometry``
      are True or False: ``allow_outside="no"`` is refused, not read as a yes.
    * ``time_limit``: seconds a xacro expansion may take (default 20, at most 3600; checked on every load,
      xacro or not).

    Raises :class:`UnknownRobotError` (with suggestions) for an unknown name
    and :class:`ModelError` for a bad parameter or option (``package_dirs`` not folders, ``time_limit`` not a
    number of seconds in ``(0, 3600]``) or an unusable model; :class:`InputError` for an option of the wrong
    kind (``geometry`` / ``allow_outside`` not True or False, ``tip`` not a str, bad ``task_axes``) and
    :class:`FrameError` for a ``tip`` the model does not have.
    """
    params = _merge_params(params, legacy_params)
    locks = dict(check_joint_values(locks, "locks") or {})
    time_limit = xacro_time_limit(time_limit)  # every load: a bad one is refused, xacro or not
    dirs = check_package_dirs(package_dirs)
    geometry, allow_outside = as_flag(geometry, "geometry"), as_flag(allow_outside, "allow_outside")
    tip, task_axes = check_tip(tip), check_task_axes(task_axes)
    opts = LoadOptions(tip, geometry, dirs, allow_outside, time_limit)
    robot = _load(name_or_path, opts, params, locks, auto_srdf=srdf is None)
    return _apply(robot, task_axes, srdf)


def _apply(robot: Robot, task_axes: tuple[str, ...] | None, srdf) -> Robot:
    """Per-call options applied to the (fresh) copy: task axes (checked: :func:`check_task_axes`) and an
    explicit SRDF."""
    if task_axes is not None:
        robot.task_axes = task_axes
    if srdf is False:
        detach_srdf(robot)
    elif srdf is not None:
        attach_srdf(robot, read_srdf(srdf, robot))
    return robot


def _load(name_or_path, opts: LoadOptions, params: dict, locks: dict, auto_srdf: bool) -> Robot:
    if isinstance(name_or_path, str) and name_or_path in ENTRIES:
        return _load_entry(ENTRIES[name_or_path], opts, params, locks)
    if isinstance(name_or_path, str) and is_xml_text(name_or_path):
        locks = {**_numbers("URDF string", params), **_numbers("URDF string", locks)}
        key = ("string", name_or_path, _freeze(locks), opts.key())
        return _cached(key, lambda: load_urdf(name_or_path, locked_joints=locks, **opts.loader_kwargs()))
    if isinstance(name_or_path, Path) or (isinstance(name_or_path, str) and _looks_like_path(name_or_path)):
        return _load_file(Path(name_or_path).expanduser(), opts, params, locks, auto_srdf)
    return _load_entry(_entry(name_or_path), opts, params, locks)  # any case; else UnknownRobotError


def _load_file(path: Path, opts: LoadOptions, params: dict, locks: dict, auto_srdf: bool) -> Robot:
    try:
        if not path.is_file():
            raise ModelError(f"robot model file {_short(path)} does not exist")
        path = path.resolve()
        st = path.stat()
    except (OSError, ValueError) as exc:  # a name too long for the file system, a NUL byte, ...
        raise ModelError(f"robot model file {_short(path)} cannot be opened: "
                         f"{getattr(exc, 'strerror', None) or exc}") from None
    stamp = (str(path), st.st_mtime_ns, st.st_size)
    attach = (lambda r: _auto_srdf(r, path)) if auto_srdf else (lambda r: r)
    if path.name.endswith(".xacro"):
        locks = _numbers(str(path), locks)
        key = ("xacro", stamp, _freeze(params), _freeze(locks), opts.key(), auto_srdf)
        return _cached(key, lambda: attach(load_xacro(path, args=params, locked_joints=locks or None,
                                                      time_limit=opts.time_limit, **opts.loader_kwargs())))
    both = sorted(set(params) & set(locks))
    if both:
        raise ModelError(f"{path}: joint(s) {both} given both in params= and locks=")
    locks = {**_numbers(str(path), params), **_numbers(str(path), locks)}
    key = ("urdf", stamp, _freeze(locks), opts.key(), auto_srdf)
    return _cached(key, lambda: attach(load_urdf(path, locked_joints=locks, **opts.loader_kwargs())))
