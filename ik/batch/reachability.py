"""Reachability maps: which share of sampled tool poses in each workspace cell IK reaches.

The workspace box is the bounding box of ``fk_batch`` over random
configurations, padded by 5 %. ``samples`` target positions are drawn
uniformly in the box (components the mechanism cannot act on - e.g. ``z``
for a planar arm - are held at their constant value), each with an
orientation that is

* ``"free"``: not constrained (position-only IK, the classical reachable workspace),
* ``"random"``: uniformly random on SO(3) (the dexterous workspace),
* a 3x3 rotation matrix: that fixed tool orientation (e.g. pointing down).

All targets are solved with :func:`ik.solve_many` (local processes or Ray);
each sample falls in one cell of a ``resolution^3`` grid, and a cell's
reachability is ``reached / sampled`` (NaN for a cell with no sample).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from kinserve.ik.batch.solve_many import solve_many
from kinserve.kinematics import Robot, as_matrix
from kinserve.kinematics.errors import InputError
from kinserve.kinematics.shapes import as_obstacles
from kinserve.kinematics.validation import as_count, as_flag, check_rotation

#: Most target poses a reachability map samples (each one a 4x4 target and an IK solve).
MAX_SAMPLES = 10**7

_POSITION_AXES = ("x", "y", "z")
_ROTATION_AXES = ("roll", "pitch", "yaw")


@dataclass
class ReachabilityMap:
    """Samples and per-cell statistics of a reachability computation (positions in m)."""

    robot: str
    frame: str
    orientation: str
    edges: list  #: three arrays of cell edges along x, y, z
    positions: np.ndarray  #: (N, 3) sampled target positions
    reached: np.ndarray  #: (N,) bool
    counts: np.ndarray  #: (nx, ny, nz) samples per cell
    hits: np.ndarray  #: (nx, ny, nz) reached samples per cell

    @property
    def fraction(self) -> np.ndarray:
        """Per-cell reached / sampled (NaN where a cell has no sample)."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(self.counts > 0, self.hits / np.maximum(self.counts, 1), np.nan)

    @property
    def overall(self) -> float:
        """Share of all samples reached."""
        return float(self.reached.mean()) if self.reached.size else 0.0

    def save(self, path: str | os.PathLike) -> Path:
        """Write a ``.npz`` with every array (and the metadata as 0-d arrays)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(
            path, robot=self.robot, frame=self.frame, orientation=self.orientation,
            edges_x=self.edges[0], edges_y=self.edges[1], edges_z=self.edges[2], positions=self.positions,
            reached=self.reached, counts=self.counts, hits=self.hits, fraction=self.fraction,
        )
        return path


def workspace_box(robot: Robot, frame: str | None = None, n: int = 5000, seed: int = 0,
                  pad: float = 0.05) -> np.ndarray:
    """``(2, 3)`` [min; max] of the frame origin over ``n`` random configurations, padded by ``pad`` of the
    size."""
    P = robot.fk_batch(robot.random_q(seed, n=n), frame)[:, :3, 3]
    lo, hi = P.min(axis=0), P.max(axis=0)
    span = hi - lo
    return np.array([lo - pad * span, hi + pad * span])


def reachability_map(
    robot: Robot,
    samples: int = 1000,
    *,
    frame: str | None = None,
    resolution: int = 8,
    orientation: str | ArrayLike = "free",
    backend: str = "processes",
    processes: int | None = None,
    ray_address: str | None = None,
    max_time: float = 0.05,
    seed: int = 0,
    bounds: ArrayLike | None = None,
    progress: bool | None = None,
    self_collision: bool = False,
    obstacles: Sequence = (),
    collision_margin: float = 0.0,
) -> ReachabilityMap:
    """Sample ``samples`` tool poses in the workspace box and record which ones IK reaches.

    With ``self_collision`` / ``obstacles`` (:func:`ik.solve`'s collision options) a
    pose counts as reached only by a collision-free solution.

    ``seed`` must be an integer from 0 to 2**63 - 1 (a bool, a float with a fraction or a negative
    seed is refused with :class:`InputError`).
    """
    seed = as_count(seed, "seed", minimum=0, maximum=2**63 - 1)
    self_collision, obstacles = as_flag(self_collision, "self_collision"), as_obstacles(obstacles)
    _check_counts(samples, resolution)
    frame = frame or robot.tip
    robot.frame_id(frame)
    rng = np.random.default_rng(seed)
    box = workspace_box(robot, frame, seed=seed) if bounds is None else as_matrix(bounds, (2, 3), "bounds")
    if np.any(box[1] < box[0]):
        raise InputError(f"bounds must be [min; max] with min <= max, got {box.tolist()}")
    acts = [a in robot.task_axes for a in _POSITION_AXES]
    P = _positions(rng, box, acts, samples)
    relax = tuple(a for a in _POSITION_AXES + _ROTATION_AXES if a not in robot.task_axes)
    R, label, relax = _orientations(robot, orientation, samples, rng, relax)
    targets = np.zeros((samples, 4, 4))
    targets[:, :3, :3] = R
    targets[:, :3, 3] = P
    targets[:, 3, 3] = 1.0
    extra = {"ray_address": ray_address} if backend == "ray" else {}
    extra.update(self_collision=self_collision, obstacles=obstacles, collision_margin=collision_margin)
    results = solve_many(robot, targets, frame=frame, relax=relax, backend=backend, processes=processes,
                         max_time=max_time, seed=seed, progress=progress, **extra)
    reached = np.array([r.success for r in results], dtype=bool)
    counts, hits = _cell_counts(P, reached, box, acts, resolution)
    return ReachabilityMap(robot.name, frame, label, _cell_edges(box, acts, resolution), P, reached, counts,
                           hits)


def _check_counts(samples: int, resolution: int) -> None:
    """:class:`InputError` unless ``samples`` is an integer in [1, :data:`MAX_SAMPLES`] (each sample is a
    4x4 target and an IK solve: a larger count would allocate and run without bound) and ``resolution`` one
    in [1, 100]."""
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 1:
        raise InputError(f"samples must be a positive integer, got {samples!r}")
    if samples > MAX_SAMPLES:
        raise InputError(f"samples must be at most {MAX_SAMPLES:,} (one IK solve each), got {samples:,}")
    if (isinstance(resolution, bool) or not isinstance(resolution, (int, np.integer))
            or not 1 <= resolution <= 100):
        raise InputError(f"resolution must be an integer in [1, 100], got {resolution!r}")


def _positions(rng: np.random.Generator, box: np.ndarray, acts: list[bool], samples: int) -> np.ndarray:
    """``(samples, 3)`` positions uniform in ``box``; an axis the mechanism cannot move along
    (``acts[k]`` False) is held at the box's centre."""
    P = rng.uniform(box[0], box[1], size=(samples, 3))
    centre = 0.5 * (box[0] + box[1])
    for k, active in enumerate(acts):
        if not active:
            P[:, k] = centre[k]  # the mechanism cannot move along this axis: its constant value
    return P


def _orientations(robot: Robot, orientation: str | ArrayLike, samples: int, rng: np.random.Generator,
                  relax: tuple) -> tuple[np.ndarray, str, tuple]:
    """``(R, label, relax)``: the ``(samples, 3, 3)`` target rotations of ``orientation`` (module docstring),
    its label and the relaxed components (``"free"`` adds the rotations the robot acts on)."""
    if isinstance(orientation, str) and orientation == "free":
        relax = tuple(dict.fromkeys(relax + tuple(a for a in _ROTATION_AXES if a in robot.task_axes)))
        return np.repeat(np.eye(3)[None], samples, axis=0), "free", relax
    if isinstance(orientation, str) and orientation == "random":
        from scipy.spatial.transform import Rotation

        return Rotation.random(samples, random_state=rng.integers(1 << 31)).as_matrix(), "random", relax
    if isinstance(orientation, str):
        raise InputError(f"orientation must be 'free', 'random' or a 3x3 rotation matrix, "
                         f"got {orientation!r}")
    R0 = as_matrix(orientation, (3, 3), "orientation")
    check_rotation(R0, "orientation")
    return np.repeat(R0[None], samples, axis=0), "fixed", relax


def _cell_edges(box: np.ndarray, acts: list[bool], resolution: int) -> list[np.ndarray]:
    """The cell edges along x, y, z: ``resolution`` cells across the box, or one 1 m bin around the constant
    value of an axis the mechanism cannot move along."""
    centre = 0.5 * (box[0] + box[1])
    return [np.linspace(box[0][k], box[1][k], resolution + 1) if acts[k]
            else centre[k] + np.array([-0.5, 0.5]) for k in range(3)]


def _cell_counts(P: np.ndarray, reached: np.ndarray, box: np.ndarray, acts: list[bool],
                 resolution: int) -> tuple[np.ndarray, np.ndarray]:
    """``(counts, hits)``: samples and reached samples per cell (integer arrays ``(nx, ny, nz)``)."""
    edges = _cell_edges(box, acts, resolution)
    counts, _ = np.histogramdd(P, bins=edges)
    hits, _ = np.histogramdd(P[reached], bins=edges) if reached.any() else (np.zeros_like(counts), None)
    return counts.astype(int), hits.astype(int)
