"""Closed-form inverse kinematics: planar 2R/3R/4R and SCARA chains (S1, S9), the youBot arm (S2).

:func:`closed_form_solver` finds the solver for a robot and frame by
*structure*, not by name: each candidate reads its parameters from the
Pinocchio model and is accepted only if its own closed-form forward
kinematics matches the robot's at random configurations. Results are cached
per model and frame.

:func:`branches` turns a solver's raw branches into :class:`ik.Result`
objects, each verified with the robot's forward kinematics (errors on the
kept components, ``success`` against the tolerances).
"""

from __future__ import annotations

import bisect
import time
from typing import TYPE_CHECKING, Union

import numpy as np

from kinserve.ik.closed_form.planar import PlanarChain, two_link, wrap_into
from kinserve.ik.closed_form.youbot import YOUBOT_DH, YouBotArm
from kinserve.ik.result import History, Result

if TYPE_CHECKING:  # annotations only
    from kinserve.ik.targets import Target
    from kinserve.kinematics.robot import Robot

#: A closed-form solver: one of :data:`_SOLVERS`.
ClosedFormSolver = Union[PlanarChain, YouBotArm]

#: One raw branch ``(q, label, free_parameter, note)`` from :func:`raw_branches`.
Branch = tuple[np.ndarray, str, Union[float, None], Union[str, None]]

__all__ = ["build_closed_form_solver", "branches", "raw_branches", "branch_result", "PlanarChain",
           "YouBotArm", "YOUBOT_DH", "two_link", "wrap_into"]

_SOLVERS = (PlanarChain, YouBotArm)
#: Branches closer than this (max abs joint difference) are one branch.
DUPLICATE_TOL = 1e-9


def build_closed_form_solver(robot: Robot, frame: str) -> ClosedFormSolver | None:
    """The closed-form solver of ``robot`` for ``frame``, or None when there is none.

    Built anew on each call: the robot's IK state (:mod:`kinserve.ik.state`) keeps the one each frame uses.
    Solvers are immutable once built.
    """
    for cls in _SOLVERS:
        try:
            return cls(robot, frame)
        except (ValueError, np.linalg.LinAlgError):
            continue
    return None


def raw_branches(robot: Robot, solver: ClosedFormSolver, target: Target,
                 samples: int = 24) -> tuple[list[Branch], str | None, dict]:
    """``(branches, note, info)``: distinct branches ``(q, label, free_parameter, note)`` inside the limits.

    Each ``q`` is a joint vector clipped into the limits. A solver's branch may carry its own
    note (why it only approaches the target); otherwise the solver's shared ``note`` applies to it.
    """
    raw, note, extra = solver.solve_all(target.T, target.relaxed, samples=samples)
    out = []
    seen = _Distinct()
    for q, label, free, *own in raw:
        q = np.clip(np.asarray(q, dtype=float), robot.lower, robot.upper)
        if seen.known(q):
            continue  # branches that coincide (stretched / folded arm)
        out.append((q, label, free, own[0] if own else note))
    return out, note, extra


class _Distinct:
    """The configurations seen so far; :meth:`known` tells whether one lies within ``DUPLICATE_TOL`` (max
    norm) of them. Only those whose first joint is that close are compared (a sorted index on it), so a
    sampled family of many branches is sifted in about ``n log n``, not ``n^2``."""

    def __init__(self) -> None:
        self.keys: list[float] = []  # first joint values, sorted
        self.rows: list[np.ndarray] = []  # the configurations in the same order

    def known(self, q: np.ndarray) -> bool:
        """True when ``q`` is within the tolerance of a configuration seen before; else remember it."""
        key = float(q[0])
        lo = bisect.bisect_left(self.keys, key - DUPLICATE_TOL)
        hi = bisect.bisect_right(self.keys, key + DUPLICATE_TOL)
        if any(np.abs(self.rows[j] - q).max() < DUPLICATE_TOL for j in range(lo, hi)):
            return True
        i = bisect.bisect_left(self.keys, key)
        self.keys.insert(i, key)
        self.rows.insert(i, q)
        return False


def branch_result(robot: Robot, target: Target, branch: Branch, note: str | None, extra: dict, tol_pos: float,
                  tol_rot: float, t0: float) -> Result:
    """One closed-form branch as a :class:`Result`, verified with the robot's forward kinematics.

    The branch's own note (4th element, from :func:`raw_branches`) takes the place of ``note``.
    """
    q, label, free, *own = branch
    note = own[0] if own else note
    T = robot.fk(q, target.frame)
    pe, re = target.errors(T[:3, :3], T[:3, 3])
    ok = pe < tol_pos and re < tol_rot
    msg = "closed form" + (f"; {note}" if note else "")
    if not ok and not note:
        msg += f"; residual {pe:.3g} m / {re:.3g} rad above tolerance"
    info = {"branch": label, "note": note, **extra}
    if free is not None:
        info["free_parameter"] = float(free)
    hist = History.from_lists([q], [pe], [re], [target.residual(T[:3, :3], T[:3, 3])], target.components)
    return Result(
        q=q, success=ok, position_error=pe, orientation_error=re, iterations=0, restarts=0,
        elapsed=time.perf_counter() - t0, message=msg, history=hist, method="analytic",
        frame=target.frame, info=info,
    )


def branches(robot: Robot, solver: ClosedFormSolver, target: Target, *, tol_pos: float = 1e-4,
             tol_rot: float = 1e-3, samples: int = 24) -> list[Result]:
    """Every closed-form branch as a :class:`Result`: the successful ones first, else in the solver's order.

    Each result's ``info`` holds the ``branch`` label, the ``free_parameter`` and the ``note``.
    """
    t0 = time.perf_counter()
    raw, note, extra = raw_branches(robot, solver, target, samples)
    results = [branch_result(robot, target, b, note, extra, tol_pos, tol_rot, t0) for b in raw]
    return sorted(results, key=lambda r: not r.success)
