"""Input checking shared by every public entry point.

The bound is per entry: every number must be finite with ``|x| <=`` :data:`MAX_ABS`.
The fast path costs well under a microsecond for a correct float64 vector: a
type/shape test and one norm, ``hypot(*q)`` for short vectors (0.4 µs for 7
entries against 0.65 µs for ``q·q``) and ``q·q`` for long ones (``|q| < MAX_ABS``
implies every entry is within the bound; NaN and inf fail it). Only when that
sufficient test fails is the exact per-entry test run, which either accepts the
vector or says exactly which entries are wrong - so the fast path never rejects
what the exact one accepts.
"""

from __future__ import annotations

import math
import numbers
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .errors import InputError, JointLimitError, NonFiniteError, RotationError, ShapeError
from .magnitude import MAX_ABS
from .se3 import matrix_from_quat, matrix_from_rpy
from .types import ArrayLike, PoseLike

_hypot = math.hypot
#: NumPy's float64 dtype: an array of native float64 holds this very object (another float64 dtype object,
#: with metadata say, takes the general path of :func:`as_vector`).
_FLOAT64 = np.dtype(np.float64)
#: Longest vector whose fast check is ``hypot(*q)`` (a Python list of that many floats); longer ones
#: use ``q·q``.
_HYPOT_MAX_N = 64

#: Tolerance on ||R^T R - I|| (max abs entry) and on |det R - 1| for poses.
ROTATION_TOL = 1e-6

#: Largest accepted ``| |q| - 1 |`` of a quaternion given as input; within it the quaternion is normalised
#: (rounded or printed values), beyond it the input is rejected (it is not a rotation, or not a quaternion).
QUATERNION_TOL = 1e-3

#: The pose forms every entry point accepts, quoted by the errors of :func:`as_pose`.
POSE_FORMS = ("a 4x4 homogeneous matrix (shape (4, 4)), a pinocchio.SE3, a pair (position [x, y, z], "
              "quaternion [qx, qy, qz, qw]) or a 7-vector [x, y, z, qx, qy, qz, qw]; "
              "kinserve.pose(xyz, quat=... | rpy=... | R=...) builds one")


def as_vector(value: ArrayLike, n: int, name: str = "q") -> np.ndarray:
    """Return ``value`` as a finite float64 vector of length ``n`` or raise.

    Accepts any sequence of real numbers. Raises :class:`ShapeError` for wrong
    length/shape, non-numeric or complex entries and :class:`NonFiniteError` for NaN,
    infinities or entries with magnitude above :data:`MAX_ABS`.
    """
    if type(value) is np.ndarray and value.dtype is _FLOAT64 and value.shape == (n,):
        if ((_hypot(*value.tolist()) < MAX_ABS) if n <= _HYPOT_MAX_N
                else (value.dot(value) < MAX_ABS * MAX_ABS)):
            return value  # NaN compares False, inf is not below the bound
        check_bounded(value, name)
        return value
    if type(value) is list and len(value) == n:
        try:  # a list of plain numbers (a parsed JSON array): same sufficient test, no NumPy call
            if _hypot(*value) < MAX_ABS and bool not in map(type, value):  # (hypot takes bools as 0 / 1)
                return np.array(value, dtype=np.float64)
        except (TypeError, OverflowError):
            pass
    try:
        if value is None or isinstance(value, (str, bytes, dict)):
            raise TypeError
        arr = _real_float64(value, name)
    except InputError:  # complex numbers, huge integers: named as such
        raise
    except (TypeError, ValueError):
        raise ShapeError(
            f"{name} must be a sequence of {n} numbers, got {describe(value)}"
        ) from None
    if arr.ndim == 2 and 1 in arr.shape and arr.size == n:
        arr = arr.reshape(n)
    if arr.shape != (n,):
        raise ShapeError(f"{name} must have shape ({n},), got shape {arr.shape}")
    if math.hypot(*arr.tolist()) < MAX_ABS:  # the norm below MAX_ABS (NaN never is): every entry is fine
        return arr
    check_bounded(arr, name)
    return arr


def _real_float64(value: object, name: str) -> np.ndarray:
    """``value`` as a float64 array: :class:`ShapeError` naming ``name`` for complex numbers (NumPy would drop
    their imaginary part with a mere warning), :class:`NonFiniteError` for an integer too large for a float;
    TypeError / ValueError when it is not numeric (text and bools included: NumPy would read ``"1"`` as 1.0
    and ``True`` as 1.0)."""
    arr = np.asarray(value)
    kind = arr.dtype.kind
    if kind == "c":
        raise ShapeError(f"{name} must hold real numbers, got complex numbers (dtype {arr.dtype})")
    if kind in "USb":
        raise TypeError(f"{name}: text or bools, not numbers")
    try:
        return arr.astype(np.float64, copy=False)
    except OverflowError:
        raise NonFiniteError(f"{name} must hold finite numbers with magnitude <= {MAX_ABS:g}; got an integer "
                             "too large for a float") from None


def _float_array(value: object, name: str = "value") -> np.ndarray | None:
    """``value`` as a float64 array, or None when it is not numeric (None, text, a mapping, ragged lists);
    :class:`ShapeError` naming ``name`` for complex numbers."""
    if value is None or isinstance(value, (str, bytes, dict)):
        return None
    try:
        return _real_float64(value, name)
    except InputError:
        raise
    except (TypeError, ValueError):
        return None


def as_numbers(value: ArrayLike, name: str) -> np.ndarray:
    """``value`` (a number or an array of any shape) as a float64 array of finite numbers with ``|x| <=``
    :data:`MAX_ABS`; :class:`ShapeError` for None, text, a mapping, bools or anything not numeric,
    :class:`NonFiniteError` for NaN, infinities or huge entries."""
    arr = None if isinstance(value, (bool, np.bool_)) else _float_array(value)
    if arr is None:
        raise ShapeError(f"{name} must be a number or an array of numbers, got {describe(value)}")
    check_bounded(arr, name)
    return arr


def as_matrix(value: ArrayLike, shape: tuple[int, ...], name: str) -> np.ndarray:
    """Return ``value`` as a finite float64 array of exactly ``shape`` (-1 = any)."""
    arr = _float_array(value, name)
    if arr is None:
        raise ShapeError(f"{name} must be a numeric array of shape {shape}, got {describe(value)}")
    if arr.ndim != len(shape) or any(s != -1 and s != a for s, a in zip(shape, arr.shape)):
        want = "(" + ", ".join("N" if s == -1 else str(s) for s in shape) + ")"
        raise ShapeError(f"{name} must have shape {want}, got shape {arr.shape}")
    check_bounded(arr, name)
    return arr


def as_rows(value: ArrayLike, n: int, name: str = "qs") -> np.ndarray:
    """Return ``value`` (stacked vectors, a float ``(N, n)`` array or a sequence of length-``n`` vectors) as
    a finite float64 ``(N, n)`` array or raise, as :func:`as_vector` does for one vector. Fast path for a
    float64 ``(N, n)`` array: ``v·v < MAX_ABS**2`` over all its entries (returned as it is)."""
    if type(value) is np.ndarray and value.dtype is _FLOAT64 and value.ndim == 2 and value.shape[1] == n:
        flat = value.reshape(-1)
        if flat.dot(flat) < MAX_ABS * MAX_ABS:
            return value
    return as_matrix(value, (-1, n), name)


def as_pose(value: PoseLike, name: str = "target") -> np.ndarray:
    """Return a homogeneous 4x4 float64 pose, checking the rotation block.

    Accepts (see :data:`POSE_FORMS`):

    * a 4x4 array-like: bottom row ``[0, 0, 0, 1]``, rotation block orthonormal
      with det +1 (within :data:`ROTATION_TOL`);
    * a ``pinocchio.SE3``;
    * a pair ``(position, quaternion)``: ``[x, y, z]`` (m) and ``[qx, qy, qz, qw]``
      (scalar last: Pinocchio's and ROS's order), a unit quaternion within
      :data:`QUATERNION_TOL` (normalised, see :func:`unit_quaternion`);
    * a 7-vector ``[x, y, z, qx, qy, qz, qw]``, read the same way.

    A well-formed float64 4x4 array is returned as it is (the fast path, tested
    first); the other forms give a new array. Raises :class:`ShapeError` naming
    the forms, :class:`RotationError`, :class:`NonFiniteError` or
    :class:`InputError` (a quaternion far from unit).
    """
    if hasattr(value, "homogeneous") and hasattr(value, "rotation"):
        value = value.homogeneous
    if (type(value) is np.ndarray and value.dtype == np.float64 and value.shape == (4, 4)
            and is_pose_fast(value)):
        return value
    T = _position_quaternion_pair(value, name)
    if T is not None:
        return T
    arr = _float_array(value, name)
    if arr is None:
        raise ShapeError(f"{name} must be a pose: {POSE_FORMS}; got {describe(value)}")
    if arr.shape == (7,):
        check_bounded(arr, name)
        quat = unit_quaternion(arr[3:], f"{name}[3:7] (a 7-vector pose is [x, y, z, qx, qy, qz, qw])")
        return _pose_matrix(arr[:3], quat)
    if arr.shape != (4, 4):
        raise ShapeError(f"{name} must be a pose: {POSE_FORMS}; got shape {arr.shape}")
    check_bounded(arr, name)
    if not np.allclose(arr[3], (0.0, 0.0, 0.0, 1.0), atol=1e-9):
        raise ShapeError(f"{name} must be homogeneous: bottom row [0, 0, 0, 1], got {arr[3].tolist()}")
    check_rotation(arr[:3, :3], name)
    return arr


def make_pose(xyz: ArrayLike, quat: ArrayLike | None = None, rpy: ArrayLike | None = None,
              R: ArrayLike | None = None) -> np.ndarray:
    """The homogeneous 4x4 pose ``[[R, xyz], [0, 1]]`` from a position and at most one orientation.

    Exported as ``kinserve.pose``. ``xyz`` is the position ``[x, y, z]`` (m).
    The orientation is one of

    * ``quat``: a unit quaternion ``[qx, qy, qz, qw]`` - scalar last, the order
      of Pinocchio's ``Quaternion.coeffs()`` and of ROS messages (not
      ``w, x, y, z``). Its norm must be within :data:`QUATERNION_TOL` of 1;
      it is then normalised (:func:`unit_quaternion`);
    * ``rpy``: ``[roll, pitch, yaw]`` (rad), ``R = Rz(yaw) Ry(pitch) Rx(roll)``
      (roll about x first, then pitch about y, then yaw about z, all about
      fixed axes; as URDF and :func:`kinserve.kinematics.se3.matrix_from_rpy`);
    * ``R``: a 3x3 rotation matrix (orthonormal with det +1 within :data:`ROTATION_TOL`);

    none of them is the identity rotation. Raises :class:`InputError` (two
    orientations, a quaternion far from unit), :class:`ShapeError`,
    :class:`NonFiniteError` or :class:`RotationError`, naming the argument.
    """
    given = [k for k, v in (("quat", quat), ("rpy", rpy), ("R", R)) if v is not None]
    if len(given) > 1:
        raise InputError(f"pose: give at most one orientation (quat, rpy or R), got {' and '.join(given)}")
    p = as_vector(xyz, 3, "xyz")
    if quat is not None:
        return _pose_matrix(p, unit_quaternion(quat, "quat"))
    T = np.eye(4)
    T[:3, 3] = p
    if rpy is not None:
        T[:3, :3] = matrix_from_rpy(*as_vector(rpy, 3, "rpy").tolist())
    elif R is not None:
        T[:3, :3] = as_matrix(R, (3, 3), "R")
        check_rotation(T[:3, :3], "R")
    return T


def unit_quaternion(quat: ArrayLike, name: str = "quat") -> np.ndarray:
    """``quat`` ``[qx, qy, qz, qw]`` (scalar last) divided by its norm, if that norm is within
    :data:`QUATERNION_TOL` of 1; else :class:`InputError` naming ``name`` and the order."""
    q = as_vector(quat, 4, name)
    norm = math.hypot(*q.tolist())
    if abs(norm - 1.0) > QUATERNION_TOL:
        raise InputError(f"{name} must be a unit quaternion [qx, qy, qz, qw] (scalar last, Pinocchio's and "
                         f"ROS's order), got {q.tolist()} with norm {norm:.6g} (accepted: within "
                         f"{QUATERNION_TOL:g} of 1, then normalised)")
    return q / norm


def _pose_matrix(p: np.ndarray, quat: np.ndarray) -> np.ndarray:
    """``[[R(quat), p], [0, 1]]`` of a checked position and unit quaternion ``[qx, qy, qz, qw]``."""
    T = np.eye(4)
    T[:3, :3] = matrix_from_quat(quat)
    T[:3, 3] = p
    return T


def _position_quaternion_pair(value: object, name: str) -> np.ndarray | None:
    """The pose of ``(position [x, y, z], quaternion [qx, qy, qz, qw])``; None when ``value`` is not a
    tuple or list of two items whose first has three entries (then it is no such pair)."""
    if type(value) not in (tuple, list) or len(value) != 2:
        return None
    position, quat = value
    try:
        if len(position) != 3:
            return None
        n_quat = len(quat)
    except TypeError:
        return None
    p = as_vector(position, 3, f"{name} position")
    if n_quat == 3:
        raise ShapeError(f"{name}: a (position, orientation) pair takes a quaternion [qx, qy, qz, qw]; got 3 "
                         "numbers - for roll, pitch, yaw use kinserve.pose(xyz, rpy=[roll, pitch, yaw])")
    return _pose_matrix(p, unit_quaternion(quat, f"{name} quaternion"))


def is_pose_fast(T: np.ndarray) -> bool:
    """True when the 4x4 array ``T`` passes every check of :func:`as_pose`, tested in plain Python floats.

    One ``tolist`` and scalar arithmetic (about 2 us, against 20+ us for the
    NumPy path): bottom row exactly ``[0, 0, 0, 1]``, finite entries,
    ``|p_i| <= MAX_ABS``, the six distinct entries of ``R^T R`` within
    :data:`ROTATION_TOL` of the identity's and ``|det R - 1| <= ROTATION_TOL``.
    False means "take the precise path" (which raises the exact error, or
    accepts a bottom row that is only within 1e-9 of ``[0, 0, 0, 1]``).
    """
    (a, b, c, x), (d, e, f, y), (g, h, i, z), bottom = T.tolist()
    tol = ROTATION_TOL
    return (
        bottom == [0.0, 0.0, 0.0, 1.0]
        and math.isfinite(a + b + c + d + e + f + g + h + i)
        and abs(x) <= MAX_ABS and abs(y) <= MAX_ABS and abs(z) <= MAX_ABS
        and abs(a * a + d * d + g * g - 1.0) <= tol and abs(b * b + e * e + h * h - 1.0) <= tol
        and abs(c * c + f * f + i * i - 1.0) <= tol and abs(a * b + d * e + g * h) <= tol
        and abs(a * c + d * f + g * i) <= tol and abs(b * c + e * f + h * i) <= tol
        and abs(a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g) - 1.0) <= tol
    )


def as_positive(value: object, name: str, maximum: float = MAX_ABS) -> float:
    """``value`` as a float if it is a finite real number in ``(0, maximum]`` (not a bool; ``maximum``
    defaults to :data:`MAX_ABS`); else the error naming ``name``."""
    if type(value) is float and 0.0 < value <= maximum:  # the common case without the abstract-class checks
        return value
    v = as_real(value, name)
    if v <= 0:
        raise InputError(f"{name} must be positive, got {value!r}")
    if v > maximum:
        raise InputError(f"{name} must be at most {maximum:g}, got {value!r}")
    return v


def as_nonnegative(value: object, name: str, maximum: float = MAX_ABS) -> float:
    """``value`` as a float if it is a finite real number in ``[0, maximum]`` (not a bool); else the error
    naming ``name``."""
    v = as_real(value, name)
    if v < 0:
        raise InputError(f"{name} must be zero or positive, got {value!r}")
    if v > maximum:
        raise InputError(f"{name} must be at most {maximum:g}, got {value!r}")
    return v


def as_real(value: object, name: str) -> float:
    """``value`` as a float if it is a real number (not a bool, not complex) that is finite with ``|x| <=``
    :data:`MAX_ABS`; else :class:`InputError` / :class:`NonFiniteError` naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InputError(f"{name} must be a number, got {describe(value)}")
    v = float(value)
    if not math.isfinite(v) or abs(v) > MAX_ABS:
        raise NonFiniteError(f"{name} must be finite with magnitude <= {MAX_ABS:g}, got {value!r}")
    return v


def as_count(value: object, name: str, minimum: int = 1, maximum: int = 10**7) -> int:
    """``value`` as an int if it is an integer (a Python or NumPy integer, not a bool, or a float with an
    integer value) in ``[minimum, maximum]``; else :class:`InputError` naming ``name`` and the range. The
    default ``maximum`` (10**7) bounds what a count may allocate or loop over."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InputError(f"{name} must be an integer, got {describe(value)}")
    if not isinstance(value, numbers.Integral):
        if not (math.isfinite(value) and float(value).is_integer()):
            raise InputError(f"{name} must be an integer, got {value!r}")
    n = int(value)
    if not minimum <= n <= maximum:
        raise InputError(f"{name} must be an integer from {minimum} to {maximum:,}, got {value!r}")
    return n


def check_rotation(R: np.ndarray, name: str = "rotation") -> None:
    """Raise :class:`RotationError` unless ``R`` is in SO(3) within tolerance."""
    err = np.abs(R.T @ R - np.eye(3)).max()
    det = float(np.linalg.det(R))
    if err > ROTATION_TOL or abs(det - 1.0) > ROTATION_TOL:
        raise RotationError(
            f"{name}: rotation block is not a rotation matrix "
            f"(max |R^T R - I| = {err:.2e}, det R = {det:.6f}; expected orthonormal with det +1, "
            f"tolerance {ROTATION_TOL:g})"
        )


def check_limits(q: np.ndarray, lower: np.ndarray, upper: np.ndarray, names: Sequence[str], name: str = "q",
                 tol: float = 1e-9) -> None:
    """Raise :class:`JointLimitError` naming every joint outside [lower, upper]."""
    bad = np.flatnonzero((q < lower - tol) | (q > upper + tol))
    if bad.size:
        parts = [f"{names[i]}={q[i]:.6g} not in [{lower[i]:.6g}, {upper[i]:.6g}]" for i in bad]
        raise JointLimitError(f"{name} outside the joint limits: " + "; ".join(parts))


def is_bounded(arr: np.ndarray) -> bool:
    """True when every entry is finite with ``|x| <= MAX_ABS`` (the one bound of every input number)."""
    return bool(np.all(np.abs(arr) <= MAX_ABS))  # False for NaN, inf and huge entries alike


def check_bounded(arr: np.ndarray, name: str) -> None:
    """Raise :class:`NonFiniteError` naming the entries of ``arr`` not finite or with ``|x| > MAX_ABS``."""
    if not is_bounded(arr):
        _raise_non_finite(arr, name)


def _raise_non_finite(arr: np.ndarray, name: str):
    bad = [i for i, v in enumerate(np.ravel(arr)) if not math.isfinite(v) or abs(v) > MAX_ABS]
    flat = np.ravel(arr).tolist()
    vals = ", ".join(f"[{i}]={flat[i]!r}" for i in bad[:5])
    raise NonFiniteError(
        f"{name} must hold finite numbers with magnitude <= {MAX_ABS:g}; bad entries: {vals}"
    )


def as_flag(value: object, name: str) -> bool:
    """``value`` if it is True or False (a NumPy bool as a bool); else :class:`InputError` naming ``name``. No
    truthiness: ``"no"``, 0, 1, None or NaN would each be read as a choice they do not state."""
    if value is True or value is False:
        return value
    if isinstance(value, np.bool_):
        return bool(value)
    raise InputError(f"{name} must be True or False, got {describe(value)}")


def as_text(value: object, name: str, optional: bool = False) -> str | None:
    """``value`` if it is a str (or None when ``optional``); else :class:`InputError` naming ``name``: names,
    labels and titles (a number or an array would be shown as its ``str`` or fail in the caller)."""
    if isinstance(value, str) or (optional and value is None):
        return value
    raise InputError(f"{name} must be a str{' or None' if optional else ''}, got {describe(value)}")


def as_path(value: object, name: str = "path") -> Path:
    """``value`` (a ``str`` or ``os.PathLike``) as a :class:`~pathlib.Path`; :class:`InputError` naming
    ``name`` for anything else (a number, None, bytes)."""
    if not isinstance(value, (str, os.PathLike)):
        raise InputError(f"{name} must be a file path (str or os.PathLike), got {describe(value)}")
    return Path(value)


def as_choice(value: object, name: str, choices: Sequence[object]) -> Any:
    """The entry of ``choices`` (strings, None, ...) that ``value`` is - equal and of the same type, so an
    array, a list or ``1`` for ``True`` is never compared by ``==`` or hashed - else :class:`InputError`
    naming ``name`` and the choices."""
    for choice in choices:
        if type(value) is type(choice) and value == choice:
            return choice
    raise InputError(f"{name} must be one of {', '.join(map(repr, choices))}, got {describe(value)}")


def describe(value: object) -> str:
    """``repr(value)``, cut to 60 characters: how a message shows what it was given."""
    text = repr(value)
    return text if len(text) < 60 else text[:57] + "..."
