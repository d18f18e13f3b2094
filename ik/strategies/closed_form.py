"""The closed-form strategy: the best branch of the robot's closed-form solver by the chooser's criteria."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from kinserve.ik.closed_form import branch_result, raw_branches
from kinserve.ik.closed_form.chooser import choose
from kinserve.ik.request import SolveRequest
from kinserve.ik.result import History, Result
from kinserve.ik.state import ik_state
from kinserve.kinematics.robot import TASK_AXES


def relaxed_names(rows: Any) -> str:
    """The names of relaxed task rows, for messages."""
    return ", ".join(TASK_AXES[i] for i in rows)


def _default_criteria(q0: np.ndarray | None) -> tuple[str, ...]:
    return ("displacement",) if q0 is not None else ("joint_limit_distance",)


def _choose_index(robot: Any, pool: list, criteria: Any, q0: np.ndarray | None, frame: str) -> int:
    i = choose(robot, pool, criteria, q_current=q0, frame=frame)
    if i is None:  # a filter dropped every branch: rank without the filters
        names = (criteria,) if isinstance(criteria, str) else criteria
        rest = tuple(c for c in names if c != "no_self_overlap")
        i = choose(robot, pool, rest or _default_criteria(q0), q_current=q0, frame=frame)
    return i


def _no_branch(req: SolveRequest, note: str | None, extra: dict) -> Result:
    robot, tgt = req.robot, req.target
    q = robot.neutral() if req.q0 is None else np.clip(req.q0, robot.lower, robot.upper)
    T = robot.fk(q, tgt.frame)
    pe, re = tgt.errors(T[:3, :3], T[:3, 3])
    message = "no closed-form branch inside the joint limits" + (f"; {note}" if note else "")
    return Result(q=q, success=False, position_error=pe, orientation_error=re, method="analytic",
                  frame=tgt.frame, message=message,
                  history=History.empty(robot.nq, tgt.components), info={"note": note, **extra})


def closed_form(req: SolveRequest, fallback: bool = False,
                admissible: Callable[[np.ndarray], bool] | None = None) -> Result | None:
    """The chosen closed-form branch, verified by forward kinematics; with ``fallback``, None when no branch
    is usable (the caller then runs LM). ``admissible``: a test every branch must pass (e.g. collision free).
    Options: ``samples`` (of a one-parameter family), ``choose``."""
    t0 = time.perf_counter()
    robot, tgt = req.robot, req.target
    solver = ik_state(robot).closed_form(tgt.frame)
    raw, note, extra = raw_branches(robot, solver, tgt, req.options.get("samples", 24))
    if admissible is not None:
        raw = [b for b in raw if admissible(b[0])]
    if not raw:
        return None if fallback else _no_branch(req, note, extra)
    criteria = req.options.get("choose") or _default_criteria(req.q0)
    exact = [b for b in raw if not b[3]]  # branches that reach the target (no note of their own) first
    pool = exact or raw
    i = _choose_index(robot, [b[0] for b in pool], criteria, req.q0, tgt.frame)
    best = branch_result(robot, tgt, pool[i], note, extra, req.tol_pos, req.tol_rot, t0)
    if not best.success and not pool[i][3]:  # numerically off: choose among the branches that verify
        results = [branch_result(robot, tgt, b, note, extra, req.tol_pos, req.tol_rot, t0) for b in raw]
        ok = [r for r in results if r.success]
        if ok:
            best = ok[_choose_index(robot, ok, criteria, req.q0, tgt.frame)]
        elif fallback:
            return None
    best.info["branches"] = len(raw)
    best.elapsed = time.perf_counter() - t0
    return best
