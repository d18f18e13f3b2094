"""The mobile-base scenarios S6 (omni), S7 (mall), S8 (coverage), end to end.

Each scenario runs once per module (``scenarios.run`` into a temporary
folder); the tests read its ``result.json`` / CSV files and check the numbers
against independent math: the obstacle geometry of SCENARIOS.md written out
here (not the planners' grids), Dijkstra on an independently built lattice
graph for the A* optimality, brute force over the 24 orders of the four
intermediate waypoints, the SE(2) matrix exponential for the omni base, and
an independent raster of the swept floor for the coverage.
"""

from __future__ import annotations

import itertools
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage, sparse
from scipy.linalg import expm
from scipy.sparse.csgraph import dijkstra

from kinserve import scenarios
from kinserve.kinematics.errors import InputError

from scenario_runs import assert_readme_row, run_scenario

ROOT = Path(__file__).resolve().parents[1]

# --------------------------------------------------------------------------- geometry (SCENARIOS.md)
S7_RECTS = [(220, 100, 260, 140), (160, 160, 200, 200), (135, 375, 185, 425), (296, 375, 345, 425)]
S7_CIRCLES = [(240, 240, 40)]
S7_INFLATE = 10.0
S7_WAYPOINTS = np.array([(260, 60), (360, 170), (150, 70), (150, 300), (310, 330), (230, 430)], dtype=float)

S8_RECTS = [(210, 90, 270, 150), (150, 150, 210, 210), (125, 365, 195, 435), (286, 365, 355, 435),
            (110, -10, 370, 50), (110, 430, 370, 490)]
S8_CIRCLES = [(240, 240, 50)]
MAP = 480.0
WALL = 10.0  # the robot centre keeps half its 20-wide footprint from the walls


def rect_distance(x, y, r):
    """Signed distance to the rectangle r = (x0, y0, x1, y1): negative inside."""
    x0, y0, x1, y1 = r
    dx = np.maximum(x0 - x, x - x1)
    dy = np.maximum(y0 - y, y - y1)
    return np.hypot(np.maximum(dx, 0), np.maximum(dy, 0)) + np.minimum(np.maximum(dx, dy), 0)


def clearance(points, rects, circles, inflate):
    """min over shapes of (signed distance - inflate) and over walls of (distance - WALL); >= 0 is allowed."""
    P = np.asarray(points, dtype=float)
    x, y = P[:, 0], P[:, 1]
    c = np.minimum.reduce([x - WALL, MAP - WALL - x, y - WALL, MAP - WALL - y])
    for r in rects:
        c = np.minimum(c, rect_distance(x, y, r) - inflate)
    for cx, cy, rad in circles:
        c = np.minimum(c, np.hypot(x - cx, y - cy) - rad - inflate)
    return c


def densify(polyline, step=0.05):
    """Every vertex plus points at most ``step`` apart on each straight piece between vertices."""
    P = np.asarray(polyline, dtype=float)
    out = [P[:1]]
    for a, b in zip(P[:-1], P[1:]):
        n = max(1, int(math.ceil(np.linalg.norm(b - a) / step)))
        out.append(a + (np.arange(1, n + 1) / n)[:, None] * (b - a))
    return np.concatenate(out)


def polyline_length(P):
    return float(np.sum(np.linalg.norm(np.diff(np.asarray(P, dtype=float), axis=0), axis=1)))


def assert_artefacts(folder: Path, pngs, html: bool):
    for name in pngs:
        p = folder / name
        assert p.is_file(), f"{name} missing"
        assert p.stat().st_size > 10_000, f"{name} is only {p.stat().st_size} bytes"
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    if html:
        from kinserve import viz

        cmds = viz.read_html_commands(folder / "scene.html")
        kinds = {c["type"] for c in cmds}
        assert "set_animation" in kinds  # the base drives along the path
        paths = {c.get("path", "") for c in cmds}
        assert "/meshcat/map/robot/body" in paths and any(p.startswith("/meshcat/map/paths/") for p in paths)


def load(folder: Path) -> dict:
    return json.loads((folder / "result.json").read_text())


# --------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def omni(tmp_path_factory):
    return run_scenario(tmp_path_factory, "omni")


@pytest.fixture(scope="module")
def mall(tmp_path_factory):
    return run_scenario(tmp_path_factory, "mall")


@pytest.fixture(scope="module")
def coverage(tmp_path_factory):
    return run_scenario(tmp_path_factory, "coverage")


# --------------------------------------------------------------------------- S6 omni
def test_omni_equal_wheel_speeds_rotate_in_place_against_the_wheels(omni):
    _, r = omni
    D, R = r["center_distance"], r["wheel_radius"]
    for case in ("positive", "negative"):
        c = r["rotation_in_place"][case]
        phi = c["wheel_speeds"][0]
        S = np.array(c["samples"])  # rows t, x, y, theta
        assert np.abs(S[:, 1:3]).max() < 1e-9  # the centre stays put
        # each hub moves tangentially at D*thetadot, its wheel rolls it at -R*phi: thetadot = -R phi / D
        np.testing.assert_allclose(S[:, 3], -R * phi / D * S[:, 0], atol=1e-9)
        assert c["theta_rate"] * phi < 0
    assert r["rotation_sense"] == "opposite to the wheels"
    assert r["rotation_max_centre_displacement"] < 1e-9


def test_omni_single_wheel_runs_on_the_analytic_circle(omni):
    _, r = omni
    D, R = r["center_distance"], r["wheel_radius"]
    c = r["circle"]
    phi_a = c["wheel_speeds"][0]
    x0, y0, th0 = c["initial_pose"]
    # wheels B and C do not roll: their hubs slide along their axles, so the instantaneous centre of rotation
    # is where the tangent lines through B (180 deg) and C (300 deg) meet: 2D from the centre, opposite wheel
    # A (60 deg)
    a = math.radians(60.0) + th0
    centre = np.array([x0, y0]) - 2 * D * np.array([math.cos(a), math.sin(a)])
    S = np.array(c["samples"])
    np.testing.assert_allclose(np.hypot(S[:, 1] - centre[0], S[:, 2] - centre[1]), 2 * D, atol=1e-7)
    # wheel A's hub is 3D from that centre and rolls along its tangent: R phi_A = -3 D thetadot
    np.testing.assert_allclose(S[:, 3] - th0, -R * phi_a / (3 * D) * S[:, 0], atol=1e-7)
    assert abs(c["fitted_radius"] - 2 * D) < 1e-6 and abs(r["circle_radius_fit"] - 2 * D) < 1e-6
    np.testing.assert_allclose(c["fitted_centre"], centre, atol=1e-6)
    assert np.hypot(S[-1, 1] - S[0, 1], S[-1, 2] - S[0, 2]) < 1e-6  # one full turn closes the circle


def test_omni_twist_sequence_matches_the_se2_exponential(omni):
    folder, r = omni
    D, R = r["center_distance"], r["wheel_radius"]
    b = np.radians(r["wheel_angles_deg"])
    T = np.eye(3)
    for cmd in r["twist_sequence"]["commands"]:
        vx, vy, w = cmd["body_twist"]
        # rolling constraint, per wheel: the hub velocity (v + w z x p_i) along the rolling direction is -R
        # phi_i
        u = np.c_[-np.sin(b), np.cos(b)]
        p = D * np.c_[np.cos(b), np.sin(b)]
        hub = np.array([vx, vy]) + w * np.c_[-p[:, 1], p[:, 0]]
        np.testing.assert_allclose(np.sum(hub * u, axis=1), -R * np.asarray(cmd["wheel_speeds"]), atol=1e-12)
        T = T @ expm(cmd["duration"] * np.array([[0, -w, vx], [w, 0, vy], [0, 0, 0]]))
        end = np.asarray(cmd["end_pose"])
        np.testing.assert_allclose(end[:2], T[:2, 2], atol=1e-7)
        assert abs(math.remainder(end[2] - math.atan2(T[1, 0], T[0, 0]), 2 * math.pi)) < 1e-7
    data = np.loadtxt(folder / "trajectory.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(data[-1, 1:3], T[:2, 2], atol=1e-7)
    assert r["sequence_round_trip_error"] < 1e-12
    assert_artefacts(folder, ["rotation.png", "circle.png", "sequence.png", "wheel_speeds.png"], html=False)


# --------------------------------------------------------------------------- S7 mall
def s7_clear(points):
    return clearance(densify(points), S7_RECTS, S7_CIRCLES, S7_INFLATE)


@pytest.fixture(scope="module")
def lattice_distances():
    """Dijkstra distances from each waypoint on an independently built 8-connected 1-unit lattice
    (free = clearance >= 0 from the shapes above; a diagonal step needs both orthogonal neighbours free)."""
    n = int(MAP) + 1
    ii, jj = np.mgrid[0:n, 0:n]
    free = clearance(np.c_[jj.ravel(), ii.ravel()], S7_RECTS, S7_CIRCLES, S7_INFLATE).reshape(n, n) >= -1e-9
    idx = np.arange(n * n).reshape(n, n)
    rows, cols, w = [], [], []
    for di, dj in ((0, 1), (1, 0), (1, 1), (1, -1)):
        a = (slice(0, n - di), slice(max(0, -dj), n - max(0, dj)))
        bb = (slice(di, n), slice(max(0, dj), n - max(0, -dj)))
        ok = free[a] & free[bb]
        if di and dj:  # no corner cutting
            ok &= free[(slice(0, n - di), bb[1])] & free[(slice(di, n), a[1])]
        rows.append(idx[a][ok])
        cols.append(idx[bb][ok])
        w.append(np.full(ok.sum(), math.sqrt(di * di + dj * dj)))
    G = sparse.coo_matrix((np.concatenate(w), (np.concatenate(rows), np.concatenate(cols))),
                          shape=(n * n, n * n)).tocsr()
    src = [int(y) * n + int(x) for x, y in S7_WAYPOINTS]
    dist = dijkstra(G, directed=False, indices=src)
    return dist[:, src]


def test_mall_segments_join_the_waypoints_in_the_given_order(mall):
    _, r = mall
    np.testing.assert_array_equal(r["waypoints"], S7_WAYPOINTS)
    assert r["waypoint_names"] == ["Start", "1", "2", "3", "4", "End"]
    segs = [np.asarray(s, dtype=float) for s in r["segments"]]
    assert len(segs) == len(S7_WAYPOINTS) - 1
    for k, s in enumerate(segs):
        np.testing.assert_array_equal(s[0], S7_WAYPOINTS[k])
        np.testing.assert_array_equal(s[-1], S7_WAYPOINTS[k + 1])
        np.testing.assert_array_equal(s, np.round(s))  # lattice points
        steps = np.abs(np.diff(s, axis=0))
        assert np.all(steps.max(axis=1) == 1)  # 8-connected moves
        np.testing.assert_allclose(polyline_length(s), r["segment_lengths"][k], rtol=1e-12)
    assert abs(sum(polyline_length(s) for s in segs) - r["length"]) < 1e-9


def test_mall_raw_and_smoothed_paths_avoid_the_inflated_obstacles(mall):
    _, r = mall
    for k, s in enumerate(r["segments"]):
        assert s7_clear(s).min() >= -1e-9, f"leg {k} enters an inflated obstacle"
    for k, s in enumerate(r["best_order_segments"]):
        assert s7_clear(s).min() >= -1e-9, f"best-order leg {k} enters an inflated obstacle"
    sm = np.asarray(r["smoothed"], dtype=float)
    assert s7_clear(sm).min() >= -1e-9
    np.testing.assert_allclose(sm[0], S7_WAYPOINTS[0], atol=1e-9)
    np.testing.assert_allclose(sm[-1], S7_WAYPOINTS[-1], atol=1e-9)
    for w in S7_WAYPOINTS:  # the robot stops at every waypoint
        assert np.min(np.linalg.norm(sm - w, axis=1)) < 1e-6
    assert abs(polyline_length(sm) - r["smoothed_length"]) < 1e-6
    assert r["smoothed_length"] < r["length"]


def test_mall_astar_is_optimal_and_the_best_order_beats_the_given_one(mall, lattice_distances):
    _, r = mall
    D = lattice_distances
    for k in range(5):
        assert abs(r["segment_lengths"][k] - D[k, k + 1]) < 1e-6  # A* = Dijkstra on the same lattice
    np.testing.assert_allclose(r["pairwise_costs"], D, atol=1e-6)
    best = min(itertools.permutations(range(1, 5)),
               key=lambda p: sum(D[a, b] for a, b in zip((0, *p), (*p, 5))))
    best_len = sum(D[a, b] for a, b in zip((0, *best), (*best, 5)))
    assert abs(r["best_order_length"] - best_len) < 1e-6
    order = r["best_order_indices"]
    assert order[0] == 0 and order[-1] == 5 and sorted(order) == list(range(6))
    assert abs(sum(D[a, b] for a, b in zip(order[:-1], order[1:])) - best_len) < 1e-6
    assert r["best_order_length"] <= r["length"] + 1e-9
    for k, s in enumerate(r["best_order_segments"]):
        np.testing.assert_array_equal(s[0], S7_WAYPOINTS[order[k]])
        np.testing.assert_array_equal(s[-1], S7_WAYPOINTS[order[k + 1]])
    assert abs(sum(polyline_length(s) for s in r["best_order_segments"]) - r["best_order_length"]) < 1e-6


def test_mall_timing_respects_the_limits_and_the_wheels_match(mall):
    folder, r = mall
    lim = r["limits"]
    t, x, y, h, v, a, w, phl, phr = np.loadtxt(folder / "trajectory.csv", delimiter=",", skiprows=1).T
    assert abs(t[-1] - r["duration"]) < 1e-6 and r["duration"] > 0
    assert v.max() <= lim["v_max"] * (1 + 1e-6) and v.min() >= -1e-9
    assert np.abs(a).max() <= lim["a_max"] * (1 + 1e-6)
    assert np.abs(w).max() <= lim["omega_max"] * (1 + 1e-6)
    assert r["max_angular_velocity"] <= lim["omega_max"] * (1 + 1e-6)
    dt = np.diff(t)
    # the samples move as a unicycle: |dp| / dt = mean speed, heading change / dt = mean turn rate
    assert np.abs(np.hypot(np.diff(x), np.diff(y)) / dt - 0.5 * (v[1:] + v[:-1])).max() < 0.01 * lim["v_max"]
    assert np.abs(np.diff(h) / dt - 0.5 * (w[1:] + w[:-1])).max() < 0.02 * lim["omega_max"]
    # continuity: no jump in speed or acceleration (a jump in a would be ~a_max in one step)
    assert np.abs(np.diff(v)).max() <= lim["a_max"] * dt.max() * (1 + 1e-6)
    assert np.abs(np.diff(a)).max() < 0.25 * lim["a_max"]
    assert v[0] == 0 and abs(v[-1]) < 1e-9
    assert s7_clear(np.c_[x, y]).min() >= -1e-9
    # differential drive: phi_R,L = (v +- w b / 2) / r
    dd = r["diff_drive"]
    np.testing.assert_allclose(phr, (v + w * dd["track"] / 2) / dd["wheel_radius"], atol=1e-6)
    np.testing.assert_allclose(phl, (v - w * dd["track"] / 2) / dd["wheel_radius"], atol=1e-6)
    assert r["dead_reckoning_error"] < 0.5
    assert_artefacts(folder, ["map.png", "best_order.png", "speed.png", "wheels.png"], html=True)


# --------------------------------------------------------------------------- S8 coverage
def test_coverage_path_stays_in_the_free_floor(coverage):
    _, r = coverage
    P = np.asarray(r["path"], dtype=float)
    np.testing.assert_allclose(P[0], (10.0, 10.0))
    assert np.all((P >= WALL - 1e-9) & (P <= MAP - WALL + 1e-9))
    assert clearance(densify(P), S8_RECTS, S8_CIRCLES, 0.0).min() >= -1e-9
    assert abs(polyline_length(P) - r["length"]) < 1e-6 * r["length"]
    assert r["path_is_free"]


def test_coverage_sweeps_lanes_20_apart_and_95_percent_of_the_floor(coverage):
    _, r = coverage
    assert r["coverage_fraction"] >= 0.95
    P = np.asarray(r["path"], dtype=float)
    d = np.diff(P, axis=0)
    lanes = (np.abs(d[:, 1]) < 1e-9) & (np.abs(d[:, 0]) > 20)
    ys = np.unique(np.round(P[:-1][lanes, 1], 6))
    np.testing.assert_allclose((ys - 10.0) / 20.0, np.round((ys - 10.0) / 20.0), atol=1e-9)
    assert len(ys) >= 20  # the floor is 460 tall for the centre: 24 lanes

    # independent raster: 1-unit pixels; free centre positions from the shapes above; a pixel is coverable
    # when its centre is within 10 (Chebyshev) of a free centre position, covered when within 10 of a path
    # sample (axis-aligned footprint; the planner rotates it in the U-turns, hence the small tolerance)
    n = int(MAP)
    qi, qj = np.mgrid[0:n + 1, 0:n + 1]
    free = clearance(np.c_[qj.ravel(), qi.ravel()], S8_RECTS, S8_CIRCLES, 0.0).reshape(n + 1, n + 1) >= -1e-9
    # pixel (i, j) reaches lattice rows i-9 .. i+10 and columns j-9 .. j+10
    coverable = ndimage.maximum_filter(free.astype(np.uint8), size=20, origin=(-1, -1),
                                       mode="constant")[:n, :n] > 0
    covered = np.zeros((n, n), dtype=bool)
    for px, py in densify(P, step=0.5):
        j0, j1 = max(0, math.ceil(px - 10.5 - 1e-9)), min(n - 1, math.floor(px + 9.5 + 1e-9))
        i0, i1 = max(0, math.ceil(py - 10.5 - 1e-9)), min(n - 1, math.floor(py + 9.5 + 1e-9))
        covered[i0:i1 + 1, j0:j1 + 1] = True
    fraction = (covered & coverable).sum() / coverable.sum()
    assert abs(coverable.sum() - r["free_area"]) < 1e-9
    assert fraction >= 0.95
    assert abs(fraction - r["coverage_fraction"]) < 0.01


# the physical S8 obstacles: S7's shapes, the no-go strips without their 10 padding, the walls of the 480
# floor
S8_RAW_RECTS = S7_RECTS + [(120, 0, 360, 40), (120, 440, 360, 480)]


def footprint_poses(P, turn_deg=1.0, step=0.5):
    """(x, y, heading) of a square base driving the polyline P: along each segment (every `step`) with the
    segment's direction, and turning in place at each vertex through the headings between (every
    `turn_deg`)."""
    out = []
    d = np.diff(P, axis=0)
    h = np.arctan2(d[:, 1], d[:, 0])
    for k, (a, b) in enumerate(zip(P[:-1], P[1:])):
        if k > 0:
            turn = math.remainder(h[k] - h[k - 1], 2 * math.pi)
            n = max(1, math.ceil(abs(math.degrees(turn)) / turn_deg))
            out += [(a[0], a[1], h[k - 1] + t * turn) for t in np.arange(1, n) / n]
        n = max(1, math.ceil(np.linalg.norm(b - a) / step))
        out += [(*(a + t * (b - a)), h[k]) for t in np.arange(n + 1) / n]
    return np.array(out)


def corner_depth(poses, half=10.0):
    """Deepest reach of the square footprint (corners; for the fountain also its edges) into the physical
    obstacles and past the walls, over all poses: max(0, -signed distance)."""
    x, y, h = poses[:, 0:1], poses[:, 1:2], poses[:, 2:3]
    ox, oy = np.array([[1, -1, -1, 1]]) * half, np.array([[1, 1, -1, -1]]) * half
    cx, cy = x + np.cos(h) * ox - np.sin(h) * oy, y + np.sin(h) * ox + np.cos(h) * oy
    depth = np.maximum.reduce([-cx, cx - MAP, -cy, cy - MAP]).max()  # walls
    for r in S8_RAW_RECTS:
        depth = max(depth, -rect_distance(cx, cy, r).min())
    for (fx, fy, fr) in S7_CIRCLES:  # edges: distance from the disc centre to each side of the square
        ax, ay = cx, cy
        bx, by = np.roll(cx, -1, axis=1), np.roll(cy, -1, axis=1)
        t = np.clip(((fx - ax) * (bx - ax) + (fy - ay) * (by - ay)) / ((bx - ax) ** 2 + (by - ay) ** 2), 0, 1)
        dist = np.hypot(ax + t * (bx - ax) - fx, ay + t * (by - ay) - fy)
        depth = max(depth, fr - dist.min())
    return max(0.0, float(depth))


def test_coverage_reports_how_deep_the_turning_footprint_reaches(coverage):
    """Padded by half the width, corners of the turning 20 x 20 base reach 10 sqrt 2 - 10 = 4.14 into the
    walls and obstacles; result.json reports it, as an independent sweep of the square along the path
    finds."""
    _, r = coverage
    assert r["padding"] == "width" and r["padding_distance"] == 10.0
    bound = 10 * math.sqrt(2) - 10
    independent = corner_depth(footprint_poses(np.asarray(r["path"], dtype=float)))
    assert independent > 4.1 and r["max_corner_penetration"] > 4.1
    assert abs(r["max_corner_penetration"] - independent) < 5e-3
    assert r["max_corner_penetration"] <= bound + 1e-9
    pen = r["penetration"]
    assert pen["max_depth"] == r["max_corner_penetration"] and pen["poses_in_contact"] > 0
    assert set(pen["per_obstacle"]) == {"hot-dog stand 1", "hot-dog stand 2", "fountain", "escalator 1",
                                        "escalator 2", "no-go zone 1", "no-go zone 2", "walls"}
    assert pen["per_obstacle"]["fountain"] > 3.5  # the "up to 3.5 units" is exceeded at the fountain


def test_coverage_with_diagonal_padding_keeps_every_corner_out(coverage, tmp_path):
    _, wide = coverage
    r = scenarios.run("coverage", tmp_path, padding="diagonal", scene=False)
    assert r["padding"] == "diagonal" and r["padding_distance"] == pytest.approx(10 * math.sqrt(2))
    assert r["max_corner_penetration"] == 0.0
    P = np.asarray(r["path"], dtype=float)
    np.testing.assert_allclose(P[0], (15.0, 15.0))
    assert corner_depth(footprint_poses(P)) == 0.0
    # the price: a wider keep-out leaves more floor unswept
    assert 0.9 < r["coverage_fraction"] < wide["coverage_fraction"]
    with pytest.raises(InputError, match="padding"):
        scenarios.run("coverage", tmp_path / "bad", padding="corner", scene=False)


def test_coverage_artefacts(coverage):
    folder, _ = coverage
    assert_artefacts(folder, ["coverage.png", "cells.png"], html=True)


# --------------------------------------------------------------------------- CLI
def test_cli_demo_mall_end_to_end(tmp_path):
    env = dict(os.environ, MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, "-m", "kinserve.service.cli", "demo", "mall", "--out",
                           str(tmp_path)], cwd=ROOT,
                          env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    r = load(tmp_path / "mall")
    assert {"waypoints", "segments", "smoothed", "length"} <= set(r)
    assert (tmp_path / "mall" / "scene.html").is_file() and (tmp_path / "mall" / "map.png").is_file()
    assert "[mall]" in proc.stdout


# --------------------------------------------------------------------------- README table
@pytest.mark.parametrize("fixture", ["omni", "mall", "coverage"])
def test_readme_row_matches_a_fresh_run(fixture, request):
    out, result = request.getfixturevalue(fixture)
    assert_readme_row(result["scenario"], result)
