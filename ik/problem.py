"""``Problem``: tasks and constraints bound to one robot - the one task-evaluation path of the solvers.

Built once per solve (or cached by :func:`kinserve.ik.step` for a control
loop). It validates the composition, groups the tasks by priority, keeps
joint limits always on, and offers the three things an iteration needs:

* :meth:`evaluate` - one ``computeJointJacobians`` pass, then every task's
  ``(e, J)``, stacked per level (rows scaled by ``sqrt(weight)``), and the goal
  errors (largest position / orientation error over the goal tasks);
* :meth:`box_and_rows` - the box on ``dq`` (joint limits, velocity limits,
  trust region) and the stacked rows ``l <= G dq <= u`` of the other constraints;
* :meth:`margin` - the true check of a configuration on a second Pinocchio
  ``Data`` (forward kinematics only), so checking a trial step never
  overwrites the kinematics of the current iterate.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import partial
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from kinserve.ik.constraints.base import (
    DAMPER_GAIN,
    Constraint,
    checked_margin,
    checked_rows,
    is_users_constraint,
)
from kinserve.ik.constraints.joint_limits import JointLimits
from kinserve.ik.constraints.obstacles import ObstacleAvoidance
from kinserve.ik.qp.hierarchy import stack_level
from kinserve.ik.tasks.base import Task, checked_output, is_users_task
from kinserve.kinematics.errors import InputError
from kinserve.kinematics.shapes import Shape

if TYPE_CHECKING:  # annotations only
    from kinserve.kinematics.robot import Robot

_cjj = pin.computeJointJacobians
_fk = pin.forwardKinematics


def _is_checked(c: Constraint) -> bool:
    """True when ``c`` implements a true check (its ``margin`` is not the protocol default)."""
    return type(c).margin is not Constraint.margin


def as_constraints(constraints: Any, tool_frames: Sequence[str] = ()) -> list[Constraint]:
    """Constraint objects from a sequence of constraints and shapes (shapes become one
    :class:`ObstacleAvoidance`)."""
    if constraints is None:
        return []
    if isinstance(constraints, (Constraint, Shape)):
        constraints = [constraints]
    try:
        items = list(constraints)
    except TypeError:
        raise InputError(f"constraints must be a sequence of ik.Constraint objects or shapes, "
                         f"got {constraints!r}") from None
    out, shapes = [], []
    for i, c in enumerate(items):
        if isinstance(c, Shape):
            shapes.append(c)
        elif isinstance(c, Constraint):
            out.append(c)
        else:
            raise InputError(f"constraints[{i}] must be an ik.Constraint or a shape (ik.Sphere, ik.Box, "
                             f"...), got {type(c).__name__}")
    if shapes:
        out.append(ObstacleAvoidance(shapes, tool_frames=tuple(tool_frames) or None))
    return out


def _task_list(tasks: Any) -> list[Task]:
    """``tasks`` (one task or a sequence) as a non-empty list of :class:`Task`; :class:`InputError` names
    what is wrong."""
    if tasks is None or isinstance(tasks, Task):
        tasks = [] if tasks is None else [tasks]
    try:
        tasks = list(tasks)
    except TypeError:
        raise InputError(f"tasks must be a sequence of ik.Task objects, got {tasks!r}") from None
    if not tasks:
        raise InputError("tasks must hold at least one ik.Task (e.g. ik.FrameTask(frame, pose))")
    for i, t in enumerate(tasks):
        if not isinstance(t, Task):
            raise InputError(f"tasks[{i}] must be an ik.Task (FrameTask, PostureTask, CentringTask or a "
                             f"subclass of ik.Task), got {type(t).__name__}")
    return tasks


def _bound_constraints(robot: Robot, constraints: Any, tasks: list[Task]) -> list[Constraint]:
    """The constraints (shapes as one :class:`ObstacleAvoidance` about the tasks' frames, joint limits
    always on, first unless given) bound to ``robot``."""
    tool_frames = [t.frame_name for t in tasks if hasattr(t, "frame_name")]
    cons = as_constraints(constraints, tool_frames)
    if not any(isinstance(c, JointLimits) for c in cons):
        cons.insert(0, JointLimits())
    return [c.bind(robot) for c in cons]


def _sqrt_weight(task: Task) -> Any:
    """``sqrt(weight)`` of a task, None for the weight 1 (its rows are used as they are)."""
    return None if (type(task.weight) is float and task.weight == 1.0) else np.sqrt(task.weight)


def _positions(tasks: list[Task], ordered: list[Task]) -> list[int]:
    """Where each of ``tasks`` is in ``ordered`` (by identity)."""
    position = {id(t): k for k, t in enumerate(ordered)}
    return [position[id(t)] for t in tasks]


def _users_margin(constraint: Constraint, robot: Robot, data: pin.Data, q: np.ndarray) -> float:
    """A user constraint's margin at ``q``, checked (:func:`~.constraints.base.checked_margin`)."""
    return checked_margin(constraint, constraint.margin(robot, data, q))


class Problem:
    """Bound tasks and constraints of one robot (see the module docstring)."""

    def __init__(self, robot: Robot, tasks: Any, constraints: Any = ()) -> None:
        tasks = _task_list(tasks)
        self.robot = robot
        self.model = robot.model
        self.data = robot.data
        self.tasks = [t.bind(robot) for t in tasks]
        self.constraints = _bound_constraints(robot, constraints, self.tasks)
        self.box_constraints = []
        self.row_constraints = []
        # constraints with a true check (JointLimits excluded: iterates are clipped)
        self.checked = [c for c in self.constraints if not isinstance(c, JointLimits) and _is_checked(c)]
        # per constraint: whether it has a true check, and whether it is a user's (outputs checked per call)
        self._plan = [(c, c in self.checked, is_users_constraint(c)) for c in self.constraints]
        # the margin of each checked constraint, a user's checked on each call (:func:`_users_margin`)
        self._margins = [partial(_users_margin, c) if users else c.margin
                         for c, checked, users in self._plan if checked]
        self.priorities = sorted({t.priority for t in self.tasks})
        self.levels = [[t for t in self.tasks if t.priority == p] for p in self.priorities]
        # sqrt(weight) of every task, None for weight 1 (rows used as they are)
        self.level_weights = [[_sqrt_weight(t) for t in lvl] for lvl in self.levels]
        # per level: the single task whose rows are used as they are, or None (stack the level's tasks)
        self._single = [lvl[0] if len(lvl) == 1 and ws[0] is None else None
                        for lvl, ws in zip(self.levels, self.level_weights)]
        # per level: which tasks are a user's (their (e, J) checked on every evaluation, so never unstacked)
        self._users = [[is_users_task(t) for t in lvl] for lvl in self.levels]
        self._checks_users = any(map(any, self._users))
        self._only_single = all(t is not None for t in self._single) and not self._checks_users
        # the tasks in level order (the order of evaluate()'s errors), and where user task i's error is
        self._ordered = [t for lvl in self.levels for t in lvl]
        self._es_index = _positions(self.tasks, self._ordered)
        self.goals = [t for t in self.tasks if t.goal]
        # the levels (indices into self.levels) holding a goal task; each level's slice of evaluate()'s errors
        self.goal_levels = [j for j, lvl in enumerate(self.levels) if any(t.goal for t in lvl)]
        ends = np.cumsum([len(lvl) for lvl in self.levels]).tolist()
        self._level_slices = list(zip([0] + ends[:-1], ends))
        self.has_objectives = any(not t.goal for t in self.tasks) or len(self.levels) > 1
        self.gain = min([getattr(c, "gain", DAMPER_GAIN) for c in self.checked] or [DAMPER_GAIN])
        self.nv = robot.model.nv
        self.q_in_data = None

    # ------------------------------------------------------------------------------- tasks
    def state(self, q: np.ndarray) -> tuple[list, float, float, list, float]:
        """``(levels, pe, re, es, margin)`` at ``q`` from one kinematics pass on the main ``Data``."""
        levels, pe, re, es = self.evaluate(q)
        if not self.checked:
            return levels, pe, re, es, math.inf
        robot, data = self.robot, self.data
        m = min(f(robot, data, q) for f in self._margins) if len(self._margins) > 1 else \
            self._margins[0](robot, data, q)
        return levels, pe, re, es, m

    def evaluate(self, q: np.ndarray) -> tuple[list, float, float, list]:
        """``(levels, pe, re, es)``: stacked ``(J, e)`` per level, goal errors (m, rad), each task's error
        (in level order: highest priority first, the given order within a level)."""
        robot, data = self.robot, self.data
        _cjj(self.model, data, q)
        self.q_in_data = q
        levels = []
        es = []
        if self._only_single:  # one task per level, weight 1 (the usual composition): no stacking
            for t in self._single:
                e, J = t.compute(robot, data, q)
                levels.append((J, e))
                es.append(e)
        else:
            for lvl, ws, users in zip(self.levels, self.level_weights, self._users):
                pairs = [t.compute(robot, data, q) for t in lvl]
                if self._checks_users:
                    nv = self.nv
                    pairs = [checked_output(t, p, nv) if user else p for t, p, user in zip(lvl, pairs, users)]
                es.extend([e for e, _ in pairs])
                levels.append(stack_level(pairs, ws))
        pe = re = 0.0  # the largest position / orientation error of the goal tasks
        for t, e in zip(self._ordered, es):
            if t.goal:
                p, r = t.errors(e)
                if p > pe:
                    pe = p
                if r > re:
                    re = r
        return levels, pe, re, es

    def level_goal_errors(self, es: list) -> list[tuple[float, float]]:
        """Per level (highest first), the largest position / orientation error (m, rad) of its goal tasks,
        ``(0.0, 0.0)`` for a level without goals; ``es`` are :meth:`evaluate`'s task errors."""
        out = []
        tasks = self._ordered
        for i, j in self._level_slices:
            pe = re = 0.0
            for k in range(i, j):
                t = tasks[k]
                if t.goal:
                    p, r = t.errors(es[k])
                    pe, re = max(pe, p), max(re, r)
            out.append((pe, re))
        return out

    def error_index(self, task: Task) -> int:
        """Where ``task`` (one of :attr:`tasks`) has its error in :meth:`evaluate`'s ``es``."""
        return self._es_index[next(k for k, t in enumerate(self.tasks) if t is task)]

    def task_errors(self, es: list) -> list[dict]:
        """Per-task report for :attr:`Result.task_errors`."""
        out = []
        for t, k in zip(self.tasks, self._es_index):  # in the order the tasks were given
            e = es[k]
            p, r = t.errors(e)
            out.append({"name": t.name, "priority": t.priority, "goal": t.goal,
                        "error": float(np.linalg.norm(e)), "position_error": float(p),
                        "orientation_error": float(r)})
        return out

    # ------------------------------------------------------------------------- constraints
    def box_and_rows(self, q: np.ndarray, dt: float | None = None, max_step: float = math.inf,
                     with_checked_rows: bool = True) -> tuple:
        """``(lb, ub, G, l, u)`` at ``q``; ``G`` is None without rows. Recomputes the kinematics if needed."""
        robot, data = self.robot, self.data
        if self.q_in_data is not q:
            _cjj(self.model, data, q)
            self.q_in_data = q
        lb = ub = None
        Gs, ls, us = [], [], []
        for c, checked, users in self._plan:
            if checked and not with_checked_rows:
                continue
            G, lo, hi = checked_rows(c, c.rows(robot, data, q, dt), self.nv) if users else \
                c.rows(robot, data, q, dt)
            if G is None:
                if lb is None:  # JointLimits' arrays are fresh; copy anyone else's before writing into them
                    lb, ub = (lo, hi) if type(c) is JointLimits else \
                        (np.array(lo, dtype=float), np.array(hi, dtype=float))
                else:
                    np.maximum(lb, lo, out=lb)
                    np.minimum(ub, hi, out=ub)
            elif G.shape[0]:
                Gs.append(G), ls.append(lo), us.append(hi)
        if max_step < math.inf:
            np.maximum(lb, -max_step, out=lb)
            np.minimum(ub, max_step, out=ub)
        if not Gs:
            return lb, ub, None, None, None
        if len(Gs) == 1:
            return lb, ub, Gs[0], ls[0], us[0]
        return lb, ub, np.concatenate(Gs), np.concatenate(ls), np.concatenate(us)

    def margin(self, q: np.ndarray) -> float:
        """Smallest margin of the checked constraints at ``q`` (``inf`` without any); forward kinematics
        only."""
        if not self.checked:
            return math.inf
        d = self.data
        _fk(self.model, d, q)
        self.q_in_data = None
        if len(self._margins) == 1:
            return self._margins[0](self.robot, d, q)
        return min(f(self.robot, d, q) for f in self._margins)

    def describe(self, q: np.ndarray) -> str:
        """Violations at ``q`` in words (forward kinematics on the main ``Data``, as :meth:`margin`)."""
        d = self.data
        _fk(self.model, d, q)
        self.q_in_data = None
        return "; ".join(s for s in (c.describe(self.robot, d, q) for c in self.checked) if s)
