"""Checkpoint files for the S3 tour: the current joint vector plus checkpoints, as JSON or CSV.

The seed documents read the checkpoints from a ROS bag; kinserve reads a plain
file. Each checkpoint is either a **joint vector** (its pose is the robot's
forward kinematics) or a **Cartesian pose**. The current configuration is
always a joint vector (the tour and the inverse kinematics start from it).

JSON::

    {"robot": "youbot",                        # optional, informative
     "units": "rad",                           # or "deg": joint values (and roll/pitch/yaw) in degrees
     "current": {"q": [q1, ..., qn]},          # or just [q1, ..., qn]
     "checkpoints": [
        {"name": "A", "q": [q1, ..., qn]},
        {"name": "B", "pose": {"position": [x, y, z], "rpy": [roll, pitch, yaw]}},
        {"name": "C", "pose": [[...4x4...]]}
     ]}

CSV (one row per point, the first row is the current configuration; a row
fills either the ``q*`` columns or the pose columns, the others stay empty)::

    name,q1,q2,q3,q4,q5,x,y,z,roll,pitch,yaw
    current,0.0,0.3,-0.6,-0.5,0.0,,,,,,
    A,0.8,0.6,-1.0,-0.9,0.2,,,,,,
    E,,,,,,0.21,-0.05,0.33,0.1,1.2,-0.2

Positions in metres; ``roll, pitch, yaw`` are the rotation ``R = Rz(yaw)
Ry(pitch) Rx(roll)`` (world axes). Any error names the file, the entry and
what was expected (:class:`kinematics.errors.InputError`).
"""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from kinserve.kinematics import se3
from kinserve.kinematics.errors import InputError, ShapeError
from kinserve.kinematics.validation import as_pose, as_vector

POSE_COLUMNS = ("x", "y", "z", "roll", "pitch", "yaw")


@dataclass
class Checkpoint:
    """One checkpoint: a joint vector ``q`` (rad / m) or a Cartesian ``pose`` (4x4); exactly one is set."""

    name: str
    q: np.ndarray | None = None
    pose: np.ndarray | None = None

    @property
    def kind(self) -> str:
        """``"q"`` for a joint configuration, ``"pose"`` for a Cartesian pose."""
        return "q" if self.q is not None else "pose"


@dataclass
class CheckpointFile:
    """The parsed file: the current configuration and the checkpoints, in file order."""

    current: np.ndarray
    checkpoints: list[Checkpoint]
    source: str = ""
    robot: str | None = None
    meta: dict = field(default_factory=dict)

    @property
    def names(self) -> list[str]:
        """The checkpoint names, in file order."""
        return [c.name for c in self.checkpoints]


def _angle_scale(units) -> float:
    if units in (None, "rad", "radian", "radians"):
        return 1.0
    if units in ("deg", "degree", "degrees"):
        return math.pi / 180.0
    raise InputError(f"units must be 'rad' or 'deg', got {units!r}")


def _pose_from_json(value, where: str, scale: float) -> np.ndarray:
    if isinstance(value, dict):
        if "position" not in value:
            raise InputError(f"{where}: a pose needs 'position' [x, y, z] (m) and 'rpy' [roll, pitch, "
                             "yaw] or 'matrix'")
        if "matrix" in value:
            return as_pose(value["matrix"], where)
        p = as_vector(value["position"], 3, f"{where} position")
        rpy = as_vector(value.get("rpy", (0.0, 0.0, 0.0)), 3, f"{where} rpy") * scale
        return se3.pose(se3.matrix_from_rpy(*rpy), p)
    return as_pose(value, where)


def _joint_vector(value, nq, where: str, scale: float) -> np.ndarray:
    if nq is None:
        try:
            nq = len(value)
        except TypeError:
            raise ShapeError(f"{where} must be a list of joint values, got {value!r}") from None
    return as_vector(value, nq, where) * scale


def parse_json(text: str, nq: int | None = None, source: str = "<json>") -> CheckpointFile:
    """Parse the JSON form (module docstring); ``nq`` checks the joint-vector length."""
    try:
        d = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"{source}: malformed JSON ({exc})") from None
    if not isinstance(d, dict) or "current" not in d or "checkpoints" not in d:
        raise InputError(f"{source}: expected an object with 'current' and 'checkpoints'")
    scale = _angle_scale(d.get("units"))
    cur = d["current"]
    cur = cur.get("q") if isinstance(cur, dict) else cur
    current = _joint_vector(cur, nq, f"{source}: current q", scale)
    nq = current.size
    items = d["checkpoints"]
    if not isinstance(items, list) or not items:
        raise InputError(f"{source}: 'checkpoints' must be a non-empty list")
    out = []
    for k, item in enumerate(items):
        where = f"{source}: checkpoints[{k}]"
        if not isinstance(item, dict):
            item = {"q": item}
        name = str(item.get("name", chr(ord("A") + k) if k < 26 else f"P{k + 1}"))
        has_q, has_pose = "q" in item, "pose" in item
        if has_q == has_pose:
            raise InputError(f"{where} ({name}) needs exactly one of 'q' (joint vector) or 'pose'")
        if has_q:
            out.append(Checkpoint(name, q=_joint_vector(item["q"], nq, f"{where} q", scale)))
        else:
            out.append(Checkpoint(name, pose=_pose_from_json(item["pose"], f"{where} pose", scale)))
    meta = {k: v for k, v in d.items() if k not in ("current", "checkpoints")}
    return CheckpointFile(current, out, source, d.get("robot"), meta)


def parse_csv(text: str, nq: int | None = None, source: str = "<csv>", units: str = "rad") -> CheckpointFile:
    """Parse the CSV form (module docstring); the first data row is the current configuration."""
    scale = _angle_scale(units)
    rows = [r for r in csv.reader(io.StringIO(text)) if r and any(c.strip() for c in r)]
    if len(rows) < 3:
        raise InputError(f"{source}: needs a header, the current configuration and at least one checkpoint")
    header = [h.strip() for h in rows[0]]
    if header[0] != "name":
        raise InputError(f"{source}: the first column must be 'name', got {header[0]!r}")
    qcols = [i for i, h in enumerate(header) if h.startswith("q") and h[1:].isdigit()]
    pcols = [header.index(c) if c in header else -1 for c in POSE_COLUMNS]
    if nq is not None and len(qcols) != nq:
        raise ShapeError(f"{source}: expected {nq} joint columns q1..q{nq}, got {len(qcols)}")

    def cells(row, idx):
        return [row[i].strip() if 0 <= i < len(row) else "" for i in idx]

    def numbers(vals, where):
        try:
            return [float(v) for v in vals]
        except ValueError:
            raise InputError(f"{where}: non-numeric value in {vals}") from None

    points = []
    for n, row in enumerate(rows[1:], start=2):
        name = row[0].strip()
        where = f"{source}: line {n} ({name})"
        qv, pv = cells(row, qcols), cells(row, pcols)
        has_q, has_pose = all(qv) and qv, all(pv) and -1 not in pcols
        if any(qv) and not all(qv) or any(pv) and not all(pv):
            raise InputError(f"{where}: fill all of q1..q{len(qcols)} or all of {', '.join(POSE_COLUMNS)}")
        if bool(has_q) == bool(has_pose):
            raise InputError(f"{where}: fill either the joint columns or the pose columns (exactly one)")
        if has_q:
            points.append(Checkpoint(name, q=as_vector(np.array(numbers(qv, where)) * scale, len(qcols),
                                                       f"{where} q")))
        else:
            x, y, z, r, p, yw = numbers(pv, where)
            R = se3.matrix_from_rpy(r * scale, p * scale, yw * scale)
            points.append(Checkpoint(name, pose=se3.pose(R, (x, y, z))))
    if points[0].q is None:
        raise InputError(f"{source}: the first row (the current configuration) must be a joint vector")
    return CheckpointFile(points[0].q, points[1:], source)


def load_checkpoints(path, nq: int | None = None, units: str = "rad") -> CheckpointFile:
    """Read a ``.json`` or ``.csv`` checkpoint file (``units`` applies to CSV; JSON says its own)."""
    path = Path(path)
    kind = path.suffix.lower()
    if kind not in (".json", ".csv"):
        raise InputError(f"checkpoint file must end in .json or .csv, got {path.name!r}")
    try:
        text = path.read_text()
    except OSError as exc:
        raise InputError(f"cannot read checkpoint file {str(path)!r}: {exc}") from None
    if kind == ".json":
        return parse_json(text, nq, str(path))
    return parse_csv(text, nq, str(path), units)


def write_csv(cf: CheckpointFile, path, nq: int) -> Path:
    """Write ``cf`` in the CSV form (joint values and poses as given; poses as x y z roll pitch yaw)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["name", *[f"q{i + 1}" for i in range(nq)], *POSE_COLUMNS])
    blank_q, blank_p = [""] * nq, [""] * 6
    w.writerow(["current", *[repr(float(v)) for v in cf.current], *blank_p])
    for c in cf.checkpoints:
        if c.q is not None:
            w.writerow([c.name, *[repr(float(v)) for v in c.q], *blank_p])
        else:
            rpy = se3.rpy_from_matrix(c.pose[:3, :3])
            w.writerow([c.name, *blank_q, *[repr(float(v)) for v in (*c.pose[:3, 3], *rpy)]])
    Path(path).write_text(buf.getvalue())
    return Path(path)
