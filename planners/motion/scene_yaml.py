"""MoveIt planning scenes and motion requests in YAML: kinserve shapes and joint configurations.

A MoveIt ``PlanningScene`` message in YAML (as ``rostopic echo`` / ``ros2 topic echo`` and
MotionBenchMaker write it) holds its obstacles in ``world.collision_objects[]``; each object has an
``id``, a list ``primitives[]`` of solid primitives and one pose per primitive in ``primitive_poses[]``,
and optionally an object-level ``pose``. A primitive's world placement is

    T_world = T_object @ T_primitive       (T_object = identity when ``pose`` is absent)

with each pose given as ``position`` ``[x, y, z]`` (m) and ``orientation`` ``[x, y, z, w]`` (unit
quaternion, ROS's order; the mapping forms ``{x: .., y: .., z: .., w: ..}`` are read as well). The
primitives become the project's shapes (:mod:`kinserve.kinematics.shapes`):

* ``box``, ``dimensions: [x, y, z]`` full edge lengths (m)       -> :class:`Box` ``size=(x, y, z)``;
* ``cylinder``, ``dimensions: [height, radius]``, axis local z  -> :class:`Cylinder` ``length, radius``;
* ``sphere``, ``dimensions: [radius]``                          -> :class:`Sphere` (its orientation is moot).

MoveIt's numeric type codes (``1`` box, ``2`` sphere, ``3`` cylinder) are accepted too. Meshes, planes,
cones and octomaps are refused with an :class:`InputError` naming the object: no obstacle is silently
left out. A ``MotionPlanRequest`` gives the start (``start_state.joint_state``: ``name[]``,
``position[]``) and a joint goal (``goal_constraints[0].joint_constraints[]``: ``joint_name``,
``position``), both as ``{joint name: value}`` (rad or m); :func:`joint_vector` turns such a mapping
into a robot's ``q`` (names the robot lacks, such as gripper fingers, are ignored).
"""

from __future__ import annotations

import math
import numbers
import os
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from kinserve.kinematics.errors import InputError
from kinserve.kinematics.robot import Robot, as_robot
from kinserve.kinematics.se3 import matrix_from_quat, quat_from_matrix
from kinserve.kinematics.shapes import Box, Cylinder, Shape, Sphere
from kinserve.kinematics.validation import MAX_ABS, describe

__all__ = ["MotionRequest", "read_planning_scene", "write_planning_scene", "read_motion_request",
           "joint_vector"]

#: MoveIt's ``shape_msgs/SolidPrimitive`` type codes of the primitives read here.
PRIMITIVE_CODES = {1: "box", 2: "sphere", 3: "cylinder"}
#: The fields of MoveIt's ``moveit_msgs/PlanningScene``: a scene document names at least one of them.
SCENE_FIELDS = ("name", "robot_state", "robot_model_name", "fixed_frame_transforms",
                "allowed_collision_matrix", "link_padding", "link_scale", "object_colors", "world", "is_diff")
#: How far a quaternion's norm may be from 1 before it is refused (it is normalised otherwise).
QUATERNION_TOL = 1e-3

#: PyYAML's safe loader, on libyaml (C) when the wheel has it: the same documents, about 8x faster than the
#: pure-Python loader on a MotionBenchMaker scene (1.0 ms against 8.1 ms).
_SAFE_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


@dataclass(frozen=True)
class MotionRequest:
    """A joint-space motion request: ``start`` and ``goal`` as ``{joint name: value}`` (rad or m).

    ``group`` is MoveIt's planning group (``group_name``), ``""`` when the request has none.
    Construction checks what :func:`read_motion_request` checks (:class:`InputError` naming the field):
    ``start`` and ``goal`` mappings of joint names (str) to finite numbers with ``|x| <= 1e6`` (not
    bools; kept as floats, in a dict), ``group`` a string.
    """

    start: dict[str, float]
    goal: dict[str, float]
    group: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "start", _joint_values(self.start, "MotionRequest.start"))
        object.__setattr__(self, "goal", _joint_values(self.goal, "MotionRequest.goal"))
        if not isinstance(self.group, str):
            raise InputError(f"MotionRequest.group must be a planning group name (str, '' for none), got "
                             f"{describe(self.group)}")


#: A number in exponent form without a dot (``1e-3``): text to YAML 1.1, a float to YAML 1.2 and MoveIt.
_EXPONENT = re.compile(r"[-+]?\d+[eE][-+]?\d+")


def _names_a_file(text: str) -> bool:
    """Whether a string is read as a file path: one line ending in .yaml / .yml, or an existing file."""
    if "\n" in text or len(text) > 4096:
        return False
    try:
        return text.endswith((".yaml", ".yml")) or Path(text).is_file()
    except OSError:  # not a usable path (too long a name, ...): YAML text
        return False


def _is_dir(path: str | os.PathLike) -> bool:
    """Whether ``path`` names an existing directory (False for a name the system cannot use)."""
    try:
        return Path(path).is_dir()
    except (OSError, ValueError):
        return False


def _load_yaml(source: str | os.PathLike, what: str) -> tuple[dict, str]:
    """``(document, label)``: the parsed document of a YAML file path or YAML text (:class:`InputError` on a
    read/parse error) and how messages name it (``what``, with the file's path when it was read from one).

    Refused: a directory, a file that is not UTF-8 text, text that is not YAML or not a mapping.
    """
    text, label = source, what
    if isinstance(source, str) and "\n" not in source and len(source) <= 4096 and _is_dir(source):
        source = Path(source)
    if isinstance(source, os.PathLike) or (isinstance(source, str) and _names_a_file(source)):
        label = f"{what} file {str(source)!r}"
        if _is_dir(source):
            raise InputError(f"{label} is a directory, expected a YAML file")
        try:
            text = Path(source).read_text(encoding="utf-8")
        except OSError as exc:
            raise InputError(f"{label} cannot be read: {exc.strerror or exc}") from None
        except UnicodeDecodeError as exc:
            raise InputError(f"{label} is not UTF-8 text (byte {exc.start}): expected a YAML file") from None
    elif not isinstance(source, str):
        raise InputError(f"{what} must be a YAML file path or YAML text, got {type(source).__name__}")
    try:
        doc = yaml.load(text, Loader=_SAFE_LOADER)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise InputError(f"{label} is not valid YAML{where}: {problem}") from None
    if not isinstance(doc, dict):
        raise InputError(f"{label} must be a YAML mapping (a MoveIt message), got {type(doc).__name__}")
    return doc, label


def _numbers(value: Any, n: int | None, label: str) -> list[float]:
    """``value`` as a list of finite floats (of length ``n`` when given).

    Refused: booleans (YAML ``yes``/``no``/``true``), text, NaN, infinities and |x| > 1e6. Accepted as
    numbers besides YAML's: exponent forms without a dot (``1e-3``), which YAML 1.1 reads as text.
    """
    if not isinstance(value, (list, tuple)) or (n is not None and len(value) != n):
        want = f"a list of {n} numbers" if n is not None else "a list of numbers"
        raise InputError(f"{label} must be {want}, got {value!r}")
    value = [float(v) if isinstance(v, str) and _EXPONENT.fullmatch(v.strip()) else v for v in value]
    if any(isinstance(v, bool) or not isinstance(v, numbers.Real) for v in value):
        raise InputError(f"{label} must hold numbers (not true/false/yes/no or text), got {value!r}")
    try:
        out = [float(v) for v in value]
    except OverflowError:  # an integer beyond float range
        out = [math.inf]
    if not all(math.isfinite(v) and abs(v) <= MAX_ABS for v in out):
        raise InputError(f"{label} must hold finite numbers with |x| <= {MAX_ABS:g}, got {value!r}")
    return out


def _joint_values(values: Any, label: str) -> dict[str, float]:
    """``{joint name: value}`` as a dict of floats (each value as :func:`_numbers` accepts it)."""
    if not isinstance(values, Mapping) or not all(isinstance(name, str) for name in values):
        raise InputError(f"{label} must be a mapping joint name (str) -> value, got {describe(values)}")
    return dict(zip(values, _numbers(list(values.values()), None, label)))


def _xyz(value: Any, keys: str, label: str) -> list[float]:
    """A list ``[x, y, z(, w)]`` or a mapping ``{x: .., y: .., ...}`` as floats in the order of ``keys``."""
    if isinstance(value, Mapping):
        missing = [k for k in keys if k not in value]
        if missing:
            raise InputError(f"{label} lacks {', '.join(missing)}: got {dict(value)!r}")
        value = [value[k] for k in keys]
    return _numbers(value, len(keys), label)


def _pose(entry: Any, label: str) -> np.ndarray:
    """The 4x4 pose of a ``{position, orientation}`` entry; a missing field is the identity's."""
    if not isinstance(entry, Mapping):
        raise InputError(f"{label} must be a mapping with position and orientation, got {entry!r}")
    T = np.eye(4)
    if entry.get("position") is not None:
        T[:3, 3] = _xyz(entry["position"], "xyz", f"{label}.position")
    if entry.get("orientation") is not None:
        quat = _xyz(entry["orientation"], "xyzw", f"{label}.orientation")
        norm = math.sqrt(sum(v * v for v in quat))
        if abs(norm - 1.0) > QUATERNION_TOL:
            raise InputError(f"{label}.orientation must be a unit quaternion [x, y, z, w], got {quat} "
                             f"(norm {norm:.6g})")
        T[:3, :3] = matrix_from_quat(quat)
    return T


def _primitive_kind(primitive: Mapping, label: str) -> str:
    kind = primitive.get("type")
    if isinstance(kind, int) and not isinstance(kind, bool):
        kind = PRIMITIVE_CODES.get(kind, kind)
    if not isinstance(kind, str) or kind.lower() not in PRIMITIVE_CODES.values():
        raise InputError(f"{label}.type must be one of box, sphere, cylinder (or MoveIt's codes 1, 2, 3), "
                         f"got {kind!r} (cones and other primitives are not supported)")
    return kind.lower()


def _shape(primitive: Any, T: np.ndarray, label: str) -> Shape:
    """The kinserve shape of one ``SolidPrimitive`` placed at ``T``."""
    if not isinstance(primitive, Mapping):
        raise InputError(f"{label} must be a mapping with type and dimensions, got {primitive!r}")
    kind = _primitive_kind(primitive, label)
    sizes = {"box": 3, "sphere": 1, "cylinder": 2}[kind]
    dims = _numbers(primitive.get("dimensions"), sizes, f"{label}.dimensions ({kind})")
    try:
        if kind == "box":
            return Box(T, dims)
        if kind == "sphere":
            return Sphere(T[:3, 3], dims[0])
        return Cylinder(T, radius=dims[1], length=dims[0])
    except InputError as exc:
        raise InputError(f"{label}: {exc}") from None


def _object_shapes(obj: Any, k: int) -> list[Shape]:
    """The shapes of ``world.collision_objects[k]`` (every primitive at ``pose @ primitive_pose``)."""
    if not isinstance(obj, Mapping):
        raise InputError(f"world.collision_objects[{k}] must be a mapping, got {obj!r}")
    label = f"collision object {obj.get('id', '')!r} (world.collision_objects[{k}])"
    for field in ("meshes", "planes"):
        if obj.get(field):
            raise InputError(f"{label} has {field}: only solid primitives (box, sphere, cylinder) are "
                             f"supported")
    operation = obj.get("operation", 0)
    if operation not in (0, "0", "add", "ADD", b"\x00"):
        raise InputError(f"{label}: operation {operation!r} is not supported (only ADD, 0)")
    primitives, poses = obj.get("primitives") or [], obj.get("primitive_poses") or []
    if not isinstance(primitives, list) or not isinstance(poses, list) or len(primitives) != len(poses):
        raise InputError(f"{label} must have lists primitives[] and primitive_poses[] of the same length, "
                         f"got {primitives!r} and {poses!r}")
    T_object = _pose(obj["pose"], f"{label}.pose") if obj.get("pose") is not None else np.eye(4)
    return [_shape(p, T_object @ _pose(pp, f"{label}.primitive_poses[{i}]"), f"{label}.primitives[{i}]")
            for i, (p, pp) in enumerate(zip(primitives, poses))]


def read_planning_scene(source: str | os.PathLike) -> list[Shape]:
    """The obstacles of a MoveIt ``PlanningScene`` YAML (a file path or the text) as kinserve shapes.

    Every primitive of ``world.collision_objects[]`` in order (module docstring for the formats and the
    pose composition). :class:`InputError` naming the object for meshes, planes, cones, an octomap, a
    malformed entry, or a file that is not YAML; also for a document that is not a mapping (a bare value
    such as ``no`` or ``3``) or a mapping with none of a ``PlanningScene``'s fields (:data:`SCENE_FIELDS`;
    another message, such as a trajectory, is not an empty scene).
    """
    doc, label = _load_yaml(source, "planning scene")
    if not any(field in doc for field in SCENE_FIELDS):
        raise InputError(f"{label} is not a MoveIt PlanningScene: it has none of the fields "
                         f"{', '.join(SCENE_FIELDS)} (got {describe(sorted(map(str, doc)))})")
    world = doc.get("world") or {}
    if not isinstance(world, Mapping):
        raise InputError(f"planning scene: world must be a mapping, got {world!r}")
    octomap = world.get("octomap")
    if isinstance(octomap, Mapping) and (octomap.get("octomap") or {}).get("data"):
        raise InputError("planning scene: world.octomap holds an octomap; octomaps are not supported "
                         "(only collision objects of solid primitives)")
    objects = world.get("collision_objects") or []
    if not isinstance(objects, list):
        raise InputError(f"planning scene: world.collision_objects must be a list, got {objects!r}")
    return [shape for k, obj in enumerate(objects) for shape in _object_shapes(obj, k)]


def _pose_yaml(T: np.ndarray) -> dict:
    return {"position": [float(v) for v in T[:3, 3]],
            "orientation": [float(v) for v in quat_from_matrix(T[:3, :3])]}


def _primitive_yaml(shape: Shape, k: int) -> tuple[dict, np.ndarray]:
    """``(SolidPrimitive, world pose)`` of a box, sphere or cylinder; :class:`InputError` for others."""
    if isinstance(shape, Box):
        return {"type": "box", "dimensions": [float(v) for v in shape.size]}, shape.pose
    if isinstance(shape, Sphere):
        return {"type": "sphere", "dimensions": [shape.radius]}, shape.pose
    if isinstance(shape, Cylinder):
        return {"type": "cylinder", "dimensions": [shape.length, shape.radius]}, shape.pose
    raise InputError(f"shapes[{k}]: a MoveIt planning scene holds boxes, spheres and cylinders, got "
                     f"{type(shape).__name__}")


def write_planning_scene(shapes: Sequence[Shape], name: str = "") -> str:
    """YAML text of a MoveIt ``PlanningScene`` whose world holds ``shapes`` (one object each, ids
    ``<kind>_<index>``); :func:`read_planning_scene` of it gives the same shapes back (up to rounding
    of the rotation through a quaternion).

    Refused (:class:`InputError`): ``shapes`` not a sequence (list, tuple, ...) of boxes, spheres and
    cylinders; ``name`` (the scene's name) not a string."""
    if isinstance(shapes, (str, bytes, Mapping, Shape)) or not isinstance(shapes, Iterable):
        raise InputError(f"shapes must be a sequence of shapes (boxes, spheres, cylinders), got "
                         f"{describe(shapes)}")
    if not isinstance(name, str):
        raise InputError(f"name must be the scene's name (a string), got {describe(name)}")
    objects = []
    for k, shape in enumerate(shapes):
        primitive, T = _primitive_yaml(shape, k)
        objects.append({"id": f"{shape.kind}_{k}", "primitives": [primitive],
                        "primitive_poses": [_pose_yaml(T)]})
    doc = {"name": name, "is_diff": False, "world": {"collision_objects": objects}}
    return yaml.safe_dump(doc, sort_keys=False, default_flow_style=None)


def _joint_state(doc: Mapping) -> dict[str, float]:
    state = (doc.get("start_state") or {}).get("joint_state") if isinstance(doc.get("start_state"),
                                                                             Mapping) else None
    if not isinstance(state, Mapping):
        raise InputError("motion request: start_state.joint_state must be a mapping with name[] and "
                         f"position[], got {state!r}")
    names, values = state.get("name"), state.get("position")
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
        raise InputError(f"motion request: start_state.joint_state.name must be a list of joint names, got "
                         f"{names!r}")
    values = _numbers(values, len(names), "motion request: start_state.joint_state.position")
    return dict(zip(names, values))


def _joint_goal(doc: Mapping) -> dict[str, float]:
    goals = doc.get("goal_constraints")
    if not isinstance(goals, list) or not goals or not isinstance(goals[0], Mapping):
        raise InputError(f"motion request: goal_constraints must be a non-empty list, got {goals!r}")
    if goals[0].get("position_constraints") or goals[0].get("orientation_constraints"):
        raise InputError("motion request: goal_constraints[0] holds a pose goal; only joint goals "
                         "(joint_constraints) are read")
    rows = goals[0].get("joint_constraints")
    if not isinstance(rows, list) or not rows:
        raise InputError(f"motion request: goal_constraints[0].joint_constraints must be a non-empty list, "
                         f"got {rows!r}")
    goal = {}
    for i, row in enumerate(rows):
        label = f"motion request: goal_constraints[0].joint_constraints[{i}]"
        if not isinstance(row, Mapping) or not isinstance(row.get("joint_name"), str):
            raise InputError(f"{label} must have a joint_name and a position, got {row!r}")
        goal[row["joint_name"]] = _numbers([row.get("position")], 1, f"{label}.position")[0]
    return goal


def read_motion_request(source: str | os.PathLike) -> MotionRequest:
    """The start and joint goal of a MoveIt ``MotionPlanRequest`` YAML (file path or text).

    ``start`` from ``start_state.joint_state``, ``goal`` from ``goal_constraints[0].joint_constraints``
    (a pose goal is refused); MoveIt's planner settings are ignored. :class:`InputError` when malformed.
    """
    doc, _ = _load_yaml(source, "motion request")
    group = doc.get("group_name") or ""
    return MotionRequest(_joint_state(doc), _joint_goal(doc), group if isinstance(group, str) else "")


def joint_vector(robot: Robot, values: Mapping[str, float], name: str = "q") -> np.ndarray:
    """The robot's configuration ``q`` (nq,) from ``{joint name: value}``.

    Names the robot does not have (gripper fingers fixed in the model, other groups) are ignored; a joint
    of the robot missing from ``values`` raises :class:`InputError` naming it and ``name``, as does a
    ``robot`` that is not a :class:`~kinserve.kinematics.Robot`.
    """
    robot = as_robot(robot)
    if not isinstance(values, Mapping):
        raise InputError(f"{name} must be a mapping joint name -> value, got {type(values).__name__}")
    missing = [j for j in robot.joint_names if j not in values]
    if missing:
        raise InputError(f"{name} lacks the value of joint(s) {missing} of robot {robot.name!r} (it names "
                         f"{sorted(values)})")
    return robot.check_q([values[j] for j in robot.joint_names], name)
