"""``JointTrajectory``: sampled joint positions (and rates) over time, like ROS's message.

Mirrors ``trajectory_msgs/JointTrajectory``: joint names plus points, each
with ``positions``, ``velocities``, ``accelerations`` and
``time_from_start`` (seconds). Stored column-wise as arrays: ``times (N,)``,
``positions (N, nq)`` and optional ``velocities``/``accelerations (N, nq)``.

File formats (both round-trip exactly up to float text precision, ``repr``):

* JSON: ``{"joint_names": [...], "points": [{"positions": [...],
  "velocities": [...], "accelerations": [...], "time_from_start": t}, ...]}``
  (``velocities``/``accelerations`` omitted when absent);
* CSV: header ``time_from_start, position:<joint>..., velocity:<joint>...,
  acceleration:<joint>...`` then one row per point.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from kinserve.kinematics.errors import InputError, ShapeError
from kinserve.kinematics.validation import (
    MAX_ABS,
    as_choice,
    as_count,
    as_flag,
    as_matrix,
    as_path,
    as_positive,
    describe,
)

from .checks import as_times

#: Largest JSON ``indent`` accepted (spaces per level).
MAX_INDENT = 16


def finite_difference_velocities(positions: ArrayLike, times: ArrayLike, *,
                                 zero_ends: bool = False) -> np.ndarray:
    """Velocities ``(N, nq)`` from positions by second-order finite differences.

    Interior points use the non-uniform central difference of
    ``numpy.gradient``; the ends use one-sided second-order differences (or
    zero when ``zero_ends``, for a trajectory that starts and ends at rest).
    Exact for quadratics in ``t``.

    Refused (:class:`InputError` / :class:`ShapeError`): positions not a finite ``(N, nq)`` array, times
    not finite ``(N,)``, times not strictly increasing (a repeated time has no velocity).
    """
    Q = as_matrix(positions, (-1, -1), "positions")
    t = as_matrix(times, (Q.shape[0],), "times")
    zero_ends = as_flag(zero_ends, "zero_ends")
    if np.any(np.diff(t) <= 0):
        k = int(np.flatnonzero(np.diff(t) <= 0)[0])
        raise InputError(f"times must be strictly increasing, got times[{k}] = {float(t[k])!r} and "
                         f"times[{k + 1}] = {float(t[k + 1])!r}")
    if Q.shape[0] < 2:
        return np.zeros_like(Q)
    V = np.gradient(Q, t, axis=0, edge_order=2 if Q.shape[0] >= 3 else 1)
    if zero_ends:
        V[0] = 0.0
        V[-1] = 0.0
    return V


def joint_name_list(joint_names: object) -> list:
    """``joint_names`` (a list or tuple, or another iterable that is not text) as a list;
    :class:`InputError` for None, a string or anything not iterable."""
    if joint_names is None or isinstance(joint_names, (str, bytes, dict)) or not hasattr(joint_names,
                                                                                         "__iter__"):
        raise InputError(f"joint_names must be a sequence of joint names (strings), got {joint_names!r:.80}")
    return list(joint_names)


def _source_text(source: object, kinds: tuple[type, ...], what: str, is_text) -> str | bytes:
    """The text of ``source``: itself when it is of one of ``kinds`` and ``is_text(source)``, else the
    contents of the file it names (a ``str`` or ``os.PathLike``); :class:`InputError` for another type, a
    file that cannot be read or that is not UTF-8 text."""
    if not isinstance(source, (os.PathLike, *kinds)):
        raise InputError(f"source must be {what} text or a path to a file of it (str or os.PathLike), got "
                         f"{describe(source)}")
    if not isinstance(source, os.PathLike) and is_text(source):
        return source
    try:
        return Path(source).read_text(encoding="utf-8")
    except OSError as exc:
        raise InputError(f"cannot read trajectory file {str(source)!r}: {exc}") from None
    except UnicodeDecodeError as exc:
        raise InputError(f"trajectory file {str(source)!r} is not UTF-8 text (byte {exc.start})") from None


def _four_digits(value: float, rounding) -> float:
    """``value`` rounded to four significant digits by ``rounding`` (``math.floor`` or ``math.ceil``)."""
    scale = 10.0 ** (math.floor(math.log10(value)) - 3)
    return rounding(value / scale) * scale


def _dt_error(message: str) -> InputError:
    """The :class:`InputError` of a bad ``dt``, with ``argument`` set (a front end points at its dt field)."""
    exc = InputError(message)
    exc.argument = "dt"
    return exc


def check_last_time(dt: float, n_points: int) -> None:
    """:class:`InputError` naming ``dt`` when ``n_points`` points at a step of ``dt`` s end later than
    :data:`~kinserve.kinematics.validation.MAX_ABS` s (``(n_points - 1) * dt``, the last ``time_from_start``,
    would be refused as a time; the message gives the largest step that fits, rounded down to four digits)."""
    last = (n_points - 1) * dt
    if last <= MAX_ABS:
        return
    most = _four_digits(MAX_ABS / (n_points - 1), math.floor)
    raise _dt_error(f"dt = {dt:g} s over {n_points} points ends at {last:g} s, beyond the {MAX_ABS:g} s a "
                    f"time may take; dt must be at most {most:.4g} s")


def _check_velocity_bound(V: np.ndarray, Q: np.ndarray, dt: float, zero_ends: bool) -> None:
    """:class:`InputError` naming ``dt`` when the finite-difference velocities ``V`` of positions ``Q`` at a
    step of ``dt`` s are not within :data:`~kinserve.kinematics.validation.MAX_ABS`. The message gives the
    least step that keeps them within: the velocities at a step of 1 s over ``MAX_ABS`` (they scale as
    ``1 / dt``), rounded up to four digits."""
    if np.all(np.abs(V) <= MAX_ABS):
        return
    unit = finite_difference_velocities(Q, np.arange(Q.shape[0], dtype=float), zero_ends=zero_ends)
    least = _four_digits(float(np.max(np.abs(unit))) / MAX_ABS * (1 + 1e-9), math.ceil)
    raise _dt_error(f"dt = {dt:g} s is too short for these positions: their finite-difference velocities "
                    f"exceed {MAX_ABS:g} rad/s or m/s; dt must be at least {least:.4g} s")


@dataclass
class JointTrajectory:
    """Joint names, ``times (N,)`` strictly increasing from >= 0, ``positions (N, nq)``.

    ``velocities`` and ``accelerations`` are optional ``(N, nq)`` arrays.
    Construction validates shapes, finiteness and the time order; ``joint_names`` must be a sequence
    of distinct non-empty strings (None or a single string is refused).
    """

    joint_names: list[str]
    times: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray | None = None
    accelerations: np.ndarray | None = None

    def __post_init__(self):
        names = joint_name_list(self.joint_names)
        if not all(isinstance(n, str) and n for n in names):
            raise InputError(f"joint_names must be non-empty strings, got {names!r}")
        if len(set(names)) != len(names):
            raise InputError(f"joint_names must be unique, got {names!r}")
        self.joint_names = names
        nq = len(names)
        self.positions = as_matrix(self.positions, (-1, nq), "positions")
        N = self.positions.shape[0]
        if N == 0:
            raise ShapeError("a trajectory needs at least one point")
        self.times = as_matrix(self.times, (N,), "times")
        if self.times[0] < 0 or np.any(np.diff(self.times) <= 0):
            raise InputError("times (time_from_start) must start at >= 0 and be strictly increasing")
        if self.velocities is not None:
            self.velocities = as_matrix(self.velocities, (N, nq), "velocities")
        if self.accelerations is not None:
            self.accelerations = as_matrix(self.accelerations, (N, nq), "accelerations")

    # ----------------------------------------------------------- constructors
    @classmethod
    def from_positions(cls, joint_names: Sequence[str], positions: ArrayLike, dt: float, *,
                       velocities: str | None = "finite_difference",
                       zero_end_velocities: bool = False) -> JointTrajectory:
        """Points at ``time_from_start = i * dt``; velocities by finite differences unless
        ``velocities=None`` (anything but ``"finite_difference"`` or None is refused). ``dt`` must be a
        finite number in ``(0, 1e6]`` s, and the last time ``(N - 1) * dt`` at most 1e6 s
        (:func:`check_last_time`)."""
        dt = as_positive(dt, "dt")
        zero_end_velocities = as_flag(zero_end_velocities, "zero_end_velocities")
        velocities = as_choice(velocities, "velocities", ("finite_difference", None))
        joint_names = joint_name_list(joint_names)
        Q = as_matrix(positions, (-1, len(joint_names)), "positions")
        check_last_time(dt, Q.shape[0])
        t = dt * np.arange(Q.shape[0])
        V = None
        if velocities == "finite_difference":
            with np.errstate(over="ignore", divide="ignore", invalid="ignore"):  # judged just below
                V = finite_difference_velocities(Q, t, zero_ends=zero_end_velocities)
            _check_velocity_bound(V, Q, dt, zero_end_velocities)
        return cls(list(joint_names), t, Q, V)

    # ------------------------------------------------------------- accessors
    @property
    def n_points(self) -> int:
        """Number of points ``N`` (rows of ``positions``)."""
        return self.positions.shape[0]

    @property
    def nq(self) -> int:
        """Number of joints (columns of ``positions``)."""
        return len(self.joint_names)

    @property
    def duration(self) -> float:
        """``time_from_start`` of the last point (s)."""
        return float(self.times[-1])

    def points(self) -> list[dict]:
        """ROS-like list of points (plain Python lists)."""
        out = []
        for i in range(self.n_points):
            p = {"positions": self.positions[i].tolist()}
            if self.velocities is not None:
                p["velocities"] = self.velocities[i].tolist()
            if self.accelerations is not None:
                p["accelerations"] = self.accelerations[i].tolist()
            p["time_from_start"] = float(self.times[i])
            out.append(p)
        return out

    def position_at(self, t: ArrayLike) -> np.ndarray:
        """Positions at times ``t`` by linear interpolation between points (clamped at the ends).

        ``t`` (s): a number or an array; NaN, infinite, None or text times are refused
        (:class:`InputError`), never answered with NaN positions."""
        t = np.atleast_1d(as_times(t))
        return np.stack([np.interp(t, self.times, self.positions[:, j]) for j in range(self.nq)], axis=-1)

    # ------------------------------------------------------------------ JSON
    def to_dict(self) -> dict:
        """``{"joint_names": [...], "points": [...]}``: the JSON document as plain Python data."""
        return {"joint_names": list(self.joint_names), "points": self.points()}

    def to_json(self, path: str | os.PathLike | None = None, indent: int | None = None) -> str:
        """JSON text (see the module docstring); also written to ``path`` if given.

        ``path``: None, a ``str`` or an ``os.PathLike``; ``indent``: None (one line) or an integer from 0 to
        :data:`MAX_INDENT` (spaces per level). Anything else is refused (:class:`InputError`)."""
        indent = None if indent is None else as_count(indent, "indent", 0, MAX_INDENT)
        file = None if path is None else as_path(path)
        text = json.dumps(self.to_dict(), indent=indent)
        if file is not None:
            file.write_text(text)
        return text

    @classmethod
    def from_dict(cls, d: dict) -> "JointTrajectory":
        """The trajectory of a document as :meth:`to_dict` writes it (:class:`InputError` /
        :class:`ShapeError` if malformed: positions, velocities and accelerations are checked as the
        constructor checks them)."""
        if not isinstance(d, dict) or "joint_names" not in d or "points" not in d:
            raise InputError("a trajectory document needs 'joint_names' and 'points'")
        pts = d["points"]
        if not isinstance(pts, list) or not pts:
            raise InputError("'points' must be a non-empty list")
        try:
            t = [float(p["time_from_start"]) for p in pts]
            Q = [p["positions"] for p in pts]
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError("every point needs 'positions' and a numeric 'time_from_start' "
                             f"({exc!r})") from None
        V = [p["velocities"] for p in pts] if all("velocities" in p for p in pts) else None
        A = [p["accelerations"] for p in pts] if all("accelerations" in p for p in pts) else None
        return cls(d["joint_names"], np.array(t), Q, V, A)

    @classmethod
    def from_json(cls, source: str | os.PathLike) -> JointTrajectory:
        """From JSON text (``str`` or ``bytes``) or a path to a ``.json`` file (``str`` or ``os.PathLike``);
        :class:`InputError` for anything else."""
        text = _source_text(source, (str, bytes, bytearray), "JSON",
                            lambda s: not isinstance(s, str) or s.lstrip().startswith("{"))
        try:
            d = json.loads(text)
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise InputError(f"trajectory JSON is malformed: {exc}") from None
        return cls.from_dict(d)

    # ------------------------------------------------------------------- CSV
    def to_csv(self, path: str | os.PathLike | None = None) -> str:
        """CSV text (see the module docstring); also written to ``path`` (None, a ``str`` or an
        ``os.PathLike``; :class:`InputError` otherwise) if given."""
        file = None if path is None else as_path(path)
        header = ["time_from_start"] + [f"position:{n}" for n in self.joint_names]
        blocks = [self.times[:, None], self.positions]
        if self.velocities is not None:
            header += [f"velocity:{n}" for n in self.joint_names]
            blocks.append(self.velocities)
        if self.accelerations is not None:
            header += [f"acceleration:{n}" for n in self.joint_names]
            blocks.append(self.accelerations)
        data = np.hstack(blocks)
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(header)
        for row in data:
            w.writerow([repr(float(v)) for v in row])
        text = buf.getvalue()
        if file is not None:
            file.write_text(text)
        return text

    @classmethod
    def from_csv(cls, source: str | os.PathLike) -> JointTrajectory:
        """From CSV text (``str``) or a path to a ``.csv`` file (``str`` or ``os.PathLike``);
        :class:`InputError` for anything else."""
        text = _source_text(source, (str,), "CSV", lambda s: "\n" in s)
        rows = [r for r in csv.reader(io.StringIO(text)) if r]  # blank lines are no rows
        if len(rows) < 2:
            raise InputError("trajectory CSV needs a header row and at least one data row")
        header = [h.strip() for h in rows[0]]
        if header[0] != "time_from_start":
            raise InputError(f"trajectory CSV must start with a 'time_from_start' column, got {header[0]!r}")
        widths = sorted({len(r) for r in rows[1:]} - {len(header)})
        if widths:
            raise ShapeError(f"trajectory CSV rows have {widths[0]} values for {len(header)} columns")
        try:
            data = np.array([[float(v) for v in r] for r in rows[1:]], dtype=float)
        except ValueError as exc:
            raise InputError(f"trajectory CSV holds a non-numeric value: {exc}") from None
        cols = {"position": [], "velocity": [], "acceleration": []}
        for k, h in enumerate(header[1:], start=1):
            kind, _, name = h.partition(":")
            if kind not in cols or not name:
                raise InputError(f"unknown trajectory CSV column {h!r}; "
                                 "expected position:/velocity:/acceleration:<joint>")
            cols[kind].append((name, k))
        names = [n for n, _ in cols["position"]]
        for kind in ("velocity", "acceleration"):
            if cols[kind] and [n for n, _ in cols[kind]] != names:
                raise InputError(f"{kind} columns must name the same joints as the position columns, "
                                 "in order")

        def block(kind):
            return data[:, [k for _, k in cols[kind]]] if cols[kind] else None

        return cls(names, data[:, 0], block("position"), block("velocity"), block("acceleration"))

    # ------------------------------------------------------------- save/load
    def save(self, path: str | os.PathLike) -> Path:
        """Write ``.json`` or ``.csv`` by the file's extension (``path``: a ``str`` or ``os.PathLike``)."""
        path = as_path(path)
        if path.suffix.lower() == ".json":
            self.to_json(path, indent=1)
        elif path.suffix.lower() == ".csv":
            self.to_csv(path)
        else:
            raise InputError(f"trajectory file must end in .json or .csv, got {path.name!r}")
        return path

    @classmethod
    def load(cls, path: str | os.PathLike) -> JointTrajectory:
        """Read a ``.json`` or ``.csv`` file written by :meth:`save` (or by hand); ``path``: a ``str`` or
        ``os.PathLike``."""
        path = as_path(path)
        if path.suffix.lower() == ".json":
            return cls.from_json(path)
        if path.suffix.lower() == ".csv":
            return cls.from_csv(path)
        raise InputError(f"trajectory file must end in .json or .csv, got {path.name!r}")
