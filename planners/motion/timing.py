"""Time parameterisation of a certified path: toppra on the blended path, rest-to-rest segments as fallback.

**The geometric path** is the certified polyline with its corners rounded inside
certified balls (:class:`~.blended_path.BlendedPath`): C1, piecewise quadratic in
``s``. **TOPP-RA** (Pham & Pham 2018, ``toppra.algorithm.TOPPRA``) finds the
time-optimal speed ``sd(s)`` on a grid of ``s`` under ``JointVelocityConstraint``
(``|q_s sd| <= v``, the URDF's velocity limits) and ``JointAccelerationConstraint``
(``|q_s sdd + q_ss sd^2| <= a``), at rest at both ends. The grid holds every break
of the path, so ``q_ss`` is constant on each grid interval.

**Sampling follows the path**: between grid points the path acceleration is
constant (toppra's ``ParametrizeConstAccel`` assumption), so
``s(t) = s_i + sd_i (t - t_i) + u_i (t - t_i)^2 / 2`` with
``u_i = (sd_{i+1}^2 - sd_i^2) / (2 (s_{i+1} - s_i))`` and
``t_{i+1} = t_i + 2 (s_{i+1} - s_i) / (sd_i + sd_{i+1})``; the trajectory is
``q(t) = path(s(t))``, ``qd = q_s sd``, ``qdd = q_s u + q_ss sd^2``: every sample lies on
the blended path, whose straight parts are pieces of certified segments and whose
blends lie in certified balls (the chord between two samples of one piece too).
The sample times are a uniform grid of :data:`TRAJECTORY_DT` plus the times of the
path's breaks, so two consecutive samples always lie on one piece.

toppra enforces the limits at the grid points; the speed profile is then checked
at :data:`CHECK_POINTS` points of every grid interval and, if any limit is
exceeded there, slowed uniformly (``sd / c``: velocities scale by ``1 / c``,
accelerations by ``1 / c^2``) so that none is.

**Fallback** (``method = "rest-to-rest"``): when toppra fails, each straight segment
of the polyline gets its own time-optimal rest-to-rest profile (trapezoidal in
``sd``: ``sd <= min_k v_k / |e_k|``, ``|sdd| <= min_k a_k / |e_k|``, ``e`` the unit
direction), stopping at every waypoint; the samples lie on the segments.

Units: rad (or m), s.
"""

from __future__ import annotations

import importlib
import warnings
from types import ModuleType
from typing import NamedTuple

import numpy as np

from kinserve.planners.joint_trajectory import JointTrajectory

from .blended_path import BlendedPath, blend_lengths

#: Sample period (s) of the returned trajectories (the path's breaks are sampled too).
TRAJECTORY_DT = 0.01
#: toppra gets this share of the limits; the check after it slows the profile where it still exceeds them.
LIMIT_SAFETY = 0.98
#: Grid intervals of toppra over the whole path (each piece gets at least :data:`MIN_PIECE_INTERVALS`).
GRID_INTERVALS = 200
#: Least grid intervals per piece of the path.
MIN_PIECE_INTERVALS = 4
#: Points of each grid interval at which the limits are checked after toppra.
CHECK_POINTS = 9


class SpeedProfile(NamedTuple):
    """Path speeds ``sd`` ``(N + 1,)`` (rad/s) at grid points ``s`` ``(N + 1,)`` (rad), constant path
    acceleration in between; ``method``: ``"toppra"`` or ``"rest-to-rest"``."""

    s: np.ndarray
    sd: np.ndarray
    method: str


class TimedPath(NamedTuple):
    """The sampled ``trajectory`` and the ``method`` that timed it (``"toppra"`` / ``"rest-to-rest"``)."""

    trajectory: JointTrajectory
    method: str


def load_toppra() -> ModuleType:
    """The ``toppra`` package with its ``algorithm`` and ``constraint`` modules loaded (call before any
    timed work: the import takes a while the first time)."""
    module = importlib.import_module("toppra")
    importlib.import_module("toppra.algorithm")
    importlib.import_module("toppra.constraint")
    return module


def toppra_grid(path: BlendedPath) -> np.ndarray:
    """Grid ``s`` ``(N + 1,)``: every break of ``path``, each piece cut into equal intervals (about
    :data:`GRID_INTERVALS` in all, at least :data:`MIN_PIECE_INTERVALS` per piece)."""
    spacing = path.length / GRID_INTERVALS
    parts = [np.zeros(1)]
    for a, b in zip(path.breaks[:-1], path.breaks[1:]):
        n = max(MIN_PIECE_INTERVALS, int(np.ceil((b - a) / spacing)))
        parts.append(np.linspace(a, b, n + 1)[1:])
    return np.concatenate(parts)


def toppra_profile(toppra: ModuleType, path: BlendedPath, v_max: np.ndarray,
                   a_max: np.ndarray) -> SpeedProfile | None:
    """TOPP-RA's time-optimal speeds on ``path`` at rest at both ends (module docstring), or None when it
    finds none."""
    grid = toppra_grid(path)
    constraints = [toppra.constraint.JointVelocityConstraint(LIMIT_SAFETY * v_max),
                   toppra.constraint.JointAccelerationConstraint(LIMIT_SAFETY * a_max)]
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")  # a failed solve is reported by NaN / None, handled below
            algorithm = toppra.algorithm.TOPPRA(constraints, path, gridpoints=grid, solver_wrapper="seidel")
            _, sd, _ = algorithm.compute_parameterization(0.0, 0.0)
    except (ValueError, RuntimeError, ArithmeticError, toppra.exceptions.ToppraError):
        return None
    if sd is None or not np.all(np.isfinite(sd)):
        return None
    sd = np.maximum(np.asarray(sd, dtype=float), 0.0)
    sd[0] = sd[-1] = 0.0
    if np.any(sd[:-1] + sd[1:] <= 0.0):
        return None
    return SpeedProfile(grid, sd, "toppra")


def rest_to_rest_profile(points: np.ndarray, v_max: np.ndarray, a_max: np.ndarray) -> SpeedProfile:
    """Time-optimal rest-to-rest speeds on each straight segment of ``points`` (arc length ``s``)."""
    s, sd = [0.0], [0.0]
    for a, b in zip(points[:-1], points[1:]):
        length = float(np.linalg.norm(b - a))
        e = np.abs(b - a) / length
        moving = e > 0.0
        v = float(np.min(v_max[moving] / e[moving]))
        acc = float(np.min(a_max[moving] / e[moving]))
        s0 = s[-1]
        ramp = v * v / (2.0 * acc)
        if 2.0 * ramp < length:  # accelerate, coast, brake
            s += [s0 + ramp, s0 + length - ramp, s0 + length]
            sd += [v, v, 0.0]
        else:  # accelerate to the middle, brake
            s += [s0 + 0.5 * length, s0 + length]
            sd += [float(np.sqrt(acc * length)), 0.0]
    return SpeedProfile(np.array(s), np.array(sd), "rest-to-rest")


def grid_times(profile: SpeedProfile) -> np.ndarray:
    """Times ``t`` ``(N + 1,)`` (s) of the grid points under constant path acceleration between them."""
    ds = np.diff(profile.s)
    return np.concatenate([[0.0], np.cumsum(2.0 * ds / (profile.sd[:-1] + profile.sd[1:]))])


def evaluate(path: BlendedPath, profile: SpeedProfile, times: np.ndarray,
             t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions, velocities and accelerations ``(n, nq)`` at times ``t`` (module docstring); ``times``:
    :func:`grid_times` of ``profile``."""
    s, sd = profile.s, profile.sd
    u = (sd[1:] ** 2 - sd[:-1] ** 2) / (2.0 * np.diff(s))
    i = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(u) - 1)
    tau = t - times[i]
    speed = np.maximum(sd[i] + u[i] * tau, 0.0)
    position = np.clip(s[i] + sd[i] * tau + 0.5 * u[i] * tau ** 2, s[i], s[i + 1])
    tangent = path(position, 1)
    q = path(position, 0)
    qd = tangent * speed[:, None]
    qdd = tangent * u[i][:, None] + path(position, 2) * (speed ** 2)[:, None]
    return q, qd, qdd


def within_limits(path: BlendedPath, profile: SpeedProfile, v_max: np.ndarray,
                  a_max: np.ndarray) -> SpeedProfile:
    """``profile`` slowed uniformly (speeds divided by ``c >= 1``) so that the velocity and acceleration
    limits hold at :data:`CHECK_POINTS` points of every grid interval."""
    times = grid_times(profile)
    frac = np.linspace(0.0, 1.0, CHECK_POINTS)
    t = (times[:-1, None] + np.diff(times)[:, None] * frac).ravel()
    _, qd, qdd = evaluate(path, profile, times, t)
    c = max(1.0, float(np.max(np.abs(qd) / v_max)), float(np.sqrt(np.max(np.abs(qdd) / a_max))))
    if c <= 1.0:
        return profile
    return SpeedProfile(profile.s, profile.sd / (c * (1.0 + 1e-9)), profile.method)


def sample_times(profile: SpeedProfile, breaks: np.ndarray, dt: float) -> np.ndarray:
    """Uniform times of period ``dt`` from 0 with the times of the grid points at path ``breaks`` (s) and
    the end; uniform ones closer than 1 us to a break time are dropped."""
    times = grid_times(profile)
    marks = np.interp(breaks, profile.s, times)
    marks[0], marks[-1] = 0.0, times[-1]
    uniform = np.arange(0.0, times[-1], dt)
    near = np.min(np.abs(uniform[:, None] - marks[None, :]), axis=1) < 1e-6
    return np.unique(np.concatenate([uniform[~near], marks]))


def _sampled(path: BlendedPath, profile: SpeedProfile, joint_names: list[str]) -> JointTrajectory:
    """The trajectory of ``profile`` on ``path`` sampled at :func:`sample_times` (exact ends, at rest)."""
    t = sample_times(profile, path.breaks, TRAJECTORY_DT)
    q, qd, qdd = evaluate(path, profile, grid_times(profile), t)
    q[0], q[-1] = path.points[0], path.points[-1]
    qd[0] = qd[-1] = 0.0
    return JointTrajectory(list(joint_names), t, q, qd, qdd)


def time_parameterize(toppra: ModuleType, points: np.ndarray, room: np.ndarray, v_max: np.ndarray,
                      a_max: np.ndarray, joint_names: list[str]) -> TimedPath:
    """The certified path ``points`` ``(k, nq)`` (distinct consecutive waypoints; ``room`` ``(k,)``: the
    certified room of each inner waypoint along its two directions, :func:`~.blended_path.blend_lengths`)
    timed under velocity limits ``v_max`` and acceleration limits ``a_max`` ``(nq,)``, starting and ending
    at rest (module docstring). A single waypoint gives a one-point trajectory (``method = "none"``)."""
    points = np.asarray(points, dtype=float)
    if len(points) < 2:
        zero = np.zeros((1, points.shape[1]))
        return TimedPath(JointTrajectory(list(joint_names), np.zeros(1), points[:1], zero, zero), "none")
    path = BlendedPath(points, blend_lengths(points, np.asarray(room, dtype=float)))
    profile = toppra_profile(toppra, path, v_max, a_max)
    if profile is None:
        path = BlendedPath(points, np.zeros(len(points)))
        profile = rest_to_rest_profile(points, v_max, a_max)
    profile = within_limits(path, profile, v_max, a_max)
    return TimedPath(_sampled(path, profile, joint_names), profile.method)


__all__ = ["CHECK_POINTS", "GRID_INTERVALS", "LIMIT_SAFETY", "MIN_PIECE_INTERVALS", "TRAJECTORY_DT",
           "SpeedProfile", "TimedPath", "evaluate", "grid_times", "load_toppra", "rest_to_rest_profile",
           "sample_times", "time_parameterize", "toppra_grid", "toppra_profile", "within_limits"]
