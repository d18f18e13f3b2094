"""Method-specific options of ``ik.solve`` (``**options``): accepted names per method and their values.

``ik.solve(robot, T, method=m, **options)`` forwards ``options`` to the solver
of method ``m``. :func:`check_options` validates them *without solving*
(:func:`ik.solve_many` checks them once in the calling process, before any
worker starts):

======================  ==========================================  ==============================
option                  meaning                                     accepted values
======================  ==========================================  ==============================
``max_iter``            iteration cap of one start                  integer in [1, 10**5]
``iteration_budget``    total iterations over all starts (a start   integer in [1, 10**6]
                        counts at least one); the clock is not
                        read without ``max_time``
``damping``             damping ``lambda_0`` (LM / QP / DLS)        finite number in (0, 1e6]
``max_starts``          cap on the number of starts                 integer in [1, 10**7] or None
``prefer_q0``           start from ``q0`` first                     bool
``seed_table``          use the table of starts (:mod:`ik.starts.seed_table`)   bool
``max_step``            bound on each joint step (QP, rad or m)     finite number in (0, 1e6]
``shortcut``            skip the QP when the free step is feasible  bool
``lazy``                add obstacle rows only when a step needs    bool
``gain``                step gain of the classical methods          finite number in (0, 1e6]
``samples``             samples of a closed-form family             integer in [2, 10**4]
``choose``              chooser criteria (:mod:`ik.closed_form.chooser`)        name or sequence of names
======================  ==========================================  ==============================

The upper bounds (:data:`MAX_ITER_CAP`, :data:`MAX_ITERATION_BUDGET`, :data:`MAX_STARTS_CAP`,
:data:`MAX_SAMPLES`) keep a call from allocating or looping without limit: ``max_iter`` sizes the
history of a start, ``iteration_budget`` is the only bound of a solve without ``max_time``, ``samples``
the number of branches built and verified. Larger values are refused, not clipped.

Accepted names per method are :data:`OPTIONS`; ``"auto"`` accepts the union
of the methods it may pick (``qp``, ``lm``, ``analytic``).
"""

from __future__ import annotations

import numbers
from collections.abc import Mapping
from typing import Any

from kinserve.ik.closed_form.chooser import CRITERIA
from kinserve.kinematics.errors import InputError
from kinserve.kinematics.validation import as_flag, as_positive, describe

#: Every IK method ``ik.solve(method=...)`` names; the last four are the classical iterations.
CLASSICAL_METHODS = ("jacobian_inverse", "jacobian_transpose", "pseudo_inverse", "dls")
METHODS = ("auto", "qp", "lm", "analytic") + CLASSICAL_METHODS
#: Methods that cannot honour centring / obstacle constraints.
NO_CENTRING_METHODS = frozenset(("lm", "analytic", "jacobian_inverse", "jacobian_transpose"))
NO_OBSTACLE_METHODS = frozenset(("lm", "analytic") + CLASSICAL_METHODS)

#: Default success thresholds: position (m) and orientation (rad) errors.
DEFAULT_TOL_POS = 1e-4
DEFAULT_TOL_ROT = 1e-3
#: Default time budgets (s) when ``max_time`` is None: Levenberg-Marquardt (joint limits only), and every
#: request that may need the QP (centring, obstacles, collision, tasks), whose iterations cost more.
MAX_TIME_LM = 0.1
MAX_TIME_QP = 0.5
#: Floor ``lambda_0`` of the LM / QP damping (m^2 / rad^2 units of ``|e|^2``) and the gain of its error term.
DAMPING = 1e-5
DAMPING_GAIN = 0.01
#: The stall test: a start is abandoned when its best squared goal error has not fallen below this fraction
#: of its best so far for ``STALL_PATIENCE`` iterations in a row. The QP's constrained iterations creep along
#: an obstacle's surface when they stall: restarting early beats patience there (docs/benchmarks.md).
STALL_RATIO_LM = 0.85
STALL_RATIO_QP = 0.7
STALL_PATIENCE = 2
#: Iteration caps of one start (LM, QP) and the QP's bound on each joint step (rad or m).
MAX_ITER_LM = 60
MAX_ITER_QP = 200
MAX_STEP = 1.0
#: Starts of the unconstrained solve tried, each checked, before the constrained one (obstacles, collision);
#: they get at most this share of the time budget.
CHECKED_ATTEMPTS = 12
CHECKED_BUDGET_SHARE = 0.5
#: Upper bounds of the integer options (module docstring): ``max_iter``, ``iteration_budget``,
#: ``max_starts``, ``samples`` (also ``ik.solve_all``'s).
MAX_ITER_CAP = 10**5
MAX_ITERATION_BUDGET = 10**6
MAX_STARTS_CAP = 10**7
MAX_SAMPLES = 10**4


_LM = ("max_iter", "iteration_budget", "damping", "max_starts", "prefer_q0", "seed_table")
_QP = _LM + ("max_step", "shortcut", "lazy")
_CLASSICAL = ("gain", "damping", "max_iter", "iteration_budget")
_ANALYTIC = ("samples", "choose")

#: Accepted option names per method.
OPTIONS: dict[str, tuple[str, ...]] = {
    "lm": _LM,
    "qp": _QP,
    "analytic": _ANALYTIC,
    "auto": tuple(dict.fromkeys(_QP + _ANALYTIC)),
    "jacobian_inverse": _CLASSICAL,
    "jacobian_transpose": _CLASSICAL,
    "pseudo_inverse": _CLASSICAL,
    "dls": _CLASSICAL,
}


def _integer(name: str, value: Any, minimum: int, maximum: int, allow_none: bool = False) -> None:
    """:class:`InputError` unless ``value`` is an integer in ``[minimum, maximum]`` (or None when allowed)."""
    if value is None and allow_none:
        return
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < minimum:
        extra = " or None" if allow_none else ""
        raise InputError(f"option {name} must be an integer >= {minimum}{extra}, got {value!r}")
    if value > maximum:
        raise InputError(f"option {name} must be at most {maximum:,} (accepted: an integer from {minimum} to "
                         f"{maximum:,}), got {value!r}")


def _positive(name, value):
    as_positive(value, f"option {name}")


def _flag(name, value):
    as_flag(value, f"option {name}")


def _criteria(name, value):
    names = (value,) if isinstance(value, str) else value
    try:
        names = tuple(names)
    except TypeError:
        names = None
    if not names or any(not isinstance(c, str) or c not in CRITERIA for c in names):
        raise InputError(f"option {name} must name criteria from {CRITERIA}, got {value!r}")


_CHECKS = {
    "max_iter": lambda n, v: _integer(n, v, 1, MAX_ITER_CAP),
    "iteration_budget": lambda n, v: _integer(n, v, 1, MAX_ITERATION_BUDGET),
    "max_starts": lambda n, v: _integer(n, v, 1, MAX_STARTS_CAP, allow_none=True),
    "samples": lambda n, v: _integer(n, v, 2, MAX_SAMPLES),
    "damping": _positive,
    "max_step": _positive,
    "gain": _positive,
    "prefer_q0": _flag,
    "seed_table": _flag,
    "shortcut": _flag,
    "lazy": _flag,
    "choose": _criteria,
}


def check_method(method: Any) -> str:
    """``method`` if it names an IK method (:data:`METHODS`); else :class:`InputError` naming them."""
    if not isinstance(method, str) or method not in METHODS:  # (a str first: no array compared or hashed)
        raise InputError(f"method must be one of {METHODS}, got {describe(method)}")
    return method


def check_options(method: str, options: dict) -> None:
    """Raise :class:`InputError` for an unknown ``method`` (:func:`check_method`), an option ``method`` does
    not accept or a value out of range (the table of the module docstring: non-finite, absurdly large or
    wrongly typed values are refused)."""
    allowed = OPTIONS[check_method(method)]
    for name in options:
        if name not in allowed:
            bad = [k for k in options if k not in allowed]
            raise InputError(f"unknown option(s) {bad} for method {method!r}; "
                             f"accepted: {', '.join(allowed) or 'none'}")
    for name, value in options.items():
        _CHECKS[name](name, value)


def options_for(method: str, options: Mapping[str, Any]) -> dict:
    """The options of ``options`` (checked) that ``method``'s solver takes, as its keywords
    (:func:`solver_keywords`); a strategy of ``"auto"`` passes each solver its own. ``iteration_budget`` is
    left out: the strategies hand each stage its share (:mod:`kinserve.ik.strategies.budget`)."""
    if not options:
        return {}
    allowed = OPTIONS[method]
    keywords = {k: v for k, v in options.items() if k in allowed and k != "iteration_budget"}
    return solver_keywords(keywords) if "seed_table" in keywords else keywords


def solver_keywords(options: dict) -> dict:
    """``options`` as the solvers' keyword arguments: the user's ``seed_table`` is the solvers'
    ``seed_table_enabled`` (a copy when renamed; ``options`` itself is left as it is)."""
    if "seed_table" in options:
        options = dict(options)
        options["seed_table_enabled"] = bool(options.pop("seed_table"))
    return options
