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
from kinserve.kinematics.robot import Robot
from kinserve.kinematics.validation import as_positive


def check_robot(robot: Any) -> None:
    """InputError unless ``robot`` is a :class:`kinserve.kinematics.Robot` (or quacks like one)."""
    if type(robot) is Robot:
        return
    if not (hasattr(robot, "model") and hasattr(robot, "frame_id") and hasattr(robot, "nq")):
        raise InputError(f"robot must be a kinserve.kinematics.Robot (e.g. robots.load('panda')), "
                         f"got {type(robot).__name__}")


def check_method(method: Any) -> str:
    """``method`` if it names an IK method (:data:`kinserve.ik.options.METHODS`)."""
    if method not in METHODS:
        raise InputError(f"method must be one of {METHODS}, got {method!r}")
    return method


def check_seed(seed: Any) -> int | None:
    """A non-negative integer seed, or None. An array is a start configuration: that goes in ``q0``."""
    if seed is None:
        return None
    if type(seed) is int and seed >= 0:
        return seed
    if isinstance(seed, (np.ndarray, list, tuple)):
        raise InputError("seed is the random seed (a non-negative integer); pass the start configuration "
                         f"as q0=, got seed={seed!r}")
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise InputError(f"seed must be a non-negative integer or None, got {seed!r}")
    return int(seed)


def check_backend(backend: Any) -> str:
    """The QP backend's name (default :data:`~kinserve.ik.qp.dense_qp.DEFAULT_BACKEND`)."""
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
    """Positive position (m) and orientation (rad) tolerances (the defaults pass on an equality test)."""
    if tol_pos != DEFAULT_TOL_POS:
        tol_pos = as_positive(tol_pos, "tol_pos")
    if tol_rot != DEFAULT_TOL_ROT:
        tol_rot = as_positive(tol_rot, "tol_rot")
    return tol_pos, tol_rot


def check_max_time(max_time: Any) -> float | None:
    """A positive time budget in seconds, or None (the method's default)."""
    return None if max_time is None else as_positive(max_time, "max_time")
