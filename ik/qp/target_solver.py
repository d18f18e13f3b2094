"""Method ``"qp"`` for one :class:`ik.Target`: the task model with a frame task, centring and obstacles.

Kept as the entry point of the single-target QP method: :func:`solve_qp`
builds an :class:`ik.FrameTask`, an :class:`ik.CentringTask` at priority 2
(when ``weights`` are given) and the obstacle constraint, and runs
:func:`ik.qp.task_solver.solve_problem` - the iteration, step back-off,
restarts and determinism are documented there; the per-step QP is
:mod:`ik.qp.hierarchy` / :mod:`ik.qp.dense_qp`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from kinserve.ik.problem import Problem
from kinserve.ik.qp.dense_qp import DEFAULT_BACKEND, box_active_set
from kinserve.ik.qp.task_solver import DAMPING, MAX_ITER, MAX_STEP, solve_problem
from kinserve.ik.result import Result, task_evaluator

__all__ = ["solve_qp", "box_active_set"]

if TYPE_CHECKING:  # annotations only
    from kinserve.ik.targets import Target
    from kinserve.kinematics.robot import Robot


def solve_qp(robot: Robot, target: Target, q0: np.ndarray | None = None, *, spheres: Any = None,
             weights: np.ndarray | None = None, backend: str = DEFAULT_BACKEND,
             tol_pos: float = 1e-4, tol_rot: float = 1e-3, max_time: float | None = None,
             seed: int | None = None, max_iter: int = MAX_ITER, iteration_budget: int | None = None,
             max_step: float = MAX_STEP, damping: float = DAMPING,
             max_starts: int | None = None, seed_table_enabled: bool = True, prefer_q0: bool = False,
             shortcut: bool = True, lazy: bool = True, defer_starts: int = 0) -> Result:
    """QP-based IK of ``target`` with hard joint limits, optional obstacles and centring, and restarts.

    ``spheres`` is a constraint (e.g. :class:`~kinserve.ik.constraints.obstacles.ObstacleAvoidance`), a list
    of constraints or None; ``weights`` the centring weights of
    :func:`~kinserve.ik.tasks.centring_weights.centring_weights` (None = off); ``defer_starts`` (starts
    the caller tried) and ``iteration_budget`` (the iterations of all starts; without ``max_time`` the
    clock decides nothing), see :func:`~kinserve.ik.qp.task_solver.solve_problem`.
    """
    from kinserve.ik.tasks.centring_task import CentringTask
    from kinserve.ik.tasks.frame_task import FrameTask

    tasks = [FrameTask.from_target(target)]
    if weights is not None:
        tasks.append(CentringTask.bound(robot, weights))
    cons = []
    if isinstance(spheres, (list, tuple)):
        cons.extend(spheres)
    elif spheres is not None:
        cons.append(spheres)
    pb = Problem(robot, tasks, cons)
    return solve_problem(pb, q0, tol_pos=tol_pos, tol_rot=tol_rot, max_time=max_time, seed=seed,
                         max_iter=max_iter, iteration_budget=iteration_budget, max_step=max_step,
                         damping=damping, max_starts=max_starts,
                         seed_table_enabled=seed_table_enabled, prefer_q0=prefer_q0, backend=backend,
                         shortcut=shortcut, lazy=lazy, defer_starts=defer_starts,
                         evaluate=task_evaluator(robot, target),
                         components=target.components)
