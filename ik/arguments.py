"""Checks of single ``ik.solve`` arguments: each returns the checked value or raises a project error
(:mod:`kinserve.ik.request` assembles them into one request)."""

from __future__ import annotations

import numbers
from typing import Any

import numpy as np

from kinserve.ik.options import DEFAULT_TOL_POS, DEFAULT_TOL_ROT
from kinserve.ik.options import check_method as check_method  # (one check of the method name, re-exported)
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


def check_backend(backend: Any, none_is_default: bool = True) -> str:
    """The QP backend's name: :data:`~kinserve.ik.qp.dense_qp.DEFAULT_BACKEND` for None (unless
    ``none_is_default`` is False), else ``backend`` (any case) if it names one of the installed QP solvers
    (:func:`~kinserve.ik.qp.backends.available_backends`); :class:`InputError` naming them otherwise
    (for ``ik.solve``, ``ik.solve_many``'s ``qp_backend`` and ``ik.step``)."""
    if (backend is None and none_is_default) or backend is DEFAULT_BACKEND:
        return DEFAULT_BACKEND
    if isinstance(backend, str):
        name = backend.lower()
        if name == DEFAULT_BACKEND or name == "osqp" or name in available_backends():
            return name
    raise InputError(f"backend must be one of the installed QP solvers {available_backends()}, "
                     f"got {describe(backend)}")


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
