"""Waypoint sequencing on the S7 mall: given order, and the best order by A* costs (checked by brute
force)."""

import itertools

import numpy as np
import pytest

from kinserve.kinematics.errors import InputError
from kinserve.planners.errors import NoPathError
from kinserve.planners.mobile import mall
from kinserve.planners.mobile.astar import astar
from kinserve.planners.mobile.maps import OccupancyGrid
from kinserve.planners.mobile.sequencing import pairwise_costs, plan_waypoints
from kinserve.planners.mobile.shapes import Rectangle

NAMES = [n for n, _ in mall.S7_WAYPOINTS]


@pytest.fixture(scope="module")
def s7():
    return mall.s7_map()


def test_given_order_visits_every_waypoint(s7):
    wp = mall.s7_waypoints()
    plan = plan_waypoints(s7, wp, names=NAMES)
    assert plan.order == list(range(6)) and len(plan.segments) == 5
    np.testing.assert_allclose(plan.points[plan.waypoint_index], wp)
    assert plan.cost == pytest.approx(sum(astar(s7, a, b).cost for a, b in zip(wp[:-1], wp[1:])))
    assert s7.path_is_free(plan.points)
    for seg in plan.segments:  # every leg avoids the inflated obstacles
        assert s7.clearance(seg.points).min() >= -1e-9


def test_optimal_order_is_the_brute_force_optimum(s7):
    wp = mall.s7_waypoints()
    C, _ = pairwise_costs(s7, wp)
    np.testing.assert_allclose(C, C.T)
    best = min(
        sum(C[a, b] for a, b in zip((0, *p, 5)[:-1], (0, *p, 5)[1:]))
        for p in itertools.permutations(range(1, 5))
    )
    plan = plan_waypoints(s7, wp, order="optimal", names=NAMES)
    assert plan.order[0] == 0 and plan.order[-1] == 5 and sorted(plan.order) == list(range(6))
    assert plan.cost == pytest.approx(best)
    assert plan.cost <= plan_waypoints(s7, wp).cost
    np.testing.assert_allclose(plan.points[plan.waypoint_index], wp[plan.order])
    assert plan.visited_names[0] == "start" and plan.visited_names[-1] == "end"


def test_unreachable_waypoints():
    g = OccupancyGrid.from_shapes((20, 20), [Rectangle(9, -1, 11, 21, "wall")])
    with pytest.raises(NoPathError, match="leg 0 -> 1"):
        plan_waypoints(g, [(2, 2), (18, 2)])
    with pytest.raises(NoPathError, match="no order"):
        plan_waypoints(g, [(2, 2), (18, 2), (3, 5)], order="optimal")
    with pytest.raises(InputError, match="order"):
        plan_waypoints(g, [(2, 2), (3, 3)], order="random")
