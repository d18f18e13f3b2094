"""The start configurations of one solve, for any set of goal tasks (the one multistart order).

* One frame task (the common case): :func:`ik.starts.seed_table.start_sequence` - ``q0``
  and the nearest samples of the frame's seed table by pose distance, then
  full-range samples, then seeded random configurations.
* Several frame tasks (two hands): the tables of the frames share their
  samples (one RNG seed per model), so the pose distances add up,
  ``D(q_i) = sum_t D_t(q_i)``; the samples are ranked by that sum.
* No frame task (a user goal such as a centre of mass): ``q0``, then seeded
  random configurations.

The sequence depends only on the robot, the targets, ``q0`` and ``seed``.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from kinserve.ik.starts.seed_table import start_sequence
from kinserve.ik.state import frame_state, seed_table

if TYPE_CHECKING:  # annotations only
    from kinserve.kinematics.robot import Robot


def _frame_tasks(goals):
    from kinserve.ik.tasks.frame_task import FrameTask

    return [t for t in goals if isinstance(t, FrameTask)]


def _features(table, task):
    return table.features(task.T[:3, :3], task.T[:3, 3], rotation=(len(task.kept) - task.n_pos) == 3)


def starts(robot: Robot, goals: list, q0: np.ndarray | None, seed: int | None, table_enabled: bool = True,
           prefer_q0: bool = False, n_table: int = 8) -> Iterator[np.ndarray]:
    """Generator of start configurations (fresh arrays); see the module docstring."""
    rng_seed = 0 if seed is None else seed
    tasks = _frame_tasks(goals) if table_enabled else []
    if not tasks:
        return start_sequence(robot, None, None, q0, rng_seed, prefer_q0=prefer_q0)
    if len(tasks) == 1:
        t = tasks[0]
        return frame_starts(robot, t.frame_name, t.frame_id, t.T[:3, :3], t.T[:3, 3],
                            (len(t.kept) - t.n_pos) == 3, q0, seed, prefer_q0=prefer_q0, n_table=n_table)
    tables = [seed_table(robot, t.frame_name) for t in tasks]
    fs = [_features(tab, t) for tab, t in zip(tables, tasks)]
    q0_dist = None
    if q0 is not None:
        data = robot.data
        pin.forwardKinematics(robot.model, data, q0)
        q0_dist = 0.0
        for tab, t, f in zip(tables, tasks, fs):
            M = pin.updateFramePlacement(robot.model, data, t.frame_id)
            q0_dist += tab.distance(f, tab.features(M.rotation, M.translation))
    return _combined(robot, tables, fs, q0, q0_dist, rng_seed, prefer_q0, n_table)


def frame_starts(robot: Robot, frame: str, frame_id: int, R: np.ndarray, p: np.ndarray, rotation: bool,
                 q0: np.ndarray | None, seed: int | None, table_enabled: bool = True, prefer_q0: bool = False,
                 n_table: int = 8) -> Iterator[np.ndarray]:
    """Starts for one frame at pose ``(R, p)`` (``rotation=False``: orientation relaxed, rank by position)."""
    rng_seed = 0 if seed is None else seed
    if not table_enabled:
        return start_sequence(robot, None, None, q0, rng_seed, prefer_q0=prefer_q0)
    if prefer_q0 and q0 is not None:
        # q0 goes first whatever its pose distance: rank the table only if a restart needs it
        return _q0_then(q0, robot, frame, R, p, rotation, rng_seed, n_table)
    table = frame_state(robot, frame).seed_table
    f = table.features(R, p, rotation=rotation)
    q0_dist = None
    if q0 is not None:
        data = robot.data
        pin.forwardKinematics(robot.model, data, q0)
        M = pin.updateFramePlacement(robot.model, data, frame_id)
        q0_dist = table.distance(f, table.features(M.rotation, M.translation))
    return start_sequence(robot, table, f, q0, rng_seed, n_table=n_table, q0_distance=q0_dist,
                          prefer_q0=prefer_q0)


def _q0_then(q0, robot, frame, R, p, rotation, rng_seed, n_table):
    """``q0``, then the table's starts (the sequence of ``prefer_q0=True``, ranked only when needed)."""
    yield np.array(q0, dtype=float)
    table = frame_state(robot, frame).seed_table
    yield from start_sequence(robot, table, table.features(R, p, rotation=rotation), None, rng_seed,
                              n_table=n_table)


def _combined(robot, tables, fs, q0, q0_dist, rng_seed, prefer_q0, n_table):
    f2 = sum(float(f[:12].dot(f[:12])) for f in fs)
    for Q, G_name in (("Q", "G"), ("Q_full", "G_full")):
        score = sum(getattr(tab, G_name).dot(f) for tab, f in zip(tables, fs)) + f2
        k = min(n_table, len(score))
        idx = np.argpartition(score, k - 1)[:k] if k < len(score) else np.arange(len(score))
        idx = idx[np.argsort(score[idx])]
        samples = getattr(tables[0], Q)
        for i in idx:
            if q0 is not None and (prefer_q0 or q0_dist <= score[i]):
                yield np.array(q0, dtype=float)
                q0 = None
            yield samples[i].copy()
    if q0 is not None:
        yield np.array(q0, dtype=float)
    rng = np.random.default_rng(rng_seed)
    while True:
        yield robot.random_q(rng)
