"""Start configurations for the iterative solvers: a table of FK samples and the restart order.

A local solver (Levenberg-Marquardt, QP iterations) converges quickly from a
start whose pose is already close to the target, and may stall at a joint
limit or a local minimum from a distant one. The :class:`SeedTable` holds
``n`` configurations drawn uniformly from the interior of the joint ranges
(a margin of :data:`MARGIN` of each range is kept from both limits: starts
next to a limit tend to stall against it) with a fixed RNG seed, so it is
reproducible, together with the pose of one frame at each. For a
target ``(R*, p*)`` it ranks them by the pose distance

    D(q_i) = |p_i - p*|^2 + w_R |R_i - R*|_F^2 = |p_i - p*|^2 + w_R (6 - 2 tr(R*^T R_i))

(m^2; ``w_R`` in m^2 weighs orientation against position), computed for all
samples at once as one matrix-vector product on the stacked features
``f_i = [p_i, sqrt(w_R) vec(R_i)]`` (``D = |f_i|^2 - 2 f_i . f* + |f*|^2``).

:func:`start_sequence` yields the starts of one solve: the ``n_table``
nearest interior samples and the caller's ``q0``, in order of ``D`` (``q0``
first with ``prefer_q0``), then the ``n_table`` nearest samples of a second
set drawn over the full joint ranges (for solutions next to a limit), then
uniform random configurations from ``numpy.random.default_rng(seed)`` - the
same sequence for the same ``seed``, so results are reproducible.

Tables are built once per model and frame (a few milliseconds with the
vectorised :meth:`kinserve.kinematics.Robot.fk_batch`) and cached. A table is
immutable (its arrays are read-only) and the cache is guarded by a lock, so
threads sharing a robot share its tables safely.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # annotations only

    from kinserve.kinematics.robot import Robot
    from kinserve.kinematics.types import VectorLike

#: Default number of samples in a table.
DEFAULT_SIZE = 2000

#: Weight ``w_R`` (m^2) of the orientation term of the pose distance.
ROTATION_WEIGHT = 0.05

#: Fraction of each joint range kept free at both ends when sampling the table.
MARGIN = 0.1

_TABLE_SEED = 20240611



class SeedTable:
    """``n`` configurations from the interior of the joint ranges and the pose of ``frame`` at each.

    A second, smaller set (``n // 2`` samples over the *full* ranges, ``Q_full``
    / ``G_full``) serves the restarts of targets whose solutions lie near a
    limit, which the interior samples cannot approach.
    """

    def __init__(self, robot: Robot, frame: str, n: int | None = None,
                 rotation_weight: float | None = None) -> None:
        n = DEFAULT_SIZE if n is None else int(n)
        rng = np.random.default_rng(_TABLE_SEED)
        span = robot.upper - robot.lower
        self.weight = float(ROTATION_WEIGHT if rotation_weight is None else rotation_weight)
        self._s = math.sqrt(self.weight)
        self.Q = rng.uniform(robot.lower + MARGIN * span, robot.upper - MARGIN * span, size=(n, robot.nq))
        self.F, self.F_norm2, self.G = self._features_of(robot, frame, self.Q)
        self.Q_full = robot.random_q(rng, max(1, n // 2))
        _, _, self.G_full = self._features_of(robot, frame, self.Q_full)
        for a in (self.Q, self.F, self.F_norm2, self.G, self.Q_full, self.G_full):
            a.flags.writeable = False  # shared by every thread and solve: nobody may change it

    @property
    def nbytes(self) -> int:
        """Memory held by the table's arrays (bytes)."""
        return sum(a.nbytes for a in (self.Q, self.F, self.F_norm2, self.G, self.Q_full, self.G_full))

    def _features_of(self, robot, frame, Q):
        T = robot.fk_batch(Q, frame)
        F = np.hstack([T[:, :3, 3], self._s * T[:, :3, :3].reshape(len(Q), 9)])
        F_norm2 = np.einsum("ij,ij->i", F, F)
        # score_i = |f_i|^2 - 2 f_i . f  as one product G @ [f, 1]
        G = np.ascontiguousarray(np.hstack([-2.0 * F, F_norm2[:, None]]))
        return F, F_norm2, G

    def features(self, R: np.ndarray, p: np.ndarray, rotation: bool = True) -> np.ndarray:
        """Stacked feature ``[p, sqrt(w_R) vec(R), 1]`` of one pose (the trailing 1 serves :meth:`scores`).

        ``rotation=False`` (a target whose orientation is relaxed) zeroes the
        rotation part: every sample's distance becomes ``|p_i - p*|^2 + 3 w_R``,
        i.e. the ranking is by position only, ``q0`` included.
        """
        f = np.empty(13)
        f[:3] = p
        if rotation:
            f[3:12] = R.reshape(9)
            f[3:12] *= self._s
        else:
            f[3:12] = 0.0
        f[12] = 1.0
        return f

    def scores(self, f_target: np.ndarray) -> np.ndarray:
        """``D_i - |f*|^2`` for every sample (one matrix-vector product)."""
        return self.G.dot(f_target)

    def distance(self, f_target: np.ndarray, f: np.ndarray) -> float:
        """Pose distance ``D`` between two feature vectors (m^2)."""
        d = f[:12] - f_target[:12]
        return float(d @ d)

    def ranked(self, f_target: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Indices of the ``k`` samples nearest the target (sorted) and their distances ``D``."""
        score = self.scores(f_target)
        k = min(k, len(score))
        if k < len(score):
            idx = np.argpartition(score, k - 1)[:k]
        else:
            idx = np.arange(len(score))
        idx = idx[np.argsort(score[idx])]
        return idx, score[idx] + float(f_target[:12] @ f_target[:12])


def start_sequence(robot: Robot, table: SeedTable | None, f_target: np.ndarray | None, q0: VectorLike | None,
                   rng_seed: int | None, n_table: int = 8, q0_distance: float | None = None,
                   prefer_q0: bool = False) -> Iterator[np.ndarray]:
    """Generator of start configurations (fresh arrays) for one solve; see the module docstring.

    ``q0_distance`` is ``D`` of ``q0`` (None when ``q0`` is None). With
    ``prefer_q0`` the caller's ``q0`` always goes first. The ranking is
    lazy: the scores of all samples are one matrix-vector product, and each
    next sample is one ``argmin`` over them (the sample taken is then set to
    ``inf``): most solves take one or two starts, and a partition of the
    2000 scores (``numpy.argpartition``) would cost more than the kernel's
    whole run (docs/benchmarks.md).
    """
    if table is not None:
        score = table.G.dot(f_target)  # a fresh array: taken samples are marked in it
        f2 = float(f_target[:12].dot(f_target[:12]))
        pending_q0 = q0 is not None
        if pending_q0 and (prefer_q0 or q0_distance is None):
            pending_q0 = False
            yield np.array(q0, dtype=float)
        for _ in range(min(n_table, len(score))):
            i = int(score.argmin())
            if pending_q0 and q0_distance <= float(score[i]) + f2:
                pending_q0 = False
                yield np.array(q0, dtype=float)
            yield table.Q[i].copy()
            score[i] = math.inf
        if pending_q0:
            yield np.array(q0, dtype=float)
        # then the nearest full-range samples (solutions close to a joint limit)
        score = table.G_full.dot(f_target)
        for _ in range(min(n_table, len(score))):
            i = int(score.argmin())
            yield table.Q_full[i].copy()
            score[i] = math.inf
    elif q0 is not None:
        yield np.array(q0, dtype=float)
    rng = np.random.default_rng(rng_seed)
    while True:
        yield robot.random_q(rng)
