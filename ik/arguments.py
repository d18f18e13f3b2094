"""Checks of single ``ik.solve`` arguments: each returns the checked value or raises a project error
(:mod:`kinserve.ik.request` assembles them into one request)."""

from __future__ import annotations

import numbers
from typing import Any

import numpy as np

from kinserve.ik.options import DEFAULT_TOL_POS, DEFAULT_TOL_ROT, METHODS
from kinserve.ik.qp.backends import available_backends
from kinserve.ik.qp.dense_qp import DEFAULT_BACKEND
from kinserve.kinematics.errors import InputError, KinserveError
from kinserve.kinematics.robot import Robot, as_robot
from kinserve.kinematics.validation import MAX_ABS, as_positive, describe

#: Largest accepted ``max_time`` (s): the bound on every number of an input (:data:`MAX_ABS`).
MAX_TIME = MAX_ABS
#: Seeds are integers in ``[0, MAX_SEED]`` (the range of NumPy's unsigned 64-bit seeds).
MAX_SEED = 2**64 - 1


def check_robot(robot: Any) -> None:
    """InputError unless ``robot`` is a :class:`kinserve.kinematics.Robot` (:func:`~.robot.as_robot`)."""
    if type(robot) is not Robot:
        as_robot(robot)


def check_method(method: Any) -> str:
    """``method`` if it names an IK method (:data:`kinserve.ik.options.METHODS`)."""
    if not isinstance(method, str) or method not in METHODS:
        raise InputError(f"method must be one of {METHODS}, got {method!r}")
    return method


def check_seed(seed: Any) -> int | None:
    """A non-negative integer seed at most :data:`MAX_SEED`, or None. An array is a start configuration:
    that goes in ``q0``. Refused (:class:`InputError`): anything else (a bool, a float, a negative or
    larger integer)."""
    if seed is None:
        return None
    if type(seed) is int and 0 <= seed <= MAX_SEED:
        return seed
    if isinstance(seed, (np.ndarray, list, tuple)):
        raise InputError("seed is the random seed (a non-negative integer); pass the start configuration "
                         f"as q0=, got seed={seed!r}")
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or not 0 <= seed <= MAX_SEED:
        raise InputError(f"seed must be a non-negative integer (at most 2**64 - 1) or None, got "
                         f"{describe(seed)}")
    return int(seed)


def check_backend(backend: Any) -> str:
    """The QP backend's name (default :data:`~kinserve.ik.qp.dense_qp.DEFAULT_BACKEND`)."""
    if backend is not None and not isinstance(backend, str):
        raise InputError(f"backend must be one of the installed QP solvers {available_backends()}, "
                         f"got {backend!r}")
    if backend is None or backend == DEFAULT_BACKEND:
        return DEFAULT_BACKEND
    if backend == "osqp":
        return backend
    if not isinstance(backend, str) or backend.lower() not in available_backends():
        raise InputError(f"backend must be one of the installed QP solvers {available_backends()}, "
                         f"got {backend!r}")
    return backend.lower()


def tag(exc: KinserveError, name: str) -> None:
    """Name the argument a :class:`KinserveError` concerns (``exc.argument``) unless the raiser did."""
    if exc.argument is None:
        exc.argument = name


def check_q0(robot: Robot, q0: Any) -> np.ndarray | None:
    """``q0`` checked by ``robot.check_q`` (errors name the argument ``q0``), or None."""
    if q0 is None:
        return None
    try:
        return robot.check_q(q0, "q0")
    except KinserveError as exc:
        tag(exc, "q0")
        raise


def check_tolerances(tol_pos: Any, tol_rot: Any) -> tuple[float, float]:
    """Positive position (m) and orientation (rad) tolerances (the defaults pass on an identity test).

    Refused: anything but a finite real number in ``(0, 1e6]`` (:func:`as_positive`): NaN, infinities,
    absurd values such as ``1e300``, arrays, text."""
    if type(tol_pos) is not float or tol_pos != DEFAULT_TOL_POS:
        tol_pos = as_positive(tol_pos, "tol_pos")
    if type(tol_rot) is not float or tol_rot != DEFAULT_TOL_ROT:
        tol_rot = as_positive(tol_rot, "tol_rot")
    return tol_pos, tol_rot


def check_max_time(max_time: Any) -> float | None:
    """A positive time budget in seconds, at most :data:`MAX_TIME` (1e6 s), or None (the method's default).
    Refused: NaN, infinities, zero or negative values, ``1e300`` and the like, non-numbers."""
    return None if max_time is None else as_positive(max_time, "max_time", MAX_TIME)
