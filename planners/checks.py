"""Argument checks shared by the planners: times to evaluate at, sample counts, and the number of steps a
step size makes over a path (so that no call allocates or loops without limit).

The bounds: :data:`MAX_SAMPLES` points of a sampled path or trajectory (a pose is 128 bytes, a joint
vector ``8 nq`` bytes: 10**6 of them stay within a few hundred MB). Everything else is checked by
:mod:`kinserve.kinematics.validation`.
"""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np

from kinserve.kinematics.errors import InputError
from kinserve.kinematics.validation import as_count, as_numbers, describe

#: Most points a planner samples on one call (poses of a path, points of a trajectory, times of a scaling).
MAX_SAMPLES = 10**6


def as_times(t: Any, name: str = "t") -> np.ndarray:
    """Times ``t`` (s; a number or an array of any shape) as a float64 array of finite numbers (see
    :func:`as_numbers`): a NaN or missing time is refused, never evaluated to NaN."""
    return as_numbers(t, name)


def sample_count(n: Any, name: str = "n", minimum: int = 2) -> int:
    """``n`` as an int in ``[minimum, MAX_SAMPLES]`` (:class:`InputError` naming ``name`` otherwise)."""
    return as_count(n, name, minimum, MAX_SAMPLES)


def step_count(length: float, step: float, name: str, unit: str, what: str = "path") -> int:
    """``ceil(length / step)`` (at least 1), the steps of size ``step`` over ``length``; :class:`InputError`
    naming ``name`` when that exceeds :data:`MAX_SAMPLES` (the message gives the smallest step accepted)."""
    ratio = length / step
    if ratio > MAX_SAMPLES:
        raise InputError(f"{name} must be at least {length / MAX_SAMPLES:.3g} {unit} ({MAX_SAMPLES:,} steps "
                         f"at most over this {length:.3g} {unit} {what}), got {step!r}")
    return max(1, math.ceil(ratio - 1e-9))


def as_index(value: Any, n: int, name: str) -> int:
    """``value`` as an index in ``[0, n - 1]`` (an integer, not a bool); :class:`InputError` otherwise."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        if not (isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)
                and float(value).is_integer()):
            raise InputError(f"{name} must be an index (an integer in [0, {n - 1}]), got {describe(value)}")
    i = int(value)
    if not 0 <= i < n:
        raise InputError(f"{name} must be an index in [0, {n - 1}], got {value!r}")
    return i
