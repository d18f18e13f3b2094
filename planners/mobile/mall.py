"""The shopping mall of the cleaning-robot scenarios (SCENARIOS.md S7, S8) as data.

Units are the document's map units (a 480 x 480 floor). The robot is a
20 x 20 square planned by its centre, so obstacles are inflated by 10 (half
the footprint) and the centre keeps 10 from the walls.

S7 gives the raw obstacles and inflates them; S8 gives obstacles that are
already padded (hot-dog stand 1 ``(220,100)-(260,140)`` padded by 10 is
``(210,90)-(270,150)``, the fountain's radius 40 becomes 50) plus two padded
no-go strips along the bottom and top of the central hallway.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .maps import OccupancyGrid
from .shapes import Circle, Rectangle

if TYPE_CHECKING:
    import numpy as np

BOUNDS = (0.0, 0.0, 480.0, 480.0)
ROBOT_WIDTH = 20.0
HALF_FOOTPRINT = ROBOT_WIDTH / 2.0

# --------------------------------------------------------------------- S7
S7_OBSTACLES = (
    Rectangle(220, 100, 260, 140, "hot-dog stand 1"),
    Rectangle(160, 160, 200, 200, "hot-dog stand 2"),
    Circle(240, 240, 40, "fountain"),
    Rectangle(135, 375, 185, 425, "escalator 1"),
    Rectangle(296, 375, 345, 425, "escalator 2"),
)
S7_INFLATION = HALF_FOOTPRINT
#: Waypoints in the order the document visits them.
S7_WAYPOINTS = (
    ("start", (260.0, 60.0)),
    ("1", (360.0, 170.0)),
    ("2", (150.0, 70.0)),
    ("3", (150.0, 300.0)),
    ("4", (310.0, 330.0)),
    ("end", (230.0, 430.0)),
)


def s7_waypoints() -> np.ndarray:
    """The six S7 waypoints ``(6, 2)`` in the given order (start, 1, 2, 3, 4, end)."""
    import numpy as np

    return np.array([p for _, p in S7_WAYPOINTS], dtype=float)


def s7_map(resolution: float = 1.0) -> OccupancyGrid:
    """S7 occupancy grid: raw obstacles inflated by 10, walls kept 10 away."""
    return OccupancyGrid.from_shapes(BOUNDS, S7_OBSTACLES, resolution=resolution, inflation=S7_INFLATION)


# --------------------------------------------------------------------- S8
S8_PADDED_OBSTACLES = (
    Rectangle(210, 90, 270, 150, "hot-dog stand 1 (padded)"),
    Rectangle(150, 150, 210, 210, "hot-dog stand 2 (padded)"),
    Circle(240, 240, 50, "fountain (padded)"),
    Rectangle(125, 365, 195, 435, "escalator 1 (padded)"),
    Rectangle(286, 365, 355, 435, "escalator 2 (padded)"),
)
S8_NO_GO = (
    Rectangle(110, -10, 370, 50, "no-go zone 1 (padded)"),
    Rectangle(110, 430, 370, 490, "no-go zone 2 (padded)"),
)
S8_START = (10.0, 10.0)
S8_LANE_SPACING = ROBOT_WIDTH
#: Store blocks (informational: the document draws no walls between them and the hallway).
S8_AREAS = {
    "stores 1-4": Rectangle(0, 0, 120, 480, "stores 1-4"),
    "hallway": Rectangle(120, 0, 360, 480, "central hallway"),
    "stores 5-8": Rectangle(360, 0, 480, 480, "stores 5-8"),
}


def s8_map(resolution: float = 1.0) -> OccupancyGrid:
    """S8 occupancy grid for the robot centre: padded shapes as given, walls kept 10 away."""
    return OccupancyGrid.from_shapes(
        BOUNDS, S8_PADDED_OBSTACLES + S8_NO_GO, resolution=resolution, inflation=0.0, border_clearance=HALF_FOOTPRINT
    )
