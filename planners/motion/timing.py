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

toppra enforces the limits at the grid points only; the largest velocity and
acceleration over every grid interval are then found exactly (on an interval,
``qdd`` is a quadratic and ``qd`` a cubic in time: :func:`limit_ratios`) and, if
any limit is exceeded, the profile is slowed uniformly (``sd / c``: velocities
scale by ``1 / c``, accelerations by ``1 / c^2``) so that none is, at any instant.

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


class TrajectorySamples(NamedTuple):
    """``positions``, ``velocities`` and ``accelerations`` ``(n, nq)`` at some times."""

    positions: np.ndarray
    velocities: np.ndarray
    accelerations: np.ndarray


def evaluate(path: BlendedPath, profile: SpeedProfile, times: np.ndarray, t: np.ndarray) -> TrajectorySamples:
    """The :class:`TrajectorySamples` at times ``t`` (module docstring); ``times``: :func:`grid_times` of
    ``profile``."""
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
    return TrajectorySamples(q, qd, qdd)


def _interval_polynomials(path: BlendedPath, profile: SpeedProfile):
    """Per grid interval ``i`` (``tau`` in ``[0, dt_i]``): its piece's ``E``, ``C`` ``(N, nq)``, ``sigma_0``,
    ``sd_i``, ``u_i``, ``dt_i`` ``(N, 1)`` and the acceleration ``qdd = alpha + beta tau + gamma tau^2``
    (:func:`limit_ratios`)."""
    s, sd = profile.s, profile.sd
    ds = np.diff(s)
    u = (sd[1:] ** 2 - sd[:-1] ** 2) / (2.0 * ds)
    dt = np.diff(grid_times(profile))
    piece = np.clip(np.searchsorted(path.breaks, 0.5 * (s[:-1] + s[1:]), side="right") - 1, 0,
                    path.n_pieces - 1)
    E, C = path.directions[piece], path.curvatures[piece]
    sigma0, v0 = (s[:-1] - path.breaks[piece])[:, None], sd[:-1, None]
    u, dt = u[:, None], dt[:, None]
    alpha = E * u + C * (sigma0 * u + v0 ** 2)
    return E, C, sigma0, v0, u, dt, alpha, 3.0 * C * v0 * u, 1.5 * C * u ** 2


def limit_ratios(path: BlendedPath, profile: SpeedProfile, v_max: np.ndarray,
                 a_max: np.ndarray) -> tuple[float, float]:
    """``(max_t max_k |qd_k| / v_k, max_t max_k |qdd_k| / a_k)`` over the whole trajectory, exactly.

    On grid interval ``i`` the path is one piece ``q = A + E sigma + C sigma^2 / 2`` and
    ``sigma(tau) = sigma_0 + sd_i tau + u_i tau^2 / 2``, ``sd(tau) = sd_i + u_i tau``, so
    ``qdd = E u + C (sigma u + sd^2) = alpha + beta tau + gamma tau^2`` with ``alpha = E u + C (sigma_0 u +
    sd_i^2)``, ``beta = 3 C sd_i u``, ``gamma = 3 C u^2 / 2``: its extremes are at the ends or at
    ``-beta / (2 gamma)``; ``qd = (E + C sigma) sd`` is a cubic whose extremes are at the ends or at the
    roots of ``qdd``."""
    E, C, sigma0, v0, u, dt, alpha, beta, gamma = _interval_polynomials(path, profile)
    with np.errstate(divide="ignore", invalid="ignore"):
        vertex = np.where(gamma != 0.0, -beta / (2.0 * gamma), 0.0)
        disc = np.sqrt(np.maximum(beta ** 2 - 4.0 * alpha * gamma, 0.0))
        roots = [np.where(gamma != 0.0, (-beta + sign * disc) / (2.0 * gamma),
                          np.where(beta != 0.0, -alpha / beta, 0.0)) for sign in (1.0, -1.0)]
    acc, vel = np.zeros_like(alpha), np.zeros_like(alpha)
    for tau in (np.zeros_like(alpha), np.broadcast_to(dt, alpha.shape), vertex, *roots):
        tau = np.clip(np.nan_to_num(tau), 0.0, dt)
        acc = np.maximum(acc, np.abs(alpha + beta * tau + gamma * tau ** 2))
        sigma = sigma0 + v0 * tau + 0.5 * u * tau ** 2
        vel = np.maximum(vel, np.abs((E + C * sigma) * (v0 + u * tau)))
    return float(np.max(vel / v_max)), float(np.max(acc / a_max))


def within_limits(path: BlendedPath, profile: SpeedProfile, v_max: np.ndarray,
                  a_max: np.ndarray) -> SpeedProfile:
    """``profile`` slowed uniformly (speeds divided by ``c >= 1``) so that the velocity and acceleration
    limits hold at every instant (:func:`limit_ratios`)."""
    ratio_v, ratio_a = limit_ratios(path, profile, v_max, a_max)
    c = max(1.0, ratio_v, float(np.sqrt(ratio_a)))
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


__all__ = ["GRID_INTERVALS", "LIMIT_SAFETY", "MIN_PIECE_INTERVALS", "TRAJECTORY_DT", "SpeedProfile",
           "TimedPath", "TrajectorySamples", "evaluate", "grid_times", "limit_ratios", "load_toppra",
           "rest_to_rest_profile", "sample_times", "time_parameterize", "toppra_grid", "toppra_profile",
           "within_limits"]
