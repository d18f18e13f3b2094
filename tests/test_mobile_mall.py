"""The mall data: S7 raw obstacles + inflation equal S8's padded ones; waypoints and start are free."""

import numpy as np

from kinserve.planners.mobile import mall
from kinserve.planners.mobile.shapes import Circle, Rectangle


def test_s8_padding_is_s7_plus_half_footprint():
    for raw, padded in zip(mall.S7_OBSTACLES, mall.S8_PADDED_OBSTACLES):
        if isinstance(raw, Rectangle):
            assert (padded.x_min, padded.y_min) == (raw.x_min - 10, raw.y_min - 10)
            assert (padded.x_max, padded.y_max) == (raw.x_max + 10, raw.y_max + 10)
        else:
            assert isinstance(padded, Circle) and padded.radius == raw.radius + 10


def test_waypoints_and_start_are_free():
    m7 = mall.s7_map()
    assert m7.is_free(mall.s7_waypoints()).all()
    assert m7.shape == (481, 481)
    m8 = mall.s8_map()
    assert m8.is_free(np.array([mall.S8_START]))[0]
    # the no-go strip blocks the hallway bottom, not the stores
    assert not m8.is_free([240.0, 30.0])[0] and m8.is_free([60.0, 30.0])[0]
