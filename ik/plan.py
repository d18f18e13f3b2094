"""One plan per request: the strategy table of ``ik.solve``.

:func:`choose_strategy` reads the request's features and takes the first row of :data:`TABLE` that matches
(``*`` matches anything). The columns:

* ``door``: ``target`` (one frame at one pose) or ``tasks`` (a composition of tasks and constraints);
* ``method``: the method named (``classical`` stands for the four Jacobian iterations);
* ``closed form``: the robot has a closed-form solver with finitely many branches for the frame that handles
  the relaxed components;
* ``obstacles``: obstacles kept clear of the link capsules (``spheres`` / ``obstacles`` without collision
  options, or a robot without collision geometry);
* ``collision``: ``self_collision`` / ``collision_margin``: the robot's collision model;
* ``shaped``: centring or extra constraints (only the QP honours them).

======  =========  ===========  =========  =========  ======  ======================================
door    method     closed form  obstacles  collision  shaped  strategy
======  =========  ===========  =========  =========  ======  ======================================
tasks   *          *            *          *          *       task QP
target  classical  *            *          *          *       classical iteration
target  analytic   *            *          no         *       closed form
target  analytic   *            *          yes        *       checked closed form, then constrained QP
target  lm         *            *          no         *       LM
target  lm         *            *          yes        *       checked LM, then constrained QP
target  qp         *            *          yes        no      checked QP, then constrained QP
target  qp         *            *          *          *       QP (constraints hard)
target  auto       *            *          no         yes     QP (constraints hard)
target  auto       *            yes        no         no      checked LM, then constrained QP
target  auto       yes          no         no         no      closed form, LM when no branch is usable
target  auto       no           no         no         no      LM
target  auto       yes          *          yes        no      checked closed form, then constrained QP
target  auto       *            *          yes        no      checked LM, then constrained QP
target  auto       *            *          yes        yes     checked QP, then constrained QP
======  =========  ===========  =========  =========  ======  ======================================

"Checked X, then constrained QP" is :func:`kinserve.ik.strategies.checked.checked_first`: X solves without
the obstacles, each answer and its iterates checked, and the QP with the obstacle or collision constraint
hard on every iterate runs only when no attempt passes.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from functools import partial
from typing import NamedTuple

from kinserve.ik.options import CLASSICAL_METHODS
from kinserve.ik.request import SolveRequest
from kinserve.ik.result import Result
from kinserve.ik.state import frame_state
from kinserve.ik.strategies.checked import checked_first
from kinserve.ik.strategies.closed_form import closed_form
from kinserve.ik.strategies.direct import classical, levenberg_marquardt, target_qp, task_qp


class Features(NamedTuple):
    """The columns of :data:`TABLE` for one request."""

    door: str
    method: str
    closed_form: bool
    obstacles: bool
    collision: bool
    shaped: bool


class Strategy(NamedTuple):
    """A named strategy: ``run(request) -> Result``."""

    name: str
    run: Callable[[SolveRequest], Result]


def _closed_form_or_lm(req: SolveRequest) -> Result:
    res = closed_form(req, fallback=True)
    return res if res is not None else levenberg_marquardt(req)


TASK_QP = Strategy("task QP", task_qp)
CLASSICAL = Strategy("classical iteration", classical)
CLOSED_FORM = Strategy("closed form", closed_form)
CLOSED_FORM_OR_LM = Strategy("closed form, LM when no branch is usable", _closed_form_or_lm)
LM = Strategy("LM", levenberg_marquardt)
QP = Strategy("QP (constraints hard)", target_qp)
CHECKED_LM = Strategy("checked LM, then constrained QP", partial(checked_first, attempts="lm"))
CHECKED_CLOSED_FORM = Strategy("checked closed form, then constrained QP",
                               partial(checked_first, attempts="closed_form"))
CHECKED_QP = Strategy("checked QP, then constrained QP", partial(checked_first, attempts="qp"))

ANY = None
#: ``(door, method, closed form, obstacles, collision, shaped) -> strategy``, first match wins.
TABLE: tuple[tuple[tuple, Strategy], ...] = (
    (("tasks", ANY, ANY, ANY, ANY, ANY), TASK_QP),
    (("target", "classical", ANY, ANY, ANY, ANY), CLASSICAL),
    (("target", "analytic", ANY, ANY, False, ANY), CLOSED_FORM),
    (("target", "analytic", ANY, ANY, True, ANY), CHECKED_CLOSED_FORM),
    (("target", "lm", ANY, ANY, False, ANY), LM),
    (("target", "lm", ANY, ANY, True, ANY), CHECKED_LM),
    (("target", "qp", ANY, ANY, True, False), CHECKED_QP),
    (("target", "qp", ANY, ANY, ANY, ANY), QP),
    (("target", "auto", ANY, ANY, False, True), QP),
    (("target", "auto", ANY, True, False, False), CHECKED_LM),
    (("target", "auto", True, False, False, False), CLOSED_FORM_OR_LM),
    (("target", "auto", False, False, False, False), LM),
    (("target", "auto", True, ANY, True, False), CHECKED_CLOSED_FORM),
    (("target", "auto", ANY, ANY, True, False), CHECKED_LM),
    (("target", "auto", ANY, ANY, True, True), CHECKED_QP),
)


def features(req: SolveRequest) -> Features:
    """The request's columns of :data:`TABLE`."""
    if req.problem is not None:
        return Features("tasks", req.method, False, False, False, False)
    return Features(*_target_columns(req))


def _target_columns(req: SolveRequest) -> tuple:
    """:func:`features` of a target request as a plain tuple (a key of :data:`LOOKUP`)."""
    method = "classical" if req.method in CLASSICAL_METHODS else req.method
    solver = frame_state(req.robot, req.target.frame).closed_form
    closed = solver is not None and solver.finite and solver.supports(req.target.relaxed)
    return ("target", method, closed, req.avoid is not None, req.collision_checker is not None,
            req.weights is not None or bool(req.extra))


def first_match(have: tuple) -> Strategy:
    """The strategy of the first row of :data:`TABLE` that matches the columns ``have``."""
    for row, strategy in TABLE:
        if all(want is ANY or want == got for want, got in zip(row, have)):
            return strategy
    raise AssertionError(f"no strategy for {have}")  # the table covers every combination (tested)


#: :func:`first_match` of every combination of the columns, evaluated once at import (a constant: the
#: table's answers laid out for one dictionary look-up per solve).
LOOKUP: dict[tuple, Strategy] = {
    combo: first_match(combo)
    for combo in itertools.product(("target",), ("auto", "qp", "lm", "analytic", "classical"),
                                   (False, True), (False, True), (False, True), (False, True))
}


def choose_strategy(req: SolveRequest) -> Strategy:
    """The first row of :data:`TABLE` matching the request's :func:`features`."""
    if req.problem is not None:
        return TASK_QP
    return LOOKUP[_target_columns(req)]
