"""``Result``: what every IK solver returns, and ``History``, its per-iteration record.

Failing to reach a target is a result, not an exception: ``success`` is False,
``q`` is the best configuration found (always inside the joint limits) and
``message`` says why the solver stopped.

Errors are measured on the *kept* (non-relaxed) task components only:

* ``position_error`` (m): norm of the kept components of ``p_target - p``
  (world or target axes, see :mod:`ik.targets`); for a full pose it is the
  Euclidean distance between the frame origin and the target position;
* ``orientation_error`` (rad): norm of the kept components of the rotation
  vector ``log(R_target R^T)``; for a full pose it is the geodesic angle
  between the two orientations.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

if TYPE_CHECKING:
    from kinserve.ik.targets import Target
    from kinserve.kinematics import Robot


class History:
    """Per-iteration record of one solver run (the run that produced ``Result.q``).

    ``q`` has shape ``(k, nq)``: the configuration *at* iteration ``i``
    (``q[0]`` is the start). ``position_error`` and ``orientation_error`` have
    shape ``(k,)`` and are measured at ``q[i]`` on the kept components.
    ``task_error`` is ``(k, m)``: the signed error of the ``m`` kept task
    components (named in ``components``) - the "errors in the operational
    space" the seed documents plot. Fast solvers do not record it while they
    iterate: it is evaluated from ``q`` with forward kinematics the first time
    it is read (and before pickling).
    """

    __slots__ = ("_q", "_position_error", "_orientation_error", "components", "_task_error", "_evaluate",
                 "_raw")

    def __init__(self, q: ArrayLike, position_error: ArrayLike, orientation_error: ArrayLike,
                 task_error: ArrayLike | None = None, components: Sequence[str] = (),
                 evaluate: Callable[[np.ndarray], np.ndarray] | None = None) -> None:
        self._q = np.asarray(q, dtype=float)
        self._position_error = np.asarray(position_error, dtype=float)
        self._orientation_error = np.asarray(orientation_error, dtype=float)
        self.components = tuple(components)
        self._task_error = None if task_error is None else np.asarray(task_error, dtype=float)
        self._evaluate = evaluate
        self._raw = None

    @classmethod
    def from_squared(cls, qs: list, pos2: list, rot2: list, k: int, components: Sequence[str] = (),
                     evaluate: Callable[[np.ndarray], np.ndarray] | None = None) -> History:
        """The first ``k`` iterations of per-iteration lists of ``q`` and *squared* errors, kept as they are.

        The arrays (``q`` stacked, errors square-rooted) are built the first time
        one is read: a fast solver that returns after a few iterations pays
        nothing for a history nobody looks at.
        """
        h = cls.__new__(cls)
        h._q = h._position_error = h._orientation_error = h._task_error = None
        h.components = components if type(components) is tuple else tuple(components)
        h._evaluate = evaluate
        h._raw = (qs, pos2, rot2, k)
        return h

    @classmethod
    def from_deferred(cls, qs: list, squared_errors: Callable[[], tuple[list, list]], k: int,
                      components: Sequence[str] = (),
                      evaluate: Callable[[np.ndarray], np.ndarray] | None = None) -> History:
        """Like :meth:`from_squared`, the squared errors given by ``squared_errors()`` (called on first read).

        A solver that tests convergence on a cheaper bound need not compute
        the exact errors of every iterate unless somebody reads them.
        """
        return cls.from_squared(qs, squared_errors, None, k, components, evaluate)

    def _materialise(self) -> None:
        qs, pos2, rot2, k = self._raw
        if rot2 is None:  # deferred (from_deferred)
            pos2, rot2 = pos2()
        nq = len(qs[0]) if k else 0
        self._q = np.array(qs[:k], dtype=float).reshape(k, nq)
        self._position_error = np.sqrt(np.array(pos2[:k], dtype=float))
        self._orientation_error = np.sqrt(np.array(rot2[:k], dtype=float))
        self._raw = None

    def iterates(self) -> list[np.ndarray]:
        """The configurations as a list of ``(nq,)`` arrays (no stacking when the history is still lazy)."""
        if self._raw is not None:
            qs, _, _, k = self._raw
            return qs[:k]
        return list(self._q)

    @property
    def q(self) -> np.ndarray:
        """Configurations ``(k, nq)``; ``q[0]`` is the start."""
        if self._raw is not None:
            self._materialise()
        return self._q

    @property
    def position_error(self) -> np.ndarray:
        """Position error ``(k,)`` at each ``q[i]`` (m)."""
        if self._raw is not None:
            self._materialise()
        return self._position_error

    @property
    def orientation_error(self) -> np.ndarray:
        """Orientation error ``(k,)`` at each ``q[i]`` (rad)."""
        if self._raw is not None:
            self._materialise()
        return self._orientation_error

    @property
    def task_error(self) -> np.ndarray | None:
        """Signed kept-component errors ``(k, m)`` (evaluated on first access if needed)."""
        if self._task_error is None and self._evaluate is not None:
            m = len(self.components)
            rows = [self._evaluate(qi) for qi in self.q]
            self._task_error = np.array(rows, dtype=float).reshape(len(rows), m)
            self._evaluate = None
        return self._task_error

    def __len__(self) -> int:
        return self._raw[3] if self._raw is not None else int(self._q.shape[0])

    def final(self) -> History:
        """A history of this one's last iteration alone (the configuration a converged run answers with)."""
        if self._raw is not None:
            qs, pos2, rot2, k = self._raw
            if rot2 is None:  # deferred errors: computed now (the run's few iterates)
                pos2, rot2 = pos2()
            return History.from_squared([qs[k - 1]], [pos2[k - 1]], [rot2[k - 1]], 1, self.components,
                                        self._evaluate)
        te = None if self._task_error is None else self._task_error[-1:]
        return History(self._q[-1:], self._position_error[-1:], self._orientation_error[-1:], te,
                       self.components, self._evaluate)

    def __getstate__(self):
        if self._raw is not None:
            self._materialise()
        self.task_error  # materialise: the evaluator holds a robot, which is not pickled
        return {k: getattr(self, k) for k in self.__slots__ if k not in ("_evaluate", "_raw")}

    def __setstate__(self, state):
        for k, v in state.items():
            setattr(self, k, v)
        self._evaluate = None
        self._raw = None

    def __repr__(self) -> str:
        return f"History({len(self)} iterations, components={self.components})"

    @classmethod
    def empty(cls, nq: int, components: Sequence[str] = ()) -> History:
        """A history with no iteration."""
        return cls(np.zeros((0, nq)), np.zeros(0), np.zeros(0), np.zeros((0, len(components))), components)

    @classmethod
    def from_lists(cls, qs: Sequence[ArrayLike], pos: Sequence[float], rot: Sequence[float],
                   task: Sequence[ArrayLike] | None = None, components: Sequence[str] = (),
                   evaluate: Callable[[np.ndarray], np.ndarray] | None = None) -> History:
        """Build from per-iteration lists (``qs`` a list of 1-D arrays)."""
        nq = len(qs[0]) if len(qs) else 0
        q = np.array(qs, dtype=float).reshape(len(qs), nq)
        te = None if task is None else np.array(task, dtype=float).reshape(len(task), len(components))
        return cls(q, pos, rot, te, components, evaluate)


#: Longest ``repr(Result)`` (characters): one readable line for ``print(result)``.
REPR_WIDTH = 160


@dataclass
class Result:
    """Outcome of an inverse-kinematics solve.

    Attributes
    ----------
    q:
        Joint vector (length ``nq``), inside the joint limits.
    success:
        True when both errors are within the requested tolerances (and every
        hard constraint holds).
    position_error, orientation_error:
        Residual errors at ``q`` on the kept components (m, rad).
    iterations:
        Total iterations over all starts (0 for closed-form solutions).
    restarts:
        Number of starts after the first one.
    elapsed:
        Wall time in seconds.
    message:
        Why the solver stopped ("converged", "time budget exhausted", "target
        out of reach", ...).
    history:
        :class:`History` of the run that produced ``q``.
    method:
        The method that produced the answer (``"lm"``, ``"qp"``, ``"analytic"``, ...).
    frame:
        The frame that was placed.
    info:
        Solver-specific extras (e.g. ``"branch"`` for a closed-form branch,
        ``"reached_pose"`` when a 5-DOF arm solved the nearest reachable pose).
    task_errors:
        One dict per task of a task-based solve (``name``, ``priority``,
        ``goal``, ``error`` = ``|e|``, ``position_error``,
        ``orientation_error``) at ``q``; empty for the single-target methods.
        With several goal tasks, ``position_error`` / ``orientation_error``
        are the largest over the goals.
    """

    q: np.ndarray
    success: bool
    position_error: float
    orientation_error: float
    iterations: int = 0
    restarts: int = 0
    elapsed: float = 0.0
    message: str = ""
    history: History | None = None
    method: str = ""
    frame: str = ""
    info: dict = field(default_factory=dict)
    task_errors: list = field(default_factory=list)

    def __repr__(self) -> str:
        """One line of at most :data:`REPR_WIDTH` characters, no arrays: success, the two errors,
        iterations and the reason (``message``, shortened with ``...`` when it does not fit)."""
        head = (f"Result(success={bool(self.success)}, position_error={self.position_error:.1e} m, "
                f"orientation_error={self.orientation_error:.1e} rad, iterations={self.iterations}, reason=")
        reason = " ".join(str(self.message).split())
        room = max(REPR_WIDTH - len(head) - 3, 12)  # 3 = the quotes and the closing parenthesis
        if len(reason) > room:
            reason = reason[:room - 3] + "..."
        return f"{head}{reason!r})"

    def summary(self) -> str:
        """One line: success, errors, iterations, time and the message."""
        return (
            f"{'ok' if self.success else 'FAILED'} [{self.method}] pos {self.position_error:.3g} m, "
            f"rot {self.orientation_error:.3g} rad, {self.iterations} it, {self.restarts} restarts, "
            f"{self.elapsed * 1e3:.3g} ms: {self.message}"
        )


def task_evaluator(robot: Robot, target: Target) -> Callable[[np.ndarray], np.ndarray]:
    """``q -> kept task error`` (:meth:`ik.targets.Target.residual`) for :attr:`History.task_error`.

    Runs forward kinematics on a private copy of the robot, made on first use.
    """
    holder = {}

    def evaluate(q):
        r = holder.get("robot")
        if r is None:
            r = holder["robot"] = robot.copy()
        T = r.fk(q, target.frame)
        return target.residual(T[:3, :3], T[:3, 3])

    return evaluate
