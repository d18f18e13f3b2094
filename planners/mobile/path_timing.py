"""Time scaling along a planar path for a differential-drive robot.

The robot drives forwards along the path with heading = path tangent, so its
angular velocity is ``omega = kappa(s) v`` (``kappa`` the path curvature). The
cleaning robot's vacuum sits at the back (SCENARIOS.md S7): sharp turns at
speed would swing it off the wet track, so ``|omega| <= omega_max`` is
imposed as a speed cap ``v <= omega_max / |kappa|`` at the turns, together
with ``v <= v_max`` and ``|dv/dt| <= a_max``.

Construction of the speed profile along one smooth piece of length ``L``:

1. speed cap ``c(s) = min(v_max, omega_max / |kappa(s)|)``, eroded to
   ``c_e(s) = min over |sigma - s| <= v_max tau of c(sigma)``;
2. the classic forward/backward pass: the fastest profile under ``c_e`` that
   starts and ends at rest with ``|dv/dt| <= a_max``
   (``v_i = min(c_e, sqrt(v_{i-1}^2 + 2 a_max ds))`` both ways);
3. the resulting ``v(t)`` (piecewise linear in time, its acceleration jumps
   between ``-a_max, 0, +a_max``) is averaged over a sliding window of
   ``tau`` seconds (``smoothing_time``). The average of a continuous function
   over a window is C1, so the acceleration becomes continuous - at the via
   points (spline knots) and everywhere else - while ``|a| <= a_max`` still
   holds (an average of accelerations) and the window can move the robot by at
   most ``v_max tau`` along the path, which the erosion in step 1 already
   accounted for: ``v(t) <= c(s(t))`` and hence ``|omega| <= omega_max``.
   The motion starts and ends at rest with zero acceleration.

Where the heading must change without moving (at the start, at a waypoint
where the next leg leaves in another direction, at the corners of a
polyline path) the robot turns in place with a quintic time scaling of the
heading under ``omega_max`` and ``alpha_max``; speed and acceleration are 0
on both sides of such a junction, so they stay continuous.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from kinserve.kinematics.errors import InputError
from kinserve.kinematics.validation import as_positive, as_real

from ..time_scaling import minimum_time, quintic_time_scaling
from ._checks import MAX_SAMPLES, check_samples
from .smoothing import SmoothPath


@dataclass
class DriveTrajectory:
    """Samples every ``dt`` of a planar drive: pose ``(x, y, heading)``, speed ``v``,
    tangential acceleration ``a`` and angular velocity ``omega``.

    ``phases`` lists ``(kind, t_start, t_end)`` with kind ``"drive"`` or ``"turn"``.
    """

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    heading: np.ndarray
    v: np.ndarray
    a: np.ndarray
    omega: np.ndarray
    phases: list = field(default_factory=list)

    @property
    def duration(self) -> float:
        """Time from the first to the last sample (s)."""
        return float(self.t[-1] - self.t[0])

    @property
    def points(self) -> np.ndarray:
        """Positions ``(N, 2)`` of the samples (map units)."""
        return np.stack([self.x, self.y], axis=1)

    @property
    def length(self) -> float:
        """Length of the polyline through the samples (map units)."""
        return float(np.sum(np.hypot(np.diff(self.x), np.diff(self.y))))

    def summary(self) -> dict:
        """Duration, length and the peak speed, acceleration and turn rate as a JSON-ready dict."""
        return {
            "duration": self.duration,
            "length": self.length,
            "max_speed": float(np.abs(self.v).max()),
            "max_acceleration": float(np.abs(self.a).max()),
            "max_angular_velocity": float(np.abs(self.omega).max()),
            "turns_in_place": sum(1 for k, *_ in self.phases if k == "turn"),
        }

    @staticmethod
    def concatenate(parts: list["DriveTrajectory"]) -> "DriveTrajectory":
        """Join trajectories end to start (each next one shifted to begin where the last ended).

        Refuses anything but a non-empty list of :class:`DriveTrajectory` (None entries are skipped)."""
        if not isinstance(parts, (list, tuple)):
            raise InputError(f"parts must be a list of DriveTrajectory, got {type(parts).__name__}")
        for k, p in enumerate(parts):
            if p is not None and not isinstance(p, DriveTrajectory):
                raise InputError(f"parts[{k}] must be a DriveTrajectory, got {type(p).__name__}")
        parts = [p for p in parts if p is not None and len(p.t)]
        if not parts:
            raise InputError("nothing to concatenate")
        out = {k: [getattr(parts[0], k)] for k in ("t", "x", "y", "heading", "v", "a", "omega")}
        phases = list(parts[0].phases)
        t_end = parts[0].t[-1]
        for p in parts[1:]:
            shift = t_end - p.t[0]
            out["t"].append(p.t[1:] + shift)
            for k in ("x", "y", "heading", "v", "a", "omega"):
                out[k].append(getattr(p, k)[1:])
            phases += [(kind, a + shift, b + shift) for kind, a, b in p.phases]
            t_end = p.t[-1] + shift
        cat = {k: np.concatenate(v) for k, v in out.items()}
        cat["heading"] = np.unwrap(cat["heading"])
        return DriveTrajectory(phases=phases, **cat)


def _positive(v: object, name: str) -> float:
    """``v`` as a float in ``(0, 1e6]`` (:func:`as_positive`: refuses bools, non-numbers, NaN, inf, huge)."""
    return as_positive(v, name)


def _check_dt(duration: float, dt: float, what: str) -> None:
    """:class:`InputError` when sampling ``duration`` seconds every ``dt`` exceeds 10**7 samples."""
    check_samples(duration / dt + 1.0, "dt", dt, f"{what} of {duration:.6g} s")


def turn_in_place(x: float, y: float, heading0: float, heading1: float, *, omega_max: float, alpha_max: float,
                  dt: float = 0.01) -> DriveTrajectory | None:
    """Rotate at ``(x, y)`` from ``heading0`` to ``heading1`` (shortest way) with a quintic; None if
    aligned.

    Refused: ``x``, ``y``, headings not finite numbers with ``|x| <= 1e6``;
    ``omega_max``, ``alpha_max``, ``dt`` not in ``(0, 1e6]``; a ``dt`` so small
    that the turn would take more than 10**7 samples."""
    x, y = as_real(x, "x"), as_real(y, "y")
    heading0, heading1 = as_real(heading0, "heading0"), as_real(heading1, "heading1")
    omega_max = _positive(omega_max, "omega_max")
    alpha_max = _positive(alpha_max, "alpha_max")
    dt = _positive(dt, "dt")
    d = (heading1 - heading0 + math.pi) % (2.0 * math.pi) - math.pi
    if abs(d) < 1e-9:
        return None
    T = minimum_time("quintic", abs(d), omega_max, alpha_max)
    _check_dt(T, dt, "this turn in place")
    sc = quintic_time_scaling(T)
    n = max(2, int(math.ceil(T / dt)) + 1)
    t = np.linspace(0.0, T, n)
    s, sd, _ = sc.evaluate(t)
    z = np.zeros(n)
    return DriveTrajectory(t, np.full(n, float(x)), np.full(n, float(y)), heading0 + d * s, z, z.copy(),
                           d * sd, [("turn", 0.0, T)])


def _drive_piece(path: SmoothPath, s_a: float, s_b: float, v_max, a_max,
                 omega_max, dt, tau) -> DriveTrajectory:
    L = s_b - s_a
    n_s = max(50, int(math.ceil(L / 0.05)))
    n_s = min(n_s, 200_000)
    ss = np.linspace(s_a, s_b, n_s + 1)
    ds = L / n_s
    _, _, _, kappa = path.at(ss)
    # |kappa| is piecewise linear between the path's samples, so its peaks sit at those samples, which
    # may fall between the grid nodes: each node takes the largest |kappa| of its two adjacent intervals
    kmax = np.abs(kappa)
    inside = (path.s > s_a) & (path.s < s_b)
    if inside.any():
        seg = np.clip(np.searchsorted(ss, path.s[inside]), 1, n_s)  # sample lies in (ss[seg-1], ss[seg]]
        ks = np.abs(path.curvature[inside])
        np.maximum.at(kmax, seg, ks)
        np.maximum.at(kmax, seg - 1, ks)
    with np.errstate(divide="ignore"):
        cap = np.minimum(v_max, np.where(kmax > 1e-12, omega_max / kmax, np.inf))
    delta = v_max * tau
    w = min(2 * int(math.ceil(delta / ds)) + 1, 2 * n_s + 1)  # a wider window sees no other value
    cap = ndimage.minimum_filter1d(cap, size=w, mode="nearest")
    v = cap.copy()
    v[0] = v[-1] = 0.0
    for i in range(1, len(v)):
        v[i] = min(v[i], math.sqrt(v[i - 1] ** 2 + 2.0 * a_max * ds))
    for i in range(len(v) - 2, -1, -1):
        v[i] = min(v[i], math.sqrt(v[i + 1] ** 2 + 2.0 * a_max * ds))
    vv = v[1:] + v[:-1]
    t_nodes = np.concatenate([[0.0], np.cumsum(2.0 * ds / np.where(vv > 0, vv, np.inf))])
    if not np.isfinite(t_nodes[-1]) or t_nodes[-1] <= 0:
        raise InputError("speed profile degenerate (zero speed cap inside a path piece)")
    T = t_nodes[-1]
    _check_dt(T, dt, "this drive")
    n_t = max(8, int(math.ceil(T / dt)))  # a dt longer than the drive still gives a few samples
    tt = np.linspace(0.0, T, n_t + 1)
    h = T / n_t
    if tau / h > MAX_SAMPLES:
        raise InputError(f"smoothing_time = {tau:.6g} s spans more than {MAX_SAMPLES:,} samples of this "
                         f"{T:.6g} s drive (sampled every {h:.3g} s): give a shorter smoothing_time or a "
                         "larger a_max")
    v_t = np.interp(tt, t_nodes, v)
    m = max(1, int(round(tau / h)))
    kernel = np.full(m, 1.0 / m)
    v_sm = np.convolve(v_t, kernel, mode="full")  # length n_t + m, starts and ends at 0
    v_sm = np.concatenate([[0.0], v_sm, [0.0]])  # at rest one sample before and after
    s_sm = np.concatenate([[0.0], np.cumsum(0.5 * (v_sm[1:] + v_sm[:-1]) * h)])
    # match the length exactly without raising any speed: the discretised integral is a hair off
    scale = L / s_sm[-1]
    s_sm *= scale
    if scale >= 1.0:
        h *= scale  # same speeds, stretched in time (accelerations shrink)
    else:
        v_sm *= scale  # same timing, slightly slower
    a_sm = np.gradient(v_sm, h)
    t = h * np.arange(len(v_sm))
    x, y, heading, kap = path.at(s_a + s_sm)
    return DriveTrajectory(t, x, y, heading, v_sm, a_sm, kap * v_sm, [("drive", 0.0, float(t[-1]))])


def time_scale_path(
    path: SmoothPath,
    *,
    v_max: float,
    a_max: float,
    omega_max: float,
    alpha_max: float | None = None,
    dt: float = 0.01,
    smoothing_time: float | None = None,
    initial_heading: float | None = None,
) -> DriveTrajectory:
    """Time-scale a :class:`SmoothPath` under ``v_max``, ``a_max`` and the turn cap ``omega_max``.

    ``alpha_max`` (rad/s^2, default ``omega_max / 0.5 s``) limits turns in
    place; ``smoothing_time`` (s, default ``0.25 v_max / a_max``) is the
    averaging window that makes the acceleration continuous (jerk
    ``<= a_max / smoothing_time``). With ``initial_heading`` the robot first
    turns in place to the path's initial tangent. Polyline corners become
    turns in place. Output sampled every ``dt`` seconds (or finer).

    Refused (:class:`InputError` and subclasses): ``path`` not a
    :class:`SmoothPath`; limits, ``dt`` or ``smoothing_time`` not in
    ``(0, 1e6]``; a smoothing window longer than 10**7 ``dt``; a ``dt`` so
    small that the trajectory would take more than 10**7 samples;
    ``initial_heading`` not a finite number with ``|x| <= 1e6``.
    """
    if not isinstance(path, SmoothPath):
        raise InputError(f"path must be a SmoothPath (from smooth_path or polyline_path), got "
                         f"{type(path).__name__}")
    if initial_heading is not None:
        initial_heading = as_real(initial_heading, "initial_heading")
    v_max = _positive(v_max, "v_max")
    a_max = _positive(a_max, "a_max")
    omega_max = _positive(omega_max, "omega_max")
    alpha_max = 2.0 * omega_max if alpha_max is None else _positive(alpha_max, "alpha_max")
    dt = _positive(dt, "dt")
    tau = 0.25 * v_max / a_max if smoothing_time is None else _positive(smoothing_time, "smoothing_time")
    if tau / dt > MAX_SAMPLES:
        what = ("smoothing_time" if smoothing_time is not None
                else "the default smoothing_time 0.25 v_max / a_max")
        raise InputError(f"{what} = {tau:.6g} s is more than {MAX_SAMPLES:,} time steps dt = {dt!r}: raise "
                         "a_max or dt, or give a shorter smoothing_time")
    parts: list[DriveTrajectory | None] = []
    stops = np.asarray(path.stops, dtype=float)
    heading = initial_heading
    for s_a, s_b in zip(stops[:-1], stops[1:]):
        if s_b - s_a <= 1e-9:
            continue
        x0, y0, h0, _ = path.at(s_a + 1e-9)
        if heading is not None:
            parts.append(turn_in_place(float(x0), float(y0), heading, float(h0), omega_max=omega_max,
                                       alpha_max=alpha_max, dt=dt))
        piece = _drive_piece(path, s_a, s_b, v_max, a_max, omega_max, dt, tau)
        parts.append(piece)
        heading = float(piece.heading[-1])
    if not any(p is not None for p in parts):
        x, y, h, _ = path.at(0.0)
        z = np.zeros(1)
        return DriveTrajectory(z, np.atleast_1d(x), np.atleast_1d(y), np.atleast_1d(h), z, z, z, [])
    return DriveTrajectory.concatenate(parts)


def drive_through(
    paths: list[SmoothPath],
    *,
    v_max: float,
    a_max: float,
    omega_max: float,
    alpha_max: float | None = None,
    dt: float = 0.01,
    smoothing_time: float | None = None,
    initial_heading: float | None = None,
) -> DriveTrajectory:
    """Drive consecutive paths (e.g. the legs between waypoints), stopping and turning in place between
    them. Refuses an empty ``paths`` or entries that are not :class:`SmoothPath`, and what
    :func:`time_scale_path` refuses."""
    if not isinstance(paths, (list, tuple)) or not paths:
        raise InputError(f"paths must be a non-empty list of SmoothPath, got {paths!r:.60}")
    for k, p in enumerate(paths):
        if not isinstance(p, SmoothPath):
            raise InputError(f"paths[{k}] must be a SmoothPath, got {type(p).__name__}")
    parts = []
    heading = initial_heading
    for p in paths:
        tr = time_scale_path(p, v_max=v_max, a_max=a_max, omega_max=omega_max, alpha_max=alpha_max, dt=dt,
                             smoothing_time=smoothing_time, initial_heading=heading)
        parts.append(tr)
        heading = float(tr.heading[-1])
    return DriveTrajectory.concatenate(parts)
