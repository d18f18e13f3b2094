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

import math
from typing import TYPE_CHECKING

from kinserve.kinematics.errors import InputError
from kinserve.kinematics.validation import as_positive

from .maps import MIN_RESOLUTION, OccupancyGrid
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
#: The no-go zones as floor areas (the padded strips above without their 10 u padding).
S8_NO_GO_RAW = (
    Rectangle(120, 0, 360, 40, "no-go zone 1"),
    Rectangle(120, 440, 360, 480, "no-go zone 2"),
)
#: The physical obstacles of S8 (the padded shapes are these grown by 10): S7's stands, fountain, escalators.
S8_OBSTACLES = S7_OBSTACLES
S8_START = (10.0, 10.0)
S8_LANE_SPACING = ROBOT_WIDTH
#: Store blocks (informational: the document draws no walls between them and the hallway).
S8_AREAS = {
    "stores 1-4": Rectangle(0, 0, 120, 480, "stores 1-4"),
    "hallway": Rectangle(120, 0, 360, 480, "central hallway"),
    "stores 5-8": Rectangle(360, 0, 480, 480, "stores 5-8"),
}


#: Padding choices for S8: half the footprint's width (the document's) or half its diagonal.
PADDINGS = {"width": HALF_FOOTPRINT, "diagonal": HALF_FOOTPRINT * math.sqrt(2.0)}


def s8_padding(padding: str = "width") -> float:
    """The clearance (u) of a padding choice: ``"width"`` 10 (half the width), ``"diagonal"`` 10 sqrt(2).
    Any other value (or a non-string) is refused with :class:`InputError`."""
    if not isinstance(padding, str) or padding not in PADDINGS:
        raise InputError(f"padding must be one of {sorted(PADDINGS)}, got {padding!r}")
    return PADDINGS[padding]


def s8_map(resolution: float = 1.0, padding: str = "width") -> OccupancyGrid:
    """S8 occupancy grid for the robot centre.

    ``padding="width"`` (the document's): the padded shapes as given (the
    physical ones grown by 10, half the width), walls kept 10 away: a turning
    20 x 20 footprint's corners can cut into obstacles. ``padding="diagonal"``:
    the physical obstacles and no-go zones inflated by half the diagonal,
    ``10 sqrt(2)``, walls kept as far: no corner can reach an obstacle.
    """
    c = s8_padding(padding)
    if padding == "width":
        return OccupancyGrid.from_shapes(
            BOUNDS, S8_PADDED_OBSTACLES + S8_NO_GO, resolution=resolution, inflation=0.0, border_clearance=c
        )
    return OccupancyGrid.from_shapes(BOUNDS, S8_OBSTACLES + S8_NO_GO_RAW, resolution=resolution, inflation=c,
                                     border_clearance=c)


def s8_start(padding: str = "width", resolution: float = 1.0) -> tuple[float, float]:
    """The start of the coverage path: ``S8_START`` (10, 10) for the width padding; for the diagonal
    one the nearest lattice corner point ``(c, c)`` with ``c`` = the clearance rounded up to the lattice.
    Refuses an unknown ``padding`` and a ``resolution`` not in ``[1e-6, 1e6]``."""
    c = s8_padding(padding)
    resolution = as_positive(resolution, "resolution")
    if resolution < MIN_RESOLUTION:
        raise InputError(f"resolution must be at least {MIN_RESOLUTION:g}, got {resolution!r}")
    if padding == "width":
        return S8_START
    k = math.ceil(c / resolution - 1e-9) * resolution
    return (k, k)
