"""The bound problems of ``ik.step`` that one thread keeps for one robot (held by the robot's ``IKState``).

A control loop calls :func:`kinserve.ik.step` with the same task and constraint objects every period; binding
them (validation, grouping by priority) once and finding the bound problem again on the next call keeps a
step cheap. A problem is found again only for the very same robot object and the very same task and
constraint objects, in the same order (identity, not equality), with the same change counters (the
``_version`` of the task and constraint protocols: a new ``weight``, ``priority``, ``PostureTask.q_ref``,
``VelocityLimits.v_max`` moves it), so a changed object is bound - and validated - again. A target moved
with ``FrameTask.set_target`` needs no new bind.

Each entry holds its robot, tasks and constraints, so none of them is collected while the entry exists.
The store is per thread (a bound problem works on the calling thread's Pinocchio ``Data``): each thread
keeps :data:`STEP_PROBLEMS_PER_THREAD` problems per robot, the least recently used dropped first.
"""

from __future__ import annotations

import operator
import threading
from collections.abc import Sequence
from typing import Any, NamedTuple

#: Bound problems of ``ik.step`` one thread keeps per robot (least recently used dropped first).
STEP_PROBLEMS_PER_THREAD = 8


class StepProblem(NamedTuple):
    """A bound problem and what it was bound from: the robot, the tasks, the constraints (as given to
    ``ik.step``) and their change counters (tasks first)."""

    robot: Any
    tasks: tuple
    constraints: tuple
    versions: tuple
    problem: Any


_is = operator.is_


def _same(a: Sequence, b: Sequence) -> bool:
    """Whether ``a`` and ``b`` hold the very same objects in the same order."""
    return len(a) == len(b) and all(map(_is, a, b))


class StepProblems(threading.local):
    """One thread's bound problems of ``ik.step`` for one robot, most recently used first (module
    docstring). ``threading.local``: every thread sees its own :attr:`entries`, made empty on its first use.
    """

    def __init__(self, size: int = STEP_PROBLEMS_PER_THREAD) -> None:
        self.size = size
        self.entries: list[StepProblem] = []

    def find(self, robot: Any, tasks: Sequence, constraints: Sequence, versions: tuple) -> Any | None:
        """The problem bound from these very objects with these change counters, or None."""
        entries = self.entries
        for i, entry in enumerate(entries):
            if (entry.robot is robot and entry.versions == versions and len(entry.tasks) == len(tasks)
                    and len(entry.constraints) == len(constraints) and all(map(_is, entry.tasks, tasks))
                    and all(map(_is, entry.constraints, constraints))):
                if i:
                    entries.insert(0, entries.pop(i))
                return entry.problem
        return None

    def keep(self, robot: Any, tasks: Sequence, constraints: Sequence, versions: tuple, problem: Any) -> None:
        """Remember ``problem`` as bound from these objects (an entry of the same objects with older change
        counters is replaced)."""
        entries = [e for e in self.entries
                   if not (e.robot is robot and _same(e.tasks, tasks) and _same(e.constraints, constraints))]
        entries.insert(0, StepProblem(robot, tuple(tasks), tuple(constraints), versions, problem))
        del entries[self.size:]
        self.entries = entries

    def clear(self) -> None:
        """Forget this thread's problems."""
        self.entries = []
