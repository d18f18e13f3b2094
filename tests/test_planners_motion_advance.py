"""The conservative advancement with look-ahead of the exact certificate stage
(kinserve.planners.motion.edges.advance), on distance profiles of one parameter whose every value is known.

A profile ``d(s)`` (m) that changes by at most ``rate`` per unit ``s`` gives the radius
``(d(s) - tol) / rate`` at ``s``: the ball it certifies keeps ``d > tol``. The checks:
``advance`` says True only when the balls it asked cover ``[0, 1]`` and the profile stays above ``tol``
at every sample; a profile that dips below ``tol`` anywhere between the certified ends is refused; the
look-ahead asks fewer points than plain advancement on a profile far from ``tol``.
"""

import numpy as np
import pytest

from kinserve.kinematics.motion_kernels import LOOKAHEAD
from kinserve.planners.motion.edges import PACE_WINDOW, advance

RATE, TOL = 1.0, 1e-3


def profile(rng: np.random.Generator, dip: bool) -> tuple[np.ndarray, np.ndarray]:
    """Knots ``(s, d)`` of a piecewise-linear profile on ``[0, 1]`` with slopes at most ``RATE``; with
    ``dip`` it falls below ``TOL`` somewhere inside."""
    s = np.sort(np.concatenate([[0.0, 1.0], rng.uniform(0.0, 1.0, 6)]))
    d = np.empty_like(s)
    d[0] = rng.uniform(0.02, 0.2)
    for k in range(1, len(s)):
        d[k] = d[k - 1] + rng.uniform(-RATE, RATE) * (s[k] - s[k - 1])
    d = np.maximum(d, 2 * TOL)
    if dip:
        k = int(rng.integers(1, len(s) - 1))
        d[k] = 0.0
        for j in range(len(s)):  # keep the slopes within RATE around the dip
            d[j] = min(d[j], d[k] + RATE * abs(s[j] - s[k]))
    return s, d


def radius_of(s_knots: np.ndarray, d_knots: np.ndarray, asked: list):
    def radius(s: float) -> float:
        d = float(np.interp(s, s_knots, d_knots))
        r = (d - TOL) / RATE
        asked.append((s, r))
        return r if d > TOL else -1.0
    return radius


def covered(asked: list, lo: float, hi: float) -> bool:
    """True when ``[0, lo]``, ``[hi, 1]`` and the balls asked (those with a radius) cover ``[0, 1]``."""
    spans = sorted([(0.0, lo), (hi, 1.0)] + [(s - r, s + r) for s, r in asked if r >= 0.0])
    reach = 0.0
    for a, b in spans:
        if a > reach:
            return False
        reach = max(reach, b)
    return reach >= 1.0


@pytest.mark.parametrize("seed", range(40))
def test_advance_certifies_only_covered_profiles_that_stay_above_the_tolerance(seed):
    rng = np.random.default_rng(seed)
    for dip in (False, True):
        s_knots, d_knots = profile(rng, dip)
        asked: list = []
        ok = advance(radius_of(s_knots, d_knots, asked), 0.0, 1.0, 10_000)
        dense = np.interp(np.linspace(0.0, 1.0, 20_001), s_knots, d_knots)
        if dip:
            assert not ok
        else:
            assert ok, "a profile at least 2 tol above everything is certified within the budget"
        if ok:
            assert covered(asked, 0.0, 1.0) and dense.min() > TOL


def test_advance_joins_balls_only_to_the_certified_ends():
    """A dip to 0 at ``s = 0.055``, within the rate: the first ball (at 0) certifies ``[0, 0.049]``, the
    look-ahead point ``0.6 * 0.049`` beyond it has a ball that does not reach back over the dip. Joining it
    anyway would skip the dip; it must be dropped, the gap asked again, and the motion refused there."""
    s_knots = np.array([0.0, 0.055, 0.2, 1.0])
    d_knots = np.array([0.05, 0.0, 0.145, 0.145])
    asked: list = []
    assert not advance(radius_of(s_knots, d_knots, asked), 0.0, 1.0, 10_000)
    first_lo = asked[0][1]
    s1, r1 = asked[2]  # the second point from below: the look-ahead one
    assert s1 == pytest.approx(first_lo * (1.0 + LOOKAHEAD)) and s1 - r1 > first_lo  # it does not join
    assert asked[4][0] == pytest.approx(first_lo)  # so the next point from below is the end itself


def test_advance_respects_its_budget_and_its_given_ends():
    asked: list = []
    flat = radius_of(np.array([0.0, 1.0]), np.array([0.011, 0.011]), asked)
    assert not advance(flat, 0.0, 1.0, 3) and len(asked) == 3
    asked.clear()
    assert advance(flat, 0.6, 0.5, 0) and not asked  # the ends already meet
    assert advance(flat, 0.45, 0.55, 10) and all(0.45 <= s <= 0.55 for s, _ in asked)


def test_the_look_ahead_asks_fewer_points_than_plain_advancement_far_from_the_tolerance():
    """Constant radius ``r``: plain advancement moves ``lo`` by ``r`` per point asked, about ``1 / r`` in
    all; with the look-ahead each ball counts on both sides, ``(1 + LOOKAHEAD) r`` per point."""
    asked: list = []
    d = 0.01 + TOL
    assert advance(radius_of(np.array([0.0, 1.0]), np.array([d, d]), asked), 0.0, 1.0, 10_000)
    plain = 1.0 / 0.01
    assert len(asked) <= plain / (1.0 + LOOKAHEAD) + 3 < 0.7 * plain


def test_a_grazing_motion_is_given_up_before_its_budget_and_a_steady_one_is_not():
    """A profile that comes within 1.5 tol of the tolerance mid-way: with a large budget it is certified;
    with a budget its pace cannot meet, it is refused after fewer points than the budget (the pace rule),
    while a flat profile whose pace just meets its budget is still certified."""
    s_knots = np.array([0.0, 0.5, 1.0])
    d_knots = np.array([0.3, 2.5 * TOL, 0.3])
    asked: list = []
    assert advance(radius_of(s_knots, d_knots, asked), 0.0, 1.0, 10_000)
    needed = len(asked)
    asked.clear()
    budget = needed // 3
    assert not advance(radius_of(s_knots, d_knots, asked), 0.0, 1.0, budget)
    assert PACE_WINDOW <= len(asked) < budget
    flat: list = []
    d = 0.01 + TOL
    assert advance(radius_of(np.array([0.0, 1.0]), np.array([d, d]), flat), 0.0, 1.0, 10_000)
    asked.clear()
    assert advance(radius_of(np.array([0.0, 1.0]), np.array([d, d]), asked), 0.0, 1.0, len(flat))
