"""Bad input to ``planners.mobile``: refused with kinserve's own errors, naming the argument, before any
unbounded allocation or loop; a valid neighbouring input still works."""

import dataclasses
import math
from fractions import Fraction

import numpy as np
import pytest

from kinserve.kinematics.errors import InputError, NonFiniteError, ShapeError
from kinserve.planners import mobile as m
from kinserve.planners.errors import BlockedPointError
from kinserve.planners.mobile import _checks, shapes

BOX = m.Rectangle(2, 2, 3, 3, "box")


@pytest.fixture(scope="module")
def grid():
    return m.OccupancyGrid.from_shapes((0, 0, 10, 10), [BOX], resolution=0.5)


@pytest.fixture(scope="module")
def path(grid):
    return m.astar(grid, (0.5, 0.5), (9.5, 9.5)).points


@pytest.fixture(scope="module")
def polyline(path):
    return m.polyline_path(path, 0.25)


# ------------------------------------------------------------------ shapes
def test_rectangle_refuses_huge_and_non_numeric_coordinates():
    with pytest.raises(NonFiniteError, match=r"rectangle '' x_max must be finite with magnitude <= 1e\+06"):
        m.Rectangle(0, 0, 1e300, 1)
    with pytest.raises(InputError, match="rectangle '' x_min must be a number, got 'a'"):
        m.Rectangle("a", 0, 1, 1)
    with pytest.raises(InputError, match="name must be a string"):
        m.Rectangle(0, 0, 1, 1, name=3)
    assert m.Rectangle(0, 0, 1e6, 1).area == 1e6


def test_circle_and_polygon_refuse_bad_numbers():
    with pytest.raises(InputError, match="circle 'c' radius must be positive"):
        m.Circle(0, 0, -1, "c")
    with pytest.raises(NonFiniteError, match="circle '' cy must be finite"):
        m.Circle(0, math.inf, 1)
    with pytest.raises(NonFiniteError, match="polygon 'p' vertices must hold finite numbers"):
        m.Polygon([(0, 0), (1e300, 0), (0, 1)], "p")
    with pytest.raises(ShapeError, match="polygon '' vertices must be a numeric array"):
        m.Polygon("abc")
    assert m.Circle(0, 0, 1).area == pytest.approx(math.pi)


def test_polygon_closed_by_repeating_its_first_vertex_gives_a_finite_distance():
    closed = m.Polygon([(0, 0), (1, 0), (0, 1), (0, 0)])  # a closed ring: its last edge has zero length
    assert len(closed.vertices) == 4 and closed.area == pytest.approx(0.5)
    assert closed.signed_distance(2.0, 2.0) == pytest.approx(math.hypot(1.5, 1.5))
    assert closed.signed_distance(0.25, 0.25) == pytest.approx(-0.25)


# -------------------------------------------------------------------- maps
def test_from_shapes_refuses_missing_or_bad_bounds_and_resolution():
    with pytest.raises(ShapeError, match=r"bounds must be \(x_min, y_min, x_max, y_max\) or "
                                         r"\(width, height\)"):
        m.OccupancyGrid.from_shapes(None)
    with pytest.raises(NonFiniteError, match="bounds must hold finite numbers"):
        m.OccupancyGrid.from_shapes((0, 0, 1e300, 10))
    with pytest.raises(InputError, match="resolution must be a number, got 'abc'"):
        m.OccupancyGrid.from_shapes((10, 10), resolution="abc")
    with pytest.raises(InputError, match="resolution must be at least 1e-06"):
        m.OccupancyGrid.from_shapes((10, 10), resolution=1e-9)
    with pytest.raises(InputError, match="shapes must be a sequence"):
        m.OccupancyGrid.from_shapes((10, 10), None)
    assert m.OccupancyGrid.from_shapes((10, 10), resolution=0.5).shape == (21, 21)


def test_from_shapes_bounds_the_lattice_size():
    with pytest.raises(InputError, match=r"resolution 0.0001 gives a 100001 x 100001 lattice .*at most "
                                         r"50,000,000 points.*at least about 0.0014"):
        m.OccupancyGrid.from_shapes((0, 0, 10, 10), resolution=1e-4)
    with pytest.raises(InputError, match="1000001 x 1000001 lattice"):
        m.OccupancyGrid.from_shapes((0, 0, 1e6, 1e6), resolution=1.0)
    assert m.OccupancyGrid.from_shapes((0, 0, 10, 10), resolution=0.01).shape == (1001, 1001)


def test_from_shapes_reads_an_iterator_of_shapes_once():
    big = m.Rectangle(2, 2, 8, 8)
    from_list = m.OccupancyGrid.from_shapes((10, 10), [big])
    from_iter = m.OccupancyGrid.from_shapes((10, 10), (s for s in [big]))
    assert from_iter.free_fraction == from_list.free_fraction < 1.0


def test_direct_construction_is_checked():
    with pytest.raises(ShapeError, match=r"free must be a boolean array of shape \(11, 11\)"):
        m.OccupancyGrid((0, 0, 10, 10), 1.0, np.ones((3, 3), dtype=bool))
    assert m.OccupancyGrid((0, 0, 10, 10), 1.0, np.ones((11, 11), dtype=bool)).free_fraction == 1.0


def test_points_beyond_1e6_are_refused_not_wrapped(grid):
    with pytest.raises(NonFiniteError, match="points must hold finite numbers with magnitude <= 1e"):
        grid.world_to_index([(1e300, 1e300)])
    with pytest.raises(NonFiniteError, match="points must hold finite numbers"):
        grid.clearance([(1e300, 1e300)])
    with pytest.raises(ShapeError, match="points must be a numeric array"):
        grid.is_free("abc")
    i, j = grid.world_to_index([(1e6, 1e6)])
    assert i[0] == j[0] == 2_000_000
    assert grid.clearance([(1e6, 1e6)])[0] < 0


def test_path_and_segment_checks_refuse_tiny_or_negative_steps(grid):
    seg = [(0.5, 0.5), (9.5, 0.5)]
    with pytest.raises(InputError, match=r"step must be at least 9e-07 \(10,000,000 samples at most over "
                                         r"this 9 long path\), got 1e-12"):
        grid.path_is_free(seg, step=1e-12)
    with pytest.raises(InputError, match="step must be at least 9e-07"):
        grid.segment_is_free(*seg, step=1e-12)
    with pytest.raises(InputError, match="step must be positive, got -1"):
        grid.path_is_free(seg, step=-1)
    with pytest.raises(ShapeError, match="a must be a sequence of 2 numbers"):
        grid.segment_is_free("ab", (1, 1))
    assert grid.path_is_free(seg, step=1e-5)
    assert grid.segment_is_free(*seg, step=1e-5)


def test_index_to_world_and_on_lattice(grid):
    with pytest.raises(InputError, match=r"i must be integer lattice indices with \|i\| <= 1e\+08"):
        grid.index_to_world(np.nan, 0)
    with pytest.raises(InputError, match="j must be integer lattice indices"):
        grid.index_to_world(0, 1.5)
    with pytest.raises(InputError, match="tol must be at most 0.5"):
        grid.on_lattice([(0.5, 0.5)], tol=2.0)
    assert grid.index_to_world(2, 4).tolist() == [[2.0, 1.0]]
    assert grid.on_lattice([(0.5, 0.5)], tol=0.1).tolist() == [True]


# -------------------------------------------------------------------- astar
def test_astar_refuses_non_point_start_and_bad_options(grid):
    with pytest.raises(ShapeError, match="start must be a sequence of 2 numbers, got 'abc'"):
        m.astar(grid, "abc", (9.5, 9.5))
    with pytest.raises(NonFiniteError, match="goal must hold finite numbers"):
        m.astar(grid, (0.5, 0.5), (np.nan, 1))
    with pytest.raises(InputError, match="grid must be an OccupancyGrid"):
        m.astar(None, (0.5, 0.5), (9.5, 9.5))
    with pytest.raises(InputError, match="turn_penalty must be a number, got True"):
        m.astar(grid, (0.5, 0.5), (9.5, 9.5), turn_penalty=True)
    with pytest.raises(InputError, match="proximity_range must be positive"):
        m.astar(grid, (0.5, 0.5), (9.5, 9.5), proximity_weight=1.0, proximity_range=-1.0)
    with pytest.raises(InputError, match="heuristic must be one of"):
        m.astar(grid, (0.5, 0.5), (9.5, 9.5), heuristic=["octile"])
    with pytest.raises(BlockedPointError, match="outside the map"):
        m.astar(grid, (0.5, 0.5), (50, 50))
    assert m.astar(grid, (0.5, 0.5), (9.5, 9.5), proximity_weight=1.0, proximity_range=1.0).length > 0


# --------------------------------------------------------------- sequencing
def test_plan_waypoints_refuses_unknown_options_and_bad_names(grid):
    wps = [(0.5, 0.5), (9.5, 9.5), (0.5, 9.5)]
    with pytest.raises(InputError, match="unknown A\\* option 'bogus'; accepted: heuristic"):
        m.plan_waypoints(grid, wps, bogus=1)
    with pytest.raises(InputError, match="unknown A\\* option 'heuristc'.*Did you mean: heuristic"):
        m.pairwise_costs(grid, wps, heuristc="octile")
    with pytest.raises(InputError, match="names must be a sequence of 3 names"):
        m.plan_waypoints(grid, wps, names=5)
    with pytest.raises(ShapeError, match=r"waypoints must hold at least 2 \(x, y\) point"):
        m.plan_waypoints(grid, [(0.5, 0.5)])
    with pytest.raises(InputError, match="order must be 'given' or 'optimal'"):
        m.plan_waypoints(grid, wps, order=["given"])
    assert m.plan_waypoints(grid, wps, heuristic="euclidean").order == [0, 1, 2]


# ---------------------------------------------------------------- smoothing
def test_smooth_path_refuses_bad_numbers(grid, path):
    with pytest.raises(InputError, match="iterations must be an integer from 0 to 10,000, got -1.0"):
        m.smooth_path(grid, path, iterations=-1.0)
    with pytest.raises(NonFiniteError, match="knot_spacing must be finite"):
        m.smooth_path(grid, path, knot_spacing=float("nan"))
    with pytest.raises(InputError, match="margin must be zero or positive"):
        m.smooth_path(grid, path, margin=-1.0)
    with pytest.raises(InputError, match=r"keep\[0\] must be an integer from 0 to"):
        m.smooth_path(grid, path, keep=[len(path)])
    with pytest.raises(InputError, match=r"not free \(point 1 \[50.0, 50.0\] lies outside the map"):
        m.smooth_path(grid, [(0.5, 0.5), (50, 50)])
    assert m.smooth_path(grid, path, iterations=5.0, knot_spacing=1.0, keep=[3]).verified


def test_shortcut_refuses_points_outside_the_map(grid, path):
    with pytest.raises(InputError, match=r"points\[1\] = \[1000000.0, 0.5\] lies outside the map"):
        m.shortcut(grid, [(0.5, 0.5), (1e6, 0.5), (9.5, 0.5)])
    assert m.shortcut(grid, path).tolist()[0] == 0


def test_polyline_path_refuses_bad_step_and_empty_points(path):
    with pytest.raises(InputError, match="step must be positive, got 0"):
        m.polyline_path(path, step=0)
    with pytest.raises(InputError, match=r"step must be at least 1.33e-06 \(10,000,000 samples at most"):
        m.polyline_path(path, step=1e-12)
    with pytest.raises(ShapeError, match=r"points must have shape \(N, 2\), got shape \(0,\)"):
        m.polyline_path([])
    assert len(m.polyline_path(path, step=1e-3).points) > 10_000


def test_smooth_path_at_refuses_nan(polyline):
    with pytest.raises(InputError, match="s must hold finite numbers"):
        polyline.at(np.nan)
    assert polyline.at(0.0)[0] == pytest.approx(0.5)


# ------------------------------------------------------------------ timing
def test_time_scale_path_refuses_non_paths_and_huge_limits(polyline):
    lim = dict(v_max=1.0, a_max=1.0, omega_max=1.0)
    with pytest.raises(InputError, match="path must be a SmoothPath .*got NoneType"):
        m.time_scale_path(None, **lim)
    with pytest.raises(NonFiniteError, match="v_max must be finite with magnitude <= 1e"):
        m.time_scale_path(polyline, **{**lim, "v_max": 1e300})
    with pytest.raises(InputError, match="a_max must be a number, got True"):
        m.time_scale_path(polyline, **{**lim, "a_max": True})
    with pytest.raises(NonFiniteError, match="initial_heading must be finite"):
        m.time_scale_path(polyline, **lim, initial_heading=float("inf"))
    assert m.time_scale_path(polyline, **{**lim, "v_max": 1e6, "a_max": 1e6}).duration > 0


def test_time_scale_path_bounds_the_number_of_samples(polyline):
    lim = dict(v_max=1.0, a_max=1.0, omega_max=1.0)
    with pytest.raises(InputError, match=r"the default smoothing_time 0.25 v_max / a_max = 0.25 s is more "
                                         r"than 10,000,000 time steps dt = 1e-12"):
        m.time_scale_path(polyline, **lim, dt=1e-12)
    with pytest.raises(InputError, match=r"dt must be at least .* \(10,000,000 samples at most over this "
                                         r"drive of"):
        m.time_scale_path(polyline, **{**lim, "v_max": 1e-4}, dt=1e-4)
    with pytest.raises(InputError, match="the default smoothing_time .* = 250000 s"):
        m.time_scale_path(polyline, **{**lim, "a_max": 1e-6})
    assert m.time_scale_path(polyline, **lim, dt=1e-3).duration > 0


def test_turn_in_place_refuses_tiny_dt_and_bad_headings():
    with pytest.raises(InputError, match=r"dt must be at least 2.4e-07 \(10,000,000 samples at most over "
                                         r"this turn in place of 2.40281 s\), got 1e-12"):
        m.turn_in_place(0, 0, 0, 1, omega_max=1, alpha_max=1, dt=1e-12)
    with pytest.raises(NonFiniteError, match="heading1 must be finite"):
        m.turn_in_place(0, 0, 0, np.nan, omega_max=1, alpha_max=1)
    with pytest.raises(InputError, match="omega_max must be positive"):
        m.turn_in_place(0, 0, 0, 1, omega_max=-1, alpha_max=1)
    assert m.turn_in_place(0, 0, 0, 1, omega_max=1, alpha_max=1, dt=1e-6).duration > 0


def test_drive_through_refuses_empty_and_foreign_paths(polyline):
    lim = dict(v_max=1.0, a_max=1.0, omega_max=1.0)
    with pytest.raises(InputError, match=r"paths must be a non-empty list of SmoothPath, got \[\]"):
        m.drive_through([], **lim)
    with pytest.raises(InputError, match=r"paths\[1\] must be a SmoothPath, got str"):
        m.drive_through([polyline, "x"], **lim)
    with pytest.raises(InputError, match="parts must be a list of DriveTrajectory"):
        m.DriveTrajectory.concatenate(None)
    assert m.drive_through([polyline, polyline], **lim).duration > 0


# ---------------------------------------------------------------- coverage
def test_coverage_refuses_bad_robot_width(grid):
    kw = dict(lane_spacing=0.5)
    with pytest.raises(InputError, match="robot_width must be positive, got -1"):
        m.boustrophedon_coverage(grid, (0.5, 0.5), **kw, robot_width=-1)
    with pytest.raises(NonFiniteError, match="robot_width must be finite"):
        m.boustrophedon_coverage(grid, (0.5, 0.5), **kw, robot_width=1e300)
    with pytest.raises(NonFiniteError, match="robot_width must be finite"):
        m.boustrophedon_coverage(grid, (0.5, 0.5), **kw, robot_width=float("nan"))
    with pytest.raises(InputError, match=r"robot_width must be at most 352.139 \(1,000,000 footprint pixels"):
        m.boustrophedon_coverage(grid, (0.5, 0.5), **kw, robot_width=1000.0)
    assert m.boustrophedon_coverage(grid, (0.5, 0.5), **kw, robot_width=1.0).covered_fraction > 0.5


def test_coverage_refuses_bad_counts_spacing_and_steps(grid):
    with pytest.raises(InputError, match="candidates must be an integer from 1 to 1,000, got 0"):
        m.boustrophedon_coverage(grid, (0.5, 0.5), lane_spacing=0.5, candidates=0)
    with pytest.raises(InputError, match="lane_spacing must be a whole multiple .* resolution 0.5"):
        m.boustrophedon_coverage(grid, (0.5, 0.5), lane_spacing=0.75)
    with pytest.raises(InputError, match=r"step must be at least .* \(10,000,000 samples at most over the 21 "
                                         r"lanes"):
        m.boustrophedon_coverage(grid, (0.5, 0.5), lane_spacing=0.5, step=1e-9)
    with pytest.raises(ShapeError, match="start must be a sequence of 2 numbers"):
        m.boustrophedon_coverage(grid, "ab", lane_spacing=0.5)
    assert m.boustrophedon_coverage(grid, (0.5, 0.5), lane_spacing=1.0, candidates=2.0).n_lanes > 0


def test_coverage_helpers_refuse_bad_input(grid):
    with pytest.raises(InputError, match="spacing must be a whole multiple"):
        m.lane_intervals(grid, 0.5, 1e-9)
    with pytest.raises(InputError, match="robot_width must be positive"):
        m.coverable_pixels(grid, -1.0)
    with pytest.raises(ShapeError, match=r"heading must have shape \(2,\) like the path, got \(5,\)"):
        m.swept_coverage(grid, [(0.5, 0.5), (1, 1)], np.zeros(5), 0.5)
    with pytest.raises(InputError, match=r"lanes\[0\] must be a non-empty list of Interval"):
        m.decompose([[]])
    lanes = m.lane_intervals(grid, 0.5, 1.0)
    assert m.decompose(lanes)
    assert m.coverable_pixels(grid, 1.0).any()


# --------------------------------------------------------------- footprint
def test_footprint_outline_refuses_bad_sizes():
    with pytest.raises(InputError, match="spacing must be positive, got 0"):
        m.footprint_outline(0.5, 0.3, 0)
    with pytest.raises(InputError, match="length must be positive, got -1"):
        m.footprint_outline(-1, 0.3, 0.1)
    with pytest.raises(InputError, match=r"spacing must be at least 1.6e-06 \(1,000,000 samples at most over "
                                         r"the outline"):
        m.footprint_outline(0.5, 0.3, 1e-12)
    assert m.footprint_outline(0.5, 0.3, 1e-5).shape[1] == 2


def test_footprint_penetration_refuses_huge_sizes_and_tiny_steps():
    P, H = [[5.0, 5.0], [6.0, 5.0]], [0.0, 3.0]
    with pytest.raises(NonFiniteError, match="length must be finite with magnitude <= 1e"):
        m.footprint_penetration(P, H, [BOX], length=10**12)
    with pytest.raises(InputError, match=r"turn_step must be at least .* \(10,000,000 samples at most over "
                                         r"the turns in place"):
        m.footprint_penetration(P, H, [BOX], length=1.0, turn_step=1e-12)
    with pytest.raises(InputError, match="poses x .* outline points is more than 1e\\+08 evaluations"):
        m.footprint_penetration(P, H, [BOX], length=1.0, spacing=1e-5, turn_step=1e-4)
    with pytest.raises(InputError, match="bounds must be .* with min < max"):
        m.footprint_penetration(P, H, [BOX], length=1.0, bounds=(10, 10, 0, 0))
    assert m.footprint_penetration(P, H, [BOX], length=1.0, bounds=(0, 0, 10, 10)).depth == 0.0


# ------------------------------------------------------------- drive bases
def test_diff_drive_simulate_refuses_nan_and_short_pose():
    dd = m.DiffDrive(0.1, 0.5)
    with pytest.raises(NonFiniteError, match=r"wheel_speeds must hold finite numbers .*\[0\]=nan"):
        dd.simulate([np.nan, 1], (0, 0, 0), (0, 1))
    with pytest.raises(ShapeError, match=r"pose0 must have shape \(3,\), got shape \(2,\)"):
        dd.simulate([1, 1], (0, 0), (0, 1))
    with pytest.raises(NonFiniteError, match="wheel_speeds\\(0\\) must hold finite numbers"):
        dd.simulate(lambda t: [np.nan, 1], (0, 0, 0), (0, 1))
    with pytest.raises(InputError, match="rtol must be positive"):
        dd.simulate([1, 1], (0, 0, 0), (0, 1), rtol=-1)
    with pytest.raises(InputError, match="t_eval must lie within t_span"):
        dd.simulate([1, 1], (0, 0, 0), (0, 1), t_eval=[0, 2])
    with pytest.raises(InputError, match="wheel_radius must be a number, got 'a'"):
        m.DiffDrive("a", 1)
    t, poses = dd.simulate([1, 1], (0, 0, 0), (0, 1), t_eval=[0, 1])
    assert poses[-1] == pytest.approx([0.1, 0, 0])


def test_diff_drive_velocity_helpers_refuse_nan():
    dd = m.DiffDrive(0.1, 0.5)
    with pytest.raises(InputError, match="v must hold finite numbers"):
        dd.wheel_speeds(np.nan, 0)
    with pytest.raises(InputError, match="phi_left must be a number or an array"):
        dd.body_velocity("a", 0)
    assert dd.body_velocity(*dd.wheel_speeds(1.0, 0.5)) == pytest.approx([1.0, 0.5])


def test_simulation_length_is_bounded(monkeypatch):
    monkeypatch.setattr(_checks, "MAX_RHS_EVALUATIONS", 50)
    with pytest.raises(InputError, match="needs more than 50 evaluations"):
        m.DiffDrive(0.1, 0.5).simulate([1000, 999], (0, 0, 0), (0, 1e6))
    assert m.DiffDrive(0.1, 0.5).simulate([1, 1], (0, 0, 0), (0, 1))[1][-1][0] == pytest.approx(0.1)


def test_omni_base_refuses_bad_shapes_and_numbers():
    ob = m.OmniBase(0.1, 0.3)
    with pytest.raises(ShapeError, match=r"wheel_speeds must be 3 numbers or an \(N, 3\) array, got shape"):
        ob.body_twist([1])
    with pytest.raises(NonFiniteError, match="theta must be finite"):
        ob.wheel_speeds([1, 0, 0], np.nan)
    with pytest.raises(ShapeError, match=r"wheel_speeds\(0\) must have shape \(3,\)"):
        ob.simulate(lambda t: [1], (0, 0, 0), (0, 1))
    with pytest.raises(ShapeError, match="pose must be a sequence of 3 numbers"):
        ob.wheel_positions("xyz")
    w = ob.wheel_speeds([0.2, -0.1, 0.3], 0.7)
    _, poses = ob.simulate(w, (0, 0, 0.7), (0, 1))
    assert ob.twist(w, 0.7) == pytest.approx([0.2, -0.1, 0.3])
    assert poses[-1][2] == pytest.approx(1.0)


BASES = {"diff_drive": (m.DiffDrive(0.1, 0.5), [1.0, 1.0]), "omni": (m.OmniBase(0.1, 0.3), [1.0, 1.0, 1.0])}


@pytest.mark.parametrize("base", sorted(BASES))
@pytest.mark.parametrize("t_eval, t_span, error, message", [
    ([], (0, 1), ShapeError, r"^t_eval must be a 1-D array of 1 to 1,000,000 times, got shape \(0,\)"),
    (np.zeros(0), (0, 1), ShapeError, r"^t_eval must be a 1-D array of 1 to 1,000,000 times"),
    (0.5, (0, 1), ShapeError, r"^t_eval must be a 1-D array .*got shape \(\)"),
    ([True, False], (0, 1), ShapeError, r"^t_eval must be a number or an array of numbers, got \[True"),
    (["0", "1"], (0, 1), ShapeError, r"^t_eval must be a number or an array of numbers"),
    ([0.5, 0.2], (0, 1), InputError, r"^t_eval must be strictly increasing; t_eval\[0\] = 0.5 and t_eval"),
    ([0.0, 0.0, 0.5], (0, 1), InputError, r"^t_eval must be strictly increasing; t_eval\[0\] = 0 and"),
    ([0.2, 0.5], (1, 0), InputError, r"^t_eval must be strictly decreasing \(t_span runs backwards\)"),
    ([1e300], (0, 1), NonFiniteError, r"^t_eval must hold finite numbers with magnitude <= 1e\+06"),
])
def test_simulate_refuses_empty_unsorted_or_non_numeric_t_eval(base, t_eval, t_span, error, message):
    """t_eval=[] was "'list' object has no attribute 'T'" (scipy), unsorted times scipy's ValueError, bools
    were read as 0 / 1 s."""
    drive, speeds = BASES[base]
    with pytest.raises(error, match=message):
        drive.simulate(speeds, (0, 0, 0), t_span, t_eval=t_eval)
    t, poses = drive.simulate(speeds, (0, 0, 0), t_span, t_eval=[0.5] if t_span == (0, 1) else [0.5, 0.2])
    assert poses.shape == (len(t), 3)


@pytest.mark.parametrize("base", sorted(BASES))
@pytest.mark.parametrize("function, error, message", [
    (lambda t: [1.0], ShapeError, r"^wheel_speeds\(0\) must have shape"),
    (lambda t: None, ShapeError, r"^wheel_speeds\(0\) must be a sequence of \d numbers, got None"),
    (lambda t: "ab", ShapeError, r"^wheel_speeds\(0\) must be a sequence of \d numbers, got 'ab'"),
    (lambda t: [math.inf] * 3, (ShapeError, NonFiniteError), r"^wheel_speeds\(0\) must"),
])
def test_simulate_refuses_a_wheel_speed_function_of_the_wrong_shape_or_value(base, function, error, message):
    drive, _ = BASES[base]
    with pytest.raises(error, match=message):
        drive.simulate(function, (0, 0, 0), (0, 1))


def test_simulate_lets_the_wheel_speed_functions_own_errors_through():
    with pytest.raises(ZeroDivisionError):
        m.DiffDrive(0.1, 0.5).simulate(lambda t: 1 / 0, (0, 0, 0), (0, 1))


@pytest.mark.parametrize("s, error, message", [
    (1e300, NonFiniteError, r"^s must hold finite numbers with magnitude <= 1e\+06; bad entries: \[0\]=1e"),
    ([0.0, -1e7], NonFiniteError, r"^s must hold finite numbers .*bad entries: \[1\]=-1"),
    (True, ShapeError, r"^s must be a number or an array of numbers, got True"),
    (np.array([True]), ShapeError, r"^s must be a number or an array of numbers"),
    ("1", ShapeError, r"^s must be a number or an array of numbers, got '1'"),
    (None, ShapeError, r"^s must be a number or an array of numbers, got None"),
])
def test_smooth_path_at_refuses_bools_text_and_huge_arc_lengths(polyline, s, error, message):
    """at(1e300) was clipped to the end and at(True) read as s = 1.0."""
    with pytest.raises(error, match=message):
        polyline.at(s)
    x, _, _, _ = polyline.at([-1.0, 1e6])  # ordinary out-of-range s: clipped to [0, length] (documented)
    assert x.tolist() == pytest.approx([polyline.points[0, 0], polyline.points[-1, 0]])


def test_mall_refuses_unhashable_padding_and_bad_resolution():
    with pytest.raises(InputError, match=r"padding must be one of \['diagonal', 'width'\], got \['a'\]"):
        m.mall.s8_padding(["a"])
    with pytest.raises(InputError, match="resolution must be positive"):
        m.mall.s8_start("diagonal", resolution=-1)
    assert m.mall.s8_start("diagonal", resolution=1.0) == (15, 15)


def test_time_scale_path_with_dt_longer_than_the_drive_still_samples_it():
    short = m.polyline_path([(1.0, 1.0), (2.0, 1.0)], 0.25)
    tr = m.time_scale_path(short, v_max=1.0, a_max=1.0, omega_max=1.0, dt=100.0)
    assert np.all(np.isfinite(tr.x)) and tr.length == pytest.approx(1.0)
    assert tr.summary()["max_speed"] <= 1.0 + 1e-9
    with pytest.raises(InputError, match=r"smoothing_time = 1e\+06 s spans more than 10,000,000 samples"):
        m.time_scale_path(short, v_max=1e6, a_max=1e6, omega_max=1.0, dt=1.0, smoothing_time=1e6)


def test_polygon_with_collinear_vertices_is_refused():
    with pytest.raises(InputError, match="polygon 'line' has zero area"):
        m.Polygon([(0, 0), (1, 0), (2, 0)], "line")
    assert m.Polygon([(0, 0), (1, 0), (2, 1e-3)]).area > 0


# ------------------------------------------------------- simple polygons
SQUARE = [(0, 0), (1, 0), (1, 1), (0, 1)]
SIMPLE = "expected a simple polygon: edges meet only at shared corners"
#: Every way a polygon reaches planners.mobile: the check runs when the Polygon is built, so a map or a
#: footprint test never sees a self-crossing one.
POLYGON_ENTRY_POINTS = {
    "Polygon": lambda V: m.Polygon(V, "p"),
    "Polygon(vertices=array)": lambda V: shapes.Polygon(vertices=np.array(V, dtype=float), name="p"),
    "Polygon closed ring": lambda V: m.Polygon(list(V) + [V[0]], "p"),
    "dataclasses.replace": lambda V: dataclasses.replace(m.Polygon(SQUARE, "p"), vertices=V),
    "OccupancyGrid.from_shapes": lambda V: m.OccupancyGrid.from_shapes((0, 0, 10, 10), [m.Polygon(V, "p")]),
    "footprint_penetration": lambda V: m.footprint_penetration([(5, 5), (6, 5)], [0, 0], [m.Polygon(V, "p")],
                                                               length=1.0),
}
NOT_SIMPLE = {
    "bow-tie": ([(0, 0), (1, 1), (1, 0), (0, 1)], r"edges 0 \(0.0, 0.0\)-\(1.0, 1.0\) and 2 \(1.0, 0.0\)-"
                                                   r"\(0.0, 1.0\) cross or touch"),
    # vertex 4 (2, 0) lies on edge 0, which does not end there
    "vertex on a non-adjacent edge": ([(0, 0), (4, 0), (4, 3), (3, 3), (2, 0), (1, 3), (0, 3)],
                                      r"edges 0 \(0.0, 0.0\)-\(4.0, 0.0\) and 3 \(3.0, 3.0\)-\(2.0, 0.0\)"),
    # edge 0 runs back along edge 4 (no other pair touches before it)
    "collinear overlap": ([(3, 0), (1, 0), (1, 2), (0, 2), (0, 0), (4, 0), (4, 1), (3, 1)],
                          r"edges 0 \(3.0, 0.0\)-\(1.0, 0.0\) and 4 \(0.0, 0.0\)-\(4.0, 0.0\)"),
    # consecutive edges 0 and 1 fold back onto each other at vertex 1
    "spike": ([(0, 0), (2, 0), (1, 0), (1, 1)], r"edges 0 \(0.0, 0.0\)-\(2.0, 0.0\) and 1 "),
    # vertices 1 and 3 coincide: the outline touches itself at a corner that is not shared by
    # consecutive edges (a figure of eight)
    "figure of eight": ([(0, 0), (1, 1), (2, 0), (2, 2), (1, 1), (0, 2)], r"edges 0 .* and 3 "),
}


@pytest.mark.parametrize("entry", POLYGON_ENTRY_POINTS.values(), ids=POLYGON_ENTRY_POINTS)
@pytest.mark.parametrize("case", NOT_SIMPLE.values(), ids=NOT_SIMPLE)
def test_self_crossing_or_touching_polygon_is_refused_naming_the_edges(entry, case):
    V, edges = case
    with pytest.raises(InputError, match=rf"polygon 'p' vertices: {edges}.*{SIMPLE}"):
        entry(V)


@pytest.mark.parametrize("entry", POLYGON_ENTRY_POINTS.values(), ids=POLYGON_ENTRY_POINTS)
def test_collinear_or_repeated_vertices_are_refused(entry):
    with pytest.raises(InputError, match=r"polygon 'p' has zero area \(collinear vertices"):
        entry([(0, 0), (1, 1), (3, 3), (2, 2)])
    with pytest.raises(InputError, match=rf"polygon 'p' vertices: vertex 2 \(1.0, 0.0\) repeats vertex 1; "
                                         rf"{SIMPLE} \(no repeated consecutive vertices"):
        entry([(0, 0), (1, 0), (1, 0), (0, 1)])


STAR = [(math.cos(math.pi / 2 + k * math.pi / 5) * (1.0 if k % 2 == 0 else 0.4),
         math.sin(math.pi / 2 + k * math.pi / 5) * (1.0 if k % 2 == 0 else 0.4)) for k in range(10)]
L_SHAPE = [(0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2)]
SIMPLE_POLYGONS = {
    "convex hexagon": ([(math.cos(k * math.pi / 3), math.sin(k * math.pi / 3)) for k in range(6)],
                       1.5 * math.sqrt(3.0), (0.0, 0.0)),
    "L shape": (L_SHAPE, 3.0, (0.5, 1.5)),
    "clockwise L shape": (L_SHAPE[::-1], 3.0, (1.5, 0.5)),
    "star": (STAR, 10 * 0.5 * 1.0 * 0.4 * math.sin(math.pi / 5), (0.0, 0.0)),
    "straight corner": ([(0, 0), (1, 0), (2, 0), (2, 1), (0, 1)], 2.0, (1.0, 0.5)),
}


@pytest.mark.parametrize("entry", POLYGON_ENTRY_POINTS.values(), ids=POLYGON_ENTRY_POINTS)
@pytest.mark.parametrize("case", SIMPLE_POLYGONS.values(), ids=SIMPLE_POLYGONS)
def test_simple_polygons_are_accepted(entry, case):
    V, area, inside = case
    entry(V)
    poly = m.Polygon(V)
    assert poly.area == pytest.approx(area)
    assert poly.signed_distance(*inside) < 0 < poly.signed_distance(5.0, 5.0)


def test_a_vertex_on_a_non_adjacent_edge_up_to_rounding_is_refused_and_one_1e9_off_is_not():
    W = np.array(NOT_SIMPLE["vertex on a non-adjacent edge"][0], dtype=float)
    c, s = math.cos(0.5), math.sin(0.5)
    W = W @ np.array([[c, s], [-s, c]]) + (123.0, -45.0)  # rotated: vertex 4 on edge 0 only up to rounding
    with pytest.raises(InputError, match="edges 0 .* and 3 .* cross or touch"):
        m.Polygon(W, "w")
    W[4] += (-1e-13 * s, 1e-13 * c)  # 1e-13 off edge 0, inwards: within the tolerance, still touching
    with pytest.raises(InputError, match="edges 0 .* and 3 .* cross or touch"):
        m.Polygon(W, "w")
    W[4] += (-1e-9 * s, 1e-9 * c)
    assert m.Polygon(W, "w").area > 0


def test_polygon_vertex_count_is_bounded_and_a_large_one_is_tested_across_chunks():
    with pytest.raises(ShapeError, match=r"polygon 'big' needs vertices of shape \(k, 2\) with "
                                         r"3 <= k <= 10000, got \(10001, 2\)"):
        m.Polygon(np.ones((10_001, 2)), "big")
    t = np.linspace(0.0, 2.0 * math.pi, 10_000, endpoint=False)
    r = 1.0 + 0.3 * np.sin(7.0 * t)
    V = np.c_[r * np.cos(t), r * np.sin(t)]
    assert m.Polygon(V).area > 0
    V[[9000, 9001]] = V[[9001, 9000]]  # swapped: edges 8999 and 9001 now cross (far past the first chunk)
    with pytest.raises(InputError, match="edges 8999 .* and 9001 .* cross or touch"):
        m.Polygon(V)


def _orient(a, b, c):
    v = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    return (v > 0) - (v < 0)


def _on_segment(p, a, b):
    return (_orient(a, b, p) == 0 and min(a[0], b[0]) <= p[0] <= max(a[0], b[0])
            and min(a[1], b[1]) <= p[1] <= max(a[1], b[1]))


def _edges_touch(n, E, i, j):
    """Exact: edges i < j of a ring of n edges E meet other than at a corner shared by consecutive edges."""
    if j == i + 1 or (i == 0 and j == n - 1):  # consecutive: touching elsewhere means one end on the other
        (a, b), (c, d) = (E[i], E[j]) if j == i + 1 else (E[j], E[i])
        return _on_segment(a, c, d) or _on_segment(d, a, b)
    (p1, p2), (p3, p4) = E[i], E[j]
    if _orient(p3, p4, p1) * _orient(p3, p4, p2) < 0 and _orient(p1, p2, p3) * _orient(p1, p2, p4) < 0:
        return True
    return (_on_segment(p1, p3, p4) or _on_segment(p2, p3, p4) or _on_segment(p3, p1, p2)
            or _on_segment(p4, p1, p2))


def _exact_touching_pairs(V):
    """Brute force in exact rational arithmetic: every pair of edges that touches."""
    P = [(Fraction(x), Fraction(y)) for x, y in V]
    n = len(P)
    E = [(P[i], P[(i + 1) % n]) for i in range(n)]
    return {(i, j) for i in range(n) for j in range(i + 1, n) if _edges_touch(n, E, i, j)}


def _random_polygons(seed, count=300):
    """Random rings of 3 to 9 vertices without repeated consecutive vertices: a third on a small integer
    grid, a third on a grid of 1/8 far from the origin (both exact in floats, with many collinear and
    touching cases), a third Gaussian."""
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < count:
        n = int(rng.integers(3, 10))
        kind = len(out) % 3
        V = (rng.integers(-3, 4, (n, 2)).astype(float) if kind == 0
             else rng.integers(0, 5, (n, 2)) / 8.0 + 1e5 if kind == 1 else rng.normal(size=(n, 2)))
        if not np.any(np.all(V == np.roll(V, -1, axis=0), axis=1)):
            out.append(V)
    return out


def test_crossing_test_matches_an_exact_rational_brute_force():
    refused = 0
    for V in _random_polygons(7):
        exact = _exact_touching_pairs(V.tolist())
        found = _checks._touching_edges(V)
        assert (found is None) == (not exact), V.tolist()
        assert found is None or found in exact, V.tolist()  # the pair named really touches
        refused += found is not None
    assert 50 < refused < 250  # both outcomes are well represented


def test_crossing_test_matches_shapely():
    geometry = pytest.importorskip("shapely.geometry")
    refused = 0
    for V in _random_polygons(11):
        simple = geometry.LinearRing(V).is_simple
        assert (_checks._touching_edges(V) is None) == simple, V.tolist()
        refused += not simple
    assert 50 < refused < 250
