"""Levenberg-Marquardt on many targets of one frame in one compiled call (``ik.solve_many``'s LM).

Each target gets the answer :func:`ik.lm.solver.solve_lm` gives it on its own - the same start sequence,
the same iteration, the same stopping rules - without the Python work per target and per start:

* the start sequences are prepared in bulk: the seed table's arrays (its ``G`` transposed once, so that
  a target's scores against every sample are one vectorised pass), the clipped ``q0`` rows, and the
  random restarts, which are the same for every target (``numpy.random.default_rng(seed)``, drawn as
  :meth:`kinserve.kinematics.Robot.random_q` draws them one by one);
* :func:`ik.lm.kernel.run_many` runs every target's starts in order - ``q0`` and the nearest table samples
  ranked as :func:`ik.starts.seed_table.start_sequence` ranks them, the full-range samples, the random
  starts - until one converges, ``max_starts`` starts or ``iteration_budget`` iterations are spent;
* a target still unsolved when its prepared starts run out (a time budget, not a count, bounds its
  search) is handed to ``fallback`` (default: :func:`ik.lm.solver.solve_lm` on that target alone).

A target's answer is that of ``solve_lm`` whenever ``solve_lm`` would stop for the same reason (a start
that converges before ``max_time`` ends, a start or iteration limit); the pose distances that rank the
starts are computed in another order of the same sums, so a start order can differ only where two samples
are equally far to rounding. ``elapsed`` is the time of the compiled call shared in proportion to each
target's iterations (plus its fallback's own time).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from kinserve.ik.lm.chains import compiled_chain
from kinserve.ik.lm.solver import (
    DAMPING,
    DAMPING_GAIN,
    MAX_ITER,
    STALL_PATIENCE,
    STALL_RATIO,
    failure_message,
    solve_lm,
)
from kinserve.ik.lm.status import CONVERGED, START_LIMIT, STARTS_EXHAUSTED
from kinserve.ik.state import seed_table
from kinserve.ik.targets import Target

if TYPE_CHECKING:  # annotations only
    from kinserve.ik.lm.chains import CompiledChain
    from kinserve.ik.result import Result
    from kinserve.kinematics.robot import Robot

#: Random restarts prepared per target (the same rows for every target); a target needing more is handed over.
RANDOM_STARTS = 16
#: Table samples tried per table, as :func:`ik.starts.seed_table.start_sequence`'s ``n_table``.
TABLE_STARTS = 8


@dataclass
class ManyAnswers:
    """Per-target answers of :func:`solve_lm_many` (arrays of length ``N``, ``q`` of shape ``(N, nq)``)."""

    q: np.ndarray
    success: np.ndarray
    position_error: np.ndarray
    orientation_error: np.ndarray
    iterations: np.ndarray
    restarts: np.ndarray
    elapsed: np.ndarray
    message: list[str]


@dataclass(frozen=True)
class ManySettings:
    """The solver settings shared by every target of :func:`solve_lm_many` (those of :func:`solve_lm`)."""

    tol_pos: float = 1e-4
    tol_rot: float = 1e-3
    max_time: float | None = None
    seed: int | None = None
    max_iter: int = MAX_ITER
    damping: float = DAMPING
    max_starts: int | None = None
    seed_table_enabled: bool = True
    prefer_q0: bool = False
    iteration_budget: int | None = None


def _tables(robot: Robot, frame: str, settings: ManySettings) -> tuple:
    """``(G^T interior, Q interior, G^T full, Q full, random starts, rotation scale, n interior, n full)``."""
    nq = robot.nq
    rng = np.random.default_rng(0 if settings.seed is None else settings.seed)
    randoms = robot.random_q(rng, RANDOM_STARTS)
    if not settings.seed_table_enabled:
        empty_g, empty_q = np.zeros((13, 0)), np.zeros((0, nq))
        return empty_g, empty_q, empty_g, empty_q, randoms, 0.0, 0, 0
    table = seed_table(robot, frame)
    return (np.ascontiguousarray(table.G.T), table.Q, np.ascontiguousarray(table.G_full.T), table.Q_full,
            randoms, math.sqrt(table.weight), min(TABLE_STARTS, len(table.Q)),
            min(TABLE_STARTS, len(table.Q_full)))


def _run_kernel(chain: CompiledChain, robot: Robot, proto: Target, poses: np.ndarray, q0s: np.ndarray | None,
                settings: ManySettings) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One call of :func:`ik.lm.kernel.run_many`: ``(q, squared errors, (status, iterations, starts))``."""
    n = len(poses)
    Gt, Q, Gt_full, Q_full, randoms, scale, n_table, n_full = _tables(robot, proto.frame, settings)
    if q0s is None:
        mode, starts_q0 = 0, np.zeros((n, robot.nq))
    else:
        mode = 1 if settings.prefer_q0 or not settings.seed_table_enabled else 2
        starts_q0 = np.clip(q0s, robot.lower, robot.upper)
    k = chain.kernel
    params = np.empty(6)
    params[[k.TP2, k.TR2, k.LAMBDA0, k.GAIN, k.STALL_RATIO, k.ROTATION_SCALE]] = (
        settings.tol_pos ** 2, settings.tol_rot ** 2, settings.damping, DAMPING_GAIN, STALL_RATIO, scale)
    limits = np.empty(8, dtype=np.int64)
    limits[[k.PATIENCE, k.MAX_ITER, k.MAX_STARTS, k.BUDGET, k.Q0_MODE, k.N_TABLE, k.N_FULL, k.ROTATION]] = (
        STALL_PATIENCE, settings.max_iter, -1 if settings.max_starts is None else settings.max_starts,
        -1 if settings.iteration_budget is None else settings.iteration_budget, mode, n_table, n_full,
        len(proto.rot_rows) == 3)
    q_out, err_out, counts = np.empty((n, robot.nq)), np.empty((n, 2)), np.empty((n, 3), dtype=np.int64)
    k.run_many(chain.geometry, chain.joints, robot.lower, robot.upper, np.ascontiguousarray(poses),
               not proto.full, proto.relax_frame == "target", np.asarray(proto.kept, dtype=np.int64), params,
               limits, starts_q0, Gt, Q, Gt_full, Q_full, randoms, q_out, err_out, counts)
    return q_out, err_out, counts


def solve_lm_many(robot: Robot, frame: str, poses: np.ndarray, q0s: np.ndarray | None = None, *,
                  relax: Iterable[str] = (), relax_frame: str = "world",
                  settings: ManySettings = ManySettings(),
                  fallback: Callable[[int], Result] | None = None) -> ManyAnswers:
    """Solve the validated poses ``(N, 4, 4)`` of ``frame`` (start rows ``q0s`` ``(N, nq)`` or None) as
    ``solve_lm`` solves each (module docstring); ``fallback(i)`` solves target ``i`` whose prepared starts
    ran out (default: ``solve_lm`` on that target with ``settings``)."""
    proto = Target(robot, np.eye(4), frame, relax, relax_frame)  # the shared rows and axes of every target
    chain = compiled_chain(robot, proto.frame_id)
    n = len(poses)
    if fallback is None:
        fallback = _solve_one(robot, frame, poses, q0s, relax, relax_frame, settings)
    if chain is None:  # no compiled kernel for this chain: every target on its own
        return _assemble([fallback(i) for i in range(n)], robot.nq)
    t0 = time.perf_counter()
    q, err, counts = _run_kernel(chain, robot, proto, poses, q0s, settings)
    status, iterations, starts = counts[:, 0], counts[:, 1], counts[:, 2]
    share = (time.perf_counter() - t0) * (iterations + 1) / max(1, int(iterations.sum()) + n)
    answers = ManyAnswers(q, status == CONVERGED, np.sqrt(err[:, 0]), np.sqrt(err[:, 1]), iterations,
                          np.maximum(starts - 1, 0), share, ["converged"] * n)
    for i in np.flatnonzero(status != CONVERGED):
        if status[i] == STARTS_EXHAUSTED:
            _put(answers, int(i), fallback(int(i)))
        else:
            stop = ("start limit reached" if status[i] == START_LIMIT
                    else f"iteration budget exhausted ({iterations[i]} iterations)")
            answers.message[i] = failure_message(settings.tol_pos, settings.tol_rot, int(starts[i]),
                                                 int(iterations[i]), stop, answers.position_error[i],
                                                 answers.orientation_error[i])
    return answers


def _solve_one(robot, frame, poses, q0s, relax, relax_frame, settings) -> Callable[[int], Result]:
    """``i -> solve_lm`` on target ``i`` alone, with ``settings``."""
    options = dataclasses.asdict(settings)  # solve_lm's keywords

    def solve(i: int) -> Result:
        return solve_lm(robot, Target(robot, poses[i], frame, relax, relax_frame),
                        None if q0s is None else q0s[i], **options)

    return solve


def _put(answers: ManyAnswers, i: int, res: Result) -> None:
    """Write one :class:`Result` into row ``i`` of ``answers``."""
    answers.q[i] = res.q
    answers.success[i] = res.success
    answers.position_error[i] = res.position_error
    answers.orientation_error[i] = res.orientation_error
    answers.iterations[i] = res.iterations
    answers.restarts[i] = res.restarts
    answers.elapsed[i] = res.elapsed
    answers.message[i] = res.message


def _assemble(results: list, nq: int) -> ManyAnswers:
    """The :class:`ManyAnswers` of per-target results."""
    n = len(results)
    answers = ManyAnswers(np.empty((n, nq)), np.zeros(n, dtype=bool), np.empty(n), np.empty(n),
                          np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64), np.empty(n), [""] * n)
    for i, res in enumerate(results):
        _put(answers, i, res)
    return answers
