"""S6: the three-wheel omnidirectional base (SCENARIOS.md S6, seed 003).

Model (:class:`planners.mobile.OmniBase`): wheels A, B, C at distance ``D``
from the centre at body angles 60, 180, 300 degrees (the seed's figure),
rolling tangentially, radius ``R``. Inverse kinematics ``phi = H(theta) qdot``
with ``qdot = (xdot, ydot, thetadot)`` in world axes; ``H`` depends on the
heading only (the seed's matrix also contained the world position (x, y) - a
mistake). Forward kinematics ``qdot = H(theta)^-1 phi``; the pose is
integrated with ``scipy.integrate.solve_ivp``.

Experiments (the seed's inputs where it gives them):

a. *Equal wheel speeds* ``phi = (+-0.1, +-0.1, +-0.1)`` rad/s from the origin
   for 10 s: the centre stays put and the base turns at
   ``thetadot = -R phi / D``, opposite to the wheels' sense (positive ``phi``
   is counter-clockwise about each outward axle).
b. *Wheel A alone* ``phi = (pi/2, 0, 0)`` from ``(0, 0, 30 deg)``: the body
   twist is constant, so the centre runs on a circle. Analytically (wheels B
   and C do not roll, so their hubs move along their axles; the instantaneous
   centre of rotation is where the tangent lines through B and C meet):
   radius ``2 D``, centre ``p0 - 2 D Rot(theta0) e_A`` (``e_A`` wheel A's
   outward direction), turn rate ``thetadot = -R phi_A / (3 D)``. The
   simulated centre path (one full turn) is fitted by a least-squares circle
   and compared with those values.
c. *A body-twist command sequence* (forward, strafe, turn in place, arc,
   diagonal): each body twist ``(v_x, v_y, omega)`` becomes constant wheel
   speeds ``H(0) (v_x, v_y, omega)`` (``H(theta) Rot(theta) = H(0)``), the
   simulation is compared with the exact SE(2) exponential of each twist, and
   the wheel speeds are mapped back to the twist (forward kinematics).

Units: metres, radians, seconds. Artefacts: ``rotation.png``, ``circle.png``,
``sequence.png``, ``wheel_speeds.png``, ``trajectory.csv`` (the sequence).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from kinserve import viz
from kinserve.planners.mobile import OmniBase

#: Default geometry (the seed gives no numbers): 0.2 m centre-to-wheel, 0.05 m wheel radius.
CENTER_DISTANCE = 0.20
WHEEL_RADIUS = 0.05
WHEEL_NAMES = ("A", "B", "C")

#: Part (c): (duration s, body twist (v_x m/s, v_y m/s, omega rad/s), label).
TWIST_SEQUENCE = (
    (2.0, (0.30, 0.0, 0.0), "forward"),
    (2.0, (0.0, 0.30, 0.0), "strafe left"),
    (2.0, (0.0, 0.0, math.pi / 4), "turn in place"),
    (3.0, (0.30, 0.0, 0.50), "forward arc"),
    (2.0, (-0.20, -0.20, 0.0), "diagonal back"),
)


def fit_circle(points) -> tuple[np.ndarray, float]:
    """Least-squares (Kasa) circle ``|p - c| = r`` through ``points (N, 2)``: solve
    ``2 c . p + (r^2 - |c|^2) = |p|^2`` for ``c`` and ``r`` (exact for points on a circle)."""
    P = np.asarray(points, dtype=float)
    A = np.c_[2.0 * P, np.ones(len(P))]
    b = np.sum(P * P, axis=1)
    (cx, cy, k), *_ = np.linalg.lstsq(A, b, rcond=None)
    return np.array([cx, cy]), float(math.sqrt(k + cx * cx + cy * cy))


def se2_step(pose, twist_body, t: float) -> np.ndarray:
    """Exact pose after moving for ``t`` s with the constant body twist ``(v_x, v_y, omega)``.

    ``omega != 0``: ``dp_body = [sin(wt) v_x - (1 - cos wt) v_y, (1 - cos wt) v_x + sin(wt) v_y] / w``;
    ``omega = 0``: ``dp_body = t (v_x, v_y)``. World ``dp = Rot(theta) dp_body``, ``theta += w t``.
    """
    x, y, th = (float(v) for v in pose)
    vx, vy, w = (float(v) for v in twist_body)
    if abs(w * t) < 1e-12:
        dx, dy = vx * t, vy * t
    else:
        s, c = math.sin(w * t), 1.0 - math.cos(w * t)
        dx, dy = (s * vx - c * vy) / w, (c * vx + s * vy) / w
    ct, st = math.cos(th), math.sin(th)
    return np.array([x + ct * dx - st * dy, y + st * dx + ct * dy, th + w * t])


def _outline(base: OmniBase, pose) -> tuple[np.ndarray, np.ndarray]:
    """Closed triangle through the wheel contact points, and the wheel positions, at ``pose``."""
    W = base.wheel_positions(pose)
    return np.vstack([W, W[:1]]), W


def _draw_bases(ax, base: OmniBase, poses, color="grey"):
    for k, pose in enumerate(poses):
        tri, W = _outline(base, pose)
        ax.plot(tri[:, 0], tri[:, 1], color=color, linewidth=0.8, alpha=0.8,
                label="base (wheels A, B, C)" if k == 0 else None)
        ax.plot(W[0, 0], W[0, 1], "o", color="#d62728", markersize=4, label="wheel A" if k == 0 else None)
        ax.plot(W[1:, 0], W[1:, 1], "o", color="black", markersize=3)
        x, y, th = pose
        ax.annotate("", xy=(x + 0.6 * base.center_distance * math.cos(th),
                            y + 0.6 * base.center_distance * math.sin(th)),
                    xytext=(x, y), arrowprops=dict(arrowstyle="->", color=color, linewidth=0.9))


def _rotation_in_place(base: OmniBase, phi: float, duration: float) -> dict:
    t_eval = np.linspace(0.0, duration, 201)
    t, X = base.simulate(np.full(3, phi), (0.0, 0.0, 0.0), (0.0, duration), t_eval=t_eval)
    rate = float((X[-1, 2] - X[0, 2]) / duration)
    expected = -base.wheel_radius * phi / base.center_distance
    return {
        "wheel_speeds": [phi] * 3,
        "duration": duration,
        "theta_rate": rate,
        "theta_rate_expected": expected,
        "final_theta": float(X[-1, 2]),
        "max_centre_displacement": float(np.max(np.hypot(X[:, 0], X[:, 1]))),
        "sense": "opposite to the wheels" if rate * phi < 0 else ("same as the wheels"
                                                                  if rate * phi > 0 else "none"),
        "samples": np.c_[t, X][::10],
        "_t": t,
        "_X": X,
    }


def run(out: Path, *, center_distance: float = CENTER_DISTANCE, wheel_radius: float = WHEEL_RADIUS,
        equal_speed: float = 0.1, single_wheel_speed: float = math.pi / 2,
        initial_heading_deg: float = 30.0) -> dict:
    """Run S6 into ``out``; returns the key numbers (see the module docstring)."""
    out = Path(out)
    base = OmniBase(wheel_radius=float(wheel_radius), center_distance=float(center_distance))
    D, R = base.center_distance, base.wheel_radius

    # (a) equal wheel speeds, both senses
    rot = {sign: _rotation_in_place(base, sign * float(equal_speed), 10.0) for sign in (+1, -1)}
    fig = viz.series_figure(
        rot[+1]["_t"],
        {f"heading θ, φ = +{equal_speed:g} rad/s (all wheels)": rot[+1]["_X"][:, 2],
         f"heading θ, φ = −{equal_speed:g} rad/s (all wheels)": rot[-1]["_X"][:, 2],
         "centre x (φ = +)": rot[+1]["_X"][:, 0], "centre y (φ = +)": rot[+1]["_X"][:, 1]},
        xlabel="time (s)", ylabel="rad or m",
        title=f"Equal wheel speeds: rotation in place, θ̇ = −Rφ/D = {rot[+1]['theta_rate_expected']:+.3f} "
              "rad/s")
    viz.save_png(fig, out / "rotation.png")

    # (b) wheel A alone: a circle
    phi_a = float(single_wheel_speed)
    pose0 = np.array([0.0, 0.0, math.radians(initial_heading_deg)])
    rate_b = -R * phi_a / (3.0 * D)
    period = 2.0 * math.pi / abs(rate_b)
    t_eval = np.linspace(0.0, period, 721)
    tb, Xb = base.simulate([phi_a, 0.0, 0.0], pose0, (0.0, period), t_eval=t_eval)
    centre_fit, radius_fit = fit_circle(Xb[:, :2])
    e_a = np.array([math.cos(base.wheel_angles[0] + pose0[2]), math.sin(base.wheel_angles[0] + pose0[2])])
    centre_exact = pose0[:2] - 2.0 * D * e_a
    radius_exact = 2.0 * D
    dev = np.abs(np.hypot(*(Xb[:, :2] - centre_exact).T) - radius_exact)
    twist_b = base.body_twist([phi_a, 0.0, 0.0])
    circle = {
        "wheel_speeds": [phi_a, 0.0, 0.0],
        "initial_pose": pose0,
        "duration": period,
        "body_twist": twist_b,
        "theta_rate": float((Xb[-1, 2] - Xb[0, 2]) / period),
        "theta_rate_expected": rate_b,
        "fitted_radius": radius_fit,
        "fitted_centre": centre_fit,
        "analytic_radius": radius_exact,
        "analytic_centre": centre_exact,
        "radius_error": abs(radius_fit - radius_exact),
        "centre_error": float(np.linalg.norm(centre_fit - centre_exact)),
        "max_radial_deviation": float(dev.max()),
        "closes": float(np.linalg.norm(Xb[-1, :2] - Xb[0, :2])),
        "samples": np.c_[tb, Xb][::8],
    }
    ang = np.linspace(0.0, 2.0 * math.pi, 361)
    fig = viz.xy_figure(
        {"centre path, wheel A only (solve_ivp)": Xb[:, :2],
         f"fitted circle r = {radius_fit:.4f} m": centre_fit + radius_fit * np.c_[np.cos(ang), np.sin(ang)]},
        points={"start": pose0[:2], f"centre ({centre_fit[0]:.3f}, {centre_fit[1]:.3f})": centre_fit},
        title=f"Wheel A only: circle of radius 2D = {radius_exact:.3f} m (fit {radius_fit:.4f} m)")
    ax = fig.axes[0]
    _draw_bases(ax, base, Xb[::90])
    ax.plot(*np.vstack([centre_fit, pose0[:2]]).T, ":", color="grey", linewidth=0.8)
    ax.legend(loc="upper right", fontsize=8)
    ax.autoscale()
    viz.save_png(fig, out / "circle.png")

    # (c) a body-twist command sequence
    pose = np.zeros(3)
    T_all, X_all, PHI_all, commands = [], [], [], []
    t0 = 0.0
    max_err = 0.0
    round_trip = 0.0
    for duration, twist, label in TWIST_SEQUENCE:
        phi = base.wheel_speeds(np.asarray(twist, dtype=float), 0.0)  # body twist = world twist at heading 0
        back = base.body_twist(phi)
        round_trip = max(round_trip, float(np.abs(back - twist).max()))
        t_eval = np.linspace(0.0, duration, int(round(duration * 50)) + 1)
        t, X = base.simulate(phi, pose, (0.0, duration), t_eval=t_eval)
        exact = se2_step(pose, twist, duration)
        err = float(np.abs(X[-1] - exact).max())
        max_err = max(max_err, err)
        commands.append({"label": label, "duration": duration, "body_twist": twist, "wheel_speeds": phi,
                         "start_pose": pose, "end_pose": X[-1], "end_pose_exact": exact, "pose_error": err})
        T_all.append(t0 + t)
        X_all.append(X)
        PHI_all.append(np.tile(phi, (len(t), 1)))
        pose = X[-1].copy()
        t0 += duration
    T = np.concatenate(T_all)
    X = np.concatenate(X_all)
    PHI = np.concatenate(PHI_all)
    np.savetxt(out / "trajectory.csv", np.c_[T, X, PHI], delimiter=",", fmt="%.12g",
               header="t_s,x_m,y_m,theta_rad,phi_A_rad_s,phi_B_rad_s,phi_C_rad_s", comments="")
    marks: dict[tuple, list[str]] = {}  # commands starting at the same place share one label
    for k, c in enumerate(commands):
        marks.setdefault(tuple(np.round(c["start_pose"][:2], 6)), []).append(f"{k + 1}: {c['label']}")
    marks.setdefault(tuple(np.round(X[-1, :2], 6)), []).append("end")
    fig = viz.xy_figure({"centre path": X[:, :2]},
                        points={", ".join(v): np.array(k) for k, v in marks.items()},
                        title="Body-twist command sequence (simulated with solve_ivp)")
    ax = fig.axes[0]
    _draw_bases(ax, base, [c["start_pose"] for c in commands
                           if abs(c["body_twist"][0]) + abs(c["body_twist"][1]) > 0]
                + [X[-1]])
    ax.legend(loc="best", fontsize=8)
    ax.autoscale()
    viz.save_png(fig, out / "sequence.png")
    fig = viz.series_figure(T, {f"wheel {n}": PHI[:, i] for i, n in enumerate(WHEEL_NAMES)}
                            | {"heading θ (rad)": X[:, 2]},
                            xlabel="time (s)", ylabel="wheel speed (rad/s)",
                            title="Wheel speeds φ = H(0)·(v_x, v_y, ω) of the command sequence")
    ax = fig.axes[0]
    for c in np.cumsum([d for d, *_ in TWIST_SEQUENCE])[:-1]:
        ax.axvline(c, color="grey", linewidth=0.6, linestyle=":")
    viz.save_png(fig, out / "wheel_speeds.png")

    for r in rot.values():
        r.pop("_t"), r.pop("_X")
    return {
        "center_distance": D,
        "wheel_radius": R,
        "wheel_angles_deg": np.degrees(base.wheel_angles),
        "rotation_rate": rot[+1]["theta_rate"],
        "rotation_sense": rot[+1]["sense"],
        "circle_radius_fit": radius_fit,
        "circle_radius_analytic": radius_exact,
        "circle_centre_error": circle["centre_error"],
        "sequence_max_pose_error": max_err,
        "rotation_max_centre_displacement": max(r["max_centre_displacement"] for r in rot.values()),
        "sequence_round_trip_error": round_trip,
        "rotation_in_place": {"positive": rot[+1], "negative": rot[-1]},
        "circle": circle,
        "twist_sequence": {"commands": commands, "final_pose": X[-1], "max_pose_error": max_err,
                           "round_trip_error": round_trip, "max_wheel_speed": float(np.abs(PHI).max())},
    }
