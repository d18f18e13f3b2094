"""S7: the cleaning robot in the mall - A* between waypoints, best order, smoothing, timing (SCENARIOS.md S7).

Map (:mod:`planners.mobile.mall`): 480 x 480 map units, hot-dog stands
(220,100)-(260,140) and (160,160)-(200,200), fountain centre (240,240) radius
40, escalators (135,375)-(185,425) and (296,375)-(345,425). The robot is a
20 x 20 differential drive planned by its centre, so every obstacle is
inflated by 10 and the centre keeps 10 from the walls.

1. *Given order* - ``waypoints`` in ``result.json`` is the visiting order of
   the document: Start (260,60), 1 (360,170), 2 (150,70), 3 (150,300),
   4 (310,330), End (230,430). Consecutive waypoints are joined by A* on the
   1-unit lattice (8-connected, Euclidean heuristic, no corner cutting);
   ``segments`` holds each leg's raw A* polyline, ``length`` their total length.
2. *Best order* - Start and End fixed, the four intermediate waypoints
   reordered to minimise the total A* path length (Held-Karp over the
   pairwise A* costs, ``pairwise_costs``): ``best_order`` (names),
   ``best_order_waypoints``, ``best_order_segments``, ``best_order_length``.
3. *Smoothing* - each leg of the given order is string-pulled, relaxed and
   fitted by a C2 spline that is verified against the inflated obstacles
   (:func:`planners.mobile.smooth_path`); ``smoothed`` is the joined path.
4. *Timing* - the robot drives each smoothed leg with heading = tangent,
   ``v <= v_max``, ``|dv/dt| <= a_max`` and the turn cap ``|omega| = |kappa| v
   <= omega_max`` (the vacuum sits at the back: sharp turns at speed would
   swing it off the track); speed and acceleration are continuous (via
   points included); at each waypoint it stops and turns in place towards the
   next leg (quintic, ``|omega| <= omega_max``). ``duration``,
   ``max_angular_velocity``...
5. *Differential drive* - wheel speeds ``phi_R,L = (v +- omega b / 2) / r``
   along the trajectory (``trajectory.csv``); integrating them back through
   the unicycle model (``solve_ivp``) reproduces the path
   (``dead_reckoning_error``).

Units: map units (u), seconds, radians. Defaults: ``v_max`` 50 u/s,
``a_max`` 25 u/s^2, ``omega_max`` 1 rad/s, wheel radius 3 u, track 20 u.
Artefacts: ``map.png``, ``best_order.png``, ``speed.png``, ``wheels.png``,
``trajectory.csv``, ``scene.html`` (the map in 3-D with the base driving).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from kinserve import viz
from kinserve.planners.mobile import (
    DiffDrive,
    drive_through,
    mall,
    pairwise_costs,
    plan_waypoints,
    smooth_path,
)

from .map_drawing import draw_keep_out, map_scene, resample_motion, viz_obstacles

LABELS = ("Start", "1", "2", "3", "4", "End")


def _join(polylines) -> np.ndarray:
    """Polylines end to start, each shared end point once."""
    parts = [np.asarray(polylines[0], dtype=float)]
    for p in polylines[1:]:
        p = np.asarray(p, dtype=float)
        parts.append(p[1:] if np.allclose(p[0], parts[-1][-1]) else p)
    return np.concatenate(parts)


def _polyline_length(P) -> float:
    return float(np.sum(np.linalg.norm(np.diff(np.asarray(P, dtype=float), axis=0), axis=1)))


def run(out: Path, *, resolution: float = 1.0, v_max: float = 50.0, a_max: float = 25.0,
        omega_max: float = 1.0, wheel_radius: float = 3.0, track: float = 20.0, heuristic: str = "euclidean",
        turn_penalty: float = 0.0, proximity_weight: float = 0.0, smoothing_margin: float = 6.0,
        knot_spacing: float = 12.0, dt: float = 0.02, fps: float = 30.0, scene: bool = True) -> dict:
    """Run S7 into ``out``; returns the key numbers (see the module docstring)."""
    out = Path(out)
    grid = mall.s7_map(resolution)
    W = mall.s7_waypoints()
    astar_kw = dict(heuristic=heuristic, turn_penalty=turn_penalty, proximity_weight=proximity_weight)

    # 1-2: the given order and the best order
    given = plan_waypoints(grid, W, order="given", names=LABELS, **astar_kw)
    best = plan_waypoints(grid, W, order="optimal", names=LABELS, **astar_kw)
    C, _ = pairwise_costs(grid, W, **astar_kw)

    # 3: smoothing, leg by leg (the robot stops at every waypoint)
    legs = [smooth_path(grid, seg.points, margin=smoothing_margin, knot_spacing=knot_spacing)
            for seg in given.segments]
    smoothed = _join([leg.points for leg in legs])

    # 4: time scaling with the turn cap
    traj = drive_through(legs, v_max=v_max, a_max=a_max, omega_max=omega_max, dt=dt)
    summary = traj.summary()
    jerk = np.diff(traj.a) / np.diff(traj.t)

    # 5: differential-drive wheel speeds, and dead reckoning back through the unicycle model
    drive = DiffDrive(wheel_radius=wheel_radius, track=track)
    phi = drive.wheel_speeds(traj.v, traj.omega)
    t0, t1 = float(traj.t[0]), float(traj.t[-1])

    def wheel_speeds_at(t):
        return [np.interp(t, traj.t, phi[:, 0]), np.interp(t, traj.t, phi[:, 1])]

    n_check = 400
    t_check = np.linspace(t0, t1, n_check + 1)
    _, X = drive.simulate(wheel_speeds_at, (traj.x[0], traj.y[0], traj.heading[0]), (t0, t1), t_eval=t_check,
                          rtol=1e-8, atol=1e-8)
    ref = np.c_[np.interp(t_check, traj.t, traj.x), np.interp(t_check, traj.t, traj.y)]
    dead_reckoning = float(np.max(np.linalg.norm(X[:, :2] - ref, axis=1)))
    np.savetxt(out / "trajectory.csv",
               np.c_[traj.t, traj.x, traj.y, traj.heading, traj.v, traj.a, traj.omega, phi], delimiter=",",
               fmt="%.12g", comments="",
               header="t_s,x_u,y_u,heading_rad,v_u_s,a_u_s2,omega_rad_s,phi_left_rad_s,phi_right_rad_s")

    # plots
    obstacles = mall.S7_OBSTACLES
    keep_out = f"keep-out for the centre (inflated by {mall.S7_INFLATION:g})"
    wp = {name: W[k] for k, name in enumerate(LABELS)}
    fig = viz.map_figure(viz_obstacles(obstacles, wrap=True), mall.BOUNDS,
                         paths={f"A*, given order ({given.length:.1f} u)": given.points,
                                f"smoothed ({_polyline_length(smoothed):.1f} u)": smoothed},
                         waypoints=wp, title="S7 mall: A* through the waypoints in the given order")
    ax = fig.axes[0]
    draw_keep_out(ax, grid, label=keep_out)
    ax.legend(loc="upper right", fontsize=8, framealpha=0.9)
    viz.save_png(fig, out / "map.png")

    visited = [LABELS[i] for i in best.order]
    fig = viz.map_figure(viz_obstacles(obstacles, wrap=True), mall.BOUNDS,
                         paths={f"best order {' → '.join(visited)} ({best.length:.1f} u)": best.points,
                                f"given order ({given.length:.1f} u)": given.points},
                         waypoints={f"{name} (#{k + 1})": W[i]
                                    for k, (i, name) in enumerate(zip(best.order, visited))},
                         title="S7 mall: best order of the intermediate waypoints (A* costs)")
    ax = fig.axes[0]
    ax.lines[1].set_linestyle(":")
    ax.lines[1].set_alpha(0.7)
    draw_keep_out(ax, grid, label=keep_out)
    ax.legend(loc="lower right", fontsize=8, framealpha=0.9)
    viz.save_png(fig, out / "best_order.png")

    fig = viz.series_figure(traj.t, {"speed v (u/s)": traj.v,
                                     "angular velocity ω (rad/s) × 10": 10 * traj.omega,
                                     "acceleration a (u/s²)": traj.a},
                            xlabel="time (s)", ylabel="v (u/s), 10·ω (rad/s), a (u/s²)",
                            title=f"Speed profile: v ≤ {v_max:g} u/s, |a| ≤ {a_max:g} u/s², "
                                  f"|ω| ≤ {omega_max:g} rad/s")
    ax = fig.axes[0]
    for c in (+1, -1):
        ax.axhline(10 * c * omega_max, color="grey", linestyle="--", linewidth=0.8)
    for kind, a, b in traj.phases:
        if kind == "turn":
            ax.axvspan(a, b, color="grey", alpha=0.12, linewidth=0)
    ax.plot([], [], color="grey", linestyle="--", linewidth=0.8, label="±ω_max (×10)")
    ax.fill_between([], [], color="grey", alpha=0.12, label="turn in place")
    ax.set_ylim(-1.6 * a_max, 1.45 * v_max)
    ax.legend(loc="upper center", fontsize=8, ncol=3, framealpha=0.9)
    viz.save_png(fig, out / "speed.png")

    fig = viz.series_figure(traj.t, {"left wheel φ_L": phi[:, 0], "right wheel φ_R": phi[:, 1]},
                            xlabel="time (s)", ylabel="wheel speed (rad/s)",
                            title=f"Differential drive: φ_R,L = (v ± ω b/2) / r  (r = {wheel_radius:g} u, "
                                  f"b = {track:g} u)")
    viz.save_png(fig, out / "wheels.png")

    if scene:
        motion = resample_motion(traj.t, traj.x, traj.y, traj.heading, fps)
        sc = map_scene("kinserve S7 mall: A* path, smoothed path, base driving", obstacles, mall.BOUNDS,
                       motion=motion, fps=fps, robot_width=mall.ROBOT_WIDTH, inflate=mall.S7_INFLATION,
                       paths={"astar": given.points, "smoothed": smoothed}, waypoints=wp)
        viz.export_html(sc, out / "scene.html")

    return {  # scalars first: `kinserve demo` prints the first few
        "length": given.length,
        "best_order_length": best.length,
        "smoothed_length": _polyline_length(smoothed),
        "duration": summary["duration"],
        "max_angular_velocity": summary["max_angular_velocity"],
        "max_speed": summary["max_speed"],
        "turns_in_place": summary["turns_in_place"],
        "dead_reckoning_error": dead_reckoning,
        "waypoint_names": list(LABELS),
        "waypoints": W,
        "segments": [seg.points for seg in given.segments],
        "segment_lengths": [seg.length for seg in given.segments],
        "smoothed": smoothed,
        "smoothed_kinds": [leg.kind for leg in legs],
        "smoothed_verified": all(leg.verified for leg in legs),
        "best_order": visited,
        "best_order_indices": best.order,
        "best_order_waypoints": W[best.order],
        "best_order_segments": [seg.points for seg in best.segments],
        "best_order_method": best.ordering_method,
        "pairwise_costs": C,
        "inflation": mall.S7_INFLATION,
        "obstacles": viz_obstacles(obstacles),
        "bounds": mall.BOUNDS,
        "max_acceleration": summary["max_acceleration"],
        "max_jerk": float(np.abs(jerk).max()),
        "limits": {"v_max": v_max, "a_max": a_max, "omega_max": omega_max},
        "diff_drive": {"wheel_radius": wheel_radius, "track": track,
                       "max_wheel_speed": float(np.abs(phi).max()),
                       "dead_reckoning_error": dead_reckoning},
    }
