"""Bad input to ``planners.mobile``: refused with kinserve's own errors, naming the argument, before any
unbounded allocation or loop; a valid neighbouring input still works."""

import math

import numpy as np
import pytest

from kinserve.kinematics.errors import InputError, NonFiniteError, ShapeError
from kinserve.planners import mobile as m
from kinserve.planners.errors import BlockedPointError
from kinserve.planners.mobile import _checks

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


def test_polygon_with_a_repeated_vertex_gives_a_finite_distance():
    sd = m.Polygon([(0, 0), (0, 0), (1, 0), (0, 1)]).signed_distance(2.0, 2.0)
    assert sd == pytest.approx(math.hypot(1.5, 1.5))


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
    with pytest.raises(InputError, match="s must hold finite arc lengths"):
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
