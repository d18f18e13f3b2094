"""The direct strategies: one solver family run on the request as it is.

* :func:`levenberg_marquardt` - LM with restarts (joint limits are the only inequalities);
* :func:`target_qp` - the QP on a frame task, centring and the request's constraints;
* :func:`task_qp` - the QP on a composition of tasks and constraints;
* :func:`classical` - the textbook Jacobian iterations from ``q0``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from kinserve.ik.classical.methods import solve_classical
from kinserve.ik.lm.solver import solve_lm
from kinserve.ik.options import MAX_TIME_LM, options_for
from kinserve.ik.qp.target_solver import solve_qp
from kinserve.ik.qp.task_solver import solve_problem
from kinserve.ik.request import SolveRequest
from kinserve.ik.result import Result
from kinserve.ik.strategies.budget import Budget, request_budget

#: Options of a request that are :func:`solve_lm`'s keywords as they are and leave the budget alone.
_LM_KEYWORDS = frozenset(("max_iter", "damping", "prefer_q0"))


def levenberg_marquardt(req: SolveRequest, budget: Budget | None = None, *, accept: Any = None,
                        admit: Any = None, max_starts: int | None = None, screen: Any = None) -> Result:
    """LM from the request's start sequence; ``accept`` / ``admit`` / ``max_starts`` / ``screen``: the checked
    strategy's tests of a converged run and of a start, its cap on the starts (the request's ``max_starts``
    option when None) and the pre-check run with each start (:class:`~kinserve.ik.lm.screen.LMScreen`)."""
    opts = req.options
    if opts.keys() <= _LM_KEYWORDS:  # the common calls: no keyword dictionary to build, no iteration budget
        seconds, iterations = (req.max_time, None) if budget is None else budget
        if seconds is None and budget is None:
            seconds = MAX_TIME_LM
        return solve_lm(req.robot, req.target, req.q0, tol_pos=req.tol_pos, tol_rot=req.tol_rot,
                        seed=req.seed, max_time=seconds, iteration_budget=iterations, max_starts=max_starts,
                        accept=accept, admit=admit, screen=screen, **opts)
    if budget is None:
        budget = request_budget(req, MAX_TIME_LM)
    opts = options_for("lm", req.options)
    if max_starts is not None:
        opts["max_starts"] = max_starts
    return solve_lm(req.robot, req.target, req.q0, tol_pos=req.tol_pos, tol_rot=req.tol_rot, seed=req.seed,
                    max_time=budget.seconds, iteration_budget=budget.iterations, accept=accept, admit=admit,
                    screen=screen, **opts)


def target_qp(req: SolveRequest, constraints: tuple | None = None, budget: Budget | None = None,
              q_start: np.ndarray | None = None, **extra: Any) -> Result:
    """The QP on the request's frame task (with its centring) under ``constraints`` (None: every constraint of
    the request - link obstacles, collision, extra constraints); ``q_start`` replaces ``q0`` (``extra``:
    solver
    keywords)."""
    if constraints is None:
        checker = req.collision_checker
        constraints = tuple(c for c in (req.avoid, None if checker is None else checker.constraint)
                            if c is not None) + req.extra
    budget = request_budget(req) if budget is None else budget
    opts = options_for("qp", req.options)
    return solve_qp(req.robot, req.target, req.q0 if q_start is None else q_start, spheres=list(constraints),
                    weights=req.weights, backend=req.backend, tol_pos=req.tol_pos, tol_rot=req.tol_rot,
                    seed=req.seed, **budget.keywords(), **{**opts, **extra})


def task_qp(req: SolveRequest) -> Result:
    """The QP on the request's bound tasks and constraints
    (:func:`kinserve.ik.qp.task_solver.solve_problem`)."""
    return solve_problem(req.problem, req.q0, tol_pos=req.tol_pos, tol_rot=req.tol_rot, seed=req.seed,
                         backend=req.backend, **request_budget(req).keywords(),
                         **options_for("qp", req.options))


def classical(req: SolveRequest) -> Result:
    """The classical iteration the request names, from ``q0`` (default: the neutral configuration)."""
    q0 = req.q0 if req.q0 is not None else req.robot.neutral()
    return solve_classical(req.robot, req.target, q0, req.method, weights=req.weights, tol_pos=req.tol_pos,
                           tol_rot=req.tol_rot, **request_budget(req).keywords(),
                           **options_for(req.method, req.options))
