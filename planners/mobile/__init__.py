"""Mobile-base planning: occupancy grids, A*, waypoint sequencing, smoothing, timing, coverage, drive
kinematics."""

from . import mall
from .astar import GridPath, astar, path_length_lower_bound
from .coverage import (
    CoverageResult,
    boustrophedon_coverage,
    coverable_pixels,
    decompose,
    lane_intervals,
    swept_coverage,
)
from .diff_drive import DiffDrive
from .footprint import Penetration, footprint_outline, footprint_penetration
from .maps import OccupancyGrid
from .omni import OmniBase
from .path_timing import DriveTrajectory, drive_through, time_scale_path, turn_in_place
from .sequencing import WaypointPlan, pairwise_costs, plan_waypoints
from .shapes import Circle, Polygon, Rectangle
from .smoothing import SmoothPath, polyline_path, shortcut, smooth_path

__all__ = [
    "OccupancyGrid", "Rectangle", "Circle", "Polygon", "mall",
    "astar", "GridPath", "path_length_lower_bound",
    "plan_waypoints", "pairwise_costs", "WaypointPlan",
    "smooth_path", "shortcut", "polyline_path", "SmoothPath",
    "time_scale_path", "drive_through", "turn_in_place", "DriveTrajectory",
    "boustrophedon_coverage", "CoverageResult", "lane_intervals", "decompose", "swept_coverage",
    "coverable_pixels", "DiffDrive", "OmniBase", "footprint_penetration", "footprint_outline", "Penetration",
]
