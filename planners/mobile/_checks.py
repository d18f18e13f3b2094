"""Argument checks shared by the public entry points of :mod:`planners.mobile`.

Thin wrappers over :mod:`kinserve.kinematics.validation`: planar points and
point lists, map objects, and the sample-count bound that keeps a step size
from allocating or looping without limit.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import numpy as np

from kinserve.kinematics.errors import InputError, ShapeError
from kinserve.kinematics.validation import as_count, as_positive, as_rows, as_vector, check_bounded, describe

#: Most samples a step size may produce along a path (or a time step along a trajectory).
MAX_SAMPLES = 10**7


def as_point(value: object, name: str) -> np.ndarray:
    """``value`` as a finite, bounded ``(x, y)`` point (:class:`ShapeError` / :class:`NonFiniteError`)."""
    return as_vector(value, 2, name)


def as_points(value: object, name: str, min_rows: int = 1, single: bool = False) -> np.ndarray:
    """``value`` as a finite, bounded ``(N, 2)`` float array with ``N >= min_rows``.

    With ``single`` one ``(x, y)`` point is accepted too (as a ``(1, 2)`` array).
    """
    if single:
        arr = np.asarray(value) if isinstance(value, (list, tuple, np.ndarray)) else None
        if arr is not None and arr.shape == (2,):
            return as_point(value, name)[None]
    P = as_rows(value, 2, name)
    if len(P) < min_rows:
        raise ShapeError(f"{name} must hold at least {min_rows} (x, y) point(s) "
                         f"(shape (N >= {min_rows}, 2)), got shape {P.shape}")
    return P


def check_samples(count: float, name: str, value: float, what: str, maximum: int = MAX_SAMPLES) -> None:
    """:class:`InputError` when a step ``value`` (argument ``name``) would give ``count > maximum``
    samples over ``what`` (e.g. "this 12.5 m path"); the message gives the smallest accepted step."""
    if not count <= maximum:  # also refuses NaN
        smallest = value * count / maximum
        raise InputError(f"{name} must be at least {smallest:.3g} ({maximum:,} samples at most over {what}), "
                         f"got {value!r}")


def as_indices(values: Iterable[object] | None, name: str, size: int) -> list[int]:
    """``values`` as a list of indices in ``[0, size)`` (each an integer; :class:`InputError` naming it)."""
    if values is None or isinstance(values, (str, bytes, dict)) or not isinstance(values, Iterable):
        raise InputError(f"{name} must be a sequence of indices, got {describe(values)}")
    out = []
    for k, v in enumerate(values):
        if size == 0:
            raise InputError(f"{name}[{k}] = {v!r}: there are no points to index")
        out.append(as_count(v, f"{name}[{k}]", minimum=0, maximum=size - 1))
    return out


def polyline_samples(P: np.ndarray, step: float) -> float:
    """How many samples a step ``step`` gives along the polyline ``P`` (one per segment at least)."""
    if len(P) < 2:
        return 1.0
    lengths = np.linalg.norm(np.diff(P, axis=0), axis=1)
    return float(np.sum(np.maximum(1.0, np.ceil(lengths / step)))) + 1.0


def describe_length(P: np.ndarray) -> str:
    """The phrase ``this <length> long path`` for messages."""
    L = float(np.sum(np.linalg.norm(np.diff(P, axis=0), axis=1))) if len(P) > 1 else 0.0
    return f"this {L:.6g} long path"


#: Most output times of a drive simulation (``t_eval``).
MAX_EVAL_TIMES = 10**6
#: Most wheel-speed evaluations of one drive simulation (a bound on its run time).
MAX_RHS_EVALUATIONS = 200_000


def simulation_arguments(wheel_speeds: object, n_wheels: int, pose0: object, t_span: object,
                         t_eval: object, rtol: object, atol: object
                         ) -> tuple[Callable[[float], np.ndarray], np.ndarray, tuple[float, float],
                                    np.ndarray | None, float, float]:
    """Checked arguments of a base's ``simulate``: ``(f, pose0, t_span, t_eval, rtol, atol)``.

    ``f(t)`` returns the wheel speeds as a finite vector of ``n_wheels`` numbers
    (a callable's output is checked at every call). Refused: wheel speeds,
    ``pose0`` (3 numbers), ``t_span`` (2 distinct times) not finite with
    ``|x| <= 1e6``; ``t_eval`` not a 1-D array of at most 10**6 times inside
    ``t_span``; ``rtol`` not in ``(0, 1]``; ``atol`` not in ``(0, 1e6]``.
    ``f`` raises :class:`InputError` once called more than
    :data:`MAX_RHS_EVALUATIONS` times (a span too long for the motion and
    tolerance: the integration would not end in reasonable time).
    """
    calls = [0]
    limit = MAX_RHS_EVALUATIONS
    if callable(wheel_speeds):
        user = wheel_speeds

        def speeds(t: float) -> np.ndarray:
            return as_vector(user(t), n_wheels, f"wheel_speeds({t:g})")
    else:
        w = as_vector(wheel_speeds, n_wheels, "wheel_speeds")

        def speeds(t: float) -> np.ndarray:
            return w

    def f(t: float) -> np.ndarray:
        calls[0] += 1
        if calls[0] > limit:
            raise InputError(f"the simulation over t_span {list(span.tolist())} needs more than {limit:,} "
                             f"evaluations (reached t = {t:.6g}): shorten t_span, slow the wheels or raise "
                             "rtol / atol")
        return speeds(t)
    p0 = as_vector(pose0, 3, "pose0")
    span = as_vector(t_span, 2, "t_span")
    if span[0] == span[1]:
        raise InputError(f"t_span must be (t0, t1) with t0 != t1, got {span.tolist()}")
    if t_eval is not None:
        try:
            if isinstance(t_eval, (str, bytes, dict)):
                raise TypeError
            te = np.asarray(t_eval, dtype=float)
        except (TypeError, ValueError):
            raise ShapeError(f"t_eval must be a 1-D array of times, got {describe(t_eval)}") from None
        if te.ndim != 1:
            raise ShapeError(f"t_eval must be a 1-D array of times, got shape {te.shape}")
        check_bounded(te, "t_eval")
        if len(te) > MAX_EVAL_TIMES:
            raise InputError(f"t_eval: at most {MAX_EVAL_TIMES:,} times, got {len(te):,}")
        lo, hi = min(span), max(span)
        if np.any((te < lo) | (te > hi)):
            raise InputError(f"t_eval must lie within t_span {span.tolist()}")
        t_eval = te
    rtol = as_positive(rtol, "rtol", maximum=1.0)
    atol = as_positive(atol, "atol")
    return f, p0, (float(span[0]), float(span[1])), t_eval, rtol, atol
